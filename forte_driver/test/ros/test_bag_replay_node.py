"""Bag replay over real DDS: project bags, foreign MCAP files, damaged files, pacing.

The replay node runs in-process with a subscriber node on a real executor; bags are real
files written by the project's writer (rosbags) or directly by ``mcap_ros2.writer``.
Bags are written with ``forte_driver.replay.bags``, the same package's writer.
"""
from __future__ import annotations

import struct
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer as McapRos2Writer
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from forte_driver.replay.bags import BagWriter, TopicSpec, forte_typestore
from forte_driver.replay.mcap_source import BagError
from forte_driver.ros.bag_replay_node import BagReplayNode, ReplayClock, message_class
from forte_msgs.msg import TactileFrames

CHANNELS = ['left_distal', 'left_middle', 'left_root', 'right_distal', 'right_middle',
            'right_root']
PERIOD_NS = 10_000_000  # one batch of 20 samples every 10 ms
START_NS = 1_700_000_000_000_000_000


def frames_message(index: int) -> TactileFrames:
    """Batch ``index`` with known content: sample k of channel c = (20*index+k)/1e5 + c/10."""
    message = TactileFrames()
    stamp = START_NS + index * PERIOD_NS + 123  # odd nanoseconds: must survive exactly
    message.header.stamp.sec = stamp // 1_000_000_000
    message.header.stamp.nanosec = stamp % 1_000_000_000
    message.header.frame_id = 'forte_base_link'
    message.first_sequence = 20 * index
    message.device_time_us = 500 * 20 * index
    message.sample_period = 0.0005
    message.channel_names = CHANNELS
    message.sample_count = 20
    rows = (20 * index + np.arange(20))[:, None] / 1e5 + np.arange(6)[None, :] / 10.0
    message.data = rows.ravel().tolist()
    return message


def write_project_bag(path: Path, count: int) -> Path:
    with BagWriter(path) as bag:
        bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames',
                                reliable=False, depth=50))
        for index in range(count):
            bag.write('tactile/frames', START_NS + index * PERIOD_NS,
                      serialize_message(frames_message(index)))
    return path


def write_foreign_mcap(path: Path, count: int) -> Path:
    """A single .mcap written by mcap_ros2 (zstd chunks), not by the project's tooling."""
    msgdef, _ = forte_typestore().generate_msgdef('forte_msgs/msg/TactileFrames', ros_version=2)
    with path.open('wb') as stream:
        writer = McapRos2Writer(stream, compression=CompressionType.ZSTD)
        schema = writer.register_msgdef('forte_msgs/msg/TactileFrames', msgdef)
        for index in range(count):
            message = frames_message(index)
            as_dict = {
                'header': {'stamp': {'sec': message.header.stamp.sec,
                                     'nanosec': message.header.stamp.nanosec},
                           'frame_id': message.header.frame_id},
                'first_sequence': message.first_sequence,
                'device_time_us': message.device_time_us,
                'sample_period': message.sample_period,
                'channel_names': list(message.channel_names),
                'sample_count': message.sample_count,
                'data': list(message.data),
                'dropped_frames': 0,
                'corrupt_frames': 0,
            }
            writer.write_message('/tactile/frames', schema, as_dict,
                                 log_time=START_NS + index * PERIOD_NS,
                                 publish_time=START_NS + index * PERIOD_NS)
        writer.finish()
    return path


class Collector(Node):
    """Subscriber recording every TactileFrames with its receive time."""

    def __init__(self) -> None:
        super().__init__('replay_collector')
        self.received: list[tuple[float, TactileFrames]] = []
        self.create_subscription(
            TactileFrames, 'tactile/frames', self._on_frames,
            QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE))

    def _on_frames(self, message: TactileFrames) -> None:
        self.received.append((time.monotonic(), message))


@pytest.fixture
def ros():
    rclpy.init()
    executor = SingleThreadedExecutor()
    thread = threading.Thread(target=executor.spin, daemon=True)
    nodes: list[Node] = []

    def add(node: Node) -> Node:
        nodes.append(node)
        executor.add_node(node)
        if not thread.is_alive():
            thread.start()
        return node

    yield add
    executor.shutdown()
    for node in nodes:
        node.destroy_node()
    rclpy.try_shutdown()
    if thread.is_alive():
        thread.join(timeout=5)


