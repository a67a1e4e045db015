"""Bag round trips: the project's recorder and writer, read back by independent readers.

Messages cross real DDS from a publisher node to the recorder (in-process and as the
``forte_record`` executable); the bag is then decoded by ``mcap`` + ``mcap_ros2`` (which
know nothing of this project: they use the schema text stored in the file) and by
rosbags' rosbag2 reader, and its ``metadata.yaml`` is checked as ``ros2 bag`` reads it.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import Reader as RosbagsReader

from forte_bringup.bag_recorder import BagRecorder
from forte_bringup.testing import interrupt, python_module
from forte_driver.replay.bags import BagError, BagWriter, TopicSpec, forte_typestore, read_bag
from forte_msgs.msg import GraspState, TactileFrames
from forte_ros.testing import wait_until

CHANNELS = ['left_distal', 'left_middle', 'left_root', 'right_distal', 'right_middle',
            'right_root']


def make_frames(index: int) -> TactileFrames:
    message = TactileFrames()
    message.header.stamp.sec = 1000 + index // 100
    message.header.stamp.nanosec = (index % 100) * 10_000_000 + 7
    message.header.frame_id = 'forte_base_link'
    message.first_sequence = 20 * index
    message.sample_period = 0.0005
    message.channel_names = CHANNELS
    message.sample_count = 20
    message.data = (np.arange(120) * 1e-3 + index).tolist()
    message.dropped_frames = index // 10
    return message


class Talker(Node):
    def __init__(self, best_effort: bool) -> None:
        super().__init__('bag_test_talker')
        self.frames = self.create_publisher(
            TactileFrames, 'tactile/frames',
            QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                       else ReliabilityPolicy.RELIABLE))
        self.state = self.create_publisher(
            GraspState, 'grasp/state',
            QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))


@pytest.fixture
def executor():
    rclpy.init()
    executor = SingleThreadedExecutor()
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    yield executor
    executor.shutdown()
    for node in list(executor.get_nodes()):
        node.destroy_node()
    rclpy.try_shutdown()
    thread.join(timeout=5)



def read_with_mcap_ros2(bag: Path) -> dict[str, list]:
    """Decode every message with mcap + mcap_ros2 (independent of rclpy and rosbags)."""
    out: dict[str, list] = {}
    files = sorted(bag.glob('*.mcap'))
    assert len(files) == 1
    with files[0].open('rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert channel.message_encoding == 'cdr' and schema.encoding == 'ros2msg'
            out.setdefault(channel.topic, []).append((schema.name, message.log_time, decoded))
    return out


def record_in_process(executor, tmp_path: Path, count: int) -> tuple[Path, BagRecorder]:
    talker = Talker(best_effort=False)
    executor.add_node(talker)
    state = GraspState(state=GraspState.LIFTING, controller=0, target_force=0.25,
                       message='latched before the recorder started')
    state.header.frame_id = 'forte_base_link'
    talker.state.publish(state)  # transient local: the late recorder still gets it
    bag = tmp_path / 'bag'
    recorder = BagRecorder(bag, topics=['tactile/frames', 'grasp/state'])
    executor.add_node(recorder.node)
    assert wait_until(lambda: len([s for s in recorder.subscriptions.values() if s]) == 2)
    assert wait_until(lambda: talker.frames.get_subscription_count() == 1)
    assert wait_until(lambda: recorder.received.get('/grasp/state', 0) == 1)
    for index in range(count):
        talker.frames.publish(make_frames(index))
        time.sleep(0.001)
    assert wait_until(lambda: recorder.received['/tactile/frames'] == count)
    executor.remove_node(recorder.node)
    recorder.close()
    return bag, recorder


def test_recorded_bag_reads_back_with_mcap_ros2_and_rosbags(executor, tmp_path):
    bag, recorder = record_in_process(executor, tmp_path, 200)

    decoded = read_with_mcap_ros2(bag)
    frames = decoded['/tactile/frames']
    assert len(frames) == 200
    for index, (schema_name, _, message) in enumerate(frames):
        expected = make_frames(index)
        assert schema_name == 'forte_msgs/msg/TactileFrames'
        assert message.header.stamp.sec == expected.header.stamp.sec
        assert message.header.stamp.nanosec == expected.header.stamp.nanosec
        assert message.header.frame_id == 'forte_base_link'
        assert list(message.channel_names) == CHANNELS
        assert message.first_sequence == 20 * index
        assert message.dropped_frames == index // 10
        np.testing.assert_array_equal(np.asarray(message.data), np.asarray(expected.data))
    log_times = [log_time for _, log_time, _ in frames]
    assert log_times == sorted(log_times)
    (_, _, state), = decoded['/grasp/state']
    assert state.state == GraspState.LIFTING and state.target_force == 0.25
    assert state.message == 'latched before the recorder started'

    typestore = forte_typestore()
    with RosbagsReader(bag) as reader:
        assert reader.message_count == 201
        connections = {c.topic: c for c in reader.connections}
        assert connections['/tactile/frames'].msgtype == 'forte_msgs/msg/TactileFrames'
        sequences = [
            typestore.deserialize_cdr(raw, connection.msgtype).first_sequence
            for connection, _, raw in reader.messages(connections=[connections['/tactile/frames']])
        ]
    assert sequences == [20 * i for i in range(200)]

    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert metadata['version'] == 9 and metadata['storage_identifier'] == 'mcap'
    assert metadata['message_count'] == 201
    counts = {t['topic_metadata']['name']: t['message_count']
              for t in metadata['topics_with_message_count']}
    assert counts == {'/tactile/frames': 200, '/grasp/state': 1}
    qos = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles'][0]
           for t in metadata['topics_with_message_count']}
    assert qos['/grasp/state']['durability'] == 'transient_local'
    assert qos['/tactile/frames']['reliability'] == 'reliable'
    assert '/tactile/frames: 200' in recorder.summary()


def test_project_reader_matches_independent_reader(executor, tmp_path):
    bag, _ = record_in_process(executor, tmp_path, 50)
    ours = [(m.topic, m.log_time) for m in read_bag(bag)]
    theirs = [(topic, log_time) for topic, items in read_with_mcap_ros2(bag).items()
              for _, log_time, _ in items]
    assert sorted(ours) == sorted(theirs)


def test_writer_refuses_overwrite_and_unknown_types(tmp_path):
    with BagWriter(tmp_path / 'bag') as bag:
        with pytest.raises(BagError, match='unknown'):
            bag.add_topic(TopicSpec('x', 'no_pkg/msg/Nothing'))
        bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
        with pytest.raises(BagError, match='already recorded'):
            bag.add_topic(TopicSpec('/tactile/frames', 'forte_msgs/msg/TactileState'))
    with pytest.raises(BagError, match='exists already'):
        BagWriter(tmp_path / 'bag')


def test_forte_record_executable_stops_cleanly_on_sigint(executor, tmp_path):
    talker = Talker(best_effort=True)  # the sensor-data QoS of the contract
    executor.add_node(talker)
    bag = tmp_path / 'cli_bag'
    with python_module('forte_bringup.bag_recorder', '-o', str(bag),
                       '--topics', 'tactile/frames') as process:
        assert wait_until(lambda: talker.frames.get_subscription_count() == 1, timeout=20.0)
        time.sleep(0.5)
        for index in range(100):
            talker.frames.publish(make_frames(index))
            time.sleep(0.005)
        time.sleep(0.5)
        output = interrupt(process, timeout=20)
    assert process.returncode == 0, output
    assert 'bag closed' in output
    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    count = metadata['message_count']
    # best effort over loopback: allowed to lose messages, never to invent or reorder them
    assert 90 <= count <= 100
    sequences = [m.first_sequence for _, _, m in read_with_mcap_ros2(bag)['/tactile/frames']]
    assert sequences == sorted(set(sequences)) and set(sequences) <= {20 * i for i in range(100)}
