"""The gripper driver's JointState command bridge with real rclpy, judged at the servos.

The driver node runs against the simulated XM430-W350 pair (its own process, on a pty,
through the real dynamixel-sdk); a probe node publishes what ros2_control's
``topic_based_ros2_control/TopicBasedSystem`` publishes on ``gripper/joint_commands`` and,
standing in for the grasp controller, ``grasp/state`` (forte_bringup's bench-twin test runs
the real controller). Each claim is read from the servos' own registers, not from the driver.
"""
from __future__ import annotations

import math

import pytest
from lifecycle_msgs.msg import Transition
from sensor_msgs.msg import JointState
from test_gripper_driver_node import Harness, configure_and_activate, values_of, wait_for

from forte_driver.dynamixel import protocol as proto
from forte_driver.emulators.simulated_servo import SimulatedServoProcess
from forte_msgs.msg import GraspState

LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'
#: 0.6 rad = 391 pulses (0.6 / (2 pi / 4096) = 391.2); the left servo is mirrored.
PULSES_06 = 391


@pytest.fixture
def servos():
    with SimulatedServoProcess(ids=(1, 2), positions=(2048, 2048)) as simulated:
        yield simulated


@pytest.fixture
def rig(servos):
    started = Harness(servos)
    yield started
    started.close()


def joint_command(names, positions, velocities=(), efforts=()) -> JointState:
    """A TopicBasedSystem command: one position (velocity, effort) per name."""
    message = JointState(name=list(names), position=[float(p) for p in positions],
                         velocity=[float(v) for v in velocities],
                         effort=[float(e) for e in efforts])
    return message


def publish(rig: Harness, message: JointState) -> None:
    assert wait_for(lambda: rig.joint_commands.get_subscription_count() >= 1)
    rig.joint_commands.publish(message)


def grasp_state(rig: Harness, state: int) -> None:
    rig.grasp_states.publish(GraspState(state=state))


def sync_writes(servos) -> int:
    return servos.count(proto.INSTRUCTION_SYNC_WRITE)


def driver_values(rig: Harness, predicate) -> dict | None:
    """The newest driver status values of /diagnostics that satisfy ``predicate``."""
    def find():
        for array in reversed(rig.diagnostics[-5:]):
            for status in array.status:
                if status.name.endswith(': driver') and predicate(values_of(status)):
                    return values_of(status)
        return None
    return wait_for(find)


def test_joint_commands_move_both_servos_with_one_sync_write(servos, rig):
    configure_and_activate(rig)
    before = sync_writes(servos)
    # TopicBasedSystem of a gripper whose right finger joint mimics the left: both, equal,
    # velocity and effort 0 (no such command interfaces): the driver's defaults
    publish(rig, joint_command([LEFT, RIGHT], [0.6, 0.6], [0.0, 0.0], [0.0, 0.0]))
    assert wait_for(lambda: servos.register_value(1, 'Present Position') == 2048 + PULSES_06)
    assert wait_for(lambda: servos.register_value(2, 'Present Position') == 2048 - PULSES_06)
    assert servos.register_value(1, 'Goal Current') == 185  # default_current 0.5 A
    assert sync_writes(servos) - before == 1                # one packet, both servos
    # joint_states come back with both joint names at the servos' angle
    back = rig.joint_state_where(lambda m: abs(m.position[0] - 0.6) < 1e-3
                                     and m.velocity[0] == 0.0)
    assert back is not None and list(back.name) == [LEFT, RIGHT]
    assert list(back.position) == [PULSES_06 * 2 * math.pi / 4096] * 2
    # republished every controller cycle: nothing more reaches the servos. One at a time:
    # the topic keeps the last 10, so a burst on a stalled machine may lose some (not a fault)
    counters = rig.driver.counters
    for count in range(1, 21):
        publish(rig, joint_command([LEFT, RIGHT], [0.6, 0.6], [0.0, 0.0], [0.0, 0.0]))
        assert wait_for(lambda taken=count: counters['bridge_commands_repeated'] == taken)
    assert sync_writes(servos) - before == 1
    # the left joint alone, with a velocity and an effort [N m]
    publish(rig, joint_command([LEFT], [0.3], [-0.5], [1.0]))
    assert wait_for(lambda: servos.register_value(1, 'Goal Position') == 2048 + 196)
    # 1.0 N m / (4.1 / 2.3 N m/A) = 0.56098 A -> 208 units; 0.5 rad/s -> 21 units
    assert servos.register_value(1, 'Goal Current') == 208
    assert servos.register_value(2, 'Goal Current') == 208
    assert servos.register_value(1, 'Profile Velocity') == 21
    assert sync_writes(servos) - before == 2
    values = driver_values(rig, lambda v: v['bridge_commands_sent'] == '2')
    assert values is not None and values['bridge_commands_repeated'] == '20'
    assert values['servo_owner'].startswith('commands') and values['grasp_state'] == \
        'none received'


