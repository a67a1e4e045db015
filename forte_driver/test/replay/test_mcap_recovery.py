"""Damaged MCAP files: every intact message once and in order, none of a failed chunk, exact losses.

The bags are real MCAP files written by the ``mcap`` package's writer (several chunks,
message index records, a summary with chunk index), with and without summary, with
uncompressed, zstd and lz4 chunks. They are damaged at places computed from the intact
file's structure as the ``mcap`` package reads it (chunk index offsets and lengths, the
footer), and the messages expected back are those of every chunk the damage left intact,
read from the intact twin with the ``mcap`` reader.
"""
from __future__ import annotations

import random
import struct
from dataclasses import dataclass
from pathlib import Path

import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import SeekingReader
from mcap.records import Chunk, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

from forte_driver.replay.mcap_source import BagLoss, BagReadReport, read_bag

MAGIC = b'\x89MCAP0\r\n'
FOOTER_SIZE = 9 + 20  # opcode, length, summary_start, summary_offset_start, summary_crc
MESSAGES = 150
COMPRESSIONS = {'none': CompressionType.NONE, 'zstd': CompressionType.ZSTD,
                'lz4': CompressionType.LZ4}


def payload(index: int) -> bytes:
    return (f'message {index:05d};' * 8).encode()


def write_bag(path: Path, compression: str, crcs: bool = True, summary: bool = True) -> Path:
    """150 messages on /a and /b in 2 kB chunks; without summary: footer says none."""
    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=2000, compression=COMPRESSIONS[compression],
                        enable_crcs=crcs)
        writer.start(profile='ros2', library='forte test')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
        channels = [writer.register_channel(topic, 'cdr', schema) for topic in ('/a', '/b')]
        for index in range(MESSAGES):
            writer.add_message(channels[index % 3 == 0], log_time=1000 + index,
                               data=payload(index), publish_time=5000 + index, sequence=index)
        writer.finish()
    if not summary:
        data = path.read_bytes()
        (summary_start,) = struct.unpack_from('<Q', data, len(data) - len(MAGIC) - 20)
        footer = struct.pack('<BQQQI', 0x02, 20, 0, 0, 0)
        path.write_bytes(data[:summary_start] + footer + MAGIC)
    return path


@dataclass
class ChunkSpan:
    """One chunk of the intact file: its record [start, end), message index end, messages."""

    start: int
    end: int
    index_end: int
    messages: list[tuple[str, bytes]]


def layout(path: Path) -> list[ChunkSpan]:
    """The chunks of an intact bag with summary, from the mcap package's own reader."""
    with path.open('rb') as stream:
        summary = SeekingReader(stream).get_summary()
        topics = {channel.id: channel.topic for channel in summary.channels.values()}
        spans = []
        for index in sorted(summary.chunk_indexes, key=lambda item: item.chunk_start_offset):
            stream.seek(index.chunk_start_offset + 9)
            chunk = Chunk.read(ReadDataStream(stream))
            messages = [(topics[record.channel_id], record.data)
                        for record in breakup_chunk(chunk, validate_crc=True)
                        if isinstance(record, Message)]
            end = index.chunk_start_offset + index.chunk_length
            spans.append(ChunkSpan(index.chunk_start_offset, end,
                                   end + index.message_index_length, messages))
    assert len(spans) >= 6 and sum(len(span.messages) for span in spans) == MESSAGES
    return spans


def bags(tmp_path: Path, compression: str, summary: bool,
         crcs: bool = True) -> tuple[Path, list[ChunkSpan]]:
    """The bag to damage and the chunk layout of its intact twin (same data section)."""
    twin = write_bag(tmp_path / 'twin.mcap', compression, crcs)
    return write_bag(tmp_path / 'bag.mcap', compression, crcs, summary), layout(twin)


def patch(path: Path, offset: int, data: bytes) -> None:
    with path.open('r+b') as stream:
        stream.seek(offset)
        stream.write(data)


def replay(path: Path) -> tuple[list[tuple[str, bytes]], BagReadReport]:
    report = BagReadReport()
    messages = [(message.topic, message.data) for message in read_bag(path, report=report)]
    return messages, report


def expected(spans: list[ChunkSpan], lost: set[int]) -> list[tuple[str, bytes]]:
    return [message for number, span in enumerate(spans) if number not in lost
            for message in span.messages]


def losses(report: BagReadReport) -> list[tuple[int, int, str, int | None]]:
    return [(loss.start, loss.end, loss.kind, loss.messages) for loss in report.losses]


