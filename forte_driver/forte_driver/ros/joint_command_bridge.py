"""The gripper driver's JointState command bridge (ros2_control's TopicBasedSystem), ROS side.

A mixin of :class:`forte_driver.ros.gripper_driver_node.GripperDriverNode`; the rules are
pure (:mod:`forte_driver.joint_command_bridge`), this module converts messages:

* ``grasp/state`` (forte_msgs/GraspState, reliable + transient local, depth 1), subscribed
  from configure: the grasp controller owns the servos while a Grasp runs or its fault is
  latched (:class:`~forte_driver.joint_command_bridge.BridgeGate`);
* ``gripper/joint_commands`` (sensor_msgs/JointState, reliable, depth 10), subscribed while
  active: a position [rad] of the finger joint(s), optional velocity [rad/s] and effort
  [N m]; sent to both servos in one sync write through the same check as ``gripper/command``
  (:meth:`forte_driver.dynamixel.gripper.Gripper.command`), or refused with the reason
  (logged, counted in ``/diagnostics``).
"""
from __future__ import annotations

import time
from typing import Any

from sensor_msgs.msg import JointState

from forte_driver.dynamixel.gripper import DynamixelError
from forte_driver.joint_command_bridge import (
    GRASP_STATE_NAMES,
    BridgeGate,
    Verdict,
    bridge_command,
)
from forte_msgs.msg import GraspState
from forte_ros.qos import COMMANDS, GRASP_STATE

__all__ = ['BRIDGE_COUNTERS', 'JOINT_COMMANDS_TOPIC', 'JointCommandBridgeMixin']

#: The bridge's command topic (relative, remappable): TopicBasedSystem's
#: ``joint_commands_topic``.
JOINT_COMMANDS_TOPIC = 'gripper/joint_commands'
#: Counters of the bridge in the driver's ``/diagnostics`` (driver status).
BRIDGE_COUNTERS = ('bridge_commands_sent', 'bridge_commands_repeated',
                   'bridge_commands_refused', 'bridge_commands_refused_grasp_running',
                   'bridge_commands_clipped', 'bridge_commands_ignored_inactive')


class JointCommandBridgeMixin:
    """``gripper/joint_commands`` and ``grasp/state`` of the gripper driver node."""

    counters: dict[str, int]
    gripper: Any
    _active: bool
    _last_error: str

    def _init_bridge(self) -> None:
        """Counters and the ownership gate (the subscriptions come with the lifecycle)."""
        self.counters.update({name: 0 for name in BRIDGE_COUNTERS})
        self._bridge_gate = BridgeGate(float(self.get_parameter('grasp_state_timeout').value))
        self._grasp_state_subscription = None
        self._bridge_subscription = None
        self._last_refusal = ''

    def _subscribe_grasp_state(self) -> None:
        """Configure: follow the grasp controller's state (its latched one arrives at once)."""
        if self._grasp_state_subscription is None:
            self._grasp_state_subscription = self.create_subscription(
                GraspState, 'grasp/state', self._on_grasp_state, GRASP_STATE)

    def _start_bridge(self) -> None:
        """Activate: take commands on ``gripper/joint_commands``."""
        if self._bridge_subscription is None:
            self._bridge_subscription = self.create_subscription(
                JointState, JOINT_COMMANDS_TOPIC, self._on_joint_commands, COMMANDS)

    def _stop_bridge(self, grasp_state: bool = False) -> None:
        """Deactivate (and with ``grasp_state`` cleanup / shutdown): stop the subscriptions."""
        if self._bridge_subscription is not None:
            self.destroy_subscription(self._bridge_subscription)
            self._bridge_subscription = None
        if grasp_state and self._grasp_state_subscription is not None:
            self.destroy_subscription(self._grasp_state_subscription)
            self._grasp_state_subscription = None

    def _on_grasp_state(self, message: GraspState) -> None:
        self._bridge_gate.on_grasp_state(message.state, time.monotonic())

    def _on_joint_commands(self, message: JointState) -> None:
        if not self._active or self.gripper is None:
            self.counters['bridge_commands_ignored_inactive'] += 1
            return
        limits = self.gripper.limits
        joints = [finger.joint_name for finger in self.gripper.config.fingers]
        command, reason = bridge_command(list(message.name), list(message.position),
                                         list(message.velocity), list(message.effort), joints,
                                         limits.theta_min, limits.theta_max)
        if command is None:
            self.counters['bridge_commands_refused'] += 1
            text = f'{JOINT_COMMANDS_TOPIC} refused: {reason}'
            if reason != self._last_refusal:  # a new reason at once, a repeated one throttled
                self._last_refusal = reason
                self.get_logger().warn(text)
            else:
                self.get_logger().warn(text, throttle_duration_sec=5.0)
            return
        verdict, warn = self._bridge_gate.judge(command, time.monotonic())
        if verdict is Verdict.REPEAT:
            self.counters['bridge_commands_repeated'] += 1
            return
        if verdict is Verdict.OWNED:
            self.counters['bridge_commands_refused_grasp_running'] += 1
            if warn:
                self.get_logger().warn(
                    f'{JOINT_COMMANDS_TOPIC} refused: {self._bridge_gate.owner(time.monotonic())}'
                    '; bridge commands are not queued: send a new command after the grasp '
                    '(the last one seen will not act)')
            return
        self._send_bridge_command(command)

    def _send_bridge_command(self, command: Any) -> None:
        """One sync write of ``command`` through the gripper's command check."""
        try:
            check = self.gripper.command(command.theta, command.max_current,
                                         command.profile_velocity)
        except DynamixelError as error:
            self.counters['write_failures'] += 1
            self._last_error = str(error)
            self.get_logger().error(f'{JOINT_COMMANDS_TOPIC} not sent: {error}')
            return
        if not check.accepted:
            self.counters['commands_refused_hardware_error' if check.hardware_error
                          else 'bridge_commands_refused'] += 1
            self.get_logger().error(f'{JOINT_COMMANDS_TOPIC} not sent: '
                                    f'{"; ".join(check.reasons)}', throttle_duration_sec=1.0)
            return
        self.counters['bridge_commands_sent'] += 1
        reasons = ([command.clipped] if command.clipped else []) + check.reasons
        if reasons:
            self.counters['bridge_commands_clipped'] += 1
            self.get_logger().warn(f'{JOINT_COMMANDS_TOPIC} clipped: {"; ".join(reasons)}',
                                   throttle_duration_sec=1.0)

    def _bridge_values(self) -> dict[str, str]:
        """The bridge's entries of the driver's diagnostic status."""
        gate = self._bridge_gate
        state = gate.grasp_state
        owner = gate.owner(time.monotonic())
        last = gate.last_seen
        return {
            'grasp_state': 'none received' if state is None
            else GRASP_STATE_NAMES.get(state, str(state)),
            'servo_owner': 'grasp controller' if owner else 'commands (gripper/command, '
                           f'{JOINT_COMMANDS_TOPIC})',
            'bridge_last_command_rad': 'none' if last is None else f'{last.theta:.4f}',
            'bridge_grasps_seen': str(gate.grasps),
        }
