"""Read serialized ROS 2 messages from MCAP bags, recovering every intact message.

Pure library (no rclpy): the bag replay node and the offline tools use it. A bag is one of

- a rosbag2 folder (``metadata.yaml`` plus one or more ``*.mcap`` files), as written by
  ``ros2 bag record -s mcap``, by rosbags or by ``forte_record``;
- a folder holding ``*.mcap`` files without metadata;
- a single ``.mcap`` file written by any MCAP writer (e.g. ``mcap_ros2.writer``).

Messages come out as CDR bytes with their topic, ROS type name and log time; decoding is
the caller's business (``rclpy.serialization.deserialize_message`` in the node, or
``mcap_ros2``). Each file is read forward record by record, one chunk in memory at a
time (:mod:`forte_driver.replay.mcap_recovery`): a damaged record does not end the reading, the
reader finds the next valid record (with the summary's chunk index when it is intact,
else by scanning) and goes on, a chunk whose content does not verify is skipped whole,
and a :class:`BagReadReport` lists every skipped byte range, chunk and message count.
"""
from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from forte_driver.replay.mcap_records import MAGIC, ChannelRecord, MessageRecord, SchemaRecord
from forte_driver.replay.mcap_recovery import LostRange, Note, RecoveringReader


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


@dataclass(frozen=True)
class BagLoss:
    """Something of a bag file that was not replayed.

    Attributes
    ----------
    file : Path
        The MCAP file.
    start, end : int or None
        Byte range [start, end) skipped; None for messages on an unknown channel (spread
        over the file).
    kind : str
        ``'chunk'`` (one whole chunk record), ``'bytes'`` (bytes not identified as a
        chunk) or ``'unknown channel'``.
    reason : str
        Why (the damage found).
    messages : int or None
        Messages lost [count] (all topics), from the chunk's message index records;
        None when unknown.
    """

    file: Path
    start: int | None
    end: int | None
    kind: str
    reason: str
    messages: int | None


@dataclass
class BagReadReport:
    """What reading a bag found: files, counts per topic, damage and losses.

    Attributes
    ----------
    files : list of Path
        MCAP files read, in order.
    messages : dict of str to int
        Messages yielded per topic [count].
    losses : list of BagLoss
        Everything skipped, in file order.
    errors : list of str
        One human-readable line per loss and per damage that lost nothing (missing
        footer, unusable summary, repaired chunk length field), in the order found.
    """

    files: list[Path] = field(default_factory=list)
    messages: dict[str, int] = field(default_factory=dict)
    losses: list[BagLoss] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every file was read to its end without damage."""
        return not self.errors

    @property
    def chunks_skipped(self) -> int:
        """Whole chunks not replayed [count]."""
        return sum(1 for loss in self.losses if loss.kind == 'chunk')

    @property
    def bytes_skipped(self) -> int:
        """Bytes of the files' data sections not replayed [bytes]."""
        return sum(loss.end - loss.start for loss in self.losses if loss.start is not None)

    @property
    def messages_lost(self) -> int:
        """Messages known to be lost (all topics) [count]; see :attr:`unknown_losses`."""
        return sum(loss.messages or 0 for loss in self.losses)

    @property
    def unknown_losses(self) -> int:
        """Losses whose message count is unknown (damaged bytes without index) [count]."""
        return sum(1 for loss in self.losses if loss.messages is None)


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


class _FileReader:
    """Streams one MCAP file's messages into bag messages; fills in the report."""

    def __init__(self, file: Path, topics: frozenset[str] | None, report: BagReadReport):
        self.file = file
        self.topics = topics
        self.report = report
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, ChannelRecord] = {}
        self.unknown_channels: dict[int, int] = {}
        self.from_summary: set[tuple[str, int]] = set()  # definitions the data may replace

    def _message(self, record: MessageRecord) -> BagMessage | None:
        channel = self.channels.get(record.channel_id)
        if channel is None:
            self.unknown_channels[record.channel_id] = (
                self.unknown_channels.get(record.channel_id, 0) + 1)
            return None
        if self.topics is not None and channel.topic not in self.topics:
            return None
        topic = channel.topic
        self.report.messages[topic] = self.report.messages.get(topic, 0) + 1
        return BagMessage(topic, self.schemas.get(channel.schema_id, ''), record.log_time,
                          record.publish_time, record.data)

    def _define(self, record: SchemaRecord | ChannelRecord) -> None:
        """Learn a schema or channel; the data section's definition beats the summary's."""
        table = self.schemas if isinstance(record, SchemaRecord) else self.channels
        value = record.name if isinstance(record, SchemaRecord) else record
        known = table.get(record.id)
        key = (type(record).__name__, record.id)
        if known is None or known == value:
            table[record.id] = value
        elif key in self.from_summary:
            self.from_summary.discard(key)
            table[record.id] = value
            self.report.errors.append(
                f'{self.file}: {key[0]} {record.id} differs between the summary and the data '
                f'section (one is damaged); using the data section\'s')
        else:
            self.report.errors.append(
                f'{self.file}: {key[0]} {record.id} defined twice, differently; the first '
                f'definition is kept')

    def _lose(self, lost: LostRange) -> None:
        self.report.losses.append(BagLoss(self.file, lost.start, lost.end, lost.kind,
                                          lost.reason, lost.messages))
        count = 'an unknown number of' if lost.messages is None else str(lost.messages)
        what = 'chunk' if lost.kind == 'chunk' else 'bytes'
        self.report.errors.append(
            f'{self.file}: skipped {what} at bytes {lost.start}-{lost.end} of '
            f'{self.file.stat().st_size} ({lost.end - lost.start} bytes): {lost.reason}; '
            f'{count} messages lost'
        )

    def messages(self) -> Iterator[BagMessage]:
        with self.file.open('rb') as stream:
            reader = RecoveringReader(stream, self.file.stat().st_size)
            if reader.summary is not None:
                for record in reader.summary.schemas + reader.summary.channels:
                    self._define(record)
                    self.from_summary.add((type(record).__name__, record.id))
            for item in reader.records():
                if isinstance(item, MessageRecord):
                    message = self._message(item)
                    if message is not None:
                        yield message
                elif isinstance(item, (SchemaRecord, ChannelRecord)):
                    self._define(item)
                elif isinstance(item, LostRange):
                    self._lose(item)
                elif isinstance(item, Note):
                    self.report.errors.append(f'{self.file}: {item.text}')
        for channel_id, count in sorted(self.unknown_channels.items()):
            self.report.losses.append(BagLoss(
                self.file, None, None, 'unknown channel',
                f'messages on channel {channel_id}, defined nowhere readable', count))
            self.report.errors.append(
                f'{self.file}: {count} messages on unknown channel {channel_id} skipped')


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
        Every intact message, in file order (per file, then file after file), each once.
        Damage is skipped as described in :mod:`forte_driver.replay.mcap_recovery` and listed
        in ``report``.

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
            if stream.read(len(MAGIC))[:5] != MAGIC[:5]:
                raise BagError(f'{file} is not an MCAP file (bad magic bytes)')
        report.files.append(file)
        yield from _FileReader(file, wanted, report).messages()
