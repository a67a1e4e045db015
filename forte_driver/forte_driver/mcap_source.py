"""Read serialized ROS 2 messages from MCAP bags, tolerating truncated and corrupt files.

Pure library (no rclpy): the bag replay node and the offline tools use it. A bag is one of

- a rosbag2 folder (``metadata.yaml`` plus one or more ``*.mcap`` files), as written by
  ``ros2 bag record -s mcap``, by rosbags or by ``forte_record``;
- a folder holding ``*.mcap`` files without metadata;
- a single ``.mcap`` file written by any MCAP writer (e.g. ``mcap_ros2.writer``).

Messages come out as CDR bytes with their topic, ROS type name and log time; decoding is
the caller's business (``rclpy.serialization.deserialize_message`` in the node, or
``mcap_ros2``). The files are read record by record from the start (the summary section
at the end is not needed), so a file cut short or damaged in the middle still yields
every message of every intact chunk before the damage; the damage is described in a
:class:`BagReadReport` instead of being silently skipped or papered over.
"""
from __future__ import annotations

import io
import re
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

#: Exceptions that mean "this file is damaged from here on" while streaming records. A
#: damaged length field can make the decoder raise almost anything (OverflowError,
#: MemoryError, zstd/lz4 errors), so every ordinary exception counts as damage.
_DAMAGE_ERRORS = (McapError, EOFError, struct.error, Exception)


class BagError(RuntimeError):
    """A bag path that cannot be read at all (missing, empty, not MCAP)."""


@dataclass(frozen=True)
class BagMessage:
    """One serialized message read from a bag.

    Attributes
    ----------
    topic : str
        Topic name as recorded (e.g. ``/tactile/frames``).
    msgtype : str
        ROS type name, ``package/msg/Name``.
    log_time : int
        Time the recorder received the message [ns since the epoch or since sim start].
    publish_time : int
        Publish time stored by the writer [ns]; equals ``log_time`` for most writers.
    data : bytes
        CDR-serialized message (with its 4-byte encapsulation header).
    """

    topic: str
    msgtype: str
    log_time: int
    publish_time: int
    data: bytes


@dataclass
class BagReadReport:
    """What reading a bag found: files, counts per topic, damage.

    Attributes
    ----------
    files : list of Path
        MCAP files read, in order.
    messages : dict of str to int
        Messages yielded per topic [count].
    errors : list of str
        One human-readable description per damaged file (file, byte offset, messages
        recovered before the damage, the decoder's error).
    """

    files: list[Path] = field(default_factory=list)
    messages: dict[str, int] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every file was read to its end without damage."""
        return not self.errors

    @property
    def total_messages(self) -> int:
        """Messages yielded over all topics [count]."""
        return sum(self.messages.values())


def _natural_key(path: Path) -> list[object]:
    return [int(part) if part.isdigit() else part for part in re.split(r'(\d+)', path.name)]


def bag_files(path: str | Path) -> list[Path]:
    """MCAP files that make up the bag at ``path``, in recording order.

    Parameters
    ----------
    path : str or Path
        A rosbag2 folder, a folder of ``.mcap`` files, or one ``.mcap`` file.

    Returns
    -------
    list of Path
        The files, split files in numeric order (``bag_0.mcap``, ``bag_1.mcap``, ...).

    Raises
    ------
    BagError
        If the path does not exist or holds no MCAP file.
    """
    path = Path(path)
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise BagError(f'bag {path} does not exist')
    files = sorted(path.glob('*.mcap'), key=_natural_key)
    if not files:
        raise BagError(f'bag folder {path} holds no .mcap file (only MCAP bags are supported)')
    return files


def _summary(file: Path):  # -> mcap.summary.Summary | None
    """The file's summary section (schemas, channels, chunk index), or None if unreadable."""
    try:
        with file.open('rb') as stream:
            return SeekingReader(stream).get_summary()
    except _DAMAGE_ERRORS:
        return None