COMBINATIONS = [(compression, summary) for compression in COMPRESSIONS
                for summary in (True, False)]


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_intact_bag_every_message_once_in_log_time_order(tmp_path, compression, summary):
    bag, spans = bags(tmp_path, compression, summary)
    messages, report = replay(bag)
    assert messages == expected(spans, set())
    assert messages == [(('/b' if i % 3 == 0 else '/a'), payload(i)) for i in range(MESSAGES)]
    assert report.complete and report.losses == []


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_chunk_crc_mismatch_skips_that_chunk_and_reads_on(tmp_path, compression, summary):
    bag, spans = bags(tmp_path, compression, summary)
    bad = spans[2]
    with bag.open('rb') as stream:
        stream.seek(bad.start + 9 + 24)
        (crc,) = struct.unpack('<I', stream.read(4))
    patch(bag, bad.start + 9 + 24, struct.pack('<I', crc ^ 0x00010000))
    messages, report = replay(bag)
    assert messages == expected(spans, {2})
    count = len(bad.messages)
    assert losses(report) == [(bad.start, bad.end, 'chunk', count)]
    assert 'CRC mismatch' in report.losses[0].reason
    assert report.chunks_skipped == 1 and report.messages_lost == count
    assert report.bytes_skipped == bad.end - bad.start and report.unknown_losses == 0


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_damaged_compressed_bytes_lose_only_their_chunk(tmp_path, compression, summary):
    bag, spans = bags(tmp_path, compression, summary)
    bad = spans[3]
    middle = (bad.start + bad.end) // 2
    with bag.open('rb') as stream:
        stream.seek(middle)
        original = stream.read(16)
    patch(bag, middle, bytes(byte ^ 0x5A for byte in original))
    messages, report = replay(bag)
    assert messages == expected(spans, {3})
    assert losses(report) == [(bad.start, bad.end, 'chunk', len(bad.messages))]


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_damaged_chunk_length_field_loses_nothing(tmp_path, compression, summary):
    """The seen failure: reading ran to the end of the file and lost every later chunk."""
    bag, spans = bags(tmp_path, compression, summary)
    patch(bag, spans[1].start + 1, struct.pack('<Q', 2**40 + 12345))
    messages, report = replay(bag)
    assert messages == expected(spans, set())
    assert report.losses == []
    assert not report.complete
    assert any('damaged length field' in error for error in report.errors)


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_damaged_data_length_field_is_resynchronised(tmp_path, compression, summary):
    """The chunk's content extent is wrong: scan to the next record (index or not)."""
    bag, spans = bags(tmp_path, compression, summary)
    bad = spans[2]
    compression_name = {'none': 0, 'zstd': 4, 'lz4': 3}[compression]
    field_at = bad.start + 9 + 32 + compression_name
    with bag.open('rb') as stream:
        stream.seek(field_at)
        (data_length,) = struct.unpack('<Q', stream.read(8))
    patch(bag, field_at, struct.pack('<Q', data_length + 1000))
    messages, report = replay(bag)
    assert messages == expected(spans, {2})
    if summary:  # the chunk index names the chunk and its message index counts it
        assert losses(report) == [(bad.start, bad.end, 'chunk', len(bad.messages))]
    else:  # the skipped bytes end where the chunk's message index starts; count unknown
        assert losses(report) == [(bad.start, bad.end, 'bytes', None)]
        assert report.unknown_losses == 1 and report.messages_lost == 0


@pytest.mark.parametrize('compression', COMPRESSIONS)
def test_truncated_file_keeps_every_complete_chunk(tmp_path, compression):
    bag, spans = bags(tmp_path, compression, True)
    cut = (spans[4].start + spans[4].end) // 2
    with bag.open('r+b') as stream:
        stream.truncate(cut)
    messages, report = replay(bag)
    assert messages == expected(spans, set(range(4, len(spans))))
    assert losses(report) == [(spans[4].start, cut, 'bytes', None)]
    assert 'truncated' in report.errors[0] and 'no MCAP footer' in report.errors[0]


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_garbage_inserted_between_records_is_skipped_exactly(tmp_path, compression, summary):
    bag, spans = bags(tmp_path, compression, summary)
    garbage = random.Random(7).randbytes(300)
    data = bag.read_bytes()
    at = spans[3].start  # after chunk 2's message index records
    bag.write_bytes(data[:at] + garbage + data[at:])
    messages, report = replay(bag)
    assert messages == expected(spans, set())
    assert losses(report) == [(at, at + 300, 'bytes', None)]
    if summary:  # the summary offsets are stale now: its CRC tells
        assert any('summary CRC mismatch' in error for error in report.errors)


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_overwritten_span_across_two_chunks(tmp_path, compression, summary):
    """Zeros over chunk 2's end, its message index and chunk 3's header."""
    bag, spans = bags(tmp_path, compression, summary)
    first, second = spans[2], spans[3]
    patch(bag, first.end - 50, bytes(second.start + 60 - (first.end - 50)))
    messages, report = replay(bag)
    assert messages == expected(spans, {2, 3})
    # chunk 2's message index records are zeros: its count is unknown, index or not
    if summary:
        assert losses(report) == [
            (first.start, first.end, 'chunk', None),
            (first.end, second.start, 'bytes', None),
            (second.start, second.end, 'chunk', len(second.messages)),
        ]
    else:
        assert losses(report) == [(first.start, first.end, 'chunk', None),
                                  (first.end, second.end, 'bytes', None)]


