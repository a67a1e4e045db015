"""The slip lift node publishes the protocol's commands on the graph's topics.

In process, on this test's own ROS domain (root conftest): a listener records
``gripper/command`` and ``arm/cmd_vel`` while the node runs a shortened lift (open 0.3 s,
close and hold 0.3 s, lift 0.6 s at 1 mm/s, rest 0.3 s, 20 Hz).
"""
from __future__ import annotations

import time

import pytest

rclpy = pytest.importorskip('rclpy')

from geometry_msgs.msg import TwistStamped  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from forte_commissioning.ros.slip_lift_node import SlipLiftNode  # noqa: E402
from forte_msgs.msg import ServoCommand  # noqa: E402
from forte_ros.qos import COMMANDS  # noqa: E402

SHORT = {'open_s': 0.3, 'hold_s': 0.3, 'lift_s': 0.6, 'rest_s': 0.3}


@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


def overrides(**values) -> list[Parameter]:
    return [Parameter(name, value=value) for name, value in values.items()]


def test_the_node_publishes_one_lift(context):
    servo, arm = [], []
    listener = rclpy.create_node('lift_listener', context=context)
    listener.create_subscription(ServoCommand, 'gripper/command',
                                 lambda m: servo.append(m.position), COMMANDS)
    listener.create_subscription(TwistStamped, 'arm/cmd_vel',
                                 lambda m: arm.append((m.twist.linear.z, m.header.frame_id)),
                                 COMMANDS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    # let the listener's subscriptions be discovered before the first command
    deadline = time.monotonic() + 5.0
    node = SlipLiftNode(context=context, parameter_overrides=overrides(
        grip_angle=0.5, open_angle=0.6, **SHORT))
    while (node.count_subscribers('arm/cmd_vel') < 1 and time.monotonic() < deadline):
        executor.spin_once(timeout_sec=0.05)
    executor.add_node(node)
    deadline = time.monotonic() + 15.0
    while not node.done and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    for _ in range(20):                     # the last messages
        executor.spin_once(timeout_sec=0.02)
    assert node.done
    velocities = [v for v, _ in arm]
    print(f'{len(servo)} servo commands, {len(arm)} arm commands')
    assert 25 <= len(arm) <= 40            # 1.5 s at 20 Hz (+ the final stop)
    assert servo[0] == 0.6 and servo[-1] == 0.5
    first_grip = servo.index(0.5)
    assert set(servo[:first_grip]) == {0.6} and set(servo[first_grip:]) == {0.5}
    lifting = [i for i, v in enumerate(velocities) if v > 0]
    assert lifting and set(velocities[lifting[0]:lifting[-1] + 1]) == {0.001}
    assert first_grip <= lifting[0] and velocities[-1] == 0.0
    assert 8 <= len(lifting) <= 16          # 0.6 s at 20 Hz
    assert {frame for _, frame in arm} == {'forte_base_link'}
    node.destroy_node()
    listener.destroy_node()
    executor.shutdown()


def test_the_grip_angle_is_required(context):
    with pytest.raises(ValueError, match='grip_angle'):
        SlipLiftNode(context=context)
