"""rclpy tests of the grasp controller's gripper position actions (real nodes over DDS).

``gripper_cmd`` (control_msgs/GripperCommand) and ``parallel_gripper_cmd``
(control_msgs/ParallelGripperCommand) run one shared move; here against the fake gripper
world of ``test_grasp_controller_node.py`` (its servo follows the command at 2 rad/s, an
object blocks the fingers below 0.3 rad when present), on simulated time, with real
ActionClients: the result and feedback fields, the servo command, a stalled move, one
gripper goal at a time, and refusals while a grasp runs. The sim-graph test
(``forte_bringup/test/test_gripper_actions_graph.py``) checks the same against the
simulator; ``forte_control/test/test_gripper_goal.py`` every goal refusal's reason.

Skips where control_msgs (with ParallelGripperCommand, 5.1+) is not installed: the launch
kit builds it.
"""
from __future__ import annotations

import time

import pytest
import rclpy
from rcl_interfaces.msg import Log
from rclpy.action import ActionClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

control_actions = pytest.importorskip(
    'control_msgs.action', reason='control_msgs is not installed here (the launch kit builds '
    'it); the gripper position actions are only served where it is')
if not hasattr(control_actions, 'ParallelGripperCommand'):
    pytest.skip('control_msgs without ParallelGripperCommand (needs 5.1 or later)',
                allow_module_level=True)

from test_grasp_controller_node import (  # noqa: E402  (the fake world and its harness)
    FREE_EFFORT,
    STATUS_ABORTED,
    STATUS_SUCCEEDED,
    Harness,
)

from forte_ros.testing import gripper_goal, parallel_gripper_goal  # noqa: E402

GripperCommand = control_actions.GripperCommand
ParallelGripperCommand = control_actions.ParallelGripperCommand
LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'


@pytest.fixture(scope='module')
def ros_context():
    rclpy.init()
    yield
    rclpy.try_shutdown()


@pytest.fixture
def harness(ros_context):
    rig = Harness()
    rig.parallel = ActionClient(rig.client_node, ParallelGripperCommand, 'parallel_gripper_cmd')
    rig.gripper = ActionClient(rig.client_node, GripperCommand, 'gripper_cmd')
    assert rig.spin_until(lambda: rig.parallel.server_is_ready()
                          and rig.gripper.server_is_ready())
    yield rig
    rig.parallel.destroy()
    rig.gripper.destroy()
    rig.close()




def send(harness, client, goal, feedback=None):
    future = client.send_goal_async(
        goal, feedback_callback=None if feedback is None
        else (lambda message: feedback.append(message.feedback)))
    assert harness.spin_until(future.done)
    return future.result()


def finish(harness, handle, timeout=5.0):
    future = handle.get_result_async()
    assert harness.spin_until(future.done, timeout)
    return future.result()


def test_parallel_gripper_command_moves_and_reports_the_state(harness):
    harness.world.object_present = False
    feedback = []
    handle = send(harness, harness.parallel,
                  parallel_gripper_goal([LEFT, RIGHT], [0.3, 0.3], velocity=[1.0, 1.0],
                                effort=[0.5, 0.5]), feedback)
    assert handle.accepted
    response = finish(harness, handle)
    assert response.status == STATUS_SUCCEEDED
    result = response.result
    assert result.reached_goal and not result.stalled
    assert list(result.state.name) == [LEFT, RIGHT]
    assert list(result.state.position) == pytest.approx([0.3, 0.3], abs=0.02)
    # the joint effort [N m] the world reports (its servo current x 1.7826 N m/A, closing)
    assert list(result.state.effort) == pytest.approx([FREE_EFFORT, FREE_EFFORT])
    assert result.state.header.stamp.sec > 0
    command = harness.world.servo_log[-1][1]
    # effort 0.5 N m -> a current cap of 0.5 / (4.1 / 2.3) = 0.28049 A
    assert (command.position, command.max_current, command.profile_velocity) == \
        pytest.approx((0.3, 0.280488, 1.0), abs=1e-6)
    # 0.4 rad at 2 rad/s: 0.2 s of motion, feedback at every control step (20 Hz)
    assert len(feedback) >= 2
    assert list(feedback[0].state.name) == [LEFT, RIGHT]
    assert feedback[0].state.position[0] > 0.3 + 0.02
    # one finger joint, no velocity or effort: the controller's release_speed and max_current
    handle = send(harness, harness.parallel, parallel_gripper_goal([RIGHT], [0.6]))
    assert handle.accepted and finish(harness, handle).result.reached_goal
    command = harness.world.servo_log[-1][1]
    assert (command.position, command.max_current, command.profile_velocity) == \
        pytest.approx((0.6, 1.0, 0.5))
    assert harness.world.theta == pytest.approx(0.6, abs=0.02)


