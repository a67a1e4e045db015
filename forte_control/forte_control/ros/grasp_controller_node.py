"""ROS 2 shell around :class:`forte_control.state_machine.GraspStateMachine`.

Serves the ``grasp`` action (forte_msgs/action/Grasp), publishes ``grasp/state``
(GraspState, reliable + transient local, depth 1), ``gripper/command`` (ServoCommand) and
``arm/cmd_vel`` (TwistStamped, ``linear.z`` = lift speed, frame ``arm_frame_id``), subscribes
``tactile/state`` (TactileState), ``joint_states`` (JointState: mean position [rad] and
effort = joint torque [N m] of ``joint_names``, read as the servo current magnitude [A] the
machine compares: :func:`forte_control.state_machine.joint_input`) and, optionally, ``arm/wrench``
(WrenchStamped from a wrist force/torque sensor: the force the gripper exerts on the wrist,
in a frame whose z axis points up, so a carried weight makes ``force.z`` negative; used by
the lift verification when ``lift_check.use_wrench`` is true), and serves
``grasp/reset_fault`` (forte_msgs/srv/ResetFault). Where ``control_msgs`` is installed it
also serves ``gripper_cmd`` (control_msgs/action/GripperCommand) and
``parallel_gripper_cmd`` (control_msgs/action/ParallelGripperCommand) so MoveIt can drive the
gripper (:mod:`forte_control.ros.gripper_command_servers`).

Execution: one thread runs every callback (``main`` spins a ``SingleThreadedExecutor``), so
nothing is locked and no callback blocks. The action execute callbacks are coroutines: a
Grasp goal starts the machine and awaits a future that the machine's step completes when
the grasp reaches its outcome (a step from the control timer, a perception message, the
cancel callback or :meth:`GraspControllerNode.prepare_shutdown`); feedback goes out from the
``feedback_rate`` timer. A gripper position goal awaits a future the control timer completes
when the joint reaches the position, stalls or times out.

Idle costs nothing per input message: the controller subscribes to ``tactile/state``,
``joint_states`` and ``arm/wrench`` and runs its control and feedback timers only while a
goal or a fault reset needs them. A goal first waits (at most ``input_wait``) for the inputs
it needs, then the machine judges their freshness as before; idle, ``grasp/state`` is
republished once a second with the diagnostics.

Slip reaction: a TactileState carrying ``slip`` during LIFTING / HOLDING steps the machine
inside the subscription callback and publishes the tightening command from there, without
waiting for the control timer.

Parameters: declared from the table of :mod:`forte_control.parameters`
(:mod:`forte_control.ros.node_parameters`), the one source of their units, ranges and
descriptions.
"""
from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rclpy.task import Future
from rclpy.time import Time
from sensor_msgs.msg import JointState

from forte_control.ros.grasp_messages import (
    feedback_msg,
    goal_from_msg,
    grasp_state_msg,
    result_msg,
    servo_command_msg,
    stamp_to_seconds,
)
from forte_control.ros.gripper_command import GripperCommandMixin
from forte_control.ros.gripper_command_servers import create_gripper_action_servers
from forte_control.ros.node_parameters import (
    CONTROLLER_FIELDS,
    declare_parameters,
    parameter_changes,
    read_controller_params,
    read_lift_check,
)
from forte_control.state_machine import GraspStateMachine
from forte_control.state_machine.types import (
    ACTIVE_STATES,
    ControlInputs,
    Controller,
    ControlOutputs,
    GraspGoal,
    GraspState,
    JointInput,
    Outcome,
    PerceptionInput,
    ServoOutput,
    WrenchInput,
    joint_input,
    perception_input,
)
from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState as GraspStateMsg
from forte_msgs.msg import ServoCommand, TactileState
from forte_msgs.srv import ResetFault
from forte_ros import run_node
from forte_ros.contract import prefixed
from forte_ros.diagnostics import ERROR, OK, WARN, diagnostic_array, diagnostic_status, node_path
from forte_ros.qos import COMMANDS, DIAGNOSTICS, GRASP_STATE, TACTILE_STATE

__all__ = ['CONTROLLER_FIELDS', 'GraspControllerNode', 'main', 'stamp_to_seconds']


