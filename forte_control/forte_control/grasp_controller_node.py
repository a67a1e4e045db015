"""ROS 2 shell around :class:`forte_control.state_machine.GraspStateMachine`.

Serves the ``grasp`` action (forte_msgs/action/Grasp), publishes ``grasp/state``
(GraspState, reliable + transient local, depth 1), ``gripper/command`` (ServoCommand) and
``arm/cmd_vel`` (TwistStamped, ``linear.z`` = lift speed, frame ``arm_frame_id``), subscribes
``tactile/state`` (TactileState) and ``joint_states`` (JointState), and serves
``grasp/reset_fault`` (forte_msgs/srv/ResetFault). Where ``control_msgs`` is installed it
also serves ``gripper_cmd`` (control_msgs/action/GripperCommand) so MoveIt can drive the
gripper.

Threading: every callback that touches the state machine (subscriptions, the 20 Hz control
timer, the reset service, goal/cancel callbacks) runs under one lock; the action's execute
callback only waits for an event and publishes feedback, in its own reentrant group, so a
running goal never blocks the control callbacks. Run it in a MultiThreadedExecutor (``main``
does).

Slip reaction: a TactileState carrying ``slip`` during LIFTING / HOLDING steps the machine
inside the subscription callback and publishes the tightening command from there, without
waiting for the control timer.
"""
from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import replace

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import (
    SetParametersResult,
)
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from forte_control.node_parameters import (
    CONTROLLER_FIELDS,  # noqa: F401 - importable from here as before
    controller_changes,
    declare_parameters,
    read_controller_params,
)
from forte_control.state_machine import (
    ACTIVE_STATES,
    ControlInputs,
    Controller,
    ControlOutputs,
    GraspGoal,
    GraspState,
    GraspStateMachine,
    JointInput,
    Outcome,
    PerceptionInput,
)
from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState as GraspStateMsg
from forte_msgs.msg import ServoCommand, TactileState
from forte_msgs.srv import ResetFault
from forte_ros import run_node

try:  # standard gripper action for MoveIt, only where control_msgs is installed
    from control_msgs.action import GripperCommand
except ImportError:  # pragma: no cover - depends on the installation
    GripperCommand = None

def stamp_to_seconds(stamp) -> float:
    """builtin_interfaces/Time -> float seconds (NaN for a zero stamp, i.e. never set)."""
    if stamp.sec == 0 and stamp.nanosec == 0:
        return math.nan
    return stamp.sec + stamp.nanosec * 1e-9


