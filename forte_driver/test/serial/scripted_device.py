"""Scripted FORTE device on a pty and a one-START-session fault stream (test helper).

Written from ``docs/firmware.md`` (``struct`` + ``binascii.crc_hqx``), not from
``forte_driver.serial.protocol``. Used by ``benchmarks/bench_node_fault_stream.py`` to push a
pre-generated fault stream through the real ``serial_sensor_node`` faster than real time:

- :class:`OneStartSessionGenerator`: the stream of :class:`fault_streams.FaultStreamGenerator`
  as the host's own START creates it (sequence from 0 after 0..3 device-missed scans,
  first-scan flag on the first scan, no START ACK inside the stream: the device sends it),
  followed only by device restarts (first-scan flag, clean); every in-session fault kind.
  Device time starts ``wrap_after_scans`` scan instants before 2**64, so the u64 device
  clock wraps inside the first session.
- :class:`ScriptedDevice`: the device end of a pty behind a symlink. It acknowledges
  STOP, IDENTIFY (+ INFO), SET_RATE and START like the firmware and, once STARTed, writes
  the stream in random-size chunks (1 B .. 4 KiB, log-uniform) as fast as the host reads.
  Replies to commands that arrive while the stream is being written are queued and sent
  after it (the firmware never cuts a frame), and counted.
"""
from __future__ import annotations

import binascii
import os
import random
import select
import struct
import tempfile
import threading
import time
import tty

from fault_streams import (
    FRAME_ACK,
    FaultStreamGenerator,
    _BlockWriter,
    _Session,
    encode_frame,
)

FRAME_COMMAND, FRAME_INFO = 0x02, 0x04
COMMAND_START, COMMAND_STOP, COMMAND_IDENTIFY, COMMAND_SET_RATE = 1, 2, 3, 4
STATUS_OK, STATUS_UNKNOWN, STATUS_BAD_ARGUMENT, STATUS_BUSY = 0, 1, 2, 3
COMMAND_LAYOUT = struct.Struct('<BBH')
ACK_LAYOUT = struct.Struct('<BBBBI')
#: protocol, firmware major/minor/patch, channels, ADC bits, counts, rate, ring, device id
INFO_LAYOUT = struct.Struct('<BBBBBBHHHQ')
COMMAND_FRAME_SIZE = 5 + COMMAND_LAYOUT.size + 2