@dataclass
class _RunningGrasp:
    """The Grasp goal in progress: its handle and the future its outcome completes."""

    handle: ServerGoalHandle
    done: Future               # result: the ControlOutputs of the step that finished it
    started: float             # time.monotonic() at the start [s]


class GraspControllerNode(GripperCommandMixin, Node):
    """The FORTE grasp controller node (see the module docstring).

    Parameters
    ----------
    **kwargs
        Passed to :class:`rclpy.node.Node` (e.g. ``parameter_overrides``, ``context``).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('grasp_controller', **kwargs)
        declare_parameters(self)
        self._machine = GraspStateMachine(read_controller_params(self), read_lift_check(self))
        self._perception: PerceptionInput | None = None
        self._slip_pending = False
        self._joint: JointInput | None = None
        self._wrench: WrenchInput | None = None
        #: TF / joint-name prefix (read-only) prepended to joint_names and the frame ids
        self._prefix = str(self.get_parameter('prefix').value)
        self._joint_names = [prefixed(str(name), self._prefix)
                             for name in self.get_parameter('joint_names').value]
        self._dry_run = bool(self.get_parameter('dry_run').value)
        self._step_on_perception = bool(self.get_parameter('step_on_perception').value)
        self._use_receive_time = bool(self.get_parameter('use_receive_time').value)
        self._last_outputs: ControlOutputs | None = None
        self._last_state_published: tuple | None = None
        self._was_active = False
        self._stopping = False
        self._grasp: _RunningGrasp | None = None
        self._gripper_move = None  # the gripper position goal in progress (GripperCommandMixin)
        self._goal_pending = False   # a Grasp goal accepted, its execute not ended
        self._resetting = False      # a fault reset waiting for its inputs
        self._input_subscriptions: list = []
        self._data_time = -math.inf  # newest input stamp since listening [s]
        self._input_waiters: list[tuple[bool, Future]] = []
        self.counters = {'joint_states_without_joints': 0, 'tactile_invalid': 0,
                         'slip_reactions': 0}
        #: receive -> publish latency of slip tightenings [s] (perf_counter), newest last
        self.slip_reaction_latency: deque[float] = deque(maxlen=10000)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._create_interfaces()
        self._publish_state(force=True)
        self.get_logger().info(
            f'grasp controller ready (dry_run={self._dry_run}, control_msgs '
            f'{", ".join(self._gripper_actions) or "not installed"})')

    def _create_interfaces(self) -> None:
        """Publishers, timers, the reset service and the action servers (the subscriptions
        come with a goal, :meth:`_listen`)."""
        self._servo_pub = self.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        self._arm_pub = self.create_publisher(TwistStamped, 'arm/cmd_vel', COMMANDS)
        self._state_pub = self.create_publisher(GraspStateMsg, 'grasp/state', GRASP_STATE)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics',
                                                      DIAGNOSTICS)
        # a group of its own: the coroutine holds its group while it awaits the inputs,
        # which arrive through the default group (one thread runs both)
        self.create_service(ResetFault, 'grasp/reset_fault', self._on_reset_fault,
                            callback_group=ReentrantCallbackGroup())
        control_period = 1.0 / float(self.get_parameter('control_rate').value)
        feedback_period = 1.0 / float(self.get_parameter('feedback_rate').value)
        self._timer = self.create_timer(control_period, self._on_timer)
        self._feedback_timer = self.create_timer(feedback_period, self._on_feedback_timer)
        self._timer.cancel()           # both run only while inputs are subscribed
        self._feedback_timer.cancel()
        self._diagnostics_timer = self.create_timer(1.0, self._publish_diagnostics)
        # wakes the executor when prepare_shutdown (outside any callback) ends a goal
        self._wake = self.create_guard_condition(lambda: None)
        self._action = ActionServer(
            self, Grasp, 'grasp', execute_callback=self._execute,
            goal_callback=self._on_goal, cancel_callback=self._on_cancel)
        # gripper_cmd / parallel_gripper_cmd, where control_msgs has them
        self._gripper_actions = create_gripper_action_servers(self)

    def destroy_node(self) -> None:
        """Destroy the action servers, then the node (rclpy's ``destroy_node``).

        rclpy's ``Node.destroy_node`` destroys publishers, subscriptions, services, timers
        and guard conditions, not waitables: an ``ActionServer`` left alive keeps the rcl
        node (and with it the DDS participant of its context) alive, also after
        ``rclpy.shutdown`` of that context, until the garbage collector frees the node. Its
        ``grasp``, ``gripper_cmd`` and ``parallel_gripper_cmd`` servers would stay
        discoverable with no executor to answer: an action client in the same domain takes
        them for a live server and sends its goal into the void. Safe to call twice.
        """
        servers = [getattr(self, '_action', None),
                   *getattr(self, '_gripper_actions', {}).values()]
        self._action = None
        self._gripper_actions = {}
        for server in servers:
            if server is not None:
                server.destroy()
        super().destroy_node()

    # -- parameters ----------------------------------------------------------------------
    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        if not hasattr(self, '_machine'):  # declarations in __init__
            return SetParametersResult(successful=True)
        changes, lift_changes, error = parameter_changes(parameters)
        if error:
            return SetParametersResult(successful=False, reason=error)
        for parameter in parameters:
            if parameter.name == 'dry_run' and self._machine.state in ACTIVE_STATES:
                return SetParametersResult(
                    successful=False, reason='dry_run cannot change during a grasp')
        lift_check = replace(self._machine.lift_check, **lift_changes)
        problems = lift_check.problems()
        if problems:
            return SetParametersResult(successful=False, reason='; '.join(problems))
        if changes:
            ok, reason = self._machine.set_params(replace(self._machine.params, **changes))
            if not ok:
                return SetParametersResult(successful=False, reason=reason)
        self._machine.set_lift_check(lift_check)
        for parameter in parameters:
            if parameter.name == 'dry_run':
                self._dry_run = bool(parameter.value)
            elif parameter.name == 'step_on_perception':
                self._step_on_perception = bool(parameter.value)
        return SetParametersResult(successful=True)

    # -- inputs, subscribed only while a goal or a reset needs them -------------------------
    def _listen(self) -> None:
        """Subscribe to the inputs and start the control and feedback timers."""
        if self._input_subscriptions:
            return
        self._input_subscriptions = [
            self.create_subscription(TactileState, 'tactile/state', self._on_tactile,
                                     TACTILE_STATE),
            self.create_subscription(JointState, 'joint_states', self._on_joint_state,
                                     COMMANDS),
            self.create_subscription(WrenchStamped, 'arm/wrench', self._on_wrench,
                                     qos_profile_sensor_data)]
        self._timer.reset()
        self._feedback_timer.reset()

    def _rest_if_idle(self) -> None:
        """Unsubscribe the inputs and stop the timers once nothing needs them.

        The latest inputs are forgotten: the next goal waits for new ones.
        """
        if self._goal_pending or self._gripper_move is not None or self._resetting \
                or self._machine.state in ACTIVE_STATES or not self._input_subscriptions:
            return
        for subscription in self._input_subscriptions:
            self.destroy_subscription(subscription)
        self._input_subscriptions = []
        self._perception = self._joint = self._wrench = None
        self._data_time = -math.inf
        self._slip_pending = False
        self._timer.cancel()
        self._feedback_timer.cancel()
        self._publish_state(force=True)

    def _have_inputs(self, perception: bool) -> bool:
        """A joint state, and if ``perception`` a tactile state with valid data (a chunk
        after a gap is marked invalid: the wait goes on to the next one)."""
        return self._joint is not None and (
            not perception or (self._perception is not None and self._perception.data_valid))

    async def _wait_for_inputs(self, perception: bool) -> None:
        """Listen, and wait until a joint state (and a valid tactile state if
        ``perception``) has arrived since, or ``input_wait`` has passed on the node's clock
        (then the machine judges what it has: a goal is refused with the reason)."""
        self._listen()
        if self._have_inputs(perception):
            return
        waiter = Future()
        entry = (perception, waiter)
        self._input_waiters.append(entry)
        timer = self.create_timer(float(self.get_parameter('input_wait').value),
                                  lambda: waiter.done() or waiter.set_result(False))
        try:
            await waiter
        finally:
            self.destroy_timer(timer)
            self._input_waiters.remove(entry)

    def _wake_input_waiters(self) -> None:
        for perception, waiter in self._input_waiters:
            if not waiter.done() and self._have_inputs(perception):
                waiter.set_result(True)

    def _now(self) -> float:
        """The machine's time [s]: the node's clock, or the newest input stamp when that is
        later (the data's own time: in simulation /clock comes at ``clock_rate``, the samples
        every batch, and a loaded machine delays both alike)."""
        return max(self.get_clock().now().nanoseconds * 1e-9, self._data_time)

    def _time_msg(self) -> Any:
        """The machine's time as a header stamp (builtin_interfaces/Time): outputs carry the
        time of the data they answer (in simulation, the sample time of the newest input)."""
        return Time(nanoseconds=round(self._now() * 1e9)).to_msg()

    def _stamp(self, header: Any) -> float:
        """A message's time [s]: its header stamp, or the receive time (use_receive_time)."""
        if self._use_receive_time:
            return self._now()
        stamp = stamp_to_seconds(header.stamp)
        if stamp > self._data_time:  # NaN (no stamp) compares false
            self._data_time = stamp
        return stamp

    def _on_tactile(self, msg: TactileState) -> None:
        received = time.perf_counter()
        if not msg.data_valid:
            self.counters['tactile_invalid'] += 1
        self._slip_pending = self._slip_pending or bool(msg.slip)
        self._perception = perception_input(msg, self._stamp(msg.header), slip=self._slip_pending)
        reacting = msg.slip and self._machine.state in (GraspState.LIFTING, GraspState.HOLDING)
        if reacting or (self._step_on_perception and self._machine.state in ACTIVE_STATES):
            outputs = self._step()
            if outputs.slip_reacted:
                self.slip_reaction_latency.append(time.perf_counter() - received)
                self.counters['slip_reactions'] += 1
        if self._input_waiters:
            self._wake_input_waiters()

    def _on_joint_state(self, msg: JointState) -> None:
        joint = joint_input(msg.name, msg.position, msg.effort, self._joint_names, math.nan)
        if joint is None:
            self.counters['joint_states_without_joints'] += 1
            return
        self._joint = replace(joint, stamp=self._stamp(msg.header))
        if self._input_waiters:
            self._wake_input_waiters()

    def _on_wrench(self, msg: WrenchStamped) -> None:
        # WrenchInput.force_z is the load the wrist carries, + = pulling the gripper down
        self._wrench = WrenchInput(stamp=self._stamp(msg.header),
                                   force_z=-float(msg.wrench.force.z))

    def _inputs(self) -> ControlInputs:
        return ControlInputs(perception=self._perception, joint=self._joint, wrench=self._wrench)

    # -- stepping and outputs ------------------------------------------------------------
    def _step(self) -> ControlOutputs:
        """Step the machine with the latest inputs and publish what changed."""
        outputs = self._machine.step(self._inputs(), self._now())
        self._consume_slip()
        self._apply(outputs)
        return outputs

    def _consume_slip(self) -> None:
        self._slip_pending = False
        if self._perception is not None and self._perception.slip:
            self._perception = replace(self._perception, slip=False)

    def _on_timer(self) -> None:
        outputs = self._step()
        if self._machine.state in ACTIVE_STATES or outputs.finished:
            self._publish_arm(outputs.arm_velocity)
        if self._gripper_move is not None:
            self._check_gripper_move(self._gripper_move)

    def _apply(self, outputs: ControlOutputs) -> None:
        """Publish what changed (servo command, arm stop, state); end a finished goal."""
        self._last_outputs = outputs
        active = outputs.state in ACTIVE_STATES
        if outputs.servo is not None and outputs.servo_changed and not self._dry_run:
            self._publish_servo(outputs.servo)
        if self._was_active and not active:
            self._publish_arm(0.0)  # stop immediately, do not wait for the timer
        self._was_active = active
        grasp = self._grasp
        if grasp is not None and not grasp.done.done() and (outputs.finished or not active):
            grasp.done.set_result(outputs)  # resumes the execute coroutine
        self._publish_state()

    def _frame(self, parameter: str) -> str:
        """The frame id parameter ``parameter`` with the node's ``prefix`` prepended."""
        return prefixed(str(self.get_parameter(parameter).value), self._prefix)

    def _publish_servo(self, servo: ServoOutput) -> None:
        self._servo_pub.publish(servo_command_msg(
            servo, self._time_msg(), self._frame('gripper_frame_id')))

    def _publish_arm(self, velocity: float) -> None:
        msg = TwistStamped()
        msg.header.stamp = self._time_msg()
        msg.header.frame_id = self._frame('arm_frame_id')
        msg.twist.linear.z = 0.0 if self._dry_run else float(velocity)
        self._arm_pub.publish(msg)

    def _publish_state(self, force: bool = False) -> None:
        machine = self._machine
        msg = grasp_state_msg(machine.state, machine.fault_flags, machine.last_outcome,
                              self._last_outputs, self._time_msg(),
                              self._frame('gripper_frame_id'))
        key = (msg.state, msg.fault_flags, msg.last_outcome, msg.message, msg.slip_events)
        if force or key != self._last_state_published:
            self._state_pub.publish(msg)
            self._last_state_published = key

    def _on_feedback_timer(self) -> None:
        """At ``feedback_rate``: grasp/state, and feedback of the running Grasp goal."""
        self._publish_state(force=True)
        grasp, out = self._grasp, self._last_outputs
        if grasp is None or grasp.done.done() or out is None:
            return
        grasp.handle.publish_feedback(feedback_msg(out, self._perception))

    # -- diagnostics -----------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        if not self._input_subscriptions:
            self._publish_state(force=True)  # idle: the once-a-second grasp/state
        now = self._now()
        state = self._machine.state
        level = ERROR if state == GraspState.FAULT else WARN if self._dry_run else OK
        message = f'{state.name}' + (' (dry run)' if self._dry_run else '') + \
            (f': {self._last_outputs.message}' if self._last_outputs is not None else '')
        ages = {
            'perception_age_s': now - self._perception.stamp
            if self._perception is not None else math.nan,
            'joint_state_age_s': now - self._joint.stamp if self._joint is not None else math.nan,
        }
        latencies = sorted(self.slip_reaction_latency)
        values = {
            'state': state.name, 'fault_flags': str(int(self._machine.fault_flags)),
            'last_outcome': self._machine.last_outcome.name,
            'inputs': 'subscribed' if self._input_subscriptions else 'idle: not subscribed',
            **{k: f'{v:.4f}' for k, v in ages.items()},
            **{k: str(v) for k, v in self.counters.items()},
            'slip_reaction_latency_p50_ms': f'{latencies[len(latencies) // 2] * 1e3:.3f}'
            if latencies else 'n/a',
            'slip_reaction_latency_max_ms': f'{latencies[-1] * 1e3:.3f}'
            if latencies else 'n/a',
        }
        status = diagnostic_status(f'{node_path(self)}: grasp controller', level, message,
                                   values, hardware_id='forte')
        self._diagnostics_pub.publish(diagnostic_array(self._time_msg(), [status]))

    # -- reset service -------------------------------------------------------------------
    async def _on_reset_fault(self, request: ResetFault.Request,
                              response: ResetFault.Response) -> ResetFault.Response:
        """Clear the latched fault once the conditions that caused it are gone (judged on
        inputs received after the request, waited for at most ``input_wait``)."""
        self._resetting = True
        try:
            await self._wait_for_inputs(perception=True)
            self._reset_fault(response)
        finally:
            self._resetting = False
            self._rest_if_idle()
        return response

    def _reset_fault(self, response: ResetFault.Response) -> None:
        now = self._now()
        ok, message, cleared = self._machine.reset_fault(now, self._inputs())
        response.success = bool(ok)
        response.message = message
        response.cleared_flags = int(cleared)
        self._last_outputs = self._machine.step(self._inputs(), now)
        self._publish_state(force=True)

    # -- Grasp action --------------------------------------------------------------------
    #: forte_msgs Grasp goal -> GraspGoal (:func:`forte_control.ros.grasp_messages.goal_from_msg`).
    goal_from_msg = staticmethod(goal_from_msg)

    def _on_goal(self, request: Grasp.Goal) -> GoalResponse:
        if self._stopping:
            return GoalResponse.REJECT
        if self._goal_pending or self._machine.state in ACTIVE_STATES:
            self.get_logger().warning('goal rejected: a grasp is in progress')
            return GoalResponse.REJECT
        if self._machine.state == GraspState.FAULT:
            self.get_logger().warning('goal rejected: fault latched, call grasp/reset_fault')
            return GoalResponse.REJECT
        params, reason = self._machine.effective_params(self.goal_from_msg(request))
        if params is None:
            self.get_logger().warning(f'goal rejected: {reason}')
            return GoalResponse.REJECT
        self._goal_pending = True  # until _execute ends: no second goal while this one waits
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle: ServerGoalHandle) -> CancelResponse:
        """Cancel the running grasp at once: arm stopped, grip held, its future completed.

        The action server marks the goal CANCELING right after this returns, before the
        execute coroutine resumes, so that coroutine ends the goal as canceled.
        """
        if self._grasp is not None and goal_handle is self._grasp.handle:
            self._apply(self._machine.cancel(self._now()))
            self._publish_arm(0.0)
        return CancelResponse.ACCEPT

    def prepare_shutdown(self) -> None:
        """Stop a running grasp (arm stopped, grip held) and end its goal (node runner).

        Called by :func:`forte_ros.run_node` after spinning stopped, while the context is
        still valid: the machine is canceled and the goal's future completed here; the
        runner's flush spin then resumes the execute coroutine, which aborts the goal with
        outcome CANCELED and sends the result. A gripper position goal is ended the same way.
        """
        self._stopping = True
        if self._grasp is not None:
            self._apply(self._machine.cancel(self._now()))
            self._publish_arm(0.0)
            if not self._grasp.done.done():
                self._grasp.done.set_result(self._last_outputs)
        if self._gripper_move is not None and not self._gripper_move.done.done():
            self._gripper_move.done.set_result(None)
        for _, waiter in self._input_waiters:
            if not waiter.done():
                waiter.set_result(False)
        self._wake.trigger()

    async def _execute(self, goal_handle: ServerGoalHandle) -> Grasp.Result:
        """Run one Grasp goal: wait for the inputs, start the machine, await its outcome."""
        try:  # _goal_pending was set when the goal was accepted (_on_goal)
            goal = self.goal_from_msg(goal_handle.request)
            await self._wait_for_inputs(perception=goal.controller != Controller.ON_OFF)
            return await self._run_grasp(goal_handle, goal)
        finally:
            self._goal_pending = False
            self._rest_if_idle()

    async def _run_grasp(self, goal_handle: ServerGoalHandle, goal: GraspGoal) -> Grasp.Result:
        if goal_handle.is_cancel_requested or self._stopping:
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
            else:
                goal_handle.abort()
            return result_msg(Outcome.CANCELED, 'canceled before the grasp started', 0.0)
        ok, reason = self._machine.start(goal, self._now(), self._inputs())
        if not ok:
            self.get_logger().warning(f'grasp refused: {reason}')
            goal_handle.abort()
            return result_msg(Outcome.FAULT, f'refused: {reason}', 0.0)
        grasp = _RunningGrasp(goal_handle, Future(), time.monotonic())
        self._grasp = grasp
        self.get_logger().info(f'grasp started ({Controller(goal.controller).name})')
        self._apply(self._machine.step(self._inputs(), self._now()))
        try:
            out: ControlOutputs | None = await grasp.done
        finally:
            self._grasp = None
        duration = time.monotonic() - grasp.started
        outcome = Outcome(int(out.outcome)) if out is not None else Outcome.FAULT
        message = out.message if out is not None else 'no outputs'
        if outcome == Outcome.CANCELED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif outcome == Outcome.LIFTED:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        self.get_logger().info(f'grasp finished: {outcome.name}: {message}')
        return result_msg(outcome, message, duration, out)


def single_threaded_executor(context: Context) -> SingleThreadedExecutor:
    """Executor factory of :func:`main`: every callback of the node on one thread."""
    return SingleThreadedExecutor(context=context)


def main(args: list[str] | None = None) -> int:
    """Run the grasp controller node in a single-threaded executor until SIGINT/SIGTERM."""
    return run_node(GraspControllerNode, args, executor_factory=single_threaded_executor)


if __name__ == '__main__':
    raise SystemExit(main())
