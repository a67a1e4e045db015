"""FORTE serial protocol v1 (binary frames) and the legacy ASCII ``T1:..,T6:..`` lines.

Pure Python, no rclpy. The byte layout, units and counting rules are documented in
``docs/firmware.md``; the C core in ``firmware/core`` implements the same protocol and both
are checked against the shared vectors in ``firmware/test_vectors``.

Frame (both directions, little-endian)::

    A5 5A | version=1 | type | length N | payload (N bytes) | CRC-16/CCITT-FALSE (2 bytes)

The CRC covers version, type, length and payload (initial value 0xFFFF, polynomial
0x1021, check value 0x29B1) and equals ``binascii.crc_hqx(data, 0xFFFF)``.

Main pieces
-----------
- :class:`FrameDecoder`: resynchronising stream decoder of binary frames, counts corrupt
  frames and discarded bytes, emits :data:`CORRUPT` markers in stream order.
- :class:`AsciiLineDecoder`: strict parser of the paper authors' ASCII lines.
- What is published of the decoded frames (plausibility, duplicates, reordering, drops,
  gap-free batches) is :mod:`forte_driver.serial.stream`'s.
- Encoders for every frame type (used by the emulated device and the tests).
"""
from __future__ import annotations

import binascii
import math
import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

from forte_ros.contract import CHANNEL_NAMES, COUNTS_PER_FULL_SCALE, N_CHANNELS
from forte_ros.sensor_identity import SensorIdentity

SYNC0 = 0xA5
SYNC1 = 0x5A
PROTOCOL_VERSION = 1
#: Bytes every frame starts with; the decoder hunts for them.
SIGNATURE = bytes([SYNC0, SYNC1, PROTOCOL_VERSION])
HEADER_SIZE = 5
CRC_SIZE = 2
SEQUENCE_MODULUS = 1 << 32
OVERRUN_MODULUS = 1 << 16

FLAG_SATURATED = 0x01
FLAG_OVERRUN = 0x02
FLAG_SESSION_START = 0x04


class FrameType(IntEnum):
    """Frame types (byte 3 of a frame)."""

    SAMPLE = 0x01
    COMMAND = 0x02
    ACK = 0x03
    INFO = 0x04


class Command(IntEnum):
    """Host commands."""

    START = 0x01
    STOP = 0x02
    IDENTIFY = 0x03
    SET_RATE = 0x04


class Status(IntEnum):
    """Acknowledgement status."""

    OK = 0
    UNKNOWN_COMMAND = 1
    BAD_ARGUMENT = 2
    BUSY = 3


_SAMPLE_STRUCT = struct.Struct('<IQ6hHBB')
_COMMAND_STRUCT = struct.Struct('<BBH')
_ACK_STRUCT = struct.Struct('<BBBBI')
_INFO_STRUCT = struct.Struct('<BBBBBBHHHQ')
#: Payload size [bytes] of each frame type.
PAYLOAD_SIZES = {
    FrameType.SAMPLE: _SAMPLE_STRUCT.size,
    FrameType.COMMAND: _COMMAND_STRUCT.size,
    FrameType.ACK: _ACK_STRUCT.size,
    FrameType.INFO: _INFO_STRUCT.size,
}
SAMPLE_FRAME_SIZE = HEADER_SIZE + PAYLOAD_SIZES[FrameType.SAMPLE] + CRC_SIZE
_PAYLOAD_SIZE_BY_BYTE = {int(k): v for k, v in PAYLOAD_SIZES.items()}


class Sample(NamedTuple):
    """One 6-channel scan as sent by the device (a named tuple: cheap to create).

    Attributes
    ----------
    sequence : int
        Scan index since START, modulo 2**32 [count].
    time_us : int
        Device clock at the scan instant [us].
    values : tuple of 6 int
        Readings in counts, 1024 = +1.0 = +1 inH2O, channel order :data:`CHANNEL_NAMES`.
    overruns : int
        Samples the device dropped since START, modulo 2**16 [count].
    flags : int
        ``FLAG_*`` bits.
    saturated : int
        Bit k set if channel k was clipped.
    """

    sequence: int
    time_us: int
    values: tuple[int, ...]
    overruns: int = 0
    flags: int = 0
    saturated: int = 0

    def normalised(self) -> tuple[float, ...]:
        """Readings on the -1..1 scale (+1 = +1 inH2O)."""
        return tuple(v / COUNTS_PER_FULL_SCALE for v in self.values)


