"""Strict parsers for the MCAP records that bag recovery needs (pure, no rclpy).

Every MCAP record is ``opcode (u8) | length (u64) | content (length bytes)``, little
endian. The parsers here accept a record's content only when every field fits and the
fields use up exactly the record's length: after damage, "the bytes parse exactly as this
record type" is what tells a real record from random bytes. They raise
:class:`InvalidRecord` otherwise. Layouts follow the MCAP specification (the same layouts
the ``mcap`` package reads in ``mcap.records``).
"""
from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass

from mcap.opcode import Opcode
from mcap.records import Chunk
from mcap.stream_reader import get_chunk_data_stream

#: The 8 magic bytes at both ends of an MCAP file.
MAGIC = b'\x89MCAP0\r\n'
#: Opcode (1 byte) plus length (8 bytes) in front of every record [bytes].
RECORD_HEADER = 9
#: Footer record: summary_start u64, summary_offset_start u64, summary_crc u32 [bytes].
FOOTER_CONTENT = 20
#: Chunk fields before the compression string: start, end, uncompressed size, CRC, string
#: length [bytes].
CHUNK_FIXED = 8 + 8 + 8 + 4 + 4
#: Largest chunk (compressed or uncompressed) or string the reader accepts [bytes]; the
#: ``mcap`` package's default record limit.
MAX_RECORD = 4 * 2**30
#: Compressions the reader can undo.
COMPRESSIONS = ('', 'zstd', 'lz4')
#: Opcodes defined by the specification.
KNOWN_OPCODES = frozenset(int(opcode) for opcode in Opcode)


class InvalidRecord(ValueError):
    """Bytes that do not parse as the expected record."""


def plausible_opcode(opcode: int) -> bool:
    """True for an opcode of the specification or a private one (0x80-0xFF)."""
    return opcode in KNOWN_OPCODES or opcode >= 0x80


