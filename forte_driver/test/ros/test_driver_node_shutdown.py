"""The forte_driver node executables stop cleanly on SIGINT / SIGTERM and survive invalid
lifecycle requests.

Each node runs as its real console script in its own process, on the driver's fake
hardware: serial_sensor_node on an emulated sensor board behind a pty (in this process),
gripper_driver_node on the simulated XM430-W350 pair (its own process, on a pty). (sim_node's
own shutdown test is forte_sim's, test_sim_node_shutdown.py.) The tests
let it publish, stop it with a signal and check the exit code, the time to exit, that no
traceback was printed, and that the lifecycle shutdown transition did its job on the
device: the sensor was told to STOP, the servos' torque is as ``release_on_shutdown`` says.
A probe node in this process calls ``<node>/change_state`` as a stale launch would.
"""
from __future__ import annotations

import signal

import pytest
from lifecycle_msgs.msg import Transition
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from forte_driver.emulators.emulated_sensor import EmulatedSensor
from forte_driver.emulators.simulated_servo import SimulatedServoProcess
from forte_driver.serial.protocol import Command
from forte_msgs.msg import TactileFrames
from forte_ros.qos import COMMANDS
from forte_ros.testing import NodeProcess, Probe, ros_args, wait_until

STOP_TIMEOUT = 5.0  # [s] from the signal to the exit
SIGNALS = pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM],
                                  ids=['SIGINT', 'SIGTERM'])


@pytest.fixture
def probe():
    with Probe('driver_shutdown_probe') as started:
        started.count(TactileFrames, 'tactile/frames', qos_profile_sensor_data)
        started.count(JointState, 'joint_states', COMMANDS)
        yield started


def wait_publishing(probe: Probe, process: NodeProcess, topic: str, at_least: int = 10) -> None:
    assert probe.wait_for_messages(topic, at_least, 40.0), f'nothing on {topic}:\n{process.output}'


# ---- serial_sensor_node ----------------------------------------------------------------------

@SIGNALS
def test_serial_sensor_node_stops_the_device_and_closes_the_port(probe, tmp_path, signum):
    link = str(tmp_path / 'forte_sensor')
    with EmulatedSensor(link) as sensor, NodeProcess(
            ['serial_sensor_node', *ros_args(port=link, autostart=True)]) as process:
        wait_publishing(probe, process, 'tactile/frames')
        assert sensor.streaming
        # a stale launch configuring the active driver again: refused, still streaming
        assert probe.change_state('serial_sensor_node',
                                  Transition.TRANSITION_CONFIGURE) is False
        wait_publishing(probe, process, 'tactile/frames')
        process.stop_cleanly(signum, within=STOP_TIMEOUT)
        assert wait_until(lambda: not sensor.streaming, 5.0), 'the device was not stopped'
        assert sensor.commands[-1].command == Command.STOP
    assert 'shut down from active: reader stopped, port closed' in process.output


# ---- gripper_driver_node ---------------------------------------------------------------------

@pytest.mark.parametrize('signum, release', [(signal.SIGINT, False), (signal.SIGTERM, True)],
                         ids=['SIGINT-hold', 'SIGTERM-release'])
def test_gripper_driver_node_leaves_the_servos_as_the_parameter_says(probe, signum, release):
    with SimulatedServoProcess(ids=(1, 2), positions=(2048, 2048)) as bus, NodeProcess(
            ['gripper_driver_node', *ros_args(port=bus.device_path, autostart=True,
                                              release_on_shutdown=release)]) as process:
        wait_publishing(probe, process, 'joint_states')
        assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(
            2, 'Torque Enable')
        assert probe.change_state('gripper_driver', Transition.TRANSITION_ACTIVATE) is False
        assert probe.state('gripper_driver') == 'active'
        wait_publishing(probe, process, 'joint_states')
        process.stop_cleanly(signum, within=STOP_TIMEOUT)
        torque = 0 if release else 1
        assert bus.register_value(1, 'Torque Enable') == torque
        assert bus.register_value(2, 'Torque Enable') == torque
    assert 'shut down from active: port closed' in process.output
    expected = 'torque OFF' if release else 'servos keep holding the grip'
    assert f'shutdown: {expected}' in process.output
