"""The gripper position actions of the grasp controller on the sim graph (launch_pytest).

``sim.launch.py`` (the raspberry scene, real time; no force model: no goal here needs one)
runs once for the module; real rclpy ActionClients in this process send goals to the
controller over DDS:

- ``parallel_gripper_cmd`` (control_msgs/ParallelGripperCommand) goals naming both finger
  joints, and one, succeed: the simulated gripper's ``joint_states`` reach the angle, the
  servo command carries the goal's effort (joint torque [N m], as a current cap [A] =
  effort / the servo torque constant) and velocity (profile velocity), the result's
  ``state`` names both joints at the measured angle with the joint effort [N m],
  ``reached_goal`` true, ``stalled`` false; feedback comes while it moves;
- ``gripper_cmd`` (control_msgs/GripperCommand) goals succeed the same way (result
  ``position`` = measured angle, ``effort`` = joint effort [N m]);
- invalid goals (unknown joint, unequal finger positions, NaN, out of range, unequal
  velocities, negative effort) are rejected, and the controller's log on ``/rosout`` gives
  the reason of each.

Needs launch_pytest, launch_ros and control_msgs with ParallelGripperCommand (a ROS 2
install, or the launch kit on a bare machine); skipped with that reason otherwise.
"""
from __future__ import annotations

import functools
import math
import time
from pathlib import Path
from typing import Any

import pytest

