"""Independent FORTE protocol v1 encoder and fault-stream generator (test helper).

Written from ``docs/firmware.md`` only - ``struct`` and ``binascii.crc_hqx`` - and not from
``forte_driver.serial.protocol``, so the decoder and stream accounting are checked against a
second implementation of the byte layout. Used by ``test_fault_streams.py`` and by
``benchmarks/bench_fault_streams.py``.

A stream is a series of device sessions. Every session is a device that samples on the
scan grid (device time = whole multiple of the period), consumes a sequence number for
each scan it drops itself (overrun) and sets the flags as the firmware does. Faults are
applied per transmitted frame; the generator knows exactly what each fault must do to
the counters (see :class:`Expected`) and which samples must be published, in order.
"""
from __future__ import annotations

import binascii
import random
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field

SIGNATURE = b'\xa5\x5a\x01'
FRAME_SAMPLE, FRAME_ACK = 0x01, 0x03
#: Payload length per frame type (docs/firmware.md, Protocol v1).
PAYLOAD_LENGTHS = {0x01: 28, 0x02: 4, 0x03: 8, 0x04: 20}
SAMPLE_LAYOUT = struct.Struct('<IQ6hHBB')
ACK_LAYOUT = struct.Struct('<BBBBI')
COMMAND_START = 1
#: Garbage bytes that can never start or continue a signature.
QUIET_BYTES = bytes(b for b in range(256) if b not in (0xA5, 0x5A, 0x01))


def encode_frame(frame_type: int, payload: bytes) -> bytes:
    """Sync, version 1, type, length, payload, CRC-16/CCITT-FALSE of bytes 2..4+N."""
    body = bytes((0x01, frame_type, len(payload))) + payload
    return b'\xa5\x5a' + body + struct.pack('<H', binascii.crc_hqx(body, 0xFFFF))


def encode_sample_frame(sequence: int, time_us: int, values: tuple[int, ...],
                        overruns: int = 0, flags: int = 0, saturated: int = 0) -> bytes:
    """A SAMPLE frame (35 bytes); sequence mod 2**32, overruns mod 2**16."""
    return encode_frame(FRAME_SAMPLE, SAMPLE_LAYOUT.pack(
        sequence % (1 << 32), time_us % (1 << 64), *values, overruns % (1 << 16), flags,
        saturated))


def encode_start_ack(token: int, rate_hz: int) -> bytes:
    """The acknowledgement of START (status OK, value = rate)."""
    return encode_frame(FRAME_ACK, ACK_LAYOUT.pack(COMMAND_START, token, 0, 0, rate_hz))


def valid_candidate_at(data: bytes | bytearray, position: int) -> bool:
    """Whether a frame starting at ``position`` would pass the header and CRC checks."""
    if data[position:position + 3] != SIGNATURE or position + 5 > len(data):
        return False
    length = PAYLOAD_LENGTHS.get(data[position + 3])
    end = position + 5 + (length or 0) + 2
    if length is None or data[position + 4] != length or end > len(data):
        return False
    received = data[end - 2] | data[end - 1] << 8
    return binascii.crc_hqx(bytes(data[position + 2:end - 2]), 0xFFFF) == received


@dataclass
class FaultRates:
    """Probability of each fault per transmitted scan (at most one fault per scan)."""

    garbage: float = 0.01       # quiet garbage before the frame: no effect
    false_sync: float = 0.005   # a false 'A5 5A 01' header before the frame: 1 corrupt
    flip: float = 0.01          # one bit flipped: 1 dropped, 1 corrupt if in byte >= 3
    truncate: float = 0.01      # frame cut after 1..33 bytes: 1 dropped, 1 corrupt if >= 3
    gap: float = 0.01           # frame not sent: 1 dropped
    delay: float = 0.005        # frame sent 1..8 frames later: 1 late
    duplicate: float = 0.005    # frame sent again 0..8 frames later: 1 duplicate
    implausible: float = 0.005  # a CRC-valid implausible frame before the frame
    overrun: float = 0.002      # the device itself drops the scan: 1 dropped, 1 overrun

    @classmethod
    def only(cls, **rates: float) -> FaultRates:
        """The faults named in ``rates`` with those probabilities, every other one 0."""
        return cls(**{**{name: 0.0 for name in cls.__dataclass_fields__}, **rates})