class _FileReader:
    """Streams one MCAP file's messages; bookkeeping of what was recovered."""

    def __init__(self, file: Path, topics: frozenset[str] | None, report: BagReadReport):
        self.file = file
        self.topics = topics
        self.report = report
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, tuple[str, str]] = {}
        self.recovered = 0

    def _handle(self, record: object) -> BagMessage | None:
        if isinstance(record, Schema):
            self.schemas[record.id] = record.name
        elif isinstance(record, Channel):
            self.channels[record.id] = (record.topic, self.schemas.get(record.schema_id, ''))
        elif isinstance(record, Message):
            topic, msgtype = self.channels.get(record.channel_id, ('', ''))
            if not topic:
                self.report.errors.append(
                    f'{self.file}: message on unknown channel {record.channel_id} skipped'
                )
                return None
            if self.topics is not None and topic not in self.topics:
                return None
            self.recovered += 1
            self.report.messages[topic] = self.report.messages.get(topic, 0) + 1
            return BagMessage(
                topic, msgtype, record.log_time, record.publish_time, bytes(record.data)
            )
        return None

    def messages(self) -> Iterator[BagMessage]:
        good_end = 0  # every chunk starting before this offset has been yielded in full
        with self.file.open('rb') as stream:
            records = StreamReader(stream, validate_crcs=True).records
            while True:
                try:
                    record = next(records)
                except StopIteration:
                    return
                except _DAMAGE_ERRORS as error:
                    damage_at = stream.tell()
                    reason = f'{type(error).__name__}: {error}'
                    break
                message = self._handle(record)
                if message is not None:
                    good_end = stream.tell()
                    yield message
        size = self.file.stat().st_size
        before = self.recovered
        text = (
            f'{self.file}: damaged or truncated near byte {damage_at} of {size} '
            f'({reason}); {before} messages read before the damage'
        )
        summary = _summary(self.file)
        if summary is None or not summary.chunk_indexes:
            self.report.errors.append(text + '; no readable summary, the rest is lost')
            return
        # The summary at the end is intact: resume at every chunk after the last good one.
        for schema in summary.schemas.values():
            self.schemas.setdefault(schema.id, schema.name)
        for channel in summary.channels.values():
            self._handle(channel)
        bad_chunks = 0
        for index in sorted(summary.chunk_indexes, key=lambda item: item.chunk_start_offset):
            if index.chunk_start_offset < good_end:
                continue
            with self.file.open('rb') as stream:
                stream.seek(index.chunk_start_offset)
                chunk_bytes = stream.read(index.chunk_length)
            try:
                if chunk_bytes[0] != Opcode.CHUNK:
                    raise McapError('chunk index points at a non-chunk record')
                (length,) = struct.unpack_from('<Q', chunk_bytes, 1)
                chunk = Chunk.read(ReadDataStream(io.BytesIO(chunk_bytes[9 : 9 + length])))
                decoded = [
                    self._handle(record) for record in breakup_chunk(chunk, validate_crc=True)
                ]
            except _DAMAGE_ERRORS:
                bad_chunks += 1
                continue
            yield from (message for message in decoded if message is not None)
        self.report.errors.append(
            text + f'; resumed from the summary: {bad_chunks} damaged chunk(s) skipped, '
            f'{self.recovered - before} messages recovered after the damage'
        )


def read_bag(
    path: str | Path,
    topics: Iterable[str] | None = None,
    report: BagReadReport | None = None,
) -> Iterator[BagMessage]:
    """Yield the serialized messages of a bag in file order.

    Parameters
    ----------
    path : str or Path
        A rosbag2 folder, a folder of ``.mcap`` files, or one ``.mcap`` file.
    topics : iterable of str, optional
        Topic names to keep (exact, with leading slash as recorded); all when omitted.
        Names without a leading slash also match their absolute form.
    report : BagReadReport, optional
        Filled in while iterating: files, counts, and a description of any damage.

    Yields
    ------
    BagMessage
        Every intact message. Reading stops at the first damaged record of a file and
        continues with the next file of the bag.

    Raises
    ------
    BagError
        If the path does not exist, holds no MCAP file, or a file does not start with the
        MCAP magic bytes.
    """
    if report is None:
        report = BagReadReport()
    wanted = None
    if topics is not None:
        names = set()
        for topic in topics:
            names.add(topic)
            names.add(topic if topic.startswith('/') else '/' + topic)
        wanted = frozenset(names)
    for file in bag_files(path):
        with file.open('rb') as stream:
            if stream.read(8)[:5] != b'\x89MCAP':
                raise BagError(f'{file} is not an MCAP file (bad magic bytes)')
        report.files.append(file)
        yield from _FileReader(file, wanted, report).messages()