@dataclass(frozen=True, slots=True)
class CommandFrame:
    """A host command (``command`` is a :class:`Command` code)."""

    command: int
    token: int
    argument: int = 0


@dataclass(frozen=True, slots=True)
class Ack:
    """Acknowledgement of one command; ``value`` is the rate [Hz] or, for STOP, the
    number of scans in the session."""

    command: int
    token: int
    status: int
    value: int


@dataclass(frozen=True, slots=True)
class Info:
    """Device identification (answer to IDENTIFY, after its ACK)."""

    protocol_version: int
    firmware_version: tuple[int, int, int]
    channel_count: int
    adc_bits: int
    counts_per_full_scale: int
    rate_hz: int
    ring_capacity: int
    device_id: int


@dataclass(frozen=True, slots=True)
class CorruptFrame:
    """Marker in the decoder output: a candidate frame was rejected here."""

    reason: str


#: Shared markers (the decoder output holds these instances).
CORRUPT_CRC = CorruptFrame('crc')
CORRUPT_HEADER = CorruptFrame('header')
CORRUPT_LINE = CorruptFrame('line')

Frame = Sample | CommandFrame | Ack | Info


def crc16(data: bytes | bytearray | memoryview) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of b'123456789' is 0x29B1)."""
    return binascii.crc_hqx(data, 0xFFFF)


def _frame(frame_type: int, payload: bytes) -> bytes:
    body = bytes((PROTOCOL_VERSION, frame_type, len(payload))) + payload
    return bytes((SYNC0, SYNC1)) + body + struct.pack('<H', crc16(body))


def encode_sample(sample: Sample) -> bytes:
    """Encode a :class:`Sample` into a complete frame (35 bytes)."""
    return _frame(FrameType.SAMPLE, _SAMPLE_STRUCT.pack(
        sample.sequence % SEQUENCE_MODULUS, sample.time_us, *sample.values,
        sample.overruns % OVERRUN_MODULUS, sample.flags, sample.saturated))


def encode_command(command: int, token: int, argument: int = 0) -> bytes:
    """Encode a host command frame (11 bytes)."""
    return _frame(FrameType.COMMAND, _COMMAND_STRUCT.pack(command, token & 0xFF, argument))


def encode_ack(ack: Ack) -> bytes:
    """Encode an acknowledgement frame (15 bytes)."""
    return _frame(FrameType.ACK, _ACK_STRUCT.pack(ack.command, ack.token, ack.status, 0,
                                                  ack.value))


def encode_info(info: Info) -> bytes:
    """Encode an identification frame (27 bytes)."""
    major, minor, patch = info.firmware_version
    return _frame(FrameType.INFO, _INFO_STRUCT.pack(
        info.protocol_version, major, minor, patch, info.channel_count, info.adc_bits,
        info.counts_per_full_scale, info.rate_hz, info.ring_capacity, info.device_id))


_TYPE_SAMPLE = int(FrameType.SAMPLE)
_TYPE_ACK = int(FrameType.ACK)
_TYPE_COMMAND = int(FrameType.COMMAND)
_unpack_sample = _SAMPLE_STRUCT.unpack_from
_new_tuple = tuple.__new__


def _parse(frame_type: int, buffer: bytearray, offset: int) -> Frame:
    if frame_type == _TYPE_SAMPLE:
        f = _unpack_sample(buffer, offset)
        return _new_tuple(Sample, (f[0], f[1], f[2:8], f[8], f[9], f[10]))
    if frame_type == _TYPE_ACK:
        f = _ACK_STRUCT.unpack_from(buffer, offset)
        return Ack(f[0], f[1], f[2], f[4])
    if frame_type == _TYPE_COMMAND:
        return CommandFrame(*_COMMAND_STRUCT.unpack_from(buffer, offset))
    f = _INFO_STRUCT.unpack_from(buffer, offset)
    return Info(f[0], (f[1], f[2], f[3]), f[4], f[5], f[6], f[7], f[8], f[9])


class FrameDecoder:
    """Resynchronising stream decoder of binary frames.

    Every input byte ends up either in a valid frame or in :attr:`discarded_bytes`
    (bytes of an incomplete candidate at the end wait in :attr:`pending_bytes`).
    A candidate starts wherever :data:`SIGNATURE` appears; a candidate with a wrong
    type/length or CRC is a corrupt frame and hunting resumes one byte after its start,
    so a good frame hidden inside rejected bytes is still found.

    Attributes
    ----------
    frames : int
        Valid frames decoded [count].
    corrupt_frames : int
        Candidates rejected for header or CRC errors [count].
    discarded_bytes : int
        Bytes not part of any valid frame [count].
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.frames = 0
        self.corrupt_frames = 0
        self.discarded_bytes = 0

    @property
    def pending_bytes(self) -> int:
        """Bytes held back as the start of a possibly incomplete frame."""
        return len(self._buffer)

    def reset(self) -> None:
        """Forget a partial frame (e.g. after reconnecting); counters are kept."""
        self._buffer.clear()

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame | CorruptFrame]:
        """Decode ``data`` appended to the stream.

        Returns
        -------
        list
            Decoded frames and :class:`CorruptFrame` markers, in stream order.
        """
        buffer = self._buffer
        buffer += data
        size = len(buffer)
        out: list[Frame | CorruptFrame] = []
        append = out.append
        position = 0
        find = buffer.find
        crc_hqx = binascii.crc_hqx
        payload_sizes = _PAYLOAD_SIZE_BY_BYTE
        frames = corrupt = discarded = 0
        while True:
            start = find(SIGNATURE, position)
            if start < 0:
                keep = 0
                if size - position >= 2 and buffer[size - 2] == SYNC0 and buffer[size - 1] == SYNC1:
                    keep = 2
                elif size - position >= 1 and buffer[size - 1] == SYNC0:
                    keep = 1
                discarded += size - position - keep
                position = size - keep
                break
            discarded += start - position
            if size - start < HEADER_SIZE:
                position = start
                break
            frame_type = buffer[start + 3]
            payload_size = payload_sizes.get(frame_type)
            if payload_size is None or buffer[start + 4] != payload_size:
                corrupt += 1
                discarded += 1
                append(CORRUPT_HEADER)
                position = start + 1
                continue
            end = start + HEADER_SIZE + payload_size + CRC_SIZE
            if end > size:
                position = start
                break
            received_crc = buffer[end - 2] | (buffer[end - 1] << 8)
            if crc_hqx(buffer[start + 2:end - 2], 0xFFFF) != received_crc:
                corrupt += 1
                discarded += 1
                append(CORRUPT_CRC)
                position = start + 1
                continue
            if frame_type == _TYPE_SAMPLE:
                f = _unpack_sample(buffer, start + HEADER_SIZE)
                append(_new_tuple(Sample, (f[0], f[1], f[2:8], f[8], f[9], f[10])))
            else:
                append(_parse(frame_type, buffer, start + HEADER_SIZE))
            frames += 1
            position = end
        del buffer[:position]
        self.frames += frames
        self.corrupt_frames += corrupt
        self.discarded_bytes += discarded
        return out


