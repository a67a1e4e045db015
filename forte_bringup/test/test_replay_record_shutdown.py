"""bag_replay_node and forte_record, as their real executables, stop cleanly on SIGINT and
SIGTERM: exit code 0 within a few seconds, no traceback (the replay thread used to publish
after the context was gone), and forte_record finishes its bag.

bag_replay_node is forte_driver's, tested here because the bags are written with
``forte_driver.replay.bags`` (see test_bag_replay_node.py for why).
"""
from __future__ import annotations

import signal
from pathlib import Path

import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.serialization import serialize_message

from forte_driver.replay.bags import BagWriter, TopicSpec
from forte_msgs.msg import TactileFrames
from forte_ros.testing import NodeProcess, Probe, ros_args, wait_until

PERIOD_NS = 10_000_000  # one batch every 10 ms, as the driver
START_NS = 1_700_000_000_000_000_000
RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def frames(index: int) -> TactileFrames:
    message = TactileFrames(first_sequence=20 * index, sample_period=0.0005, sample_count=20)
    message.header.frame_id = 'forte_base_link'
    message.data = [0.001 * index] * 120
    return message


def write_bag(path: Path, count: int) -> Path:
    with BagWriter(path) as writer:
        writer.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames',
                                   reliable=False, depth=50))
        for index in range(count):
            writer.write('tactile/frames', START_NS + index * PERIOD_NS,
                         serialize_message(frames(index)))
    return path


@pytest.fixture(scope='module')
def bag(tmp_path_factory) -> Path:
    """20 s of frames at the recorded timing."""
    return write_bag(tmp_path_factory.mktemp('bags') / 'short', 2000)


@pytest.fixture(scope='module')
def long_bag(tmp_path_factory) -> Path:
    """5 min of frames: still replaying when the signal comes, even as fast as possible."""
    return write_bag(tmp_path_factory.mktemp('bags') / 'long', 30000)


@pytest.mark.parametrize('signum, rate', [(signal.SIGINT, 1.0), (signal.SIGTERM, 1.0),
                                          (signal.SIGINT, 0.0)],
                         ids=['SIGINT', 'SIGTERM', 'SIGINT-as-fast-as-possible'])
def test_bag_replay_node_stops_cleanly_mid_replay(long_bag, signum, rate):
    reliable = rate == 0.0  # as fast as possible: the replay thread publishes flat out
    with Probe('replay_shutdown_probe') as probe:
        probe.count(TactileFrames, 'tactile/frames',
                    RELIABLE if reliable else qos_profile_sensor_data)
        # the replay starts once the probe has matched: flat out, the 30000 messages take
        # about 2 s, less than a loaded machine may need to discover the probe
        command = ['bag_replay_node', *ros_args(bag_path=str(long_bag), rate=rate,
                                                reliable=reliable, start_delay=0.0,
                                                wait_for_subscribers=1)]
        with NodeProcess(command) as process:
            assert wait_until(lambda: probe.counts['tactile/frames'] >= 20, 40.0), \
                process.output
            process.stop_cleanly(signum)
    assert 'replay finished' not in process.output  # it was stopped in the middle


def test_bag_replay_node_exits_by_itself_when_done(bag):
    command = ['bag_replay_node', *ros_args(bag_path=str(bag), rate=0.0, start_delay=0.0,
                                            exit_when_done=True)]
    with NodeProcess(command) as process:
        assert wait_until(lambda: process.process.poll() is not None, 60.0), process.output
    assert process.process.returncode == 0, process.output
    assert 'replay finished: 2000 messages published' in process.output
    assert not process.failures(), process.output


def test_bag_replay_node_without_a_bag_is_one_fatal_line_and_exit_code_2(tmp_path):
    command = ['bag_replay_node', *ros_args(bag_path=str(tmp_path / 'missing'))]
    with NodeProcess(command) as process:
        assert wait_until(lambda: process.process.poll() is not None, 60.0), process.output
    assert process.process.returncode == 2, process.output
    assert 'FATAL' in process.output
    assert not process.failures(), process.output


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_forte_record_finishes_the_bag_on_a_signal(tmp_path, signum):
    output = tmp_path / 'recorded'
    with Probe('record_shutdown_probe') as probe:
        publisher = probe.node.create_publisher(TactileFrames, 'tactile/frames', RELIABLE)
        sent = [0]

        def publish() -> None:
            publisher.publish(frames(sent[0]))
            sent[0] += 1

        probe.node.create_timer(0.01, publish)
        command = ['forte_record', '-o', str(output), '--topics', 'tactile/frames']
        with NodeProcess(command) as process:
            assert wait_until(lambda: 'recording /tactile/frames' in process.output, 40.0), \
                process.output
            start = sent[0]
            assert wait_until(lambda: sent[0] >= start + 50, 20.0)
            process.stop_cleanly(signum)
    assert 'bag closed' in process.output
    recorded = int(process.output.split('/tactile/frames: ')[1].split()[0])
    assert recorded >= 40, process.output
    assert (output / 'metadata.yaml').is_file()
