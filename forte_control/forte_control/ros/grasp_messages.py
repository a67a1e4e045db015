"""Conversions between the grasp controller's messages (forte_msgs) and the state machine.

The grasp controller node (:mod:`forte_control.ros.grasp_controller_node`) builds every message it
sends from the machine's outputs here, and reads its goals here; the perception input is
:func:`forte_control.state_machine.perception_input`. Messages only, no node.
"""
from __future__ import annotations

import math
from typing import Any

from forte_control.state_machine import (
    ControlOutputs,
    FaultFlag,
    GraspGoal,
    GraspState,
    Outcome,
    PerceptionInput,
    ServoOutput,
)
from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState as GraspStateMsg
from forte_msgs.msg import ServoCommand

__all__ = ['feedback_msg', 'finite_or_zero', 'goal_from_msg', 'grasp_state_msg', 'result_msg',
           'servo_command_msg', 'stamp_to_seconds']


def stamp_to_seconds(stamp: Any) -> float:
    """builtin_interfaces/Time -> float seconds (NaN for a zero stamp, i.e. never set)."""
    if stamp.sec == 0 and stamp.nanosec == 0:
        return math.nan
    return stamp.sec + stamp.nanosec * 1e-9


def finite_or_zero(value: float) -> float:
    """``value`` as a float, 0.0 when it is NaN or infinite (message fields want numbers)."""
    return float(value) if math.isfinite(value) else 0.0


def goal_from_msg(request: Grasp.Goal) -> GraspGoal:
    """forte_msgs Grasp goal -> :class:`GraspGoal`."""
    return GraspGoal(
        controller=request.controller, initial_force=request.initial_force,
        lift_speed=request.lift_speed, lift_distance=request.lift_distance,
        slip_increment=request.slip_increment, max_tightening=request.max_tightening,
        max_force=request.max_force, timeout=request.timeout,
        release_after=request.release_after)


def servo_command_msg(servo: ServoOutput, stamp: Any, frame_id: str) -> ServoCommand:
    """The ``gripper/command`` message of a servo command (header ``stamp``, ``frame_id``)."""
    msg = ServoCommand()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.position = servo.position
    msg.max_current = servo.max_current
    msg.profile_velocity = servo.profile_velocity
    return msg


def _servo_position(out: ControlOutputs) -> float:
    return float(out.servo.position) if out.servo is not None else math.nan


def grasp_state_msg(state: GraspState, fault_flags: FaultFlag, last_outcome: Outcome,
                    out: ControlOutputs | None, stamp: Any, frame_id: str) -> GraspStateMsg:
    """The ``grasp/state`` message: the machine's state and its last outputs (``None``:
    no step yet, reported as idle)."""
    msg = GraspStateMsg(state=int(state), fault_flags=int(fault_flags),
                        last_outcome=int(last_outcome))
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    if out is not None:
        msg.controller = int(out.controller)
        msg.target_force = finite_or_zero(out.target_force)
        msg.estimated_force = finite_or_zero(out.estimated_force)
        msg.force_valid = bool(out.force_valid)
        msg.servo_command = _servo_position(out)
        msg.tightening = float(out.tightening)
        msg.lift_height = float(out.lift_height)
        msg.slip_events = int(out.slip_events)
        msg.message = out.message
    else:
        msg.servo_command = math.nan
        msg.message = 'idle'
    return msg


def feedback_msg(out: ControlOutputs, perception: PerceptionInput | None) -> Grasp.Feedback:
    """Feedback of a running Grasp goal from the last outputs and the latest perception."""
    feedback = Grasp.Feedback()
    feedback.state = int(out.state)
    feedback.estimated_force = finite_or_zero(out.estimated_force)
    feedback.slip = bool(perception.slip) if perception is not None else False
    feedback.slipping = bool(perception.slipping) if perception is not None else False
    if perception is not None:
        feedback.finger_variance = [float(v) for v in perception.finger_variance]
    feedback.servo_command = _servo_position(out)
    feedback.lift_height = float(out.lift_height)
    feedback.slip_events = int(out.slip_events)
    return feedback


def result_msg(outcome: Outcome, message: str, duration: float,
               out: ControlOutputs | None = None) -> Grasp.Result:
    """The result of a Grasp goal (``out``: the outputs of the step that ended it, if any)."""
    result = Grasp.Result(outcome=int(outcome), message=message, duration=float(duration))
    if out is not None:
        result.final_force = finite_or_zero(out.estimated_force)
        result.lift_height = float(out.lift_height)
        result.slip_events = int(out.slip_events)
        result.tightening = float(out.tightening)
        result.slip_duration = float(out.slip_duration)
    return result
