"""Gripper position goals (GripperCommand / ParallelGripperCommand) as FORTE servo moves.

Pure: the goal mapping of docs/control.md ("Gripper position actions"), every refusal and its
reason, the servo command a goal becomes, and the bookkeeping of a move (reached, stalled,
timed out) on synthetic joint angles.
"""
from __future__ import annotations

import math

import pytest

from forte_control.gripper_goal import (
    MAX_VELOCITY,
    POSITION_MATCH,
    GripperGoal,
    GripperMove,
    gripper_command_goal,
    parallel_gripper_goal,
    position_problem,
)
from forte_control.state_machine import ControllerParams, ServoOutput
from forte_ros.contract import SERVO_TORQUE_CONSTANT

LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'
JOINTS = (LEFT, RIGHT)
PARAMS = ControllerParams()


def parallel(names, positions, velocities=(), efforts=(), joints=JOINTS, params=PARAMS):
    return parallel_gripper_goal(names, positions, velocities, efforts, joints, params)


# -- ParallelGripperCommand: accepted goals ---------------------------------------------------
@pytest.mark.parametrize('names, positions', [
    ([LEFT], [0.8]), ([RIGHT], [0.8]), ([LEFT, RIGHT], [0.8, 0.8]), ([RIGHT, LEFT], [0.8, 0.8]),
    ([LEFT, RIGHT], [0.8, 0.8 + 0.5 * POSITION_MATCH]),
])
def test_either_finger_joint_or_both_give_the_gripper_angle(names, positions):
    goal, reason = parallel(names, positions)
    assert reason == ''
    assert goal == GripperGoal(position=positions[0], max_effort=0.0, max_velocity=0.0)


def test_velocity_and_effort_one_value_or_one_per_joint():
    # what MoveIt's ParallelGripperCommand handle sends: one value per named joint
    goal, _ = parallel([LEFT, RIGHT], [0.3, 0.3], velocities=[0.4, 0.4], efforts=[0.6, 0.6])
    assert goal == GripperGoal(0.3, max_effort=0.6, max_velocity=0.4)
    goal, _ = parallel([LEFT, RIGHT], [0.3, 0.3], velocities=[0.4], efforts=[0.6])
    assert goal == GripperGoal(0.3, max_effort=0.6, max_velocity=0.4)
    goal, _ = parallel([LEFT], [0.3], velocities=[0.0], efforts=[0.0])
    assert goal == GripperGoal(0.3)


def test_joint_names_follow_the_controller_prefix():
    prefixed = ('right_' + LEFT, 'right_' + RIGHT)
    goal, reason = parallel(['right_' + RIGHT], [0.5], joints=prefixed)
    assert goal is not None and goal.position == 0.5, reason
    goal, reason = parallel([LEFT], [0.5], joints=prefixed)
    assert goal is None and repr(LEFT) in reason and 'right_' + LEFT in reason


# -- ParallelGripperCommand: refused goals, with the reason -------------------------------------
@pytest.mark.parametrize('names, positions, velocities, efforts, words', [
    ([], [], [], [], ['no joint named', LEFT, RIGHT]),
    (['forte_finger_joint'], [0.5], [], [], ["unknown joint(s) 'forte_finger_joint'", LEFT]),
    ([LEFT, 'panda_finger_joint1'], [0.5, 0.5], [], [], ["'panda_finger_joint1'"]),
    ([LEFT, LEFT], [0.5, 0.5], [], [], [repr(LEFT), 'more than once']),
    ([LEFT, RIGHT], [0.5], [], [], ['1 position(s) for 2 joint name(s)']),
    ([LEFT], [], [], [], ['0 position(s) for 1 joint name(s)']),
    ([LEFT, RIGHT], [0.5, 0.6], [], [], ['positions differ', f'{LEFT} 0.5000',
                                          f'{RIGHT} 0.6000', 'same gripper angle']),
    ([LEFT], [math.nan], [], [], [LEFT, 'nan rad is not a finite number']),
    ([RIGHT], [math.inf], [], [], [RIGHT, 'inf rad is not a finite number']),
    ([LEFT], [-0.1], [], [], ['position -0.1000 rad outside [0.0000, 1.0000]']),
    # beyond the joint limit (URDF and driver: 1.0 rad), not only beyond the servo's travel
    ([LEFT], [2.0], [], [], ['position 2.0000 rad outside [0.0000, 1.0000] rad',
                             'max_angle, the joint limit']),
    ([LEFT], [1.0001], [], [], ['outside [0.0000, 1.0000]']),
    ([LEFT], [0.5], [math.nan], [], ['velocity nan rad/s is not a finite number']),
    ([LEFT], [0.5], [-0.2], [], ['velocity -0.2 rad/s is negative']),
    ([LEFT], [0.5], [], [math.inf], ['effort inf N m is not a finite number']),
    ([LEFT], [0.5], [], [-1.0], ['effort -1.0 N m is negative']),
    ([LEFT, RIGHT], [0.5, 0.5], [0.2, 0.3], [], ['unequal velocity values 0.2, 0.3 rad/s']),
    ([LEFT, RIGHT], [0.5, 0.5], [], [0.5, 0.4], ['unequal effort values 0.5, 0.4 N m']),
    ([LEFT], [0.5], [], [0.5, 0.5], ['2 effort values for 1 joint(s)']),
    ([LEFT, RIGHT], [0.5, 0.5], [0.1, 0.1, 0.1], [], ['3 velocity values for 2 joint(s)']),
])
def test_invalid_parallel_goals_are_refused_with_the_reason(names, positions, velocities,
                                                            efforts, words):
    goal, reason = parallel(names, positions, velocities, efforts)
    assert goal is None
    for word in words:
        assert word in reason, reason


