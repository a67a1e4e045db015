"""The shared execution path of the gripper position actions of the grasp controller.

A mixin of :class:`forte_control.ros.grasp_controller_node.GraspControllerNode`. Every
position action it serves (control_msgs ``GripperCommand`` and ``ParallelGripperCommand``,
:mod:`forte_control.ros.gripper_command_servers`) is a :class:`GripperAction`: how its goal
becomes a :class:`forte_control.gripper_goal.GripperGoal` and how a move becomes its result
and feedback. Everything else is one path here: the goal is refused (with the reason, logged)
while the controller is busy, faulted or stopping, or when the goal is invalid; the execute
callback is a coroutine that waits for a joint state (the controller subscribes to its inputs
only while a goal needs them), commands the servo, and awaits a future the control timer
completes when the joint reaches the position, or at ``release_timeout``; feedback goes out
at each check of the control timer. One gripper goal runs at a time, of either action.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from rclpy.action import GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.task import Future

from forte_control.gripper_goal import GripperGoal, GripperMove
from forte_control.state_machine import ACTIVE_STATES, ControllerParams, GraspState

__all__ = ['GripperAction', 'GripperCommandMixin']


@dataclass(frozen=True)
class GripperAction:
    """One gripper position action served through the shared move.

    Attributes
    ----------
    name : str
        Action name (relative, remappable), e.g. ``'gripper_cmd'``.
    action_type : type
        The action class, e.g. ``control_msgs.action.GripperCommand``.
    goal : callable
        ``goal(request, joint_names, params) -> (GripperGoal | None, reason)``.
    result : callable
        ``result(move, joint_names, stamp) -> action_type.Result``.
    feedback : callable
        ``feedback(move, joint_names, stamp) -> action_type.Feedback``.
    """

    name: str
    action_type: Any
    goal: Callable[[Any, Sequence[str], ControllerParams], tuple[GripperGoal | None, str]]
    result: Callable[[GripperMove, Sequence[str], Any], Any]
    feedback: Callable[[GripperMove, Sequence[str], Any], Any]


@dataclass
class _RunningMove:
    """A gripper goal being executed: its action, handle, and the future that ends it."""

    action: GripperAction
    handle: ServerGoalHandle
    done: Future                      # result: None; completed by the control timer
    move: GripperMove | None = None   # None while the goal waits for a joint state


class GripperCommandMixin:
    """Gripper position goals of the grasp controller node (needs its inputs, machine and
    publishers: see :class:`forte_control.ros.grasp_controller_node.GraspControllerNode`)."""

    _gripper_move: _RunningMove | None

    def _gripper_busy(self) -> str:
        """Why no gripper goal can start now ('' if one can)."""
        if self._stopping:
            return 'the controller is shutting down'
        if self._gripper_move is not None:
            return 'another gripper goal is running'
        if self._goal_pending or self._machine.state in ACTIVE_STATES:
            return 'a grasp is in progress'
        if self._machine.state == GraspState.FAULT:
            return 'fault latched, call grasp/reset_fault'
        return ''

    def _on_gripper_goal(self, action: GripperAction, request: Any) -> GoalResponse:
        """Accept a goal of ``action`` unless busy or invalid (the reason is logged)."""
        reason = self._gripper_busy() or \
            action.goal(request, self._joint_names, self._machine.params)[1]
        if reason:
            self.get_logger().warning(f'{action.name} goal rejected: {reason}')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def _execute_gripper(self, action: GripperAction,
                               goal_handle: ServerGoalHandle) -> Any:
        """Run one gripper goal of ``action``: wait for a joint state, move, await the end.

        The move ends when the joint is within ``release_tolerance`` of the position, or
        after ``release_timeout`` (checked by the control timer; ``stalled`` when the joint
        no longer moved between two checks). The goal succeeds when the move ends, with
        ``reached_goal`` / ``stalled`` telling how; it is aborted only when the controller
        stops (or the goal became invalid while waiting, e.g. ``min_angle`` changed).
        """
        running = _RunningMove(action, goal_handle, Future())
        self._gripper_move = running
        try:
            await self._wait_for_inputs(perception=False)
            return await self._move_gripper(running)
        finally:
            self._gripper_move = None
            self._rest_if_idle()

    async def _move_gripper(self, running: _RunningMove) -> Any:
        action, handle = running.action, running.handle
        params = self._machine.params
        goal, reason = action.goal(handle.request, self._joint_names, params)
        if self._stopping or goal is None:
            if goal is None:
                self.get_logger().warning(f'{action.name} goal aborted: {reason}')
            handle.abort()
            return action.action_type.Result()
        if not self._dry_run:
            self._publish_servo(goal.servo(params))
        running.move = GripperMove(goal, params.release_tolerance,
                                   self._now() + params.release_timeout)
        self._check_gripper_move(running)
        await running.done
        result = action.result(running.move, self._joint_names, self._time_msg())
        if self._stopping:
            handle.abort()
        else:
            handle.succeed()
        return result

    def _check_gripper_move(self, running: _RunningMove) -> None:
        """Complete the goal's future once the move ended, else publish feedback (control
        timer)."""
        move = running.move
        if move is None or running.done.done():
            return
        joint = self._joint
        if move.observe(None if joint is None else joint.theta,
                        None if joint is None else joint.torque, self._now()):
            running.done.set_result(None)
        else:
            running.handle.publish_feedback(
                running.action.feedback(move, self._joint_names, self._time_msg()))
