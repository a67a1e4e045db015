"""Read every intact record of a damaged MCAP file, in file order, and say what was lost.

Pure (no rclpy); :mod:`forte_driver.replay.mcap_source` turns the output into bag messages.

The rules (docs/bringup.md, "Damaged bags"):

- The file is read forward, record by record (``opcode u8 | length u64 | content``), one
  chunk in memory at a time. Each position is read once, so no message comes out twice,
  and messages come out in file order.
- When the footer, the summary and its chunk index are intact (summary CRC when not 0,
  every record parsing exactly, chunk entries inside the data and not overlapping), the
  summary's schemas and channels are known from the start, and every indexed chunk whose
  header matches its entry is a fixed point: a damaged record never makes the reader
  miss one, and a record that would overlap one is damage.
- A chunk is replayed only when its content verifies: data decompresses to exactly the
  uncompressed size, the CRC matches (when not 0) and its records parse exactly to the
  end. The chunk's extent comes from its content (header + data length field); a record
  length field that disagrees is damage of that field only when the index entry (or,
  without index, a plausible record right after the extent) confirms the content's
  extent; the chunk is then read and a note says so.
- A chunk whose framing is intact but whose content does not verify (CRC mismatch,
  undecodable data) is skipped whole, and reading continues right after it.
- Any other damage: scan forward for the next position where a valid record starts (a
  plausible opcode and a length inside the data, content parsing exactly, a plausible
  record after it; for a chunk the checks above), never past the next indexed chunk. In
  a chunked file only chunks, message indexes, data end and footer count as such a
  position: loose schema/channel/message records there may be the inside of a damaged
  uncompressed chunk.
- Every skipped byte range is reported as a :class:`LostRange` (whole chunks as
  ``'chunk'`` with their message count from the message index records when readable),
  damage that lost nothing (length field, footer, summary) as a :class:`Note`.
"""
from __future__ import annotations

import bisect
import re
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import BinaryIO

from mcap.opcode import Opcode

from forte_driver.replay.mcap_records import (
    CHUNK_FIXED,
    FOOTER_CONTENT,
    MAGIC,
    MAX_RECORD,
    RECORD_HEADER,
    ChannelRecord,
    ChunkIndexRecord,
    InvalidRecord,
    MessageRecord,
    SchemaRecord,
    chunk_records,
    decompress,
    iter_records,
    parse_channel,
    parse_chunk_header,
    parse_chunk_index,
    parse_message,
    parse_message_index,
    parse_schema,
    plausible_opcode,
)

#: Bytes scanned per read while looking for the next valid record [bytes].
SCAN_WINDOW = 1 << 20
#: Records a resynchronisation may land on in a chunked file.
_LANDING_CHUNKED = (Opcode.CHUNK, Opcode.MESSAGE_INDEX, Opcode.DATA_END, Opcode.FOOTER)
#: ... and in addition in a file without chunks.
_LANDING_LOOSE = (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE)

#: First byte of what may follow a data end record: a summary record or the footer.
_SUMMARY_OPENINGS = frozenset(bytes((int(op),)) for op in (
    Opcode.SCHEMA, Opcode.CHANNEL, Opcode.CHUNK_INDEX, Opcode.ATTACHMENT_INDEX,
    Opcode.METADATA_INDEX, Opcode.STATISTICS, Opcode.SUMMARY_OFFSET, Opcode.FOOTER))


@dataclass(frozen=True)
class LostRange:
    """Bytes of the data section that were skipped.

    Attributes
    ----------
    start, end : int
        Byte range [start, end) in the file.
    kind : str
        ``'chunk'`` (one whole chunk record) or ``'bytes'`` (not identified).
    reason : str
        Why it was skipped.
    messages : int or None
        Messages lost with it (from the chunk's message index records), None if unknown.
    """

    start: int
    end: int
    kind: str
    reason: str
    messages: int | None