@dataclass(frozen=True, slots=True)
class AsciiSample:
    """One line of the legacy ASCII protocol: 6 readings on the -1..1 scale."""

    values: tuple[float, ...]


class AsciiLineDecoder:
    """Strict parser of the legacy ``T1:<v>,T2:<v>,...,T6:<v>\\n`` lines.

    A line is accepted only if it has exactly the keys T1..T6 in this order and six finite
    values in [-1, 1]; anything else is a corrupt line (counted, dropped, never replaced by
    a previous sample). Lines longer than ``max_line_bytes`` are corrupt (counted once,
    discarded whole, wherever the reads split them). After
    :meth:`reset` (connect) the stream may start in the middle of a line: if the first
    line is malformed it is discarded without being counted as corrupt.

    Attributes
    ----------
    lines : int
        Lines accepted [count].
    corrupt_lines : int
        Lines rejected [count].
    discarded_bytes : int
        Bytes of rejected lines and of the partial first line [count].
    """

    def __init__(self, max_line_bytes: int = 256) -> None:
        self._buffer = bytearray()
        self._skip_first_line = True
        self._discarding = False  # inside an overlong line: drop bytes up to its newline
        self.max_line_bytes = max_line_bytes
        self.lines = 0
        self.corrupt_lines = 0
        self.discarded_bytes = 0

    def reset(self) -> None:
        """Forget a partial line; the next bytes may start mid-line."""
        self._buffer.clear()
        self._skip_first_line = True
        self._discarding = False

    @staticmethod
    def parse_line(line: bytes) -> tuple[float, ...] | None:
        """Parse one line without its newline; ``None`` if it is malformed."""
        fields = line.rstrip(b'\r').split(b',')
        if len(fields) != N_CHANNELS:
            return None
        values = []
        for index, field in enumerate(fields, start=1):
            key, separator, text = field.partition(b':')
            if separator != b':' or key.strip() != b'T%d' % index:
                return None
            try:
                value = float(text)
            except ValueError:
                return None
            if not math.isfinite(value) or value < -1.0 or value > 1.0:
                return None
            values.append(value)
        return tuple(values)

    def feed(self, data: bytes | bytearray | memoryview) -> list[AsciiSample | CorruptFrame]:
        """Decode ``data``; returns samples and :data:`CORRUPT_LINE` markers in order.

        The result does not depend on how the stream is split into calls: a line longer
        than ``max_line_bytes`` is rejected once, as soon as it is known to be too long,
        and the rest of it up to its newline is discarded unparsed.
        """
        buffer = self._buffer
        buffer += data
        out: list[AsciiSample | CorruptFrame] = []
        start = 0
        while True:
            end = buffer.find(b'\n', start)
            if end < 0:
                break
            line = bytes(buffer[start:end])
            start = end + 1
            if self._discarding:  # the tail of an overlong line, already counted
                self._discarding = False
                self.discarded_bytes += len(line) + 1
                continue
            self._take_line(line, out)
        del buffer[:start]
        if self._discarding:
            self.discarded_bytes += len(buffer)
            buffer.clear()
        elif len(buffer) > self.max_line_bytes:
            # already too long without its newline: reject it now, discard up to '\n'
            if not self._skip_first_line:
                self.corrupt_lines += 1
                out.append(CORRUPT_LINE)
            self._skip_first_line = False
            self._discarding = True
            self.discarded_bytes += len(buffer)
            buffer.clear()
        return out

    def _take_line(self, line: bytes, out: list[AsciiSample | CorruptFrame]) -> None:
        """Judge one complete line (without its newline)."""
        first_line = self._skip_first_line
        self._skip_first_line = False
        values = self.parse_line(line) if len(line) <= self.max_line_bytes else None
        if values is None and first_line:
            self.discarded_bytes += len(line) + 1
        elif values is None:
            self.corrupt_lines += 1
            self.discarded_bytes += len(line) + 1
            out.append(CORRUPT_LINE)
        else:
            self.lines += 1
            out.append(AsciiSample(values))