def test_the_range_follows_min_angle_and_max_angle():
    params = ControllerParams(min_angle=0.2)
    goal, reason = parallel([LEFT], [0.1], params=params)
    assert goal is None and '[0.2000, 1.0000]' in reason
    assert parallel([LEFT], [0.2], params=params)[0] is not None
    assert parallel([LEFT], [params.max_angle], params=params)[0] is not None
    assert position_problem(0.5, params) == ''
    # a gripper whose joint opens further (another URDF, the driver's theta_max raised)
    wide = ControllerParams(max_angle=1.5, open_angle=1.2)
    assert parallel([LEFT], [1.5], params=wide)[0] is not None
    assert 'outside [0.0000, 1.5000]' in parallel([LEFT], [1.6], params=wide)[1]


def test_max_angle_is_the_joint_limit_and_bounds_open_angle():
    assert ControllerParams().max_angle == 1.0  # the URDF's and the driver's theta_max
    assert ControllerParams(open_angle=1.2).problems() == [
        'open_angle=1.2 rad above max_angle=1.0 rad (the joint limit)']


# -- GripperCommand ---------------------------------------------------------------------------
def test_gripper_command_goal_is_the_same_mapping():
    assert gripper_command_goal(0.3, 0.5, PARAMS) == (GripperGoal(0.3, max_effort=0.5), '')
    assert gripper_command_goal(0.3, 0.0, PARAMS) == (GripperGoal(0.3), '')
    goal, reason = gripper_command_goal(math.nan, 0.0, PARAMS)
    assert goal is None and 'not a finite number' in reason
    goal, reason = gripper_command_goal(-0.5, 0.0, PARAMS)
    assert goal is None and 'outside' in reason
    goal, reason = gripper_command_goal(0.5, -1.0, PARAMS)
    assert goal is None and 'max_effort -1.0 N m is negative' in reason
    # both actions give the same goal for the same request
    assert gripper_command_goal(0.7, 0.4, PARAMS)[0] == parallel([LEFT], [0.7],
                                                                 efforts=[0.4])[0]


# -- the servo command -----------------------------------------------------------------------
def test_servo_command_caps_effort_and_velocity():
    params = ControllerParams(max_current=1.0, release_speed=0.5)
    assert GripperGoal(0.4).servo(params) == ServoOutput(0.4, max_current=1.0,
                                                         profile_velocity=0.5)
    # effort is joint torque [N m]: 0.5 N m / (4.1 N m / 2.3 A) = 0.28049 A of current cap
    servo = GripperGoal(0.4, max_effort=0.5, max_velocity=0.2).servo(params)
    assert servo.max_current == pytest.approx(0.280488, abs=1e-6)
    assert servo.max_current == pytest.approx(0.5 / SERVO_TORQUE_CONSTANT, rel=1e-12)
    assert (servo.position, servo.profile_velocity) == (0.4, 0.2)
    # 4.1 N m is the servo's stall torque at 12 V: its stall current, 2.3 A, then capped
    assert GripperGoal(0.4, max_effort=4.1).servo(
        ControllerParams(max_current=2.3)).max_current == pytest.approx(2.3, rel=1e-12)
    # a larger request is capped: the goal's values are maxima the move must not exceed
    assert GripperGoal(0.4, max_effort=5.0, max_velocity=10.0).servo(params) == ServoOutput(
        0.4, max_current=1.0, profile_velocity=MAX_VELOCITY)


# -- the move --------------------------------------------------------------------------------
def test_move_reaches_the_goal():
    move = GripperMove(GripperGoal(0.8), tolerance=0.02, deadline=3.0)
    assert move.position == 0.8 and not move.reached  # no joint state yet: the goal
    assert not move.observe(None, None, 0.0)
    assert not move.observe(0.6, 0.05, 0.05)
    assert move.theta == 0.6 and move.effort == 0.05 and not move.stalled
    assert move.observe(0.79, None, 0.10)
    assert move.finished and move.reached and not move.stalled_short
    assert move.position == 0.79 and math.isnan(move.effort)
    assert move.observe(0.5, 0.0, 0.15) and move.theta == 0.79  # ended: no more changes


def test_move_stalls_short_of_the_goal_and_times_out():
    move = GripperMove(GripperGoal(0.1), tolerance=0.02, deadline=1.0)
    assert not move.observe(0.5, 0.1, 0.0)
    assert not move.observe(0.4, 0.3, 0.05)
    assert not move.observe(0.4, 0.6, 0.10)  # blocked by an object: stalled, still waiting
    assert move.stalled and move.stalled_short and not move.reached
    assert move.observe(0.4, 0.6, 1.0)       # deadline
    assert move.finished and move.stalled_short and move.position == 0.4


def test_move_without_joint_states_ends_at_the_deadline():
    move = GripperMove(GripperGoal(0.3), tolerance=0.02, deadline=2.0)
    assert not move.observe(None, None, 1.9)
    assert move.observe(None, None, 2.0)
    assert not move.reached and not move.stalled_short and move.position == 0.3