@dataclass(frozen=True)
class Note:
    """Damage that lost no message (e.g. a missing footer, an unusable summary)."""

    text: str


@dataclass
class Summary:
    """What the summary section holds that recovery uses."""

    schemas: list[SchemaRecord] = field(default_factory=list)
    channels: list[ChannelRecord] = field(default_factory=list)
    chunks: dict[int, ChunkIndexRecord] = field(default_factory=dict)


@dataclass
class _Step:
    end: int
    records: list = field(default_factory=list)
    lost: LostRange | None = None
    indexed_messages: int | None = None
    note: str | None = None
    finished: bool = False
    chunk_without_index: bool = False


def _read(stream: BinaryIO, offset: int, size: int) -> bytes:
    stream.seek(offset)
    return stream.read(size)


def read_summary(stream: BinaryIO, size: int) -> tuple[int, Summary | None, list[str]]:
    """Locate the data section's end and read the summary when it is intact.

    Returns
    -------
    data_end : int
        Byte offset where the data section ends (summary start, footer, or file end).
    summary : Summary or None
        None when there is no summary or it cannot be trusted.
    notes : list of str
        Why the footer or summary was not used.
    """
    footer_at = size - len(MAGIC) - RECORD_HEADER - FOOTER_CONTENT
    tail = _read(stream, footer_at, size - footer_at) if footer_at >= len(MAGIC) else b''
    if (len(tail) != size - footer_at or tail[-len(MAGIC):] != MAGIC
            or tail[0] != Opcode.FOOTER
            or struct.unpack_from('<Q', tail, 1)[0] != FOOTER_CONTENT):
        return size, None, ['no MCAP footer at the end (file truncated, or its end damaged); '
                            'summary not used']
    summary_start, _, summary_crc = struct.unpack_from('<QQI', tail, RECORD_HEADER)
    if summary_start == 0:
        return footer_at, None, []
    if not len(MAGIC) < summary_start <= footer_at or footer_at - summary_start > MAX_RECORD:
        return footer_at, None, [f'footer points at a summary at byte {summary_start}, outside '
                                 f'the file; summary not used']
    summary_bytes = _read(stream, summary_start, footer_at - summary_start)
    if summary_crc and zlib.crc32(tail[:RECORD_HEADER + 16], zlib.crc32(summary_bytes)) != (
            summary_crc):
        return footer_at, None, ['summary CRC mismatch; summary not used']
    try:
        summary = _parse_summary(summary_bytes, summary_start)
    except InvalidRecord as error:
        return footer_at, None, [f'summary does not parse ({error}); summary not used']
    return summary_start, summary, []


def _parse_summary(summary_bytes: bytes, summary_start: int) -> Summary:
    summary = Summary()
    for _, opcode, content in iter_records(summary_bytes, 'summary section'):
        if opcode == Opcode.SCHEMA:
            summary.schemas.append(parse_schema(content))
        elif opcode == Opcode.CHANNEL:
            summary.channels.append(parse_channel(content))
        elif opcode == Opcode.CHUNK_INDEX:
            entry = parse_chunk_index(content)
            summary.chunks[entry.chunk_start_offset] = entry
        elif not plausible_opcode(opcode):
            raise InvalidRecord(f'opcode {opcode:#04x} in the summary')
    previous_end = len(MAGIC)
    for offset in sorted(summary.chunks):
        entry = summary.chunks[offset]
        if offset < previous_end or offset + entry.chunk_length > summary_start:
            raise InvalidRecord(f'chunk index entry at byte {offset} overlaps another chunk '
                                f'or lies outside the data section')
        previous_end = offset + entry.chunk_length
    return summary