def replay(ros, bag: Path, timeout: float = 30.0, **parameters) -> tuple[BagReplayNode, Collector]:
    collector = ros(Collector())
    values = {'bag_path': str(bag), 'reliable': True, 'rate': 0.0, 'start_delay': 0.0,
              'wait_for_subscribers': 1}
    values.update(parameters)
    node = ros(BagReplayNode(parameter_overrides=[
        Parameter(name, value=value) for name, value in values.items()]))
    assert node.done.wait(timeout), 'replay did not finish'
    expected = sum(node.published.values())
    deadline = time.monotonic() + 10.0
    while len(collector.received) < expected and time.monotonic() < deadline:
        time.sleep(0.05)
    return node, collector


def assert_frames_equal(received: TactileFrames, index: int) -> None:
    expected = frames_message(index)
    assert received.header.stamp.sec == expected.header.stamp.sec
    assert received.header.stamp.nanosec == expected.header.stamp.nanosec
    assert received.header.frame_id == 'forte_base_link'
    assert received.first_sequence == expected.first_sequence
    assert list(received.channel_names) == CHANNELS
    np.testing.assert_array_equal(np.asarray(received.data), np.asarray(expected.data))


def test_project_bag_replays_every_message_with_its_stamps(ros, tmp_path):
    bag = write_project_bag(tmp_path / 'bag', 300)
    node, collector = replay(ros, bag)
    assert node.report.complete and node.undecodable == 0
    assert node.published == {'/tactile/frames': 300}
    assert len(collector.received) == 300
    for index, (_, message) in enumerate(collector.received):
        assert_frames_equal(message, index)


def test_bag_written_by_another_tool_replays(ros, tmp_path):
    bag = write_foreign_mcap(tmp_path / 'foreign.mcap', 120)
    node, collector = replay(ros, bag)
    assert node.report.complete
    assert [m.first_sequence for _, m in collector.received] == [20 * i for i in range(120)]
    for index, (_, message) in enumerate(collector.received):
        assert_frames_equal(message, index)


def intact_prefix_count(original: Path, cut: int) -> int:
    """Messages of the chunks that end before byte ``cut``, from the intact original file."""
    with original.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    complete_end_times = [c.message_end_time for c in summary.chunk_indexes
                          if c.chunk_start_offset + c.chunk_length <= cut]
    if not complete_end_times:
        return 0
    last = max(complete_end_times)
    with original.open('rb') as stream:
        return sum(1 for _, _, msg in make_reader(stream).iter_messages() if msg.log_time <= last)


def test_truncated_bag_reports_the_damage_and_replays_the_intact_part(ros, tmp_path):
    bag = write_project_bag(tmp_path / 'bag', 3000)  # ~3.5 MB, four 1 MiB chunks
    mcap_file = next(bag.glob('*.mcap'))
    original = tmp_path / 'original.mcap'
    original.write_bytes(mcap_file.read_bytes())
    cut = int(mcap_file.stat().st_size * 0.6)
    with mcap_file.open('r+b') as stream:
        stream.truncate(cut)
    expected = intact_prefix_count(original, cut)
    assert 0 < expected < 3000
    node, collector = replay(ros, bag)
    assert not node.report.complete
    assert 'truncated' in node.report.errors[0] and str(mcap_file) in node.report.errors[0]
    assert node.published == {'/tactile/frames': expected}
    assert len(collector.received) == expected
    for index, (_, message) in enumerate(collector.received):
        assert_frames_equal(message, index)


