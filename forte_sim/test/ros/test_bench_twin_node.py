"""The bench twin node with real rclpy: devices behind its links, the arm on arm/cmd_vel,
the ground truth on sim/ground_truth."""
from __future__ import annotations

import os
import time

import pytest
from geometry_msgs.msg import TwistStamped
from rclpy.parameter import Parameter

from forte_msgs.msg import SimGroundTruth
from forte_ros.qos import COMMANDS, reliable
from forte_ros.testing import SpinningGraph, wait_until
from forte_sim.ros.bench_twin_node import BenchTwinNode


@pytest.fixture
def graph(tmp_path):
    ros = SpinningGraph('bench_twin_peer')
    overrides = [Parameter('sensor_link', value=str(tmp_path / 'bench' / 'sensor')),
                 Parameter('servo_link', value=str(tmp_path / 'bench' / 'gripper')),
                 Parameter('object', value='raspberry'), Parameter('seed', value=4),
                 Parameter('cmd_vel_timeout', value=0.3)]
    node = ros.add(BenchTwinNode(context=ros.context, parameter_overrides=overrides))
    truth = ros.collect(SimGroundTruth, 'sim/ground_truth', reliable(1000))
    arm = ros.node.create_publisher(TwistStamped, 'arm/cmd_vel', COMMANDS)
    ros.start()
    yield node, truth, arm, tmp_path / 'bench'
    ros.stop()
    node.prepare_shutdown()
    ros.close()


def lift(arm, velocity: float) -> None:
    message = TwistStamped()
    message.twist.linear.z = velocity
    arm.publish(message)


def test_links_point_at_the_devices_and_truth_flows(graph):
    node, truth, _, folder = graph
    assert os.path.realpath(folder / 'gripper') == node.twin.servo_device
    assert os.path.realpath(folder / 'sensor').startswith('/dev/pts/')
    assert wait_until(lambda: len(truth) >= 20, 20.0)
    latest = truth[-1]
    assert latest.scene == 'grasp' and latest.object_name == 'raspberry'
    assert latest.object_state == SimGroundTruth.OBJECT_RESTING
    assert latest.lift_height == 0.0


def test_the_arm_moves_while_commanded_and_stops_on_the_timeout(graph):
    """Commands at 20 Hz for 0.5 s at 10 mm/s lift the (empty) gripper by about 5 mm; after
    the last command the arm stops within the 0.3 s timeout: the height stays below 5 mm +
    0.3 s x 10 mm/s."""
    node, truth, arm, _ = graph
    assert wait_until(lambda: truth, 20.0)
    start = time.monotonic()
    while time.monotonic() - start < 0.5:
        lift(arm, 0.01)
        time.sleep(0.05)
    time.sleep(1.0)
    settled = truth[-1].lift_height
    time.sleep(0.3)
    assert truth[-1].lift_height == settled  # stopped
    assert 0.003 < settled < 0.005 + 0.3 * 0.01 + 0.002  # [m]
    assert node.twin.scene.time > 1.5  # the scene ran in real time meanwhile


def test_shutdown_removes_the_servo_link(graph):
    node, _, _, folder = graph
    node.prepare_shutdown()
    assert not (folder / 'gripper').exists()
    assert not (folder / 'sensor').exists()


def test_the_prefix_names_the_ground_truth_and_load_cell_frames(tmp_path):
    from geometry_msgs.msg import WrenchStamped

    from forte_ros.qos import LOAD_CELL

    ros = SpinningGraph('bench_twin_prefix_peer')
    overrides = [Parameter('sensor_link', value=str(tmp_path / 'sensor')),
                 Parameter('servo_link', value=str(tmp_path / 'gripper')),
                 Parameter('scene', value='calibration'), Parameter('object', value='flat_wide'),
                 Parameter('prefix', value='right_')]
    node = ros.add(BenchTwinNode(context=ros.context, parameter_overrides=overrides))
    truth = ros.collect(SimGroundTruth, 'sim/ground_truth', reliable(1000))
    load = ros.collect(WrenchStamped, 'load_cell/wrench', LOAD_CELL)
    ros.start()
    try:
        assert wait_until(lambda: truth and load, 20.0)
        assert {message.header.frame_id for message in truth} == {'right_forte_base_link'}
        assert {message.header.frame_id for message in load} == {'right_forte_load_cell'}
    finally:
        ros.stop()
        node.prepare_shutdown()
        ros.close()
