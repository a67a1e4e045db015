"""The ``gripper_cmd`` action (control_msgs/action/GripperCommand) of the grasp controller.

A mixin of :class:`forte_control.ros.grasp_controller_node.GraspControllerNode`, so MoveIt can
open and close the gripper through the standard action, where ``control_msgs`` is installed.
The execute callback is a coroutine: it waits for a joint state (the controller subscribes
to its inputs only while a goal needs them), commands the servo, and awaits a future the
control timer completes when the joint reaches the position, stalls or times out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from rclpy.action import GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.task import Future

from forte_control.state_machine import ACTIVE_STATES, GraspState, ServoOutput

try:  # standard gripper action for MoveIt, only where control_msgs is installed
    from control_msgs.action import GripperCommand
except ImportError:  # pragma: no cover - depends on the installation
    GripperCommand = None

__all__ = ['GripperCommand', 'GripperCommandMixin']


@dataclass
class _GripperMove:
    """A GripperCommand goal in progress (checked by the control timer)."""

    position: float            # target [rad]
    tolerance: float           # [rad]
    deadline: float            # node clock [s]
    done: Future               # result: None
    last: float = math.nan     # joint angle at the previous check [rad]
    stalled: bool = False


class GripperCommandMixin:
    """GripperCommand goals of the grasp controller node (needs its inputs, machine and
    publishers: see :class:`forte_control.ros.grasp_controller_node.GraspControllerNode`)."""

    _gripper_move: _GripperMove | None

    def _on_gripper_goal(self, request: Any) -> GoalResponse:
        if self._stopping or self._gripper_move is not None:
            return GoalResponse.REJECT
        if self._machine.state in ACTIVE_STATES or self._machine.state == GraspState.FAULT:
            return GoalResponse.REJECT
        position = float(request.command.position)
        if not math.isfinite(position) or not self._machine.params.min_angle <= position \
                <= math.pi:
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def _execute_gripper(self, goal_handle: ServerGoalHandle) -> Any:
        """Move the servo to ``command.position`` [rad]; ``max_effort`` [A] caps the current.

        Ends when the joint is within ``release_tolerance`` of the position, or after
        ``release_timeout`` (checked by the control timer; ``stalled`` when the joint no
        longer moved between two checks).
        """
        move = _GripperMove(math.nan, 0.0, math.inf, Future())  # holds the place while waiting
        self._gripper_move = move
        try:
            await self._wait_for_inputs(perception=False)
            return await self._move_gripper(goal_handle)
        finally:
            self._gripper_move = None
            self._rest_if_idle()

    async def _move_gripper(self, goal_handle: ServerGoalHandle) -> Any:
        if self._stopping:
            goal_handle.abort()
            return GripperCommand.Result()
        params = self._machine.params
        position = float(goal_handle.request.command.position)
        effort = float(goal_handle.request.command.max_effort)
        if not self._dry_run:
            self._publish_servo(ServoOutput(
                position=position, profile_velocity=params.release_speed,
                max_current=min(effort, params.max_current) if effort > 0.0
                else params.max_current))
        move = _GripperMove(position, params.release_tolerance,
                            self._now() + params.release_timeout, Future())
        self._gripper_move = move
        self._check_gripper_move(move)
        await move.done
        result = GripperCommand.Result()
        result.position = float(move.last) if math.isfinite(move.last) else position
        result.reached_goal = bool(math.isfinite(move.last)
                                   and abs(move.last - position) <= move.tolerance)
        result.stalled = bool(move.stalled and not result.reached_goal)
        if self._stopping:
            goal_handle.abort()
        else:
            goal_handle.succeed()
        return result

    def _check_gripper_move(self, move: _GripperMove) -> None:
        """Complete the move's future once reached, or at its deadline (control timer)."""
        if move.done.done():
            return
        joint = self._joint
        if joint is not None:
            move.stalled = abs(joint.theta - move.last) < 1e-4
            move.last = joint.theta
            if abs(joint.theta - move.position) <= move.tolerance:
                move.done.set_result(None)
                return
        if self._now() >= move.deadline:
            move.done.set_result(None)
