"""Lifecycle node driving the two XM430-W350 finger servos of the FORTE gripper.

Thin ROS shell over :mod:`forte_driver.dynamixel.gripper` (which holds all the protocol
and unit logic):

* configure: open the port, ping both servos, write Operating Mode 5 (current-based
  position) and the limits into each servo's EEPROM, read them back and verify;
* activate: command each finger to hold where it is, then switch torque on; start
  publishing ``joint_states`` at ``publish_rate``;
* ``gripper/command`` (forte_msgs/ServoCommand): validated (non-finite or negative values
  refused, out-of-range values clipped, each with a logged reason), then sent to both
  servos in ONE sync write packet;
* ``gripper/joint_commands`` (sensor_msgs/JointState, while active): the command bridge of
  ros2_control's ``topic_based_ros2_control/TopicBasedSystem`` (position of the finger
  joint(s) [rad], optional velocity [rad/s] and effort [N m]), through the same check and
  one sync write; refused while the grasp controller owns the servos (``grasp/state``: a
  Grasp runs or its fault is latched) and ignored when it repeats the last command seen
  (:mod:`forte_driver.joint_command_bridge`, :mod:`forte_driver.ros.joint_command_bridge`);
* ``joint_states``: position theta [rad], velocity [rad/s] and effort = joint torque [N m]
  (servo current x the torque constant of ``forte_ros.contract``), all along theta;
* ``/diagnostics``: Hardware Error Status, temperature, input voltage, torque and the
  command/communication counters of each servo, at ``diagnostics_rate`` while configured;
* status error byte: a state reply with an error number is not state: that sample is
  skipped (nothing published, the previous one not repeated), counted per servo and kind,
  and reported as an ERROR; a latched hardware error (alert bit) is reported with the
  decoded Hardware Error Status, and commands are refused while it keeps a torque off;
* deactivate / shutdown: the servos keep holding the grip (torque stays on) unless
  ``release_on_shutdown`` is true: a dropped object is not a safe default.

Hardware parameters can be changed only while unconfigured (cleanup, set, configure).
Set ``autostart:=true`` to configure and activate at start without a lifecycle manager.
"""
from __future__ import annotations

import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from sensor_msgs.msg import JointState

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel.gripper import (
    DynamixelError,
    FingerConfig,
    FingerState,
    Gripper,
    GripperConfig,
    StatusError,
)
from forte_driver.ros.gripper_driver_parameters import (
    HARDWARE_PARAMETERS,
    PARAMETERS,
    gripper_config,
)
from forte_driver.ros.joint_command_bridge import JointCommandBridgeMixin
from forte_msgs.msg import ServoCommand
from forte_ros import ForteLifecycleNode, run_node
from forte_ros.diagnostics import ERROR, OK, WARN, diagnostic_array, diagnostic_status, node_path
from forte_ros.parameters import declare_table, read_table
from forte_ros.qos import COMMANDS, DIAGNOSTICS

TEMPERATURE_WARNING_MARGIN_C = 5.0
"""Diagnostics warn when a servo is this close to its Temperature Limit [degC]."""
READ_FAILURES_FOR_ERROR = 3
"""Consecutive failed state reads after which diagnostics report an error."""

