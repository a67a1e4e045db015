"""An emulated FORTE sensor board on a pseudo-terminal, with fault injection.

It behaves like the firmware in ``firmware/`` (binary protocol v1: START/STOP/IDENTIFY/
SET_RATE with acknowledgements, a 512-sample ring, overruns counted when the host does not
read, sequence numbers still consumed by dropped scans) or like the paper authors' legacy
firmware (ASCII ``T1:..,T6:..`` lines streamed from power-on, no commands).

The device end is the master side of a pty; the host opens the slave through a symlink
(``link_path``, e.g. ``/tmp/forte_sensor``), the same way it opens ``/dev/forte_sensor``
on the robot. :meth:`EmulatedSensor.unplug` closes the pty and removes the symlink;
:meth:`EmulatedSensor.replug` creates a new pty (a power-cycled device) behind the same
symlink.

Faults are injected per transmitted scan with seeded probabilities (:class:`FaultPlan`)
or on demand (:meth:`EmulatedSensor.inject`); their kinds and bookkeeping are in
:mod:`forte_driver.emulators.emulated_faults`
(line faults: garbage, truncation, bit flips, gaps,
bursts; binary-only sequence faults: duplicated, reordered and CRC-valid implausible
frames, device restarts without a host START). Every fault is logged with its expected
effect on a decoder that follows docs/firmware.md, so tests can demand exact counts:
:attr:`EmulatedSensor.log` (a :class:`FaultLog`: expected dropped, corrupt, implausible,
duplicate and late frames, device restarts), and the truth of every scan delivered intact
in :attr:`EmulatedSensor.delivered`.

Command line: ``forte_emulated_sensor --link /tmp/forte_sensor`` (see ``--help``).
"""
from __future__ import annotations

import argparse
import math
import os
import random
import signal
import threading
import time
import tty
from collections import deque

from forte_driver.emulators.emulated_faults import (
    BINARY_ONLY_FAULTS,
    FAULTS,
    IMPLAUSIBLE_KINDS,
    FaultLog,
    FaultPlan,
    implausible_frame,
)
from forte_driver.serial import protocol
from forte_driver.serial.protocol import Ack, Command, CommandFrame, Info, Sample, Status
from forte_ros.contract import COUNTS_PER_FULL_SCALE, N_CHANNELS, SAMPLE_RATE


def default_signal(sequence: int, time_us: int) -> tuple[int, ...]:
    """Synthetic readings [counts]: six sines of different frequency plus a ramp."""
    t = time_us * 1e-6
    return tuple(int(round(300.0 * math.sin(2.0 * math.pi * (1.0 + k) * t) + (sequence % 97) - 48
                           + 40 * k)) for k in range(N_CHANNELS))


