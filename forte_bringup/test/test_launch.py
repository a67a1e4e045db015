"""launch_pytest tests of the three launch files (need a ROS 2 install with launch_ros).

On a bare machine (pip-installed rclpy, no launch / launch_ros / launch_pytest) they are
skipped with the reason below; the same graphs are brought up there by ``forte_bringup``
and tested in test_bringup.py. On a lab machine with ROS 2 Jazzy sourced and the workspace
built with colcon, ``python -m pytest forte_bringup/test/test_launch.py`` runs them.
"""
from __future__ import annotations

import time
from pathlib import Path

import pytest

launch_pytest = pytest.importorskip(
    'launch_pytest',
    reason='launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest); '
           'on a bare machine forte_bringup starts the same graphs (test_bringup.py)')

import launch  # noqa: E402
import rclpy  # noqa: E402
from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

from forte_msgs.msg import GraspState, TactileState  # noqa: E402

pytestmark = pytest.mark.launch
LAUNCH = Path(__file__).resolve().parents[1] / 'launch'


def include(name: str, **arguments: str) -> launch.LaunchDescription:
    return launch.LaunchDescription([
        IncludeLaunchDescription(PythonLaunchDescriptionSource(str(LAUNCH / name)),
                                 launch_arguments=arguments.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


def receive(topic: str, message_type, qos: QoSProfile, count: int, timeout: float) -> int:
    rclpy.init()
    node = rclpy.create_node('launch_test_listener')
    received = []
    node.create_subscription(message_type, topic, received.append, qos)
    deadline = time.monotonic() + timeout
    try:
        while len(received) < count and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return len(received)


@pytest.mark.parametrize('name', ['hardware.launch.py', 'sim.launch.py', 'replay.launch.py'])
def test_every_argument_has_a_description(name):
    source = PythonLaunchDescriptionSource(str(LAUNCH / name))
    description = source.get_launch_description(launch.LaunchContext())
    arguments = description.get_launch_arguments()
    assert arguments, name
    for argument in arguments:
        assert argument.description and argument.description != 'no description given', (
            name, argument.name)


@launch_pytest.fixture
def sim_launch():
    return include('sim.launch.py', object='soda_can')


@pytest.mark.launch(fixture=sim_launch)
def test_sim_launch_publishes_tactile_and_grasp_state():
    reliable = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    assert receive('tactile/state', TactileState, reliable, 20, 30.0) >= 20
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    assert receive('grasp/state', GraspState, latched, 1, 30.0) >= 1


@pytest.fixture(scope='module')
def recorded_bag(tmp_path_factory):
    """A short bag of tactile frames written by the project's writer."""
    import numpy as np
    from rclpy.serialization import serialize_message

    from forte_bringup.bags import BagWriter, TopicSpec
    from forte_msgs.msg import TactileFrames

    path = tmp_path_factory.mktemp('replay') / 'bag'
    with BagWriter(path) as bag:
        bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
        for index in range(500):
            message = TactileFrames(sample_count=20, sample_period=0.0005)
            message.header.stamp.sec = 100 + index // 100
            message.header.stamp.nanosec = (index % 100) * 10_000_000
            message.channel_names = ['left_distal', 'left_middle', 'left_root',
                                     'right_distal', 'right_middle', 'right_root']
            message.first_sequence = 20 * index
            message.data = (np.random.default_rng(index).normal(0, 1e-3, 120)).tolist()
            bag.write('tactile/frames', 100_000_000_000 + index * 10_000_000,
                      serialize_message(message))
    return path


@launch_pytest.fixture
def replay_launch(recorded_bag):
    return include('replay.launch.py', bag=str(recorded_bag))


@pytest.mark.launch(fixture=replay_launch)
def test_replay_launch_drives_perception():
    reliable = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    assert receive('tactile/state', TactileState, reliable, 20, 30.0) >= 20


@launch_pytest.fixture
def hardware_launch():
    # no devices: the lifecycle nodes must come up unconfigured-or-inactive, not crash
    return include('hardware.launch.py', sensor_port='/nonexistent/forte_sensor',
                   gripper_port='/nonexistent/forte_gripper')


@pytest.mark.launch(fixture=hardware_launch)
def test_hardware_launch_starts_control_without_devices():
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    assert receive('grasp/state', GraspState, latched, 1, 30.0) >= 1