def test_gripper_command_result_and_feedback(harness):
    harness.world.object_present = False
    harness.world.servo_speed = 1.0
    feedback = []
    handle = send(harness, harness.gripper, gripper_goal(0.2, max_effort=0.4), feedback)
    assert handle.accepted
    response = finish(harness, handle)
    assert response.status == STATUS_SUCCEEDED
    result = response.result
    assert result.reached_goal and not result.stalled
    assert result.position == pytest.approx(0.2, abs=0.02)
    assert result.effort == pytest.approx(FREE_EFFORT)
    assert feedback and not feedback[0].reached_goal and feedback[0].position > 0.22
    assert harness.world.servo_log[-1][1].max_current == pytest.approx(0.4 * 2.3 / 4.1)


def test_a_blocked_gripper_stalls_short_of_the_goal(harness):
    # the object blocks the fingers at 0.3 rad: the move ends at release_timeout (3 s),
    # succeeded, stalled, not reached (MoveIt's allow_failure / allow_stalling cases)
    handle = send(harness, harness.parallel, parallel_gripper_goal([LEFT], [0.1]))
    assert handle.accepted
    response = finish(harness, handle, timeout=6.0)
    assert response.status == STATUS_SUCCEEDED
    result = response.result
    assert result.stalled and not result.reached_goal
    assert list(result.state.position) == pytest.approx([0.3, 0.3], abs=1e-6)
    assert result.state.effort[0] < FREE_EFFORT  # squeezing the object: more torque


def test_one_gripper_goal_at_a_time_and_none_during_a_grasp(harness):
    harness.world.object_present = False
    harness.world.servo_speed = 0.5
    first = send(harness, harness.gripper, gripper_goal(0.2))
    assert first.accepted
    harness.spin_for(0.05)  # its execute callback has started
    # a second goal of either action is refused while the first moves
    assert not send(harness, harness.parallel, parallel_gripper_goal([LEFT], [0.6])).accepted
    assert not send(harness, harness.gripper, gripper_goal(0.6)).accepted
    assert finish(harness, first).result.reached_goal
    # and while a grasp runs
    harness.world.object_present = True
    harness.world.servo_speed = 2.0
    harness.world.theta = 0.7
    harness.world.command = None
    grasp = harness.lifting()
    assert not send(harness, harness.parallel, parallel_gripper_goal([LEFT], [0.6])).accepted
    assert harness.result(grasp).status in (STATUS_SUCCEEDED, STATUS_ABORTED)
    # idle again: accepted
    handle = send(harness, harness.parallel, parallel_gripper_goal([LEFT, RIGHT], [0.8, 0.8]))
    assert handle.accepted and finish(harness, handle).status == STATUS_SUCCEEDED


def test_invalid_parallel_goal_is_refused_before_any_motion(harness):
    count = len(harness.world.servo_log)
    for goal in (parallel_gripper_goal(['gripper_joint'], [0.5]),
                 parallel_gripper_goal([LEFT, RIGHT], [0.5, 0.55]),
                 parallel_gripper_goal([LEFT], [float('nan')]),
                 parallel_gripper_goal([LEFT], [0.5], effort=[-1.0])):
        assert not send(harness, harness.parallel, goal).accepted
    harness.spin_for(0.2)
    assert len(harness.world.servo_log) == count


def test_a_goal_beyond_the_joint_limit_is_rejected_at_once_naming_the_limit(harness):
    """The joint's limit is max_angle (1.0 rad, the URDF's and the driver's), not the servo's
    travel: a goal of 2.0 rad was accepted and ended SUCCEEDED with reached_goal false.
    Now the goal callback rejects it (REJECTED, within 0.1 s of sending, wall clock) and
    the log names the limit."""
    log: list[str] = []
    rosout = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
    harness.client_node.create_subscription(
        Log, '/rosout',
        lambda message: log.append(message.msg) if message.name.endswith('grasp_controller')
        else None, rosout)
    count = len(harness.world.servo_log)
    elapsed = {}
    for name, client, goal in (
            ('gripper_cmd', harness.gripper, gripper_goal(2.0)),
            ('parallel_gripper_cmd', harness.parallel,
             parallel_gripper_goal([LEFT, RIGHT], [2.0, 2.0])),
            ('gripper_cmd', harness.gripper, gripper_goal(1.0 + 1e-3))):
        started = time.perf_counter()
        handle = send(harness, client, goal)
        elapsed[name] = time.perf_counter() - started
        assert not handle.accepted, name
        assert elapsed[name] < 0.1, elapsed
    limit = 'outside [0.0000, 1.0000] rad (min_angle .. max_angle, the joint limit)'
    for expected in (f'gripper_cmd goal rejected: position 2.0000 rad {limit}',
                     f'parallel_gripper_cmd goal rejected: {LEFT}: position 2.0000 rad {limit}',
                     f'gripper_cmd goal rejected: position 1.0010 rad {limit}'):
        assert harness.spin_until(lambda text=expected: text in log, 5.0), (expected, log[-3:])
    # at the limit: accepted and reached
    handle = send(harness, harness.gripper, gripper_goal(1.0))
    assert handle.accepted and finish(harness, handle).result.reached_goal
    assert len(harness.world.servo_log) == count + 1  # the refused ones moved nothing
    print(f'rejection round trips [s]: {elapsed}')