class GripperDriverNode(JointCommandBridgeMixin, ForteLifecycleNode):
    """The FORTE gripper driver (lifecycle node ``gripper_driver``)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('gripper_driver', **kwargs)
        declare_table(self, PARAMETERS, GripperConfig())
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.gripper: Gripper | None = None
        self._configured = False
        self._active = False
        self._command_subscription = None
        self._joint_publisher = None
        self._diagnostics_publisher = self.create_publisher(
            DiagnosticArray, '/diagnostics', DIAGNOSTICS)
        self._state_timer = None
        self._diagnostics_timer = None
        self._last_state: dict[str, FingerState] | None = None
        self._last_state_time = 0.0
        self._last_stamp = self.get_clock().now()
        self._hardware_errors: dict[int, int] = {}
        self._hardware_error_read_failures: dict[int, str] = {}
        self._torque: dict[int, bool] = {}
        self._reported_error_replies: dict[int, int] = {}
        self.counters = {
            'commands_sent': 0, 'commands_clipped': 0, 'commands_refused': 0,
            'commands_refused_hardware_error': 0, 'commands_ignored_inactive': 0,
            'state_reads': 0, 'state_read_failures': 0, 'state_samples_skipped_status_error': 0,
            'consecutive_read_failures': 0, 'write_failures': 0, 'joint_states_published': 0,
        }
        self._last_error = ''
        self._init_bridge()
        if self.get_parameter('autostart').value:
            if self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
                self.trigger_activate()

    # -- parameters ------------------------------------------------------------------
    def _config_from(self, overrides: dict[str, Any] | None = None) -> GripperConfig:
        values = read_table(self, PARAMETERS)
        values.update(overrides or {})
        return gripper_config(values)

    def _on_set_parameters(self, parameters: list) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        hardware = sorted(set(changed) & set(HARDWARE_PARAMETERS))
        if hardware and self._configured:
            return SetParametersResult(
                successful=False,
                reason=f'{hardware} can change only while unconfigured (cleanup first)')
        try:
            self._config_from(changed).validate()
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(error))
        if self.gripper is not None and (
                'default_current' in changed or 'default_profile_velocity' in changed):
            self.gripper.config = self._config_from(changed)
        if 'grasp_state_timeout' in changed and hasattr(self, '_bridge_gate'):
            self._bridge_gate.grasp_state_timeout = float(changed['grasp_state_timeout'])
        return SetParametersResult(successful=True)

    # -- lifecycle -------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        config = self._config_from()
        gripper = Gripper(config)
        try:
            gripper.open()
            models = gripper.ping()
            report = gripper.configure()
        except DynamixelError as error:
            gripper.close()
            self.get_logger().error(f'configure failed: {error}')
            self._last_error = str(error)
            return TransitionCallbackReturn.FAILURE
        self.gripper = gripper
        self.get_logger().info(
            f'{config.port} at {config.baud_rate} bit/s: servos {sorted(models)} are '
            f'XM430-W350; EEPROM items written: {report.written}; read back: '
            f'{report.read_back}')
        if report.torque_was_disabled:
            self.get_logger().warn(
                f'torque of servo(s) {report.torque_was_disabled} had to be switched off to '
                'write EEPROM limits that differed from the configuration (any grip was '
                'released)')
        limits = gripper.limits
        self.get_logger().info(
            f'limits in force (from the servos\' registers): theta {limits.theta_min:.4f}..'
            f'{limits.theta_max:.4f} rad, current {limits.current_limit:.3f} A, velocity '
            f'{limits.velocity_limit:.3f} rad/s, temperature {limits.temperature_limit} degC')
        self._joint_publisher = self.create_lifecycle_publisher(
            JointState, 'joint_states', COMMANDS)
        self._command_subscription = self.create_subscription(
            ServoCommand, 'gripper/command', self._on_command, COMMANDS)
        self._subscribe_grasp_state()
        self._diagnostics_timer = self.create_timer(
            1.0 / self.get_parameter('diagnostics_rate').value, self._publish_diagnostics)
        self._configured = True
        return super().on_configure(state)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            held = self.gripper.hold_present_position()
            self.gripper.set_torque(True)
        except DynamixelError as error:
            self.get_logger().error(f'activate failed: {error}')
            self._last_error = str(error)
            return TransitionCallbackReturn.FAILURE
        self.get_logger().info(f'torque on, holding theta = {held.theta:.4f} rad')
        self._state_timer = self.create_timer(
            1.0 / self.get_parameter('publish_rate').value, self._publish_state)
        self._active = True
        self._start_bridge()
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._stop_publishing_state()
        self._stop_or_hold('deactivate', close=False)
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._close_port()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._stop_publishing_state()
        self._release_ros_entities()
        self.stop_hardware('shutdown')
        self.get_logger().info(f'shut down from {state.label}: port closed')
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.get_logger().error(f'error in transition from {state.label}; closing the port '
                                '(torque left as it is)')
        self._active = False
        self._close_port()
        return TransitionCallbackReturn.SUCCESS

    def _stop_publishing_state(self) -> None:
        """Inactive: no more joint_states (the state timer is destroyed), no bridge."""
        self._active = False
        self._stop_bridge()
        if self._state_timer is not None:
            self.destroy_timer(self._state_timer)
            self._state_timer = None

    def _close_port(self) -> None:
        """Unconfigured: release the ROS entities and close the port (torque left as is)."""
        self._release_ros_entities()
        if self.gripper is not None:
            self.gripper.close()
            self.gripper = None
        self._configured = False

    def _release_ros_entities(self) -> None:
        self._stop_bridge(grasp_state=True)
        if self._diagnostics_timer is not None:
            self.destroy_timer(self._diagnostics_timer)
            self._diagnostics_timer = None
        if self._command_subscription is not None:
            self.destroy_subscription(self._command_subscription)
            self._command_subscription = None
        if self._joint_publisher is not None:
            self.destroy_lifecycle_publisher(self._joint_publisher)
            self._joint_publisher = None

    def _stop_or_hold(self, why: str, close: bool) -> None:
        if self.gripper is None:
            return
        release = bool(self.get_parameter('release_on_shutdown').value)
        try:
            if close:
                self.gripper.shutdown(release=release)
                self.gripper = None
                self._configured = False
            elif release:
                self.gripper.set_torque(False)
        except DynamixelError as error:
            self.get_logger().error(f'{why}: {error}')
        if release:
            self.get_logger().warn(f'{why}: torque OFF (release_on_shutdown is true)')
        else:
            self.get_logger().info(f'{why}: servos keep holding the grip (torque stays on; '
                                   'set release_on_shutdown:=true to release)')

    def stop_hardware(self, why: str = 'shutdown') -> None:
        """Hold (or release, per ``release_on_shutdown``) and close the port.

        Safe to call without a running rclpy context (used by ``main`` after Ctrl-C).
        """
        self._stop_or_hold(why, close=True)

    # -- callbacks -------------------------------------------------------------------
    def _on_command(self, message: ServoCommand) -> None:
        if not self._active or self.gripper is None:
            self.counters['commands_ignored_inactive'] += 1
            self.get_logger().warn('gripper/command ignored: driver is not active',
                                   throttle_duration_sec=1.0)
            return
        try:
            check = self.gripper.command(message.position, message.max_current,
                                         message.profile_velocity)
        except DynamixelError as error:
            self.counters['write_failures'] += 1
            self._last_error = str(error)
            self.get_logger().error(f'gripper/command not sent: {error}')
            return
        if check.hardware_error:
            self.counters['commands_refused_hardware_error'] += 1
            self.get_logger().error(f'gripper/command not sent: {"; ".join(check.reasons)}',
                                    throttle_duration_sec=1.0)
            return
        if not check.accepted:
            self.counters['commands_refused'] += 1
            self.get_logger().warn(f'gripper/command refused: {"; ".join(check.reasons)}')
            return
        self.counters['commands_sent'] += 1
        if check.clipped:
            self.counters['commands_clipped'] += 1
            self.get_logger().warn(f'gripper/command clipped: {"; ".join(check.reasons)}')

    def _count_failed_read(self, counter: str, error: DynamixelError) -> None:
        """Count a state read that gave no state (in ``counter`` and the consecutive
        failures) and keep its error for the diagnostics."""
        self.counters[counter] += 1
        self.counters['consecutive_read_failures'] += 1
        self._last_error = str(error)

    def _read_state(self) -> dict[str, FingerState] | None:
        start = time.monotonic()
        stamp_start = self.get_clock().now()
        try:
            state = self.gripper.read_state()
        except StatusError as error:
            # The servo flagged its reply: not state. Skip this sample, repeat nothing.
            self._count_failed_read('state_samples_skipped_status_error', error)
            self.get_logger().error(f'state sample skipped (no joint_states): {error}',
                                    throttle_duration_sec=1.0)
            return None
        except DynamixelError as error:
            self._count_failed_read('state_read_failures', error)
            self.get_logger().warn(f'state not read (no joint_states sample): {error}',
                                   throttle_duration_sec=1.0)
            return None
        elapsed = time.monotonic() - start
        self.counters['state_reads'] += 1
        self.counters['consecutive_read_failures'] = 0
        self._last_state = state
        self._last_state_time = time.monotonic()
        # Stamp: middle of the transaction (the servos sampled while answering).
        self._last_stamp = stamp_start + Duration(seconds=elapsed / 2.0)
        return state

    def _publish_state(self) -> None:
        if self.gripper is None or self._joint_publisher is None:
            return
        state = self._read_state()
        if state is None:
            return
        message = JointState()
        message.header.stamp = self._last_stamp.to_msg()
        message.name = [finger.joint_name for finger in self.gripper.config.fingers]
        left, right = state['left'], state['right']
        message.position = [left.theta, right.theta]
        message.velocity = [left.velocity, right.velocity]
        message.effort = [left.effort, right.effort]
        self._joint_publisher.publish(message)
        self.counters['joint_states_published'] += 1

    def _publish_diagnostics(self) -> None:
        if self.gripper is None:
            return
        if time.monotonic() - self._last_state_time > 1.0:
            self._read_state()  # inactive: no state timer, keep temperature fresh
        previous = self._hardware_errors
        self._read_hardware_errors()
        self._torque = {}
        for servo_id in self._hardware_errors:
            try:
                self._torque[servo_id] = self.gripper.read_torque(servo_id)
            except DynamixelError as error:
                self._last_error = str(error)
        for servo_id, bits in self._hardware_errors.items():
            if bits and bits != previous.get(servo_id):
                self.get_logger().error(
                    f'servo {servo_id}: hardware error {ct.hardware_error_text(bits)} '
                    f'(0x{bits:02x}); torque '
                    f'{"on" if self._torque.get(servo_id) else "OFF (shutdown; reboot needed)"}')
        statuses = [self._servo_status(finger) for finger in self.gripper.config.fingers]
        statuses.append(self._driver_status())
        self._diagnostics_publisher.publish(
            diagnostic_array(self.get_clock().now().to_msg(), statuses))

    def _read_hardware_errors(self) -> None:
        """Hardware Error Status of both servos; if the sync read fails, ask each servo on
        its own, to tell which one is silent or refuses (and keep the other's status)."""
        self._hardware_error_read_failures = {}
        try:
            self._hardware_errors = self.gripper.read_hardware_errors()
            return
        except DynamixelError as error:
            self._last_error = str(error)
        self._hardware_errors = {}
        for finger in self.gripper.config.fingers:
            try:
                self._hardware_errors[finger.servo_id] = self.gripper.read_register(
                    finger.servo_id, ct.HARDWARE_ERROR_STATUS)
            except StatusError as servo_error:
                self._last_error = str(servo_error)
                self._hardware_error_read_failures[finger.servo_id] = (
                    f'Hardware Error Status read refused: {servo_error}')
            except DynamixelError as servo_error:
                self._last_error = str(servo_error)
                self._hardware_error_read_failures[finger.servo_id] = (
                    'no answer to Hardware Error Status read')

    def _hardware_problems(self, servo_id: int) -> tuple[int, list[str]]:
        """(level, problems) from Hardware Error Status, the alert bit and the status
        error numbers of one servo since the previous report."""
        level, problems = OK, []
        errors = self._hardware_errors.get(servo_id)
        alert = self.gripper.alerts.get(servo_id)
        if errors is None:
            level = ERROR
            problems.append(self._hardware_error_read_failures.get(
                servo_id, 'no answer to Hardware Error Status read'))
        elif errors and self._torque.get(servo_id) is True:
            level = WARN
            problems.append(f'hardware error: {ct.hardware_error_text(errors)} (not in the '
                            'Shutdown mask: torque stays on)')
        elif errors:
            level = ERROR
            problems.append(f'hardware error: {ct.hardware_error_text(errors)}')
            problems.append('torque off by shutdown, commands refused (remove the cause, '
                            'reboot the servo, then configure and activate)')
        elif alert is not None:
            level = WARN
            problems.append(f'alert bit in status packets: {alert.text}')
        replies = self.gripper.status_errors.error_replies(servo_id)
        new = replies - self._reported_error_replies.get(servo_id, 0)
        self._reported_error_replies[servo_id] = replies
        if new:
            level = ERROR
            problems.append(f'{new} status replies with an error number since the last '
                            f'report, not used as state (last: '
                            f'{self.gripper.status_errors.last_error.get(servo_id)})')
        return level, problems

    def _servo_status(self, finger: FingerConfig) -> DiagnosticStatus:
        errors = self._hardware_errors.get(finger.servo_id)
        fresh = (self._last_state is not None
                 and time.monotonic() - self._last_state_time < 3.0)
        state = self._last_state[finger.name] if fresh else None
        limit = self.gripper.limits.temperature_limit
        level, problems = self._hardware_problems(finger.servo_id)
        if state is None:
            level = ERROR
            problems.append('no recent state read')
        elif state.temperature >= limit - TEMPERATURE_WARNING_MARGIN_C:
            level = max(level, WARN)
            problems.append(f'temperature {state.temperature:.0f} degC near limit {limit}')
        counts = self.gripper.status_errors.of(finger.servo_id)
        values = {
            'hardware_error_status': 'unknown' if errors is None else f'0x{errors:02x}',
            'hardware_errors': 'unknown' if errors is None else ct.hardware_error_text(errors),
            'alert_bit': str(finger.servo_id in self.gripper.alerts),
            'torque_enabled': str(self._torque.get(finger.servo_id, 'unknown')),
            'temperature_limit_C': str(limit),
            'status_error_replies': str(self.gripper.status_errors.error_replies(
                finger.servo_id)),
        }
        values.update({f'status_errors.{kind}': str(count) for kind, count in counts.items()})
        if state is not None:
            values.update({
                'temperature_C': f'{state.temperature:.0f}',
                'input_voltage_V': f'{state.input_voltage:.1f}',
                'theta_rad': f'{state.theta:.5f}',
                'current_A': f'{state.current:.4f}',
                'effort_Nm': f'{state.effort:.4f}',
            })
        return diagnostic_status(
            f'{node_path(self)}: {finger.name} finger servo (id {finger.servo_id})', level,
            '; '.join(problems) if problems else 'ok', values,
            hardware_id=f'dynamixel xm430-w350 id {finger.servo_id} on '
                        f'{self.gripper.config.port}')

    def _driver_status(self) -> DiagnosticStatus:
        failing = self.counters['consecutive_read_failures'] >= READ_FAILURES_FOR_ERROR
        message = (f'state reads failing: {self._last_error}' if failing
                   else ('active' if self._active else 'inactive (holding)'))
        values = {name: str(value) for name, value in self.counters.items()}
        values['retried_transactions'] = str(self.gripper.retried_transactions)
        values['alert_read_failures'] = str(self.gripper.alert_read_failures)
        values['last_error'] = self._last_error or 'none'
        values['release_on_shutdown'] = str(self.get_parameter('release_on_shutdown').value)
        values.update(self._bridge_values())
        return diagnostic_status(f'{node_path(self)}: driver', ERROR if failing else OK,
                                 message, values,
                                 hardware_id=f'dynamixel bus {self.gripper.config.port}')


def main(args: list[str] | None = None) -> int:
    """Run the gripper driver until SIGINT/SIGTERM; the shutdown transition then holds (or,
    with ``release_on_shutdown``, releases) the grip and closes the port."""
    return run_node(GripperDriverNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