@dataclass
class Expected:
    """What the host must report after the whole stream (and :meth:`flush`)."""

    sent_scans: int = 0          # scans transmitted intact (first copy)
    dropped: int = 0
    duplicate: int = 0
    late: int = 0
    decoder_corrupt: int = 0
    implausible: int = 0
    restarts: int = 0
    device_overruns: int = 0
    counts: dict[str, int] = field(default_factory=dict)  # injected faults per kind


@dataclass
class Block:
    """A piece of the byte stream and the rows the host must publish for it, in order."""

    data: bytes
    rows: list[tuple[int, tuple[int, ...]]]  # (device time [us], readings [counts])


@dataclass
class _Session:
    kind: str            # attach, start, device_restart, power_cycle, foreign_start
    scans: int           # scan instants in the session
    sequence: int        # device sequence counter (not wrapped)
    time_us: int         # device time of the next scan instant [us]
    overruns: int = 0
    reported: int = 0
    first_pushed: bool = True
    from_zero: bool = False
    first_received: int | None = None
    overrun_index: int = -1_000_000
    index: int = 0
    last_received: int = 0
    received: int = 0


class FaultStreamGenerator:
    """Seeded generator of FORTE byte streams with exactly accounted faults.

    Parameters
    ----------
    seed : int
        Random seed (the same seed gives the same stream).
    rates : FaultRates
        Fault probabilities per scan.
    period_us : int
        Scan period [us].
    reorder_window : int
        The host's reorder window; delays and duplicates stay well inside it.
    """

    KINDS = ('start', 'device_restart', 'power_cycle', 'foreign_start')

    def __init__(self, seed: int, rates: FaultRates | None = None, period_us: int = 500,
                 reorder_window: int = 64) -> None:
        self.rng = random.Random(seed)
        self.rates = rates or FaultRates()
        self.period_us = period_us
        self.max_shift = min(8, reorder_window // 4)
        self.expected = Expected(counts={})
        self._table = self._fault_table()

    def _fault_table(self) -> list[tuple[float, str]]:
        table, total = [], 0.0
        for name, rate in vars(self.rates).items():
            total += rate
            table.append((total, name))
        return table

    def blocks(self, total_scans: int, block_scans: int = 50_000) -> Iterator[Block]:
        """Yield the stream in blocks (each ends with clean frames: no candidate spans
        two blocks); :attr:`expected` is complete once the iterator is exhausted."""
        remaining = total_scans
        session = self._first_session(total_scans)
        out = _BlockWriter()
        while True:
            remaining -= session.scans
            yield from self._session(session, out, block_scans)
            self._close(session)
            if remaining < 300:
                break
            session = self._next_session(
                session, min(remaining, self._session_length(total_scans)), out)
        if out.data:
            yield out.take(self)
        self.expected.counts = dict(self.expected.counts)

    def _session_length(self, total_scans: int) -> int:
        """Scans of one session: a sixth to a third of the stream, at least 300."""
        return max(300, self.rng.randint(total_scans // 6, total_scans // 3 + 1))

    def _first_session(self, total_scans: int) -> _Session:
        """A host attaching mid-stream: sequence just below the 2**32 wrap, device time
        near 2**63 us, overruns already counted."""
        rng = self.rng
        start_time = (2 ** 63 // self.period_us - 8 * total_scans - 10_000) * self.period_us
        session = _Session('attach', 0, (1 << 32) - rng.randint(100, 5000), start_time,
                           overruns=rng.randint(0, 5000))
        session.reported = session.overruns
        session.first_pushed = False
        session.scans = min(total_scans, self._session_length(total_scans))
        return session

    def _next_session(self, old: _Session, scans: int, out: _BlockWriter) -> _Session:
        rng = self.rng
        kind = rng.choice(self.KINDS)
        self.expected.counts[kind] = self.expected.counts.get(kind, 0) + 1
        idle = rng.randint(10, 10_000) * self.period_us
        time_us = old.time_us + idle
        if kind == 'power_cycle':
            time_us = rng.randint(2_000, 20_000) * self.period_us  # device clock restarted
        initial = rng.randint(0, 3) if kind in ('start', 'device_restart') else 0
        session = _Session(kind, scans, initial, time_us + initial * self.period_us,
                           overruns=initial)
        if kind == 'start':
            out.write(encode_start_ack(rng.randrange(256), 1_000_000 // self.period_us),
                      frame=True)
            session.from_zero = True
        elif kind == 'device_restart':
            session.from_zero = True      # its first-scan flag arrives (kept clean)
            self.expected.restarts += 1
        else:
            session.sequence = max(session.sequence, 1)
            session.first_pushed = False  # the first scan (with the flag) is lost
            self.expected.restarts += 1
        return session

    def _close(self, session: _Session) -> None:
        expected = self.expected
        low = 0 if session.from_zero else session.first_received
        expected.dropped += session.last_received - low + 1 - session.received
        expected.device_overruns += session.overruns

    def _session(self, session: _Session, out: _BlockWriter, block_scans: int
                 ) -> Iterator[Block]:
        rng, rates, expected = self.rng, self.rates, self.expected
        clean_head, clean_tail = 6, 12
        for index in range(session.scans):
            session.index = index
            middle = clean_head <= index < session.scans - clean_tail
            if middle and rng.random() < rates.overrun:
                session.sequence += 1
                session.time_us += self.period_us
                session.overruns += 1
                session.overrun_index = index
                continue
            sequence, time_us = session.sequence, session.time_us
            session.sequence += 1
            session.time_us += self.period_us
            values, saturated = self._readings(sequence)
            flags = (1 if saturated else 0) | (2 if session.overruns != session.reported else 0)
            if session.first_pushed:
                flags |= 4
                session.first_pushed = False
            session.reported = session.overruns
            frame = encode_sample_frame(sequence, time_us, values, session.overruns, flags,
                                        saturated)
            fault = self._choose(middle and not out.forced_clean and SIGNATURE not in frame[1:])
            delivered = self._transmit(frame, fault, session, out, (sequence, time_us))
            if delivered:
                if session.first_received is None:
                    session.first_received = sequence
                session.last_received = sequence
                session.received += 1
                expected.sent_scans += 1
                if fault != 'delay':
                    out.rows.append((time_us, values))
            out.release()
            out.scans += 1
            if out.scans >= block_scans and out.quiet():
                yield out.take(self)
        if session.first_received is None:
            session.first_received = 0

    def _readings(self, sequence: int) -> tuple[tuple[int, ...], int]:
        values = [(sequence * 2654435761 + k * 40503) % 2049 - 1024 for k in range(6)]
        saturated = 0
        if sequence % 97 == 13:  # a clipped scan: reading at the limit, bit and flag set
            channel = sequence % 6
            values[channel] = 1024 if sequence % 2 else -1024
            saturated = 1 << channel
        return tuple(values), saturated

    def _choose(self, allowed: bool) -> str:
        if not allowed:
            return 'none'
        draw = self.rng.random()
        for limit, name in self._table:
            if draw < limit:
                return 'none' if name == 'overrun' else name
        return 'none'

    def _transmit(self, frame: bytes, fault: str, session: _Session, out: _BlockWriter,
                  scan: tuple[int, int]) -> bool:
        """Write one frame with ``fault``; whether the scan was delivered intact."""
        rng, expected = self.rng, self.expected
        if fault != 'none':
            expected.counts[fault] = expected.counts.get(fault, 0) + 1
        if fault == 'garbage':
            out.write(bytes(rng.choice(QUIET_BYTES) for _ in range(rng.randint(1, 40))))
        elif fault == 'false_sync':
            header = bytes((1, 28)) if rng.random() < 0.5 else bytes((rng.choice((7, 9)), 28))
            tail = bytes(rng.choice(QUIET_BYTES) for _ in range(rng.randint(0, 25)))
            out.write(SIGNATURE[:2] + SIGNATURE[2:] + header + tail, corrupt=1)
        elif fault == 'implausible':
            out.write(self._implausible(session, scan), frame=True)
            expected.implausible += 1
        if fault == 'flip':
            while True:
                position = rng.randrange(len(frame))
                damaged = bytearray(frame)
                damaged[position] ^= 1 << rng.randrange(8)
                if SIGNATURE not in damaged[1:]:
                    break
            out.write(bytes(damaged), corrupt=int(position >= 3))
            return False
        if fault == 'truncate':
            cut = rng.randint(1, len(frame) - 2)
            out.write(frame[:cut], corrupt=int(cut >= 3))
            return False
        if fault == 'gap':
            return False
        if fault == 'delay':
            out.hold(frame, rng.randint(1, self.max_shift))
            expected.late += 1
            return True
        out.write(frame, frame=True)
        if fault == 'duplicate':
            out.hold(frame, rng.randint(0, self.max_shift))
            expected.duplicate += 1
        return True

    def _implausible(self, session: _Session, scan: tuple[int, int]) -> bytes:
        """A CRC-valid frame the firmware cannot have sent in this session."""
        rng, period = self.rng, self.period_us
        sequence, time_us = scan
        values = [0, 1, -1, 2, -2, 3]
        overruns = session.overruns
        kind = rng.randrange(10)
        flags = saturated = 0
        if kind == 0:
            values[rng.randrange(6)] = rng.choice((1025, 28158, -1025, -32768, 32767))
        elif kind == 1:
            flags = 1 << rng.randint(3, 7)
        elif kind == 2:
            saturated, flags = 1 << rng.randint(6, 7), 1
        elif kind == 3:
            saturated, flags = 1 << rng.randrange(6), 1 if rng.random() < 0.5 else 0
        elif kind == 4:
            time_us += rng.randint(1, period - 1)                   # off the time line
        elif kind == 5:
            time_us += rng.choice((-1, 1)) * rng.randint(1, 1000) * period  # wrong instant
        elif kind == 6:
            overruns += rng.randint(100, 5000)                      # overruns jump
        elif kind == 7 and session.index - session.overrun_index > 100:
            flags = 2                                               # overrun flag, none
        elif kind == 7:
            time_us += rng.randint(1, period - 1)
        elif kind == 8:
            jump = rng.randint(10**5, 10**9)                        # far sequence
            sequence += jump
            time_us += (jump + rng.randint(1, 1000)) * period
        else:
            sequence = overruns = rng.randint(0, 60_000)            # a false first scan
            flags = 4 | (2 if overruns else 0)
            time_us += rng.randint(1, 10**6) * period
        return encode_sample_frame(sequence, time_us, tuple(values), overruns, flags,
                                   saturated)


class _BlockWriter:
    """Accumulates one block of bytes; records damaged byte ranges for the CRC check."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.rows: list[tuple[int, tuple[int, ...]]] = []
        self.damaged: list[tuple[int, int, int]] = []  # (start, end, corrupt count)
        self.held: list[list] = []                     # [frames to wait, bytes]
        self.scans = 0
        self.forced_clean = False
        self._clean_run = 0

    def write(self, data: bytes, corrupt: int = 0, frame: bool = False) -> None:
        if not frame:
            self.damaged.append((len(self.data), len(self.data) + len(data), corrupt))
            self._clean_run = 0
        else:
            self._clean_run += 1
        self.data += data
        self.forced_clean = False

    def hold(self, data: bytes, frames_later: int) -> None:
        self.held.append([frames_later, data])
        self.forced_clean = True  # the next scan goes out clean: it overtakes this one

    def release(self) -> None:
        still = []
        for entry in self.held:
            if entry[0] <= 0:
                self.data += entry[1]
            else:
                entry[0] -= 1
                still.append(entry)
        self.held = still

    def quiet(self) -> bool:
        return not self.held and self._clean_run >= 2

    def take(self, generator: FaultStreamGenerator) -> Block:
        """Finish the block: remove damaged bytes that form a CRC-valid candidate by
        chance (~1 in 65 536; the scan is then a plain gap), account the rest."""
        data, damaged = self.data, self.damaged
        while True:
            hit = next((k for k in range(len(damaged) - 1, -1, -1)
                        if any(valid_candidate_at(data, p)
                               for p in range(damaged[k][0], damaged[k][1]))), None)
            if hit is None:
                break
            start, end, _ = damaged.pop(hit)
            del data[start:end]
            damaged[hit:] = [(s - (end - start), e - (end - start), c)
                             for s, e, c in damaged[hit:]]
            generator.expected.counts['crc_collision'] = (
                generator.expected.counts.get('crc_collision', 0) + 1)
        generator.expected.decoder_corrupt += sum(c for _, _, c in damaged)
        block = Block(bytes(data), self.rows)
        self.data, self.rows, self.damaged, self.scans = bytearray(), [], [], 0
        return block


@dataclass
class Report:
    """What the host published and counted for a stream, compared with :class:`Expected`."""

    frames_sent: int = 0
    published: int = 0
    invented: int = 0    # published rows that are no intact scan that was sent
    altered: int = 0     # published rows whose device time was sent with other readings
    missing: int = 0     # rows that should have been published but were not
    order_errors: int = 0
    counters: dict[str, tuple[int, int]] = field(default_factory=dict)  # name: (exp, got)
    bytes_fed: int = 0

    @property
    def counter_errors(self) -> int:
        return sum(expected != got for expected, got in self.counters.values())


def run_stream(generator: FaultStreamGenerator, total_scans: int, chunk_seed: int,
               batch_size: int = 20, block_scans: int = 50_000,
               max_chunk: int = 4096) -> Report:
    """Feed a generated stream through ``FrameDecoder`` + ``StreamAssembler`` in random
    chunk sizes (1..``max_chunk`` bytes, log-uniform) and compare with the truth."""
    import numpy as np

    from forte_driver.serial.protocol import Ack, CorruptFrame, FrameDecoder, Sample
    from forte_driver.serial.stream import StreamAssembler

    rng = random.Random(chunk_seed)
    period = generator.period_us
    decoder = FrameDecoder()
    assembler = StreamAssembler(batch_size, sample_period_us=period)
    report = Report()
    truth: dict[int, set[tuple[int, ...]]] = {}
    expected_rows: list[tuple[int, tuple[int, ...]]] = []
    published: list[tuple[int, tuple[int, ...]]] = []
    last_sequence = None

    def take() -> None:
        nonlocal last_sequence
        for batch in assembler.take_batches():
            if last_sequence is not None and batch.first_sequence <= last_sequence:
                report.order_errors += 1
            last_sequence = batch.first_sequence + len(batch.values) - 1
            counts = np.rint(batch.values * 1024).astype(np.int64).tolist()
            for row, values in enumerate(counts):
                time_us = (batch.device_time_us + row * period) % (1 << 64)
                published.append((time_us, tuple(values)))

    for block in generator.blocks(total_scans, block_scans):
        for time_us, values in block.rows:
            truth.setdefault(time_us, set()).add(values)
        expected_rows += block.rows
        data, position = block.data, 0
        report.bytes_fed += len(data)
        while position < len(data):
            size = min(max_chunk, int(2 ** rng.uniform(0, 13)))
            for item in decoder.feed(data[position:position + size]):
                if type(item) is Sample:
                    assembler.add_sample(item)
                elif isinstance(item, CorruptFrame):
                    assembler.add_corrupt(item.reason)
                elif isinstance(item, Ack) and item.command == 1 and item.status == 0:
                    assembler.start_session(from_zero=True)
            position += size
        take()
        _compare(report, truth, expected_rows, published)
    assembler.flush()
    take()
    _compare(report, truth, expected_rows, published)
    report.missing += len(expected_rows)
    expected = generator.expected
    report.frames_sent = expected.sent_scans
    report.counters = {
        'dropped': (expected.dropped, assembler.dropped_frames),
        'duplicate': (expected.duplicate, assembler.duplicate_frames),
        'late': (expected.late, assembler.late_frames),
        'stale': (0, assembler.stale_frames),
        'implausible': (expected.implausible, assembler.implausible_frames),
        'corrupt': (expected.decoder_corrupt + expected.implausible, assembler.corrupt_frames),
        'decoder_corrupt': (expected.decoder_corrupt, decoder.corrupt_frames),
        'restarts': (expected.restarts, assembler.restarts),
        'device_overruns': (expected.device_overruns, assembler.device_overruns),
        'unconfirmed': (0, assembler.unconfirmed_frames),
    }
    return report


def _compare(report: Report, truth: dict, expected_rows: list, published: list) -> None:
    """Match published rows against the expected ones (in order), then forget both."""
    matched = 0
    for row in published:
        report.published += 1
        known = truth.get(row[0])
        if known is None:
            report.invented += 1
        elif row[1] not in known:
            report.altered += 1
        if matched < len(expected_rows) and expected_rows[matched] == row:
            matched += 1
        else:
            report.order_errors += 1
    del expected_rows[:matched]
    published.clear()