class Fields:
    """Little-endian field reader over ``data[start:end]`` that refuses to overrun.

    Parameters
    ----------
    data : bytes or memoryview
        The buffer.
    start, end : int
        Byte range [start, end) holding the fields.
    """

    def __init__(self, data: bytes | memoryview, start: int = 0, end: int | None = None):
        self.data = data
        self.position = start
        self.end = len(data) if end is None else end

    def take(self, size: int) -> bytes | memoryview:
        if size < 0 or self.position + size > self.end:
            raise InvalidRecord(f'field of {size} bytes overruns the record')
        value = self.data[self.position:self.position + size]
        self.position += size
        return value

    def u16(self) -> int:
        return struct.unpack('<H', self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack('<I', self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack('<Q', self.take(8))[0]

    def string(self) -> str:
        try:
            return str(self.take(self.u32()), 'utf-8')
        except UnicodeDecodeError as error:
            raise InvalidRecord(f'string is not UTF-8: {error}') from error

    def string_map(self) -> dict[str, str]:
        size = self.u32()
        stop = self.position + size
        if stop > self.end:
            raise InvalidRecord('map overruns the record')
        result = {}
        while self.position < stop:
            key = self.string()
            result[key] = self.string()
        if self.position != stop:
            raise InvalidRecord('map entries do not fill the map length')
        return result

    def finish(self) -> None:
        """Require that the fields used up the whole range."""
        if self.position != self.end:
            raise InvalidRecord(f'{self.end - self.position} bytes left over after the fields')


@dataclass(frozen=True)
class SchemaRecord:
    """Schema: ``id`` (non-zero) and ROS type ``name``."""

    id: int
    name: str
    encoding: str


@dataclass(frozen=True)
class ChannelRecord:
    """Channel: ``id``, ``schema_id`` (0 = none), ``topic``."""

    id: int
    schema_id: int
    topic: str
    message_encoding: str


@dataclass(frozen=True)
class MessageRecord:
    """Message: channel, sequence, log and publish time [ns], payload."""

    channel_id: int
    sequence: int
    log_time: int
    publish_time: int
    data: bytes


@dataclass(frozen=True)
class ChunkHeader:
    """The fields of a chunk record before its compressed data.

    Attributes
    ----------
    record_length : int
        The record's length field [bytes] (may be damaged).
    header_size : int
        Opcode, length and fields up to the data [bytes].
    data_length : int
        Compressed data length field [bytes].
    """

    message_start_time: int
    message_end_time: int
    uncompressed_size: int
    uncompressed_crc: int
    compression: str
    data_length: int
    record_length: int
    header_size: int

    @property
    def extent(self) -> int:
        """Record size implied by the content fields [bytes], header included."""
        return self.header_size + self.data_length


@dataclass(frozen=True)
class ChunkIndexRecord:
    """The summary's entry for one chunk (times [ns], offsets and sizes [bytes])."""

    message_start_time: int
    message_end_time: int
    chunk_start_offset: int
    chunk_length: int
    message_index_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int


def parse_schema(content: bytes | memoryview) -> SchemaRecord:
    fields = Fields(content)
    schema_id, name, encoding = fields.u16(), fields.string(), fields.string()
    fields.take(fields.u32())
    fields.finish()
    if schema_id == 0:
        raise InvalidRecord('schema id 0 is reserved')
    return SchemaRecord(schema_id, name, encoding)


def parse_channel(content: bytes | memoryview) -> ChannelRecord:
    fields = Fields(content)
    channel_id, schema_id = fields.u16(), fields.u16()
    topic, encoding = fields.string(), fields.string()
    fields.string_map()
    fields.finish()
    return ChannelRecord(channel_id, schema_id, topic, encoding)


def parse_message(content: bytes | memoryview) -> MessageRecord:
    fields = Fields(content)
    channel_id, sequence = fields.u16(), fields.u32()
    log_time, publish_time = fields.u64(), fields.u64()
    return MessageRecord(channel_id, sequence, log_time, publish_time,
                         bytes(content[fields.position:]))


def parse_message_index(content: bytes | memoryview) -> tuple[int, int]:
    """Channel id and number of messages a message index record lists."""
    fields = Fields(content)
    channel_id, size = fields.u16(), fields.u32()
    fields.take(size)
    fields.finish()
    if size % 16:
        raise InvalidRecord('message index entries are not 16 bytes each')
    return channel_id, size // 16


def parse_chunk_index(content: bytes | memoryview) -> ChunkIndexRecord:
    fields = Fields(content)
    start, end, offset, length = fields.u64(), fields.u64(), fields.u64(), fields.u64()
    offsets_size = fields.u32()
    if offsets_size % 10:
        raise InvalidRecord('message index offsets are not 10 bytes each')
    fields.take(offsets_size)
    index_length, compression = fields.u64(), fields.string()
    compressed, uncompressed = fields.u64(), fields.u64()
    fields.finish()
    return ChunkIndexRecord(start, end, offset, length, index_length, compression,
                            compressed, uncompressed)


def parse_chunk_header(head: bytes) -> ChunkHeader:
    """Parse ``head``: the first bytes of a chunk record (opcode included).

    Raises
    ------
    InvalidRecord
        If ``head`` is too short, or the compression string is not one this reader knows
        how to read, or a size is beyond :data:`MAX_RECORD`.
    """
    fields = Fields(head)
    if fields.take(1)[0] != Opcode.CHUNK:
        raise InvalidRecord('not a chunk record')
    record_length = fields.u64()
    start, end, size, crc = fields.u64(), fields.u64(), fields.u64(), fields.u32()
    compression = fields.string()
    data_length = fields.u64()
    if compression not in COMPRESSIONS:
        raise InvalidRecord(f'unknown chunk compression {compression[:20]!r}')
    if size > MAX_RECORD or data_length > MAX_RECORD:
        raise InvalidRecord(f'chunk sizes {size}/{data_length} beyond the 4 GiB limit')
    if compression == '' and size != data_length:
        raise InvalidRecord('uncompressed chunk whose size fields disagree')
    return ChunkHeader(start, end, size, crc, compression, data_length, record_length,
                       fields.position)


def decompress(header: ChunkHeader, data: bytes) -> bytes:
    """The chunk's uncompressed records, checked against its size and CRC fields.

    Raises
    ------
    InvalidRecord
        If decompression fails, the size differs, or the CRC (when not 0) mismatches.
    """
    chunk = Chunk(compression=header.compression, data=data,
                  message_end_time=header.message_end_time,
                  message_start_time=header.message_start_time,
                  uncompressed_crc=header.uncompressed_crc,
                  uncompressed_size=header.uncompressed_size)
    try:  # the mcap package's codecs (zstandard, lz4), checks below
        stream, size = get_chunk_data_stream(chunk, validate_crc=False)
        records = stream.read(size)
    except Exception as error:  # the codecs raise their own error types
        raise InvalidRecord(f'{header.compression} decompression failed: {error}') from error
    if len(records) != header.uncompressed_size:
        raise InvalidRecord(f'decompressed to {len(records)} bytes, the chunk says '
                            f'{header.uncompressed_size}')
    if header.uncompressed_crc:
        crc = zlib.crc32(records)
        if crc != header.uncompressed_crc:
            raise InvalidRecord(f'CRC mismatch: computed {crc:#010x}, stored '
                                f'{header.uncompressed_crc:#010x}')
    return records


def iter_records(data: bytes | memoryview, where: str) -> Iterator[tuple[int, int, memoryview]]:
    """Split a run of records that must fill ``data`` exactly (a chunk, a summary section).

    Parameters
    ----------
    data : bytes or memoryview
        Consecutive records: opcode (u8), length (u64 little-endian), content.
    where : str
        What ``data`` is, for the error messages (e.g. ``'chunk'``).

    Yields
    ------
    tuple of (int, int, memoryview)
        Position of the record in ``data`` [byte], opcode, content.

    Raises
    ------
    InvalidRecord
        If a record header or content runs past the end of ``data``.
    """
    view = memoryview(data)
    position = 0
    while position < len(view):
        if position + RECORD_HEADER > len(view):
            raise InvalidRecord(f'record header at {position} overruns the {where}')
        opcode = view[position]
        (length,) = struct.unpack_from('<Q', view, position + 1)
        start = position + RECORD_HEADER
        if length > len(view) - start:
            raise InvalidRecord(f'record at {position} in the {where} overruns it')
        yield position, opcode, view[start:start + length]
        position = start + length


def chunk_records(records: bytes) -> list[SchemaRecord | ChannelRecord | MessageRecord]:
    """Parse a chunk's uncompressed records, all of them, exactly to the end.

    Raises
    ------
    InvalidRecord
        If any record overruns, does not parse, or is of a type not allowed in a chunk.
    """
    result: list[SchemaRecord | ChannelRecord | MessageRecord] = []
    for _, opcode, content in iter_records(records, 'chunk'):
        if opcode == Opcode.MESSAGE:
            result.append(parse_message(content))
        elif opcode == Opcode.SCHEMA:
            result.append(parse_schema(content))
        elif opcode == Opcode.CHANNEL:
            result.append(parse_channel(content))
        elif opcode < 0x80:
            raise InvalidRecord(f'opcode {opcode:#04x} is not allowed in a chunk')
    return result
