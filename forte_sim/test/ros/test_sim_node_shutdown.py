"""sim_node stops cleanly on SIGINT / SIGTERM and survives invalid lifecycle requests.

It runs as its real console script in its own process; the test lets it publish, stops it
with a signal and checks the exit code, the time to exit and that no traceback was printed.
A probe node in this process calls ``forte_sim/change_state`` as a stale launch would.
"""
from __future__ import annotations

import signal

import pytest
from lifecycle_msgs.msg import Transition
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from forte_msgs.msg import TactileFrames
from forte_ros.qos import COMMANDS
from forte_ros.testing import NodeProcess, Probe, ros_args, wait_until

STOP_TIMEOUT = 5.0  # [s] from the signal to the exit


@pytest.fixture
def probe():
    with Probe('sim_shutdown_probe') as started:
        started.count(TactileFrames, 'tactile/frames', qos_profile_sensor_data)
        started.count(JointState, 'joint_states', COMMANDS)
        yield started


def wait_publishing(probe: Probe, process: NodeProcess, topic: str, at_least: int = 10) -> None:
    assert probe.wait_for_messages(topic, at_least, 40.0), f'nothing on {topic}:\n{process.output}'


@pytest.mark.parametrize('signum, factor', [(signal.SIGINT, 1.0), (signal.SIGTERM, 1.0),
                                            (signal.SIGINT, 0.0)],
                         ids=['SIGINT', 'SIGTERM', 'SIGINT-as-fast-as-possible'])
def test_sim_node_stops_cleanly(probe, signum, factor):
    with NodeProcess(['sim_node', *ros_args(real_time_factor=factor)]) as process:
        wait_publishing(probe, process, 'tactile/frames')
        wait_publishing(probe, process, 'joint_states')
        process.stop_cleanly(signum, within=STOP_TIMEOUT)
    assert 'shut down from active: production stopped' in process.output


def test_sim_node_refuses_invalid_transitions_and_keeps_publishing(probe):
    with NodeProcess(['sim_node', *ros_args(autostart=False)]) as process:
        assert wait_until(lambda: probe.state('forte_sim') == 'unconfigured', 40.0), \
            process.output
        assert probe.change_state('forte_sim', Transition.TRANSITION_ACTIVATE) is False
        assert probe.change_state('forte_sim', Transition.TRANSITION_CONFIGURE) is True
        # the second configure of a stale launch on the same domain
        assert probe.change_state('forte_sim', Transition.TRANSITION_CONFIGURE) is False
        assert probe.change_state('forte_sim', Transition.TRANSITION_ACTIVATE) is True
        wait_publishing(probe, process, 'tactile/frames')
        assert probe.change_state('forte_sim', Transition.TRANSITION_CONFIGURE) is False
        assert probe.change_state('forte_sim', label='cleanup') is False  # only from inactive
        assert probe.state('forte_sim') == 'active'
        wait_publishing(probe, process, 'tactile/frames')
        process.stop_cleanly(signal.SIGINT, within=STOP_TIMEOUT)
    assert process.output.count('refused in state') == 4
    assert 'shut down from active' in process.output