class OneStartSessionGenerator(FaultStreamGenerator):
    """Fault stream of one host START session, then device restarts only.

    Attributes
    ----------
    session_starts : list of tuple of int
        (device time [us, unwrapped], device sequence) of the first scan instant of each
        session, in stream order.
    """

    KINDS = ('device_restart',)

    def __init__(self, seed: int, wrap_after_scans: int = 1000, **kwargs) -> None:
        super().__init__(seed, **kwargs)
        self.wrap_after_scans = wrap_after_scans
        self.session_starts: list[tuple[int, int]] = []

    def start_time_us(self) -> int:
        """Device time of the first scan instant [us, unwrapped]."""
        return (2 ** 64 // self.period_us - self.wrap_after_scans) * self.period_us

    def _first_session(self, total_scans: int) -> _Session:
        """The START session the host's command created (instead of an attach)."""
        initial = self.rng.randint(0, 3)  # scans the device missed right after START
        session = _Session('start', 0, initial,
                           self.start_time_us() + initial * self.period_us, overruns=initial)
        session.from_zero = True
        session.scans = min(total_scans, self._session_length(total_scans))
        self.expected.counts['host_start'] = 1
        return session

    def _session(self, session: _Session, out: _BlockWriter, block_scans: int):
        self.session_starts.append((session.time_us, session.sequence))
        yield from super()._session(session, out, block_scans)


def encode_ack(command: int, token: int, status: int, value: int) -> bytes:
    """An ACK frame (type 0x03, 15 bytes)."""
    return encode_frame(FRAME_ACK, ACK_LAYOUT.pack(command, token, status, 0, value))


def encode_info(rate_hz: int) -> bytes:
    """An INFO frame (type 0x04, 27 bytes) of a scripted board with a 512-scan ring."""
    return encode_frame(FRAME_INFO, INFO_LAYOUT.pack(1, 0, 9, 0, 6, 12, 1024, rate_hz, 512,
                                                     0x00F0_47E5_C0DE_0001))


def parse_commands(buffer: bytearray) -> list[tuple[int, int, int]]:
    """Remove and return the complete COMMAND frames at the start of ``buffer`` as
    (command, token, argument); bytes that cannot start a valid command are dropped."""
    commands = []
    while True:
        start = buffer.find(b'\xa5\x5a\x01')
        if start < 0:
            del buffer[:max(0, len(buffer) - 2)]
            return commands
        del buffer[:start]
        if len(buffer) < COMMAND_FRAME_SIZE:
            return commands
        frame = bytes(buffer[:COMMAND_FRAME_SIZE])
        crc = struct.unpack_from('<H', frame, COMMAND_FRAME_SIZE - 2)[0]
        if (frame[3] == FRAME_COMMAND and frame[4] == COMMAND_LAYOUT.size
                and binascii.crc_hqx(frame[2:-2], 0xFFFF) == crc):
            commands.append(COMMAND_LAYOUT.unpack_from(frame, 5))
            del buffer[:COMMAND_FRAME_SIZE]
        else:
            del buffer[:1]


class ScriptedDevice:
    """The device end of a pty that answers commands and streams ``stream`` on START.

    Parameters
    ----------
    stream : bytes
        The bytes to write after the ACK of the first START.
    chunk_seed : int
        Seed of the random write sizes.
    max_chunk : int
        Largest write [bytes].
    max_bytes_per_s : float or None
        Pace the stream to at most this rate [B/s] (None: as fast as the host reads;
        70 000 B/s is real time at 2 kHz).

    Attributes
    ----------
    link : str
        Symlink to the pty slave (the port the host opens).
    commands : list of tuple
        (monotonic time [s], command, token, argument) of every command received.
    late_replies : int
        Replies queued because their command arrived while the stream was written.
    stream_started, stream_finished : float or None
        Monotonic times of the first and after the last stream write [s].
    """

    def __init__(self, stream: bytes, chunk_seed: int, max_chunk: int = 4096,
                 max_bytes_per_s: float | None = None) -> None:
        self.stream = stream
        self.max_bytes_per_s = max_bytes_per_s
        self.rng = random.Random(chunk_seed)
        self.max_chunk = max_chunk
        self.rate_hz = 2000
        self.commands: list[tuple[float, int, int, int]] = []
        self.late_replies = 0
        self.stream_started: float | None = None
        self.stream_finished: float | None = None
        self._streaming = False
        self._queued = bytearray()
        self._write_lock = threading.Lock()
        self._stop = threading.Event()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.link = os.path.join(tempfile.mkdtemp(prefix='forte_scripted_'), 'forte_sensor')
        os.symlink(os.ttyname(self._slave), self.link)
        self._reader = threading.Thread(target=self._read_commands, daemon=True)
        self._writer: threading.Thread | None = None
        self._reader.start()

    def _write_all(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            written = os.write(self._master, view)
            view = view[written:]

    def _read_commands(self) -> None:
        buffer = bytearray()
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                buffer += os.read(self._master, 4096)
            except OSError:
                return
            for command, token, argument in parse_commands(buffer):
                self.commands.append((time.monotonic(), command, token, argument))
                self._answer(command, token, argument)

    def _answer(self, command: int, token: int, argument: int) -> None:
        start = False
        if command == COMMAND_STOP:
            reply = encode_ack(command, token, STATUS_OK, 0)
        elif command == COMMAND_IDENTIFY:
            reply = encode_ack(command, token, STATUS_OK, self.rate_hz) + encode_info(
                self.rate_hz)
        elif command == COMMAND_SET_RATE:
            busy = self._writer is not None
            valid = 1 <= argument <= 4000 and 1_000_000 % argument == 0
            status = STATUS_BUSY if busy else STATUS_OK if valid else STATUS_BAD_ARGUMENT
            if status == STATUS_OK:
                self.rate_hz = argument
            reply = encode_ack(command, token, status, self.rate_hz)
        elif command == COMMAND_START:
            start = self._writer is None
            reply = encode_ack(command, token, STATUS_OK if start else STATUS_BUSY,
                               self.rate_hz)
        else:
            reply = encode_ack(command, token, STATUS_UNKNOWN, 0)
        with self._write_lock:
            if self._streaming:
                self._queued += reply  # sent after the stream: never inside a frame
                self.late_replies += 1
                return
            self._write_all(reply)
            if start:
                self._streaming = True
                self._writer = threading.Thread(target=self._write_stream, daemon=True)
                self._writer.start()

    def _write_stream(self) -> None:
        data, position = self.stream, 0
        self.stream_started = time.monotonic()
        while position < len(data) and not self._stop.is_set():
            size = min(self.max_chunk, int(2 ** self.rng.uniform(0, 12.01)))
            try:
                self._write_all(data[position:position + size])
            except OSError:  # closed under the writer
                return
            position += size
            if self.max_bytes_per_s:
                ahead = position / self.max_bytes_per_s - (time.monotonic()
                                                           - self.stream_started)
                if ahead > 0.002:
                    time.sleep(ahead)
        self.stream_finished = time.monotonic()
        with self._write_lock:
            self._streaming = False
            if self._queued:
                self._write_all(bytes(self._queued))
                self._queued.clear()

    def close(self) -> None:
        """Stop the threads, close the pty and remove the symlink."""
        self._stop.set()
        self._reader.join(timeout=2.0)
        for fd in (self._master, self._slave):
            os.close(fd)
        os.unlink(self.link)
        os.rmdir(os.path.dirname(self.link))