@pytest.mark.parametrize('compression', COMPRESSIONS)
def test_damaged_summary_or_footer_loses_nothing(tmp_path, compression):
    bag, spans = bags(tmp_path, compression, True)
    size = bag.stat().st_size
    data = bag.read_bytes()
    (summary_start,) = struct.unpack_from('<Q', data, size - len(MAGIC) - 20)
    patch(bag, (summary_start + size - FOOTER_SIZE - len(MAGIC)) // 2, b'\xee\xee')
    messages, report = replay(bag)
    assert messages == expected(spans, set()) and report.losses == []
    assert any('summary' in error for error in report.errors)

    bag.write_bytes(data)
    patch(bag, size - len(MAGIC) - FOOTER_SIZE, b'\x55')  # the footer's opcode
    messages, report = replay(bag)
    assert messages == expected(spans, set()) and report.losses == []
    assert any('no MCAP footer' in error for error in report.errors)


@pytest.mark.parametrize('summary', (True, False))
def test_chunks_with_crc_zero(tmp_path, summary):
    """CRC 0 = not checkable: a chunk is replayed when its records parse exactly."""
    bag, spans = bags(tmp_path, 'none', summary, crcs=False)
    bad = spans[1]
    header = 9 + 32 + 0 + 8
    patch(bag, bad.start + header + 1, struct.pack('<Q', 10**6))  # first inner record's length
    patch(bag, spans[4].start + 1, struct.pack('<Q', 12))  # length field only
    messages, report = replay(bag)
    assert messages == expected(spans, {1})
    # counted from the chunk index, or without summary from the message index records
    # that follow the chunk
    assert losses(report) == [(bad.start, bad.end, 'chunk', len(bad.messages))]
    assert 'do not parse' in report.losses[0].reason or 'overruns' in report.losses[0].reason
    assert any('damaged length field' in error for error in report.errors)


def test_loss_record_is_a_plain_value(tmp_path):
    bag, spans = bags(tmp_path, 'zstd', True)
    patch(bag, spans[0].start + 9 + 24, b'\x00\x00\x00\x01')
    _, report = replay(bag)
    assert report.losses == [BagLoss(bag, spans[0].start, spans[0].end, 'chunk',
                                     report.losses[0].reason, len(spans[0].messages))]


def test_file_without_chunks_resynchronises_on_the_next_message(tmp_path):
    """Loose message records (no chunks): a damaged one is skipped, the next one found."""
    path = tmp_path / 'loose.mcap'
    with path.open('wb') as stream:
        writer = Writer(stream, use_chunking=False)
        writer.start(profile='ros2', library='forte test')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
        channel = writer.register_channel('/a', 'cdr', schema)
        for index in range(MESSAGES):
            writer.add_message(channel, log_time=1000 + index, data=payload(index),
                               publish_time=1000 + index, sequence=index)
        writer.finish()
    data = path.read_bytes()
    records, position = [], len(MAGIC)  # (offset, opcode, length) along the framing
    while data[position] != 0x02:
        (length,) = struct.unpack_from('<Q', data, position + 1)
        records.append((position, data[position], length))
        position += 9 + length
    messages = [record for record in records if record[1] == 0x05]
    assert len(messages) == MESSAGES
    offset, _, length = messages[40]
    patch(path, offset + 1, struct.pack('<Q', 2**50))
    replayed, report = replay(path)
    assert replayed == [('/a', payload(i)) for i in range(MESSAGES) if i != 40]
    assert losses(report) == [(offset, offset + 9 + length, 'bytes', None)]


@pytest.mark.parametrize(('compression', 'summary'), COMBINATIONS)
def test_damaged_chunk_opcode(tmp_path, compression, summary):
    """The chunk index locates a chunk whose opcode byte is gone; without it, it is lost."""
    bag, spans = bags(tmp_path, compression, summary)
    bad = spans[2]
    patch(bag, bad.start, b'\x00')
    messages, report = replay(bag)
    if summary:
        assert messages == expected(spans, set()) and report.losses == []
        assert any('damaged opcode byte 0x00' in error for error in report.errors)
    else:  # the scan lands on the chunk's message index records: the chunk's bytes lost
        assert messages == expected(spans, {2})
        assert losses(report) == [(bad.start, bad.end, 'bytes', None)]


def test_summary_channel_damaged_without_crc_is_overruled_by_the_data(tmp_path):
    """Summary CRC 0 (unchecked): a damaged topic there must not rename the messages."""
    bag, spans = bags(tmp_path, 'zstd', True, crcs=False)
    data = bag.read_bytes()
    (summary_start,) = struct.unpack_from('<Q', data, len(data) - len(MAGIC) - 20)
    topic_at = data.index(b'\x02\x00\x00\x00/b', summary_start) + 4
    patch(bag, topic_at + 1, b'x')
    messages, report = replay(bag)
    assert messages == expected(spans, set()) and report.losses == []
    assert any('differs between the summary and the data section' in error
               for error in report.errors)