REASON = ('launch_pytest / launch_ros / control_msgs need a ROS 2 install or the launch kit '
          '(../shared/ros2-launch-kit, which builds control_msgs)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)
control_actions = pytest.importorskip('control_msgs.action', reason=REASON)
if not hasattr(control_actions, 'ParallelGripperCommand'):
    pytest.skip('control_msgs without ParallelGripperCommand (needs 5.1 or later)',
                allow_module_level=True)

import launch  # noqa: E402
from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_bringup.testing import Watcher, watching  # noqa: E402
from forte_ros.contract import effort_to_current  # noqa: E402
from forte_ros.testing import gripper_goal, parallel_gripper_goal, wait_until  # noqa: E402

GripperCommand = control_actions.GripperCommand
ParallelGripperCommand = control_actions.ParallelGripperCommand
LAUNCH = Path(__file__).resolve().parents[1] / 'launch'
LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'
STATUS_SUCCEEDED = 4     # action_msgs/msg/GoalStatus
TOLERANCE = 0.02         # the controller's release_tolerance [rad]
UP = 90.0                # longest wait for the graph [s] (2 shared cores)
WAIT = 60.0


@launch_pytest.fixture(scope='module')
def sim_launch() -> launch.LaunchDescription:
    return launch.LaunchDescription([
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(LAUNCH / 'sim.launch.py')),
            launch_arguments={'object': 'raspberry', 'real_time_factor': '1.0'}.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


class Observed:
    """What the test sees besides the action: servo commands and the controller's log."""

    def __init__(self, watcher: Watcher) -> None:
        from rcl_interfaces.msg import Log
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        from forte_msgs.msg import ServoCommand
        from forte_ros import call_in_executor, qos

        self.servo: list[Any] = []
        self.log: list[str] = []
        # transient local: /rosout keeps its history, so a line logged before this
        # subscription matched still arrives
        rosout = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
        call_in_executor(watcher.executor, watcher.create_subscription, ServoCommand,
                         'gripper/command', self.servo.append, qos.COMMANDS)
        call_in_executor(watcher.executor, watcher.create_subscription, Log, '/rosout',
                         self._on_log, rosout)

    def _on_log(self, message: Any) -> None:
        if message.name.endswith('grasp_controller'):
            self.log.append(message.msg)

    def logged(self, start: str, text: str) -> bool:
        """A line of the controller's log starts with ``start`` and holds ``text``."""
        return any(line.startswith(start) and text in line for line in self.log)


def send(watcher: Watcher, action_type: Any, name: str, goal: Any,
         timeout: float = WAIT) -> tuple[bool, int | None, Any, list]:
    """Send ``goal`` to action ``name`` with a real ActionClient; wait for the result.

    Returns
    -------
    accepted, status, result, feedback
        Whether it was accepted; the final GoalStatus and the result (None if rejected or
        not answered in time); the feedback messages received.
    """
    from rclpy.action import ActionClient

    from forte_ros import call_in_executor

    client = ActionClient(watcher, action_type, name)
    try:
        assert client.wait_for_server(timeout_sec=timeout), f'no {name} action server'
        feedback: list = []
        future = call_in_executor(watcher.executor, client.send_goal_async, goal,
                                  lambda message: feedback.append(message.feedback))
        assert wait_until(future.done, timeout), f'{name}: goal not answered'
        handle = future.result()
        if not handle.accepted:
            return False, None, None, feedback
        result_future = call_in_executor(watcher.executor, handle.get_result_async)
        if not wait_until(result_future.done, timeout):
            return True, None, None, feedback
        answer = result_future.result()
        return True, answer.status, answer.result, feedback
    finally:
        watcher.destroy_action_client(client)




def at(watcher: Watcher, position: float) -> bool:
    """Both simulated finger joints within TOLERANCE of ``position`` (``joint_states``)."""
    positions = watcher.joint_positions
    return len(positions) == 2 and all(abs(p - position) <= TOLERANCE for p in positions)


@pytest.fixture(scope='module')
def probe():
    """The graph probe and the observer, for every test of the module."""
    with watching() as watcher:
        yield watcher, Observed(watcher)


def graph_up(watcher: Watcher) -> None:
    """Wait until the graph runs (in the test: the launch service, which activates ``sim``,
    only runs while a test or the launch fixture does)."""
    assert watcher.wait_for_lifecycle_state('sim', 'active', UP) == 'active'
    assert wait_until(lambda: watcher.counts['joint_states'] > 10, WAIT), watcher.counts
    assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, WAIT), watcher.counts


@pytest.mark.slow
@pytest.mark.launch(fixture=sim_launch)
def test_parallel_gripper_command_moves_the_simulated_gripper(probe):
    watcher, seen = probe
    graph_up(watcher)
    start = list(watcher.joint_positions)
    goal = parallel_gripper_goal([LEFT, RIGHT], [0.8, 0.8], velocity=[0.6, 0.6], effort=[0.5, 0.5])
    accepted, status, result, feedback = send(watcher, ParallelGripperCommand,
                                              'parallel_gripper_cmd', goal)
    assert accepted and status == STATUS_SUCCEEDED, (status, seen.log[-5:])
    assert result.reached_goal and not result.stalled
    state = result.state
    assert list(state.name) == [LEFT, RIGHT]
    assert all(abs(p - 0.8) <= TOLERANCE for p in state.position), state
    assert len(state.effort) == 2 and all(math.isfinite(e) for e in state.effort), state
    assert wait_until(lambda: at(watcher, 0.8), 10.0), (start, watcher.joint_positions)
    command = seen.servo[-1]
    # effort 0.5 N m -> current cap 0.5 / (4.1 / 2.3) = 0.2805 A
    assert (command.position, command.max_current, command.profile_velocity) == \
        pytest.approx((0.8, effort_to_current(0.5), 0.6)), command
    assert feedback and list(feedback[-1].state.name) == [LEFT, RIGHT]
    print(f'\nparallel_gripper_cmd 0.8 rad: joints {start} -> {watcher.joint_positions}, '
          f'result {list(state.position)} rad, {list(state.effort)} N m, '
          f'{len(feedback)} feedback messages')
    # one finger joint names the gripper angle too
    goal = parallel_gripper_goal([RIGHT], [0.7])
    accepted, status, result, _ = send(watcher, ParallelGripperCommand,
                                       'parallel_gripper_cmd', goal)
    assert accepted and status == STATUS_SUCCEEDED and result.reached_goal, seen.log[-5:]
    assert wait_until(lambda: at(watcher, 0.7), 10.0), watcher.joint_positions
    assert seen.servo[-1].position == pytest.approx(0.7)


@pytest.mark.slow
@pytest.mark.launch(fixture=sim_launch)
def test_gripper_command_moves_the_simulated_gripper(probe):
    watcher, seen = probe
    graph_up(watcher)
    accepted, status, result, _ = send(watcher, GripperCommand, 'gripper_cmd',
                                       gripper_goal(0.85, max_effort=0.4))
    assert accepted and status == STATUS_SUCCEEDED, (status, seen.log[-5:])
    assert result.reached_goal and not result.stalled
    assert result.position == pytest.approx(0.85, abs=TOLERANCE)
    assert math.isfinite(result.effort)
    assert wait_until(lambda: at(watcher, 0.85), 10.0), watcher.joint_positions
    command = seen.servo[-1]
    assert (command.position, command.max_current) == \
        pytest.approx((0.85, effort_to_current(0.4))), command


@pytest.mark.slow
@pytest.mark.launch(fixture=sim_launch)
def test_invalid_goals_are_rejected_with_the_reason(probe):
    watcher, seen = probe
    graph_up(watcher)
    commands = len(seen.servo)
    parallel = (ParallelGripperCommand, 'parallel_gripper_cmd')
    gripper = (GripperCommand, 'gripper_cmd')
    refused = [
        (parallel, parallel_gripper_goal(['forte_finger_joint'], [0.5]),
         "unknown joint(s) 'forte_finger_joint'"),
        (parallel, parallel_gripper_goal([LEFT, RIGHT], [0.5, 0.6]), 'positions differ'),
        (parallel, parallel_gripper_goal([LEFT], [math.nan]), 'nan rad is not a finite number'),
        (parallel, parallel_gripper_goal([LEFT], [-0.3]), 'position -0.3000 rad outside'),
        (gripper, gripper_goal(2.0), 'position 2.0000 rad outside [0.0000, 1.0000] rad'),
        (parallel, parallel_gripper_goal([LEFT, RIGHT], [0.5, 0.5], velocity=[0.2, 0.3]),
         'unequal velocity values'),
        (parallel, parallel_gripper_goal([], []), 'no joint named'),
        (gripper, gripper_goal(math.inf), 'inf rad is not a finite number'),
        (gripper, gripper_goal(0.5, max_effort=-1.0), 'max_effort -1.0 N m is negative'),
    ]
    for (action_type, name), goal, reason in refused:
        accepted, _, _, _ = send(watcher, action_type, name, goal)
        assert not accepted, reason
        logged = functools.partial(seen.logged, f'{name} goal rejected: ', reason)
        assert wait_until(logged, 10.0), (name, reason, seen.log[-5:])
    time.sleep(0.5)
    assert len(seen.servo) == commands, 'a refused goal moved the gripper'