class RecoveringReader:
    """Yield the records of one MCAP file in file order, skipping and reporting damage.

    Parameters
    ----------
    stream : binary file
        The file, open for reading; it must start with the MCAP magic (checked by the
        caller).
    size : int
        File size [bytes].
    """

    def __init__(self, stream: BinaryIO, size: int) -> None:
        self.stream = stream
        self.size = size
        self.data_end, self.summary, self.notes = read_summary(stream, size)
        self.index = self.summary.chunks if self.summary else {}
        self.index_offsets = sorted(self.index)
        self.fixed = [offset for offset in self.index_offsets if self._matches_index(offset)]
        self.fixed_set = frozenset(self.fixed)
        self.chunked = bool(self.index)
        self.channel_ids: set[int] = set()
        self._landed: tuple[int, _Step] | None = None

    def _matches_index(self, offset: int) -> bool:
        entry = self.index[offset]
        head = _read(self.stream, offset, RECORD_HEADER + CHUNK_FIXED + 8 + len(entry.compression))
        try:  # the opcode and length fields are framing, which the index entry replaces
            header = parse_chunk_header(bytes((Opcode.CHUNK,)) + head[1:])
        except InvalidRecord:
            return False
        return (header.compression == entry.compression
                and header.data_length == entry.compressed_size
                and header.uncompressed_size == entry.uncompressed_size
                and header.message_start_time == entry.message_start_time
                and header.message_end_time == entry.message_end_time
                and header.extent == entry.chunk_length)

    def records(self) -> Iterator[SchemaRecord | ChannelRecord | MessageRecord | LostRange | Note]:
        """Every intact record of the data section and every loss, in file order.

        The summary's schemas and channels (:attr:`summary`) are not repeated here.
        """
        yield from (Note(text) for text in self.notes)
        if self.summary is not None:
            self.channel_ids.update(channel.id for channel in self.summary.channels)
        position = len(MAGIC)
        pending: LostRange | None = None  # a skipped chunk still counting its messages
        while position < self.data_end:
            try:
                step = self._step(position)
            except InvalidRecord as damage:
                if pending is not None:
                    yield pending
                    pending = None
                resume = self._resynchronise(position)
                yield from self._lost(position, resume, str(damage))
                position = resume
                continue
            if pending is not None and step.indexed_messages is not None:
                pending = replace(pending, messages=(pending.messages or 0) + step.indexed_messages)
            elif pending is not None:
                yield pending
                pending = None
            if step.note:
                yield Note(step.note)
            if step.lost is not None:
                if step.chunk_without_index:
                    pending = step.lost
                else:
                    yield step.lost
            for record in step.records:
                if isinstance(record, ChannelRecord):
                    self.channel_ids.add(record.id)
                yield record
            if step.finished:
                break
            position = step.end
        if pending is not None:
            yield pending

    def _step(self, position: int) -> _Step:
        landed, self._landed = self._landed, None
        if landed is not None and landed[0] == position:
            return landed[1]
        return self._read_at(position, landing=False)

    def _next_fixed(self, position: int) -> int:
        """The first indexed chunk after ``position``, or the end of the data."""
        at = bisect.bisect_right(self.fixed, position)
        return self.fixed[at] if at < len(self.fixed) else self.data_end

    def _plausible_at(self, position: int) -> bool:
        """A plausible record header at ``position``, or the end of the data."""
        if position == self.data_end:
            return True
        head = _read(self.stream, position, RECORD_HEADER)
        return (len(head) == RECORD_HEADER and plausible_opcode(head[0])
                and struct.unpack_from('<Q', head, 1)[0] < 1 << 40)

    def _ends_data(self, opcode: int, end: int) -> bool:
        """Whether a data end / footer record ending at ``end`` can really end the data."""
        if opcode == Opcode.FOOTER:
            return end + len(MAGIC) == self.size
        if end in (self.data_end, self.size):
            return True
        return _read(self.stream, end, 1) in _SUMMARY_OPENINGS

    def _read_at(self, position: int, landing: bool) -> _Step:
        head = _read(self.stream, position, RECORD_HEADER)
        if len(head) < RECORD_HEADER:
            raise InvalidRecord(f'record header at byte {position} cut off by the end of '
                                f'the file (truncated)')
        opcode = head[0]
        (length,) = struct.unpack_from('<Q', head, 1)
        if opcode == Opcode.CHUNK or position in self.fixed_set:
            return self._read_chunk(position, landing)
        if landing and opcode not in _LANDING_CHUNKED + (() if self.chunked else _LANDING_LOOSE):
            raise InvalidRecord('not a resynchronisation point')
        end = position + RECORD_HEADER + length
        if end > self.data_end:
            raise InvalidRecord(f'record at byte {position} (opcode {opcode:#04x}) claims '
                                f'{length} bytes, past the end of the data at byte '
                                f'{self.data_end} (truncated or damaged)')
        if self._next_fixed(position) < end:
            raise InvalidRecord(f'record at byte {position} overlaps the indexed chunk at '
                                f'byte {self._next_fixed(position)}')
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            if length != (4 if opcode == Opcode.DATA_END else FOOTER_CONTENT):
                raise InvalidRecord(f'end record at byte {position} of the wrong length')
            if landing and not self._ends_data(opcode, end):
                raise InvalidRecord('end record not at the end of the data')
            return _Step(end, finished=True)
        if opcode not in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.MESSAGE_INDEX):
            if opcode == Opcode.HEADER and position != len(MAGIC):
                raise InvalidRecord(f'header record at byte {position}')
            if not plausible_opcode(opcode):
                raise InvalidRecord(f'byte {position}: opcode {opcode:#04x} is not an MCAP record')
            return _Step(end)  # header, attachment, metadata, private: nothing to replay
        if landing:
            if not self._plausible_at(end):
                raise InvalidRecord('no plausible record after it')
            if opcode == Opcode.MESSAGE and length >= 2:
                (channel_id,) = struct.unpack('<H', _read(self.stream, position + 9, 2))
                if channel_id not in self.channel_ids:
                    raise InvalidRecord('message on a channel not seen')
        content = _read(self.stream, position + RECORD_HEADER, length)
        if opcode == Opcode.MESSAGE_INDEX:
            channel_id, count = parse_message_index(content)
            if landing and (channel_id not in self.channel_ids or count == 0):
                raise InvalidRecord('message index of an unknown channel, or empty')
            return _Step(end, indexed_messages=count)
        parser = {Opcode.SCHEMA: parse_schema, Opcode.CHANNEL: parse_channel,
                  Opcode.MESSAGE: parse_message}[opcode]
        return _Step(end, records=[parser(content)])

    def _read_chunk(self, position: int, landing: bool) -> _Step:
        head = _read(self.stream, position, RECORD_HEADER + CHUNK_FIXED)
        if len(head) < RECORD_HEADER + CHUNK_FIXED:
            raise InvalidRecord(f'chunk at byte {position} cut off by the end of the file '
                                f'(truncated)')
        (name_length,) = struct.unpack_from('<I', head, RECORD_HEADER + CHUNK_FIXED - 4)
        if name_length > 16:
            raise InvalidRecord(f'chunk at byte {position}: compression name of {name_length} '
                                f'bytes')
        note = None
        if head[0] != Opcode.CHUNK:  # only at an indexed chunk: see _read_at
            note = (f'chunk at byte {position}: damaged opcode byte {head[0]:#04x}; located by '
                    f'the chunk index and read by its content')
        header = parse_chunk_header(bytes((Opcode.CHUNK,)) + head[1:] + _read(
            self.stream, position + len(head), name_length + 8))
        extent = header.extent
        end = position + extent
        if end > self.data_end:
            raise InvalidRecord(f'chunk at byte {position} of {extent} bytes extends past the '
                                f'end of the data at byte {self.data_end} (truncated or damaged)')
        if self._next_fixed(position) < end:
            raise InvalidRecord(f'chunk at byte {position} overlaps the indexed chunk at byte '
                                f'{self._next_fixed(position)}')
        entry = self.index.get(position)
        if RECORD_HEADER + header.record_length != extent:
            confirmed = (entry.chunk_length == extent if entry is not None
                         else self._plausible_at(end))
            if landing or not confirmed:
                raise InvalidRecord(f'chunk at byte {position}: length field '
                                    f'{header.record_length} disagrees with its data '
                                    f'({extent - RECORD_HEADER} bytes)')
            note = (f'{note}; ' if note else f'chunk at byte {position}: ') + (
                f'damaged length field {header.record_length}, its content says '
                f'{extent - RECORD_HEADER} bytes; read by its content')
        data = _read(self.stream, position + header.header_size, header.data_length)
        try:
            records = chunk_records(decompress(header, data))
        except InvalidRecord as error:
            if landing and not self._plausible_at(end):
                raise
            self.chunked = True
            lost = LostRange(position, end, 'chunk', f'chunk content damaged: {error}',
                             self._indexed_count(entry))
            return _Step(end, lost=lost, chunk_without_index=entry is None)
        self.chunked = True
        return _Step(end, records=records, note=note)

    def _indexed_count(self, entry: ChunkIndexRecord | None) -> int | None:
        """Messages in an indexed chunk, from its message index records; None if unknown."""
        if entry is None or entry.message_index_length == 0:
            return None
        start = entry.chunk_start_offset + entry.chunk_length
        if start + entry.message_index_length > self.data_end:
            return None
        block = memoryview(_read(self.stream, start, entry.message_index_length))
        count, position = 0, 0
        try:
            while position < len(block):
                (length,) = struct.unpack_from('<Q', block, position + 1)
                if block[position] != Opcode.MESSAGE_INDEX or length > len(block) - position - 9:
                    return None
                count += parse_message_index(block[position + 9:position + 9 + length])[1]
                position += RECORD_HEADER + length
        except (InvalidRecord, struct.error):
            return None
        return count

    def _resynchronise(self, position: int) -> int:
        """The next position after damage at ``position`` where a valid record starts."""
        if _read(self.stream, position, 1) == bytes((Opcode.CHUNK,)):
            self.chunked = True
        limit = self._next_fixed(position)
        start = position + 1
        if position in self.fixed:
            start = position + self.index[position].chunk_length
        opcodes = _LANDING_CHUNKED + (() if self.chunked else _LANDING_LOOSE)
        pattern = re.compile(
            b'(?=[' + b''.join(re.escape(bytes((int(op),))) for op in opcodes)
            + b'].{5}\x00\x00\x00)', re.DOTALL)
        window_start = start
        while window_start < limit:
            block = _read(self.stream, window_start,
                          min(SCAN_WINDOW, limit - window_start) + RECORD_HEADER - 1)
            for match in pattern.finditer(block):
                candidate = window_start + match.start()
                if candidate >= limit or match.start() >= SCAN_WINDOW:
                    break
                try:
                    step = self._read_at(candidate, landing=True)
                except (InvalidRecord, struct.error):
                    continue
                self._landed = (candidate, step)
                return candidate
            window_start += SCAN_WINDOW
        return limit

    def _lost(self, start: int, end: int, reason: str) -> Iterator[LostRange]:
        """The range [start, end) as losses: whole indexed chunks, and bytes between."""
        cursor = start
        first = bisect.bisect_left(self.index_offsets, start)
        for offset in self.index_offsets[first:]:
            entry = self.index[offset]
            if offset >= end:
                break
            if offset + entry.chunk_length > end:
                continue
            if offset > cursor:
                yield LostRange(cursor, offset, 'bytes', reason, None)
            yield LostRange(offset, offset + entry.chunk_length, 'chunk', reason,
                            self._indexed_count(entry))
            cursor = offset + entry.chunk_length
        if cursor < end:
            yield LostRange(cursor, end, 'bytes', reason, None)