class GraspControllerNode(Node):
    """The FORTE grasp controller node (see the module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('grasp_controller', **kwargs)
        declare_parameters(self)

        self._lock = threading.RLock()
        self._machine = GraspStateMachine(read_controller_params(self))
        self._perception: PerceptionInput | None = None
        self._slip_pending = False
        self._joint: JointInput | None = None
        self._joint_names = list(self.get_parameter('joint_names').value)
        self._dry_run = bool(self.get_parameter('dry_run').value)
        self._step_on_perception = bool(self.get_parameter('step_on_perception').value)
        self._use_receive_time = bool(self.get_parameter('use_receive_time').value)
        self._last_outputs: ControlOutputs | None = None
        self._last_state_published: tuple | None = None
        self._was_active = False
        self._done_event = threading.Event()
        self._stopping = threading.Event()
        self._execute_idle = threading.Event()
        self._execute_idle.set()
        self._goal_start = 0.0
        self._active_goal = None
        self.counters = {'joint_states_without_joints': 0, 'tactile_invalid': 0,
                         'slip_reactions': 0}
        #: receive -> publish latency of slip tightenings [s] (perf_counter), newest last
        self.slip_reaction_latency: deque[float] = deque(maxlen=10000)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        reliable10 = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                                reliability=ReliabilityPolicy.RELIABLE)
        reliable50 = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50,
                                reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._control_group = MutuallyExclusiveCallbackGroup()
        self._action_group = ReentrantCallbackGroup()
        self._servo_pub = self.create_publisher(ServoCommand, 'gripper/command', reliable10)
        self._arm_pub = self.create_publisher(TwistStamped, 'arm/cmd_vel', reliable10)
        self._state_pub = self.create_publisher(GraspStateMsg, 'grasp/state', latched)
        self.create_subscription(TactileState, 'tactile/state', self._on_tactile, reliable50,
                                 callback_group=self._control_group)
        self.create_subscription(JointState, 'joint_states', self._on_joint_state, reliable10,
                                 callback_group=self._control_group)
        self.create_service(ResetFault, 'grasp/reset_fault', self._on_reset_fault,
                            callback_group=self._control_group)
        control_rate = float(self.get_parameter('control_rate').value)
        self._feedback_period = 1.0 / float(self.get_parameter('feedback_rate').value)
        self._timer = self.create_timer(1.0 / control_rate, self._on_timer,
                                        callback_group=self._control_group)
        self._state_timer = self.create_timer(self._feedback_period, self._publish_state_timer,
                                              callback_group=self._control_group)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics',
                                                      reliable10)
        self._diagnostics_timer = self.create_timer(1.0, self._publish_diagnostics,
                                                    callback_group=self._control_group)
        self._action = ActionServer(
            self, Grasp, 'grasp', execute_callback=self._execute,
            goal_callback=self._on_goal, cancel_callback=self._on_cancel,
            callback_group=self._action_group)
        self._gripper_action = None
        if GripperCommand is not None:  # pragma: no cover - control_msgs not installed here
            self._gripper_action = ActionServer(
                self, GripperCommand, 'gripper_cmd', execute_callback=self._execute_gripper,
                goal_callback=self._on_gripper_goal, callback_group=self._action_group)
        self._publish_state(force=True)
        self.get_logger().info(
            f'grasp controller ready (dry_run={self._dry_run}, control_msgs '
            f'{"available" if GripperCommand is not None else "not installed"})')

    # -- parameters ----------------------------------------------------------------------
    def _on_set_parameters(self, parameters) -> SetParametersResult:
        with self._lock:
            if not hasattr(self, '_machine'):
                return SetParametersResult(successful=True)
            changes, error = controller_changes(parameters)
            if error:
                return SetParametersResult(successful=False, reason=error)
            for parameter in parameters:
                if parameter.name == 'dry_run':
                    if self._machine.state in ACTIVE_STATES:
                        return SetParametersResult(
                            successful=False, reason='dry_run cannot change during a grasp')
            if changes:
                ok, reason = self._machine.set_params(replace(self._machine.params, **changes))
                if not ok:
                    return SetParametersResult(successful=False, reason=reason)
            for parameter in parameters:
                if parameter.name == 'dry_run':
                    self._dry_run = bool(parameter.value)
                elif parameter.name == 'step_on_perception':
                    self._step_on_perception = bool(parameter.value)
            return SetParametersResult(successful=True)

    # -- inputs --------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_tactile(self, msg: TactileState) -> None:
        received = time.perf_counter()
        with self._lock:
            if not msg.data_valid:
                self.counters['tactile_invalid'] += 1
            self._slip_pending = self._slip_pending or bool(msg.slip)
            stamp = self._now() if self._use_receive_time \
                else stamp_to_seconds(msg.header.stamp)
            self._perception = PerceptionInput(
                stamp=stamp, force=float(msg.force),
                force_valid=bool(msg.force_valid),
                contact=(bool(msg.contact[0]), bool(msg.contact[1])),
                slip=self._slip_pending, slip_active=bool(msg.slip_active),
                data_valid=bool(msg.data_valid), filtered=tuple(float(v) for v in msg.filtered),
                finger_variance=(float(msg.finger_variance[0]), float(msg.finger_variance[1])))
            reacting = msg.slip and self._machine.state in (GraspState.LIFTING,
                                                            GraspState.HOLDING)
            if reacting or (self._step_on_perception and self._machine.state in ACTIVE_STATES):
                outputs = self._step()
                if outputs.slip_reacted:
                    self.slip_reaction_latency.append(time.perf_counter() - received)
                    self.counters['slip_reactions'] += 1

    def _on_joint_state(self, msg: JointState) -> None:
        positions = [msg.position[i] for i, name in enumerate(msg.name)
                     if name in self._joint_names and i < len(msg.position)]
        if not positions:
            self.counters['joint_states_without_joints'] += 1
            return
        with self._lock:
            stamp = self._now() if self._use_receive_time \
                else stamp_to_seconds(msg.header.stamp)
            self._joint = JointInput(stamp=stamp,
                                     theta=float(sum(positions) / len(positions)))

    def _inputs(self) -> ControlInputs:
        return ControlInputs(perception=self._perception, joint=self._joint)

    # -- stepping and outputs ------------------------------------------------------------
    def _step(self) -> ControlOutputs:
        """Step the machine with the latest inputs and publish (lock held)."""
        outputs = self._machine.step(self._inputs(), self._now())
        self._consume_slip()
        self._apply(outputs)
        return outputs

    def _consume_slip(self) -> None:
        self._slip_pending = False
        if self._perception is not None and self._perception.slip:
            self._perception = replace(self._perception, slip=False)

    def _on_timer(self) -> None:
        with self._lock:
            outputs = self._step()
            if self._machine.state in ACTIVE_STATES or outputs.finished:
                self._publish_arm(outputs.arm_velocity)

    def _apply(self, outputs: ControlOutputs) -> None:
        """Publish what changed: servo command at once, arm stop at once, state."""
        self._last_outputs = outputs
        active = outputs.state in ACTIVE_STATES
        if outputs.servo is not None and outputs.servo_changed and not self._dry_run:
            msg = ServoCommand()
            msg.header.stamp = self.get_clock().now().to_msg()
            msg.header.frame_id = str(self.get_parameter('gripper_frame_id').value)
            msg.position = outputs.servo.position
            msg.max_current = outputs.servo.max_current
            msg.profile_velocity = outputs.servo.profile_velocity
            self._servo_pub.publish(msg)
        if self._was_active and not active:
            self._publish_arm(0.0)  # stop immediately, do not wait for the timer
        self._was_active = active
        if outputs.finished:
            self._done_event.set()
        self._publish_state()

    def _publish_arm(self, velocity: float) -> None:
        msg = TwistStamped()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = str(self.get_parameter('arm_frame_id').value)
        msg.twist.linear.z = 0.0 if self._dry_run else float(velocity)
        self._arm_pub.publish(msg)

    def _state_msg(self) -> GraspStateMsg:
        out = self._last_outputs
        msg = GraspStateMsg()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = str(self.get_parameter('gripper_frame_id').value)
        msg.state = int(self._machine.state)
        msg.fault_flags = int(self._machine.fault_flags)
        msg.last_outcome = int(self._machine.last_outcome)
        if out is not None:
            msg.controller = int(out.controller)
            msg.target_force = float(out.target_force) if math.isfinite(out.target_force) \
                else 0.0
            msg.estimated_force = float(out.estimated_force) \
                if math.isfinite(out.estimated_force) else 0.0
            msg.force_valid = bool(out.force_valid)
            msg.servo_command = float(out.servo.position) if out.servo is not None else math.nan
            msg.tightening = float(out.tightening)
            msg.lift_height = float(out.lift_height)
            msg.slip_events = int(out.slip_events)
            msg.message = out.message
        else:
            msg.servo_command = math.nan
            msg.message = 'idle'
        return msg

    def _publish_state(self, force: bool = False) -> None:
        msg = self._state_msg()
        key = (msg.state, msg.fault_flags, msg.last_outcome, msg.message, msg.slip_events)
        if force or key != self._last_state_published:
            self._state_pub.publish(msg)
            self._last_state_published = key

    def _publish_state_timer(self) -> None:
        with self._lock:
            self._publish_state(force=True)

    # -- diagnostics -----------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        with self._lock:
            now = self._now()
            state = self._machine.state
            flags = self._machine.fault_flags
            status = DiagnosticStatus()
            status.name = f'{self.get_name()}: grasp controller'
            status.hardware_id = 'forte'
            if state == GraspState.FAULT:
                status.level = DiagnosticStatus.ERROR
            elif self._dry_run:
                status.level = DiagnosticStatus.WARN
            else:
                status.level = DiagnosticStatus.OK
            status.message = f'{state.name}' + (' (dry run)' if self._dry_run else '') + \
                (f': {self._last_outputs.message}' if self._last_outputs is not None else '')
            ages = {
                'perception_age_s': now - self._perception.stamp
                if self._perception is not None else math.nan,
                'joint_state_age_s': now - self._joint.stamp
                if self._joint is not None else math.nan,
            }
            latencies = sorted(self.slip_reaction_latency)
            values = {
                'state': state.name, 'fault_flags': str(int(flags)),
                'last_outcome': self._machine.last_outcome.name,
                **{k: f'{v:.4f}' for k, v in ages.items()},
                **{k: str(v) for k, v in self.counters.items()},
                'slip_reaction_latency_p50_ms': f'{latencies[len(latencies) // 2] * 1e3:.3f}'
                if latencies else 'n/a',
                'slip_reaction_latency_max_ms': f'{latencies[-1] * 1e3:.3f}'
                if latencies else 'n/a',
            }
            status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
            array = DiagnosticArray()
            array.header.stamp = self.get_clock().now().to_msg()
            array.status = [status]
        self._diagnostics_pub.publish(array)

    # -- reset service -------------------------------------------------------------------
    def _on_reset_fault(self, request, response):
        with self._lock:
            ok, message, cleared = self._machine.reset_fault(self._now())
            response.success = bool(ok)
            response.message = message
            response.cleared_flags = int(cleared)
            self._last_outputs = self._machine.step(self._inputs(), self._now())
            self._publish_state(force=True)
        return response

    # -- Grasp action --------------------------------------------------------------------
    @staticmethod
    def goal_from_msg(request) -> GraspGoal:
        """forte_msgs Grasp goal -> :class:`GraspGoal`."""
        return GraspGoal(
            controller=request.controller, initial_force=request.initial_force,
            lift_speed=request.lift_speed, lift_distance=request.lift_distance,
            slip_increment=request.slip_increment, max_tightening=request.max_tightening,
            max_force=request.max_force, timeout=request.timeout,
            release_after=request.release_after)

    def _on_goal(self, request) -> GoalResponse:
        with self._lock:
            if self._active_goal is not None or self._machine.state in ACTIVE_STATES:
                self.get_logger().warning('goal rejected: a grasp is in progress')
                return GoalResponse.REJECT
            if self._machine.state == GraspState.FAULT:
                self.get_logger().warning('goal rejected: fault latched, call grasp/reset_fault')
                return GoalResponse.REJECT
            params, reason = self._machine.effective_params(self.goal_from_msg(request))
            if params is None:
                self.get_logger().warning(f'goal rejected: {reason}')
                return GoalResponse.REJECT
            return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle) -> CancelResponse:
        with self._lock:
            if goal_handle is self._active_goal:
                outputs = self._machine.cancel(self._now())
                self._apply(outputs)
                self._publish_arm(0.0)
        return CancelResponse.ACCEPT

    def prepare_shutdown(self, timeout: float = 3.0) -> None:
        """Stop a running grasp (arm stopped, grip held) and end its goal (node runner).

        Called while the context is still valid, before the node is destroyed: the execute
        callback aborts its goal and returns, so no executor thread outlives the node.
        """
        self._stopping.set()
        with self._lock:
            if self._active_goal is not None:
                self._apply(self._machine.cancel(self._now()))
                self._publish_arm(0.0)
            self._done_event.set()
        if not self._execute_idle.wait(timeout):
            self.get_logger().warning(f'grasp goal still running after {timeout} s')

    def _execute(self, goal_handle):
        self._execute_idle.clear()
        try:
            return self._execute_goal(goal_handle)
        finally:
            self._execute_idle.set()

    def _execute_goal(self, goal_handle):
        goal = self.goal_from_msg(goal_handle.request)
        with self._lock:
            self._done_event.clear()
            ok, reason = self._machine.start(goal, self._now(), self._inputs())
            if ok:
                self._active_goal = goal_handle
                self._goal_start = time.monotonic()
                self._apply(self._machine.step(self._inputs(), self._now()))
        if not ok:
            self.get_logger().warning(f'grasp refused: {reason}')
            goal_handle.abort()
            return self._result(Outcome.FAULT, f'refused: {reason}', 0.0)
        self.get_logger().info(f'grasp started ({Controller(goal.controller).name})')
        feedback = Grasp.Feedback()
        while not self._done_event.wait(self._feedback_period):
            if self._stopping.is_set() or not self.context.ok():
                break
            with self._lock:
                out = self._last_outputs
                perception = self._perception
            if out is None:
                continue
            feedback.state = int(out.state)
            feedback.estimated_force = float(out.estimated_force) \
                if math.isfinite(out.estimated_force) else 0.0
            feedback.slip = bool(perception.slip) if perception is not None else False
            if perception is not None:
                feedback.finger_variance = [float(v) for v in perception.finger_variance]
            feedback.servo_command = float(out.servo.position) if out.servo is not None \
                else math.nan
            feedback.lift_height = float(out.lift_height)
            feedback.slip_events = int(out.slip_events)
            goal_handle.publish_feedback(feedback)
        with self._lock:
            out = self._last_outputs
            self._active_goal = None
            duration = time.monotonic() - self._goal_start
        outcome = Outcome(int(out.outcome)) if out is not None else Outcome.FAULT
        if outcome == Outcome.CANCELED and not self._stopping.is_set():
            # the server marks the goal CANCELING right after _on_cancel returns
            deadline = time.monotonic() + 2.0
            while not goal_handle.is_cancel_requested and time.monotonic() < deadline:
                time.sleep(0.002)
        if outcome == Outcome.CANCELED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif outcome == Outcome.LIFTED:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        self.get_logger().info(f'grasp finished: {outcome.name}: {out.message}')
        return self._result(outcome, out.message, duration, out)

    @staticmethod
    def _result(outcome: Outcome, message: str, duration: float,
                out: ControlOutputs | None = None):
        result = Grasp.Result()
        result.outcome = int(outcome)
        result.message = message
        result.duration = float(duration)
        if out is not None:
            result.final_force = float(out.estimated_force) \
                if math.isfinite(out.estimated_force) else 0.0
            result.lift_height = float(out.lift_height)
            result.slip_events = int(out.slip_events)
            result.tightening = float(out.tightening)
        return result

    # -- control_msgs/GripperCommand (MoveIt), only where installed ----------------------
    def _on_gripper_goal(self, request) -> GoalResponse:  # pragma: no cover
        with self._lock:
            if self._machine.state in ACTIVE_STATES or self._machine.state == GraspState.FAULT:
                return GoalResponse.REJECT
            position = float(request.command.position)
            params = self._machine.params
            if not math.isfinite(position) or not params.min_angle <= position <= math.pi:
                return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute_gripper(self, goal_handle):  # pragma: no cover
        """Move the servo to ``command.position`` [rad]; ``max_effort`` [A] caps the current."""
        params = self._machine.params
        position = float(goal_handle.request.command.position)
        effort = float(goal_handle.request.command.max_effort)
        current = min(effort, params.max_current) if effort > 0.0 else params.max_current
        if not self._dry_run:
            msg = ServoCommand()
            msg.header.stamp = self.get_clock().now().to_msg()
            msg.position = position
            msg.max_current = current
            msg.profile_velocity = params.release_speed
            self._servo_pub.publish(msg)
        deadline = time.monotonic() + params.release_timeout
        result = GripperCommand.Result()
        last = math.nan
        stalled = False
        while time.monotonic() < deadline:
            with self._lock:
                joint = self._joint
            if joint is not None:
                if abs(joint.theta - position) <= params.release_tolerance:
                    break
                stalled = abs(joint.theta - last) < 1e-4
                last = joint.theta
            time.sleep(0.05)
        result.position = float(last) if math.isfinite(last) else position
        result.reached_goal = math.isfinite(last) and abs(last - position) \
            <= params.release_tolerance
        result.stalled = bool(stalled and not result.reached_goal)
        goal_handle.succeed()
        return result


def main(args: list[str] | None = None) -> int:
    """Run the grasp controller node in a multi-threaded executor until SIGINT/SIGTERM."""
    return run_node(GraspControllerNode, args, executor_factory=lambda context:
                    MultiThreadedExecutor(num_threads=3, context=context))


if __name__ == '__main__':
    raise SystemExit(main())
