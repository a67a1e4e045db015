"""The bench twin node's commissioning aids with real rclpy: the ``sensor_fault`` parameter
and the scripted operator's presses asked on ``sim/operator_press``."""
from __future__ import annotations

import pytest
from rclpy.parameter import Parameter
from std_msgs.msg import String

from forte_ros.qos import COMMANDS
from forte_ros.testing import SpinningGraph, wait_until
from forte_sim.ros.bench_twin_node import BenchTwinNode, parse_press


def test_press_requests_are_read_or_refused():
    assert parse_press('left tip') == (0, 0.10, 4.0, 1.0)
    assert parse_press('right root 3.5') == (1, 0.85, 3.5, 1.0)
    assert parse_press('right 0.4 2 0.5') == (1, 0.4, 2.0, 0.5)
    for text in ('', 'left', 'middle tip', 'left knuckle', 'left tip x', 'left tip 1 2 3'):
        with pytest.raises(ValueError):
            parse_press(text)


def overrides(tmp_path, fault: str) -> list[Parameter]:
    return [Parameter('sensor_link', value=str(tmp_path / 'bench' / 'sensor')),
            Parameter('servo_link', value=str(tmp_path / 'bench' / 'gripper')),
            Parameter('scene', value='calibration'), Parameter('object', value='flat_wide'),
            Parameter('sensor_fault', value=fault)]


def test_an_unreadable_fault_stops_the_node(tmp_path):
    ros = SpinningGraph('bench_twin_fault_peer')
    try:
        with pytest.raises(ValueError, match='unknown channel'):
            BenchTwinNode(context=ros.context,
                          parameter_overrides=overrides(tmp_path, 'reversed:left_thumb'))
    finally:
        ros.close()


def test_the_fault_is_applied_and_a_press_request_schedules_a_press(tmp_path):
    ros = SpinningGraph('bench_twin_press_peer')
    node = ros.add(BenchTwinNode(context=ros.context, parameter_overrides=overrides(
        tmp_path, 'reversed:left_root;noisy:right_root:noise_lsb=5')))
    press = ros.node.create_publisher(String, 'sim/operator_press', COMMANDS)
    ros.start()
    try:
        assert [fault.label for fault in node.twin.faults] == [
            'reversed:left_root', 'noisy:right_root:noise_lsb=5']
        assert wait_until(lambda: ros.node.count_subscribers('sim/operator_press') > 0, 10.0)
        press.publish(String(data='left knuckle'))  # refused, logged
        press.publish(String(data='right root 3.0 0.5'))
        assert wait_until(lambda: node.twin.presses, 10.0)
        (scheduled,) = node.twin.presses
        assert (scheduled.finger, scheduled.location, scheduled.force, scheduled.hold) == (
            1, 0.85, 3.0, 0.5)
    finally:
        ros.stop()
        node.prepare_shutdown()
        ros.close()