def test_out_of_range_and_malformed_commands_are_refused_naming_why(servos, rig):
    configure_and_activate(rig)
    before = sync_writes(servos)
    publish(rig, joint_command([LEFT], [2.0]))
    publish(rig, joint_command(['panda_finger_joint1'], [0.02]))
    publish(rig, joint_command([LEFT, RIGHT], [0.5, 0.7]))
    assert wait_for(lambda: rig.driver.counters['bridge_commands_refused'] == 3)
    # the limits read back from the servos: 1.0 rad is 652 pulses = 1.0002 rad
    for text in ('gripper/joint_commands refused: position 2.0000 rad outside the joint '
                 'limits [0.0000, 1.0002] rad (theta_min .. theta_max',
                 'names none of the finger joints forte_left_finger_joint, '
                 'forte_right_finger_joint (got panda_finger_joint1)',
                 'finger positions differ (0.5000, 0.7000 rad)'):
        assert wait_for(lambda text=text: any(text in line for line in rig.log)), (
            text, rig.log[-3:])
    assert sync_writes(servos) == before
    # a rounding beyond a limit is clipped to it (Min Position Limit of the right servo)
    publish(rig, joint_command([RIGHT], [0.5]))
    assert wait_for(lambda: servos.register_value(1, 'Goal Position') == 2048 + 326)
    publish(rig, joint_command([RIGHT], [-0.0005]))
    assert wait_for(lambda: servos.register_value(1, 'Goal Position') == 2048)
    # the node counts the clip once its write has returned, after the bus applied it
    assert wait_for(lambda: rig.driver.counters['bridge_commands_clipped'] == 1)
    assert wait_for(lambda: any('position -0.000500 rad clipped to the limit 0.0000 rad'
                                in line for line in rig.log)), rig.log[-3:]


def test_a_running_grasp_owns_the_servos_and_its_stale_command_does_not_act(servos, rig):
    grasp_state(rig, GraspState.IDLE)  # latched before the driver configures
    configure_and_activate(rig)
    publish(rig, joint_command([LEFT], [0.6]))
    assert wait_for(lambda: servos.register_value(1, 'Goal Position') == 2048 + PULSES_06)
    writes = sync_writes(servos)
    grasp_state(rig, GraspState.CLOSING)   # the controller starts a Grasp
    assert driver_values(rig, lambda v: v['grasp_state'] == 'CLOSING') is not None
    counters = rig.driver.counters
    publish(rig, joint_command([LEFT], [0.9]))  # MoveIt opens the gripper: refused
    assert wait_for(lambda: counters['bridge_commands_refused_grasp_running'] == 1)
    publish(rig, joint_command([LEFT], [0.8]))
    for state in (GraspState.LOADING, GraspState.LIFTING, GraspState.HOLDING):
        grasp_state(rig, state)
    publish(rig, joint_command([LEFT], [0.8]))  # the controller manager repeats it
    assert wait_for(lambda: counters['bridge_commands_refused_grasp_running'] == 2
                    and counters['bridge_commands_repeated'] == 1), counters
    assert wait_for(lambda: any('a Grasp is running' in line for line in rig.log))
    warnings = [line for line in rig.log if 'a Grasp is running' in line]
    assert len(warnings) == 1 and 'grasp/state CLOSING' in warnings[0], warnings
    assert 'not queued' in warnings[0]
    values = driver_values(rig, lambda v: v['grasp_state'] == 'HOLDING')
    assert values is not None and values['servo_owner'] == 'grasp controller'
    assert values['bridge_commands_refused_grasp_running'] == '2'
    # the grasp ends with the object held: the stale command must not open the gripper
    grasp_state(rig, GraspState.DONE)
    assert driver_values(rig, lambda v: v['grasp_state'] == 'DONE') is not None
    for _ in range(5):
        publish(rig, joint_command([LEFT], [0.8]))
    assert wait_for(lambda: counters['bridge_commands_repeated'] == 6), counters
    assert sync_writes(servos) == writes
    assert servos.register_value(1, 'Goal Position') == 2048 + PULSES_06
    # a new command acts at once
    publish(rig, joint_command([LEFT], [0.5]))
    assert wait_for(lambda: servos.register_value(1, 'Goal Position') == 2048 + 326)
    assert sync_writes(servos) == writes + 1
    # a latched fault holds the grip too
    grasp_state(rig, GraspState.FAULT)
    assert driver_values(rig, lambda v: v['grasp_state'] == 'FAULT') is not None
    publish(rig, joint_command([LEFT], [0.9]))
    assert wait_for(lambda: counters['bridge_commands_refused_grasp_running'] == 3)
    assert wait_for(lambda: any('latched fault' in line for line in rig.log)), rig.log
    assert sync_writes(servos) == writes + 1


def test_no_bridge_while_inactive(servos, rig):
    assert rig.transition(Transition.TRANSITION_CONFIGURE)
    rig.joint_commands.publish(joint_command([LEFT], [0.6]))
    assert rig.driver._bridge_subscription is None  # subscribed only while active
    configure = sync_writes(servos)
    assert rig.transition(Transition.TRANSITION_ACTIVATE)
    publish(rig, joint_command([LEFT], [0.6]))
    assert wait_for(lambda: rig.driver.counters['bridge_commands_sent'] == 1)
    assert rig.transition(Transition.TRANSITION_DEACTIVATE)
    assert rig.driver._bridge_subscription is None
    assert sync_writes(servos) == configure + 2  # activate's "hold here", the one command