def test_damaged_chunks_in_the_middle_lose_only_the_unverifiable_chunk(ros, tmp_path):
    """rosbags writes CRC 0: a chunk whose records do not parse is skipped, reading goes
    on; a chunk whose only damage is its length field is read by its content."""
    bag = write_project_bag(tmp_path / 'bag', 3000)  # four 1 MiB chunks, uncompressed
    mcap_file = next(bag.glob('*.mcap'))
    with mcap_file.open('rb') as stream:
        chunks = sorted(make_reader(stream).get_summary().chunk_indexes,
                        key=lambda index: index.chunk_start_offset)
    assert len(chunks) >= 3
    bad, length_only = chunks[1], chunks[2]
    with mcap_file.open('r+b') as stream:
        stream.seek(bad.chunk_start_offset + 9 + 40 + 1)  # length of its first record
        stream.write(struct.pack('<Q', 10**9))
        stream.seek(length_only.chunk_start_offset + 1)  # the chunk record's length field
        stream.write(struct.pack('<Q', 2**40))
    lost = [index for index in range(3000)
            if bad.message_start_time <= START_NS + index * PERIOD_NS <= bad.message_end_time]
    assert 0 < len(lost) < 3000
    node, collector = replay(ros, bag)
    kept = [index for index in range(3000) if index not in set(lost)]
    assert node.published == {'/tactile/frames': len(kept)}
    assert [m.first_sequence for _, m in collector.received] == [20 * i for i in kept]
    report = node.report
    assert report.chunks_skipped == 1 and report.messages_lost == len(lost)
    assert report.bytes_skipped == bad.chunk_length and report.unknown_losses == 0
    assert [(loss.start, loss.end) for loss in report.losses] == [
        (bad.chunk_start_offset, bad.chunk_start_offset + bad.chunk_length)]
    assert any('damaged length field' in error for error in report.errors)


def test_corrupt_payload_is_skipped_and_counted(ros, tmp_path):
    path = tmp_path / 'bag'
    with BagWriter(path) as bag:
        bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
        for index in range(10):
            data = serialize_message(frames_message(index))
            if index == 4:
                data = data[:4] + b'\xff' * 8  # valid record, payload cut: not a TactileFrames
            bag.write('tactile/frames', START_NS + index * PERIOD_NS, data)
    node, collector = replay(ros, path)
    assert node.undecodable == 1
    assert [m.first_sequence for _, m in collector.received] == [
        20 * i for i in range(10) if i != 4]


def test_original_timing_scaled_by_rate(ros, tmp_path):
    bag = write_project_bag(tmp_path / 'bag', 101)  # 1.0 s of log time
    node, collector = replay(ros, bag, rate=2.0)
    assert len(collector.received) == 101
    times = np.array([t for t, _ in collector.received])
    span = times[-1] - times[0]
    # 1 s of recording at rate 2 takes 0.5 s; never less, allow for scheduling on CI
    assert span >= 0.45
    assert span < 2.0
    # the pacing follows the log times: the midpoint message arrives near mid-span
    assert abs((times[50] - times[0]) - span / 2) < 0.2


def test_missing_bag_is_a_clear_error(ros, tmp_path):
    with pytest.raises(BagError, match='does not exist'):
        BagReplayNode(parameter_overrides=[
            Parameter('bag_path', value=str(tmp_path / 'nothing'))])
    with pytest.raises(BagError, match='bag_path is empty'):
        BagReplayNode()


def test_not_an_mcap_file_is_a_clear_error(ros, tmp_path):
    bogus = tmp_path / 'bag.mcap'
    bogus.write_bytes(b'SQLite format 3\x00' + bytes(100))
    node, _ = replay(ros, bogus, timeout=10.0)
    assert node.published == {}
    assert any('not an MCAP file' in error for error in node.report.errors)


def test_replay_clock():
    clock = ReplayClock(rate=2.0)
    assert clock.due(5_000_000_000, now=100.0) == 100.0
    assert clock.due(6_000_000_000, now=100.1) == pytest.approx(100.5)
    assert clock.due(4_000_000_000, now=101.0) == pytest.approx(99.5)  # out of order: overdue
    fast = ReplayClock(rate=0.0)
    assert fast.due(0, now=3.0) == 3.0 and fast.due(10**12, now=4.0) == 4.0
    with pytest.raises(ValueError):
        ReplayClock(rate=-1.0)
    with pytest.raises(ValueError):
        ReplayClock(rate=float('nan'))


def test_message_class():
    assert message_class('forte_msgs/msg/TactileFrames') is TactileFrames
    with pytest.raises(BagError):
        message_class('forte_msgs/NoSuch')
    with pytest.raises(BagError, match='not installed'):
        message_class('no_such_pkg/msg/Thing')
