"""The JointState command bridge and its ownership rule, pure (known answers, no ROS graph).

What ``topic_based_ros2_control/TopicBasedSystem`` publishes (every joint of its system, a
position, a velocity and an effort per joint; 0 where a joint has no such command
interface; the mimic joint at the mimicked joint's value) becomes one servo command or a
refusal with the reason; :class:`BridgeGate` keeps a running Grasp's servos from the bridge
and stale repeats from acting after it.
"""
from __future__ import annotations

import math

import pytest

from forte_driver.joint_command_bridge import (
    GRASP_STATE_NAMES,
    LIMIT_TOLERANCE,
    MIN_CURRENT,
    MIN_PROFILE_VELOCITY,
    OWNING_STATES,
    BridgeCommand,
    BridgeGate,
    Verdict,
    bridge_command,
)

LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'
JOINTS = (LEFT, RIGHT)
IDLE, CLOSING, LOADING, LIFTING, HOLDING, RELEASING, DONE, FAULT = range(8)


def command(names, positions, velocities=(), efforts=(), joints=JOINTS, low=0.0, high=1.0):
    return bridge_command(names, positions, velocities, efforts, joints, low, high)


# -- the message -------------------------------------------------------------------------
@pytest.mark.parametrize('names, positions', [
    ([LEFT], [0.6]), ([RIGHT], [0.6]), ([LEFT, RIGHT], [0.6, 0.6]),
    # TopicBasedSystem of an arm and the gripper: the arm's joints are ignored
    (['panda_joint1', 'panda_joint2', LEFT, RIGHT], [1.5, -0.3, 0.6, 0.6]),
])
def test_a_finger_joint_position_is_the_gripper_angle(names, positions):
    assert command(names, positions) == (BridgeCommand(0.6), '')


def test_topic_based_system_zero_velocity_and_effort_mean_the_driver_defaults():
    # a joint with only a position command interface: velocity and effort published as 0
    assert command([LEFT, RIGHT], [0.4, 0.4], [0.0, 0.0], [0.0, 0.0]) == (BridgeCommand(0.4), '')


def test_velocity_and_effort_become_profile_velocity_and_current_cap():
    result, reason = command([LEFT, RIGHT], [0.4, 0.4], [-0.5, -0.5], [1.0, 1.0])
    assert reason == ''
    # 1.0 N m / (4.1 N m / 2.3 A) = 0.560976 A; the speed is the magnitude (closing: -)
    assert result.max_current == pytest.approx(0.560976, abs=1e-6)
    assert result.profile_velocity == 0.5
    # the left joint's values count (the right one is its mimic)
    result, _ = command([RIGHT, LEFT], [0.4, 0.4], [0.2, 0.3], [0.0, 4.1])
    assert result.profile_velocity == 0.3 and result.max_current == pytest.approx(2.3)
    # tiny non-zero values would become register 0 (= no speed limit / no torque): raised
    result, _ = command([LEFT], [0.4], [1e-4], [1e-5])
    assert result.profile_velocity == MIN_PROFILE_VELOCITY == pytest.approx(0.0239809, rel=1e-5)
    assert result.max_current == MIN_CURRENT


def test_prefixed_joints():
    joints = ('right_' + LEFT, 'right_' + RIGHT)
    assert command(['right_' + RIGHT], [0.5], joints=joints)[0] == BridgeCommand(0.5)
    result, reason = command([LEFT], [0.5], joints=joints)
    assert result is None and 'names none of the finger joints right_' in reason


@pytest.mark.parametrize('names, positions, velocities, efforts, words', [
    ([], [], [], [], ['names none of the finger joints', LEFT, RIGHT, 'no names']),
    (['gripper_joint'], [0.5], [], [], ['names none', 'got gripper_joint']),
    ([LEFT, LEFT], [0.5, 0.5], [], [], [f'names {LEFT} more than once']),
    ([LEFT, RIGHT], [0.5], [], [], ['1 positions for 2 names']),
    ([LEFT], [math.nan], [], [], ['is not finite']),
    ([LEFT, RIGHT], [0.5, 0.6], [], [], ['finger positions differ (0.5000, 0.6000 rad)']),
    ([LEFT], [2.0], [], [], ['position 2.0000 rad outside the joint limits [0.0000, 1.0000] '
                             'rad (theta_min .. theta_max']),
    ([LEFT], [-0.1], [], [], ['position -0.1000 rad outside the joint limits']),
    ([LEFT], [1.0 + 2 * LIMIT_TOLERANCE], [], [], ['outside the joint limits']),
    ([LEFT], [0.5], [math.inf], [], ['velocity inf is not a finite number']),
    ([LEFT], [0.5], [], [math.nan], ['effort nan is not a finite number']),
    ([LEFT, RIGHT], [0.5, 0.5], [0.1], [], ['1 velocity values for 2 names']),
])
def test_refusals_name_the_problem(names, positions, velocities, efforts, words):
    result, reason = command(names, positions, velocities, efforts)
    assert result is None
    for word in words:
        assert word in reason, reason


