"""The gripper position actions of the grasp controller (control_msgs), for MoveIt and
other action clients.

- ``gripper_cmd``: control_msgs/action/GripperCommand. ``command.position`` = gripper angle
  theta [rad], ``command.max_effort`` = joint torque cap [N m], converted to the servo
  current cap (0 = the controller's ``max_current``). Result and feedback: ``position`` =
  measured theta [rad], ``effort`` = measured joint effort [N m] along theta (negative while
  squeezing; 0 when the driver reports none), ``reached_goal``, ``stalled``.
- ``parallel_gripper_cmd``: control_msgs/action/ParallelGripperCommand (Jazzy's interface
  for parallel grippers: MoveIt's ``ParallelGripperCommand`` controller type calls it,
  ros2_control's parallel_gripper_controller serves it). ``command`` (JointState) names
  one finger joint or both (the controller's ``joint_names``), position = theta [rad] (the
  same for both), optional ``velocity`` = profile velocity [rad/s], optional ``effort`` =
  joint torque cap [N m]. Result and feedback ``state``: every finger joint at the measured
  theta (the mean of the two, on which the move is judged) and the measured joint effort
  [N m] where the driver reports it.

Both run the same move (:class:`forte_control.ros.gripper_command.GripperCommandMixin`);
the goal mapping and its checks are pure (:mod:`forte_control.gripper_goal`). Each action
is served only where its type is installed (control_msgs has no wheel on the package
index: the launch kit builds it; ParallelGripperCommand is in control_msgs 5.1 and later).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from rclpy.action import ActionServer
from sensor_msgs.msg import JointState

from forte_control.gripper_goal import (
    GripperGoal,
    GripperMove,
    gripper_command_goal,
    parallel_gripper_goal,
)
from forte_control.ros.grasp_messages import finite_or_zero
from forte_control.ros.gripper_command import GripperAction
from forte_control.state_machine import ControllerParams

try:  # standard gripper actions, only where control_msgs is installed
    from control_msgs.action import GripperCommand
except ImportError:  # pragma: no cover - depends on the installation
    GripperCommand = None
try:  # control_msgs 5.1+ (Jazzy); older ones lack it
    from control_msgs.action import ParallelGripperCommand
except ImportError:  # pragma: no cover - depends on the installation
    ParallelGripperCommand = None

__all__ = ['GRIPPER_COMMAND_ACTION', 'GripperCommand', 'PARALLEL_GRIPPER_COMMAND_ACTION',
           'ParallelGripperCommand', 'create_gripper_action_servers', 'gripper_actions',
           'joint_state']

#: Action names (relative to the node's namespace, remappable).
GRIPPER_COMMAND_ACTION = 'gripper_cmd'
PARALLEL_GRIPPER_COMMAND_ACTION = 'parallel_gripper_cmd'


# -- GripperCommand ------------------------------------------------------------------------
def _gripper_command_goal(request: Any, joint_names: Sequence[str],
                          params: ControllerParams) -> tuple[GripperGoal | None, str]:
    return gripper_command_goal(request.command.position, request.command.max_effort, params)


def _fill_gripper_command(message: Any, move: GripperMove) -> Any:
    """Fill a GripperCommand result or feedback (same fields) from ``move``."""
    message.position = float(move.position)
    message.effort = finite_or_zero(move.effort)
    message.stalled = bool(move.stalled_short)
    message.reached_goal = bool(move.reached)
    return message


def _gripper_command_result(move: GripperMove, joint_names: Sequence[str], stamp: Any) -> Any:
    return _fill_gripper_command(GripperCommand.Result(), move)


def _gripper_command_feedback(move: GripperMove, joint_names: Sequence[str],
                              stamp: Any) -> Any:
    return _fill_gripper_command(GripperCommand.Feedback(), move)


# -- ParallelGripperCommand ----------------------------------------------------------------
def _parallel_goal(request: Any, joint_names: Sequence[str],
                   params: ControllerParams) -> tuple[GripperGoal | None, str]:
    command = request.command
    return parallel_gripper_goal(list(command.name), list(command.position),
                                 list(command.velocity), list(command.effort), joint_names,
                                 params)


def joint_state(move: GripperMove, joint_names: Sequence[str], stamp: Any) -> JointState:
    """The gripper's state for a ParallelGripperCommand result or feedback.

    Parameters
    ----------
    move : GripperMove
        The move (its latest measured angle and joint effort).
    joint_names : sequence of str
        The controller's finger joints.
    stamp : builtin_interfaces/Time
        Header stamp.

    Returns
    -------
    sensor_msgs/JointState
        Each finger joint at the measured theta [rad] (no position before the first joint
        state), the measured joint effort [N m] when reported, no velocity.
    """
    state = JointState()
    state.header.stamp = stamp
    state.name = list(joint_names)
    if math.isfinite(move.theta):
        state.position = [float(move.theta)] * len(joint_names)
    if math.isfinite(move.effort):
        state.effort = [float(move.effort)] * len(joint_names)
    return state


def _parallel_result(move: GripperMove, joint_names: Sequence[str], stamp: Any) -> Any:
    result = ParallelGripperCommand.Result()
    result.state = joint_state(move, joint_names, stamp)
    result.stalled = bool(move.stalled_short)
    result.reached_goal = bool(move.reached)
    return result


def _parallel_feedback(move: GripperMove, joint_names: Sequence[str], stamp: Any) -> Any:
    feedback = ParallelGripperCommand.Feedback()
    feedback.state = joint_state(move, joint_names, stamp)
    return feedback


# -- servers -------------------------------------------------------------------------------
def gripper_actions() -> list[GripperAction]:
    """The gripper position actions whose type is installed here."""
    actions = []
    if GripperCommand is not None:
        actions.append(GripperAction(GRIPPER_COMMAND_ACTION, GripperCommand,
                                     _gripper_command_goal, _gripper_command_result,
                                     _gripper_command_feedback))
    if ParallelGripperCommand is not None:
        actions.append(GripperAction(PARALLEL_GRIPPER_COMMAND_ACTION, ParallelGripperCommand,
                                     _parallel_goal, _parallel_result, _parallel_feedback))
    return actions


def create_gripper_action_servers(node: Any) -> dict[str, ActionServer]:
    """Serve every installed gripper position action on ``node`` (the grasp controller).

    Parameters
    ----------
    node : GraspControllerNode
        The node; its :class:`forte_control.ros.gripper_command.GripperCommandMixin`
        methods handle the goals.

    Returns
    -------
    dict of str to rclpy.action.ActionServer
        Action name -> its server, one per action of :func:`gripper_actions` (empty
        without control_msgs).
    """
    return {action.name: ActionServer(node, action.action_type, action.name,
                                      execute_callback=_execute_callback(node, action),
                                      goal_callback=_goal_callback(node, action))
            for action in gripper_actions()}


def _execute_callback(node: Any, action: GripperAction) -> Any:
    async def execute(goal_handle: Any) -> Any:
        return await node._execute_gripper(action, goal_handle)
    return execute


def _goal_callback(node: Any, action: GripperAction) -> Any:
    def on_goal(request: Any) -> Any:
        return node._on_gripper_goal(action, request)
    return on_goal