def format_ascii_line(values: tuple[float, ...] | list[float]) -> bytes:
    """Format readings as one legacy ASCII line; ``repr`` keeps every float exact."""
    return (','.join(f'T{k + 1}:{float(v)!r}' for k, v in enumerate(values)) + '\n').encode()


def normalise_adc_code(code: int, zero_code: int, half_span_code: int) -> tuple[int, bool]:
    """Map a raw ADC code to protocol counts exactly as the firmware does.

    ``round((code - zero) * 1024 / half_span)`` with ties away from zero, clipped to
    [-1024, 1024].

    Returns
    -------
    tuple of (int, bool)
        Reading [counts] and whether it was clipped.
    """
    half_span = half_span_code if half_span_code > 0 else 1
    numerator = (code - zero_code) * COUNTS_PER_FULL_SCALE
    sign = -1 if numerator < 0 else 1
    value = sign * ((2 * abs(numerator) + half_span) // (2 * half_span))
    if value > COUNTS_PER_FULL_SCALE:
        return COUNTS_PER_FULL_SCALE, True
    if value < -COUNTS_PER_FULL_SCALE:
        return -COUNTS_PER_FULL_SCALE, True
    return value, False


def sensor_identity(info: Info, rate_hz: int | None = None) -> SensorIdentity:
    """The sensor identity of an IDENTIFY answer (forte_msgs/SensorInfo's fields).

    Parameters
    ----------
    info : Info
        The board's answer to IDENTIFY.
    rate_hz : int, optional
        The rate the board acknowledged since (SET_RATE) [Hz]; default ``info.rate_hz``.

    Returns
    -------
    SensorIdentity
        ``device_id`` as 16 hex digits, firmware ``'major.minor.patch'``; the channel order
        of docs/contracts.md for a six-channel board, ``channel_<k>`` names otherwise (so a
        board of another size never matches a FORTE model).
    """
    names = CHANNEL_NAMES if info.channel_count == N_CHANNELS else tuple(
        f'channel_{index}' for index in range(info.channel_count))
    return SensorIdentity(
        source='serial', device_id=f'{info.device_id:016x}',
        firmware='.'.join(str(part) for part in info.firmware_version),
        protocol_version=info.protocol_version,
        sample_rate=float(info.rate_hz if rate_hz is None else rate_hz), channel_names=names,
        counts_per_full_scale=info.counts_per_full_scale, adc_bits=info.adc_bits)