def test_a_position_a_rounding_beyond_the_limit_is_clipped_to_it():
    result, reason = command([LEFT], [1.0 + 0.5 * LIMIT_TOLERANCE])
    assert reason == '' and result.theta == 1.0
    assert 'clipped to the limit 1.0000 rad' in result.clipped
    result, _ = command([LEFT], [-0.5 * LIMIT_TOLERANCE])
    assert result.theta == 0.0 and result.clipped
    assert command([LEFT], [1.0])[0].clipped == ''


# -- the ownership rule ---------------------------------------------------------------------
def test_grasp_state_names_are_the_message_constants():
    from forte_msgs.msg import GraspState

    for value, name in GRASP_STATE_NAMES.items():
        assert getattr(GraspState, name) == value
    assert {GRASP_STATE_NAMES[state] for state in OWNING_STATES} == {
        'CLOSING', 'LOADING', 'LIFTING', 'HOLDING', 'RELEASING', 'FAULT'}


def test_a_running_grasp_refuses_and_its_stale_command_never_acts_after_it():
    gate = BridgeGate(grasp_state_timeout=3.0)
    open_ = BridgeCommand(0.9)
    assert gate.judge(open_, 0.0) == (Verdict.ACT, False)       # no grasp state yet
    assert gate.judge(open_, 0.01) == (Verdict.REPEAT, False)   # republished: nothing to do
    gate.on_grasp_state(IDLE, 0.5)
    assert gate.judge(BridgeCommand(0.8), 0.6) == (Verdict.ACT, False)
    # a Grasp starts: the controller owns the servos
    gate.on_grasp_state(CLOSING, 1.0)
    assert gate.grasps == 1 and 'a Grasp is running (grasp/state CLOSING)' in gate.owner(1.0)
    assert gate.judge(open_, 1.1) == (Verdict.OWNED, True)      # warned once per grasp
    assert gate.judge(BridgeCommand(0.7), 1.2) == (Verdict.OWNED, False)
    for state in (LOADING, LIFTING, HOLDING, RELEASING):
        gate.on_grasp_state(state, 1.5)
        assert gate.owner(1.5)
    assert gate.grasps == 1                                     # one grasp, one period
    # it ends (held object): the controller manager republishes its last command
    gate.on_grasp_state(DONE, 2.0)
    assert gate.owner(2.0) == ''
    assert gate.judge(BridgeCommand(0.7), 2.1) == (Verdict.REPEAT, False)  # does not open
    assert gate.judge(BridgeCommand(0.7), 2.2) == (Verdict.REPEAT, False)
    assert gate.judge(BridgeCommand(0.9), 2.3) == (Verdict.ACT, False)     # a new command
    # the next grasp warns again; a latched fault owns the servos too
    gate.on_grasp_state(FAULT, 3.0)
    assert gate.grasps == 2 and 'latched fault' in gate.owner(3.0)
    assert gate.judge(BridgeCommand(0.5), 3.1) == (Verdict.OWNED, True)


def test_a_silent_controller_no_longer_owns_the_servos():
    gate = BridgeGate(grasp_state_timeout=3.0)
    gate.on_grasp_state(LIFTING, 10.0)
    assert gate.judge(BridgeCommand(0.5), 12.9)[0] is Verdict.OWNED
    assert gate.owner(13.0) and gate.owner(13.01) == ''
    assert gate.judge(BridgeCommand(0.5), 13.5)[0] is Verdict.REPEAT  # seen while owned
    assert gate.judge(BridgeCommand(0.6), 13.6)[0] is Verdict.ACT
    gate.on_grasp_state(LIFTING, 14.0)                                # it is back
    assert gate.grasps == 2 and gate.judge(BridgeCommand(0.4), 14.1) == (Verdict.OWNED, True)


def test_commands_differing_in_speed_or_cap_are_new():
    gate = BridgeGate()
    assert gate.judge(BridgeCommand(0.5, 0.3, 1.0), 0.0)[0] is Verdict.ACT
    assert gate.judge(BridgeCommand(0.5, 0.3, 1.0), 0.0)[0] is Verdict.REPEAT
    assert gate.judge(BridgeCommand(0.5, 0.4, 1.0), 0.0)[0] is Verdict.ACT
    assert gate.judge(BridgeCommand(0.5, 0.4, 2.0), 0.0)[0] is Verdict.ACT