class EmulatedSensor:
    """Emulated sensor board behind a pty symlink.

    Parameters
    ----------
    link_path : str
        Symlink the host opens (created, replaced on replug, removed on unplug).
    protocol_name : str
        ``'binary'`` (firmware protocol v1) or ``'ascii'`` (legacy lines, always streaming).
    rate_hz : int
        Initial scan rate [Hz].
    faults : FaultPlan, optional
        Per-scan fault probabilities.
    seed : int
        Seed of the fault and garbage generator.
    drift_ppm : float
        Device clock error: device time runs (1 + drift_ppm * 1e-6) times host time.
    clock_offset_us : int
        Device time at the emulator's creation [us].
    max_scans : int, optional
        Stop streaming after this many scans of a session (a finite recording); its last
        3 scans are never faulted.
    ring_capacity : int
        Device sample buffer [scans]; when the host does not read and the pty is full,
        scans beyond it are dropped and counted as overruns.
    signal_fn : callable, optional
        ``(sequence, device_time_us) -> 6 counts``.
    stream_on_power_up : bool
        ASCII mode: stream from plug-in (like the legacy firmware); if False, streaming
        begins with :meth:`set_ascii_streaming` (lets tests start at a line boundary).
    """

    def __init__(self, link_path: str, protocol_name: str = 'binary',
                 rate_hz: int = int(SAMPLE_RATE),
                 faults: FaultPlan | None = None, seed: int = 0, drift_ppm: float = 0.0,
                 clock_offset_us: int = 5_000_000, max_scans: int | None = None,
                 ring_capacity: int = 512, signal_fn=None,
                 stream_on_power_up: bool = True) -> None:
        if protocol_name not in ('binary', 'ascii'):
            raise ValueError(f"protocol_name must be 'binary' or 'ascii', not {protocol_name!r}")
        if protocol_name == 'ascii' and any(getattr(faults, name, 0.0)
                                            for name in BINARY_ONLY_FAULTS):
            raise ValueError(f'faults {BINARY_ONLY_FAULTS} exist only in binary mode')
        self.link_path = link_path
        self.protocol_name = protocol_name
        self.faults = faults or FaultPlan()
        self.drift = drift_ppm * 1e-6
        self.clock_offset_us = clock_offset_us
        self.max_scans = max_scans
        self.ring_capacity = ring_capacity
        self.signal_fn = signal_fn or default_signal
        self.stream_on_power_up = stream_on_power_up
        self.device_id = 0xF0E7E500 + seed
        self._random = random.Random(seed)
        self._lock = threading.RLock()
        self._host_origin_ns = time.monotonic_ns()
        self._rate_hz = rate_hz
        self._master: int | None = None
        self._slave: int | None = None
        self._thread: threading.Thread | None = None
        self._running = False
        self._pending_faults: deque[tuple[str | None, str | None]] = deque()
        self.log = FaultLog()
        #: (unwrapped session index, sequence, device time [us], values) of scans sent intact
        self.delivered: list[tuple[int, int, int, tuple]] = []
        self.commands: list[CommandFrame] = []
        self.sessions = 0
        self.scans_generated = 0
        self.device_overruns = 0
        self._reset_device_state()

    # ---- device state -----------------------------------------------------------------

    def _reset_device_state(self) -> None:
        """Power-up state: nothing buffered, a new session (streaming only in ASCII mode)."""
        self._streaming = self.protocol_name == 'ascii' and self.stream_on_power_up
        self._ascii_merge_pending = False
        self._restart_sequence()
        self._restart_scan_counts()
        self._ring: deque[Sample] = deque()
        self._out = bytearray()
        self._hold_until_ns = 0
        self._decoder = protocol.FrameDecoder()
        self._held: tuple[bytes, tuple] | None = None  # reordered frame, sent after the next
        self._restart_pending = False

    def _restart_sequence(self) -> None:
        """Sequence numbers, overrun counter and scan clock start again, the next scan
        carries the first-scan flag (START, power-up, device restart)."""
        self._sequence = 0
        self._overruns = self._overruns_reported = 0
        self._session_start = True
        self._next_scan_us: int | None = None

    def _restart_scan_counts(self) -> None:
        """The session's scan counts (``max_scans``, clean tail) and scan clock start again."""
        self._session_scans = 0
        self._transmitted = 0
        self._next_scan_us = None

    def set_ascii_streaming(self, streaming: bool) -> None:
        """ASCII mode: start or stop the line stream (the legacy firmware has no commands)."""
        with self._lock:
            self._streaming = streaming
            self._restart_scan_counts()

    @property
    def streaming(self) -> bool:
        """True while the device streams scans."""
        return self._streaming

    @property
    def rate_hz(self) -> int:
        """Current scan rate [Hz]."""
        return self._rate_hz

    def device_time_us(self, host_ns: int | None = None) -> int:
        """Device clock [us] at host monotonic time ``host_ns`` (default: now)."""
        host_ns = time.monotonic_ns() if host_ns is None else host_ns
        elapsed_us = (host_ns - self._host_origin_ns) / 1000.0
        return self.clock_offset_us + int(elapsed_us * (1.0 + self.drift))

    def host_ns_of_device_time(self, device_time_us: int) -> int:
        """Host monotonic time [ns] at which the device clock showed ``device_time_us``."""
        elapsed_us = (device_time_us - self.clock_offset_us) / (1.0 + self.drift)
        return self._host_origin_ns + int(elapsed_us * 1000.0)

    # ---- pty lifecycle ------------------------------------------------------------------

    def start(self) -> EmulatedSensor:
        """Create the pty and symlink and start the device thread (plug in)."""
        self._open_pty()
        self._running = True
        self._thread = threading.Thread(target=self._run, name='forte-emulated-sensor',
                                        daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the device thread, close the pty and remove the symlink."""
        self._running = False
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        with self._lock:
            self._close_pty()

    def __enter__(self) -> EmulatedSensor:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no newline translation: a binary-clean line
        os.set_blocking(master, False)
        temporary = f'{self.link_path}.{os.getpid()}.tmp'
        if os.path.lexists(temporary):
            os.unlink(temporary)
        os.symlink(os.ttyname(slave), temporary)
        os.replace(temporary, self.link_path)
        self._master, self._slave = master, slave

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None
        if os.path.lexists(self.link_path):
            os.unlink(self.link_path)

    def unplug(self) -> None:
        """Pull the USB cable: the pty disappears with whatever was in flight."""
        with self._lock:
            self._close_pty()
            self._reset_device_state()

    def replug(self) -> None:
        """Plug a freshly powered device back in behind the same symlink."""
        with self._lock:
            self._reset_device_state()
            self._open_pty()

    # ---- faults -------------------------------------------------------------------------

    def inject(self, fault: str, count: int = 1, kind: str | None = None,
               after: int = 0) -> None:
        """Apply ``fault`` to ``count`` transmitted scans (one each), after ``after``
        clean scans (counted from the end of the faults already queued); ``kind`` selects
        the implausibility of an ``implausible`` fault (default: drawn)."""
        if fault not in FAULTS:
            raise ValueError(f'unknown fault {fault!r}; known: {FAULTS}')
        if fault in BINARY_ONLY_FAULTS and self.protocol_name != 'binary':
            raise ValueError(f'fault {fault!r} exists only in binary mode')
        if kind is not None and (fault != 'implausible' or kind not in IMPLAUSIBLE_KINDS):
            raise ValueError(f'kind applies to implausible faults only: {IMPLAUSIBLE_KINDS}')
        with self._lock:
            self._pending_faults.extend([(None, None)] * after + [(fault, kind)] * count)

    def _choose_fault(self) -> tuple[str | None, str | None]:
        if self._pending_faults:
            return self._pending_faults.popleft()
        plan = self.faults
        draw = self._random.random()
        for name in FAULTS:
            probability = getattr(plan, name)
            if draw < probability:
                return name, None
            draw -= probability
        return None, None

    def _restart_device(self) -> None:
        """Watchdog/brown-out reset while streaming: clock and sequence start again and
        the device resumes streaming by itself (no host START)."""
        self.log.restarts += 1
        self.sessions += 1
        self._restart_pending = False
        self._host_origin_ns = time.monotonic_ns()
        self.clock_offset_us = 1_000_000  # 1 s after boot
        self._restart_sequence()

    def _garbage(self, exclude: tuple[int, ...]) -> bytes:
        allowed = [b for b in range(256) if b not in exclude]
        return bytes(self._random.choice(allowed) for _ in range(self._random.randint(1, 40)))

    # ---- device thread --------------------------------------------------------------------

    def _run(self) -> None:
        while self._running:
            with self._lock:
                if self._master is not None:
                    try:
                        self._service_commands()
                        self._sample_due_scans()
                        self._flush_output()
                    except OSError:
                        pass  # host side closed while writing: like a USB hiccup
            time.sleep(0.001)

    def _service_commands(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return
        if self.protocol_name != 'binary' or not data:
            return
        for item in self._decoder.feed(data):
            if isinstance(item, CommandFrame):
                self.commands.append(item)
                self._handle_command(item)

    def _handle_command(self, command: CommandFrame) -> None:
        status, value, send_info = Status.OK, self._rate_hz, False
        if command.command == Command.START:
            if self._streaming:
                status = Status.BUSY
            else:
                self._streaming = True
                self._restart_sequence()
                self._restart_scan_counts()
                self._ring.clear()
                self.sessions += 1
        elif command.command == Command.STOP:
            value = self._sequence
            self._streaming = False
            self._release_held()
        elif command.command == Command.IDENTIFY:
            send_info = True
        elif command.command == Command.SET_RATE:
            rate = command.argument
            if self._streaming:
                status = Status.BUSY
            elif not (1 <= rate <= 4000 and 1_000_000 % rate == 0):
                status = Status.BAD_ARGUMENT
            else:
                self._rate_hz = rate
            value = self._rate_hz
        else:
            status = Status.UNKNOWN_COMMAND
        self._out += protocol.encode_ack(Ack(command.command, command.token, status, value))
        if send_info:
            self._out += protocol.encode_info(Info(
                protocol.PROTOCOL_VERSION, (1, 0, 0), N_CHANNELS, 12,
                COUNTS_PER_FULL_SCALE, self._rate_hz, self.ring_capacity,
                self.device_id))

    def _sample_due_scans(self) -> None:
        if not self._streaming:
            return
        period_us = 1_000_000 // self._rate_hz
        now_us = self.device_time_us()
        if self._next_scan_us is None:
            self._next_scan_us = (now_us // period_us + 1) * period_us
        while self._next_scan_us <= now_us:
            if self.max_scans is not None and self._session_scans >= self.max_scans:
                return
            time_us = self._next_scan_us
            self._next_scan_us += period_us
            sample = Sample(self._sequence % protocol.SEQUENCE_MODULUS, time_us,
                            self.signal_fn(self._sequence, time_us))
            self._sequence += 1
            self._session_scans += 1
            self.scans_generated += 1
            if len(self._ring) >= self.ring_capacity:
                self._overruns += 1  # host too slow: drop, keep sampling, report later
                self.device_overruns += 1
                self.log.dropped += 1
                continue
            flags = protocol.FLAG_SESSION_START if self._session_start else 0
            if self._overruns != self._overruns_reported:
                flags |= protocol.FLAG_OVERRUN
            self._session_start = False
            self._overruns_reported = self._overruns
            self._ring.append(Sample(sample.sequence, sample.time_us, sample.values,
                                     self._overruns % protocol.OVERRUN_MODULUS, flags, 0))

    def _transmit(self, sample: Sample) -> None:
        """Encode one scan into the output, applying at most one fault."""
        if self.protocol_name == 'binary':
            data = protocol.encode_sample(sample)
        else:
            data = protocol.format_ascii_line([v / COUNTS_PER_FULL_SCALE
                                               for v in sample.values])
        merging = self.protocol_name == 'ascii' and self._ascii_merge_pending
        # the last 3 scans of a finite session go out clean: a damaged last frame would
        # wait forever for bytes that never come and could not be counted
        tail = self.max_scans is not None and self._transmitted >= self.max_scans - 3
        self._transmitted += 1
        # the scan after a reordered one, and scans before a pending restart, go out clean
        clean = merging or tail or self._held is not None or self._restart_pending
        fault, kind = (None, None) if clean else self._choose_fault()
        log = self.log
        if fault is not None:
            log.counts[fault] += 1
        truth = (self.sessions, sample.sequence, sample.time_us,
                 tuple(v / COUNTS_PER_FULL_SCALE for v in sample.values))
        if fault in BINARY_ONLY_FAULTS:
            self._transmit_sequence_fault(fault, kind, sample, data, truth)
            return
        if fault == 'garbage' and self.protocol_name == 'binary':
            self._out += self._garbage((0xA5, 0x5A, 0x01))
        elif fault == 'garbage':
            self._out += self._garbage((0x0A,)) + b'\n'
            log.corrupt += 1
        elif fault == 'random_garbage':
            self._out += bytes(self._random.randrange(256)
                               for _ in range(self._random.randint(1, 40)))
            log.exact = False
        elif fault == 'burst':
            self._hold_until_ns = time.monotonic_ns() + 20_000_000
        if fault == 'gap':
            log.dropped += 1
            return
        if fault == 'truncate':
            # at least 2 bytes missing: a single missing CRC byte could be supplied by
            # the next byte on the wire (1 in 256) and the frame would survive
            cut = self._random.randint(1, len(data) - 2)
            if self.protocol_name == 'binary':
                self._out += data[:cut]
                log.dropped += 1
                log.corrupt += 1 if cut >= 3 else 0
            else:
                # a cut line runs into the next line: one malformed line, this scan lost;
                # the next scan is lost too (its line is the tail of the malformed one)
                self._out += data[:cut]
                self._ascii_merge_pending = True
                log.dropped += 1
            return
        if fault == 'bitflip':
            if self.protocol_name == 'binary':
                index = self._random.randrange(len(data))
                flipped = bytearray(data)
                flipped[index] ^= 1 << self._random.randrange(8)
                if protocol.SIGNATURE in flipped[1:]:
                    flipped = bytearray(data)  # never create a second candidate
                    flipped[5] ^= 0x01
                    index = 5
                self._out += flipped
                log.dropped += 1
                log.corrupt += 1 if index >= 3 else 0
            else:
                self._out += data.replace(b'T3:', b'T9:')
                log.dropped += 1
                log.corrupt += 1
            return
        if merging:
            self._ascii_merge_pending = False
            log.corrupt += 1
            log.dropped += 1
            self._out += data
            return
        self._out += data
        self.delivered.append(truth)
        self._release_held()

    def _transmit_sequence_fault(self, fault: str, kind: str | None, sample: Sample,
                                 data: bytes, truth: tuple) -> None:
        log = self.log
        if fault == 'implausible':  # the scan is lost, a CRC-valid impostor takes its place
            self._out += implausible_frame(sample, kind, self._random)
            log.implausible += 1
            log.corrupt += 1
            log.dropped += 1
            return
        if fault == 'reorder':  # sent right after the next scan
            self._held = (data, truth)
            log.late += 1
            return
        self._out += data
        self.delivered.append(truth)
        if fault == 'duplicate':
            self._out += data
            log.duplicate += 1
        else:  # restart: once the ring is empty (nothing lost)
            self._restart_pending = True

    def _release_held(self) -> None:
        """Send the reordered frame (after its successor, or at STOP)."""
        if self._held is not None:
            data, truth = self._held
            self._held = None
            self._out += data
            self.delivered.append(truth)

    def _flush_output(self) -> None:
        if time.monotonic_ns() < self._hold_until_ns:
            return
        while self._ring and len(self._out) < 4096:
            self._transmit(self._ring.popleft())
        if self._restart_pending and not self._ring:
            self._restart_device()
        if not self._out:
            return
        try:
            written = os.write(self._master, self._out)
        except BlockingIOError:
            written = 0
        del self._out[:written]


def main(argv: list[str] | None = None) -> None:
    """Run an emulated sensor until interrupted; prints the fault log at exit."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--link', default='/tmp/forte_sensor', help='symlink the host opens')
    parser.add_argument('--protocol', choices=('binary', 'ascii'), default='binary')
    parser.add_argument('--rate', type=int, default=int(SAMPLE_RATE), help='scan rate [Hz]')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--drift-ppm', type=float, default=0.0)
    for name in FAULTS:
        parser.add_argument(f'--{name.replace("_", "-")}', type=float, default=0.0,
                            help=f'probability per scan of fault {name}')
    args = parser.parse_args(argv)
    plan = FaultPlan(**{name: getattr(args, name) for name in FAULTS})
    if args.protocol == 'ascii' and any(getattr(plan, name) for name in BINARY_ONLY_FAULTS):
        parser.error(f'--{", --".join(BINARY_ONLY_FAULTS)} exist only with --protocol binary')
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with EmulatedSensor(args.link, args.protocol, args.rate, plan, args.seed,
                        args.drift_ppm) as sensor:
        print(f'emulated FORTE sensor ({args.protocol}) at {args.link}', flush=True)
        stop.wait()
        log = sensor.log
        print(f'scans {sensor.scans_generated}, delivered {len(sensor.delivered)}, '
              f'faults {log.counts}, expected dropped {log.dropped}, '
              f'expected corrupt {log.corrupt} (implausible {log.implausible}), '
              f'expected duplicate {log.duplicate}, expected late {log.late}, '
              f'device restarts {log.restarts}', flush=True)


if __name__ == '__main__':
    main()
