"""``forte_commission``: sensor commissioning of a FORTE gripper over ROS (issue 24).

Run it beside the hardware graph (``hardware.launch.py``: the serial sensor driver and the
gripper driver active), with the rig's indentor standing between the open fingers::

    ros2 run forte_commissioning forte_commission --output commissioning/
    ros2 launch forte_commissioning commission.launch.py sensor_port:=/dev/forte_sensor \\
        gripper_port:=/dev/forte_gripper

It records ``tactile/frames`` (sensor-data QoS) and follows the protocol of
:func:`forte_commissioning.simulated_commissioning.protocol`: rest, then one press per finger at the
tip and at the root (the operator is prompted on the terminal; with ``--headless`` the
bench twin's scripted operator presses, asked on ``sim/operator_press``), then a squeeze
held on the indentor for the leak test (forte_msgs/ServoCommand on ``gripper/command``,
the controller's path to the gripper driver: goal 0 rad under a current limit), then it
opens the gripper to where it was. It writes ``report.txt`` (PASS / FAIL per check, what
to fix), ``report.png`` and ``recording.npz`` into the output folder. The serial driver's
latest ``/diagnostics`` status (of this node's namespace) goes into the report's header.

Every topic but ``/diagnostics`` is relative, so the node follows its namespace: beside a
hardware graph started with ``namespace:=right prefix:=right_`` run it as
``ros2 run forte_commissioning forte_commission --ros-args -r __ns:=/right -p prefix:=right_``
(``commission.launch.py namespace:=right prefix:=right_`` does both). Its read-only
``prefix`` parameter is the TF / joint-name prefix of that gripper: the open position is the
mean of the joints ``<prefix>forte_left_finger_joint`` and ``<prefix>forte_right_finger_joint``
(forte_ros.contract).

Exit code: 0 when every check passed, 1 when one failed, 2 when no readings arrived.
The node waits for readings and a joint state; it never blocks a callback (a 20 Hz timer
drives the schedule). It joins the ROS domain of its environment.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from datetime import datetime
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from forte_commissioning.live_commissioning import (
    Action,
    CommissioningSchedule,
    FrameRecorder,
    mean_joint_position,
    phases_from_boundaries,
    write_outputs,
)
from forte_commissioning.simulated_commissioning import SQUEEZE_CURRENT, ProtocolStep, protocol
from forte_msgs.msg import ServoCommand, TactileFrames
from forte_ros.contract import FINGER_NAMES, check_prefix, joint_names
from forte_ros.qos import COMMANDS, DIAGNOSTICS, SENSOR_FRAMES

__all__ = ['CommissionNode', 'main']

#: Schedule timer period [s].
TICK = 0.05
#: Readings needed before the protocol starts (0.5 s at 2 kHz) [rows].
WARM_UP_ROWS = 1000
_LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}


class CommissionNode(Node):
    """Records the readings, runs the schedule, commands the gripper (module docstring).

    Parameters
    ----------
    steps : list of ProtocolStep
    headless : bool
        The bench twin presses (True) or the operator is prompted (False).
    press_force : float
        Force of the bench twin's presses [N].
    squeeze_current : float
        Servo current limit of the squeeze [A].
    **kwargs
        Passed to :class:`rclpy.node.Node` (e.g. ``parameter_overrides`` with ``prefix``).

    Raises
    ------
    ValueError
        If the ``prefix`` parameter is not a valid TF / joint-name prefix.
    """

    def __init__(self, steps: list[ProtocolStep], headless: bool, press_force: float = 4.0,
                 squeeze_current: float = SQUEEZE_CURRENT, **kwargs) -> None:
        super().__init__('forte_commission', **kwargs)
        self.steps = steps
        self.headless = headless
        self.press_force = press_force
        self.squeeze_current = squeeze_current
        self.recorder = FrameRecorder()
        self.schedule = CommissioningSchedule(steps, headless)
        self.boundaries: list[int] = []
        self.open_position = math.nan
        self.driver_status = 'no diagnostics seen'
        self.done = False
        prefix = self.declare_parameter('prefix', '', ParameterDescriptor(
            description='TF / joint-name prefix of the gripper (its joint_states names), '
                        'e.g. right_', read_only=True)).value
        #: The finger joints whose mean position is the open position (with the prefix).
        self.joints = joint_names(check_prefix(str(prefix)))
        self.create_subscription(TactileFrames, 'tactile/frames', self._on_frames,
                                 SENSOR_FRAMES)
        self.create_subscription(JointState, 'joint_states', self._on_joints, COMMANDS)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                 DIAGNOSTICS)
        self._command = self.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        self._press = self.create_publisher(String, 'sim/operator_press', COMMANDS)
        self.create_timer(TICK, self._tick)

    def _on_frames(self, message: TactileFrames) -> None:
        self.recorder.add(np.asarray(message.data), message.first_sequence,
                          message.device_time_us, message.dropped_frames,
                          message.corrupt_frames, time.monotonic())

    def _on_joints(self, message: JointState) -> None:
        if math.isnan(self.open_position):
            self.open_position = mean_joint_position(list(message.name),
                                                     list(message.position),
                                                     self.joints)

    def _on_diagnostics(self, message: DiagnosticArray) -> None:
        for status in message.status:
            if not self._own_serial_status(status.name):
                continue
            level = status.level
            level = level[0] if isinstance(level, bytes) else int(level)
            values = ', '.join(f'{item.key}={item.value}' for item in status.values
                               if 'frames' in item.key or 'rate' in item.key)
            self.driver_status = (f'{status.name}: {_LEVELS.get(level, level)} '
                                  f'{status.message} {values}').strip()

    def _own_serial_status(self, name: str) -> bool:
        """Whether a ``/diagnostics`` status is the serial driver's of this namespace.

        ``/diagnostics`` is shared by every gripper on the domain; a status names its node
        with the namespace (``right/serial_sensor: tactile sensor``, in the root namespace
        ``serial_sensor: ...``), so only a node path of this node's namespace counts.
        """
        namespace = self.get_namespace().strip('/')
        path = name.split(':', 1)[0]
        if namespace:
            if not path.startswith(namespace + '/'):
                return False
            path = path[len(namespace) + 1:]
        return '/' not in path and 'serial' in path

    def _tick(self) -> None:
        if self.done:
            return
        now = time.monotonic()
        if not self.schedule.started:
            if self.recorder.received < WARM_UP_ROWS or math.isnan(self.open_position):
                return
            self.get_logger().info('readings and joint states arrive: commissioning starts')
            self.schedule.start(now)
        for action in self.schedule.advance(now):
            self._do(action)

    def _do(self, action: Action) -> None:
        if action.kind == 'phase':
            self.boundaries.append(self.recorder.next_sequence)
            self.get_logger().info(f'phase {action.step.name}')
        elif action.kind == 'prompt':
            print(f'>>> {action.text}', flush=True)
        elif action.kind == 'press':
            step = action.step
            hold = max(step.duration - 1.0, 0.2)
            self._press.publish(String(data=f'{FINGER_NAMES[step.finger]} {step.place} '
                                            f'{self.press_force:g} {hold:g}'))
        elif action.kind == 'squeeze':
            self._servo(0.0, self.squeeze_current)
        elif action.kind == 'open':
            self._servo(self.open_position, 0.0)
        elif action.kind == 'done':
            self.done = True

    def _servo(self, position: float, current: float) -> None:
        message = ServoCommand(position=float(position), max_current=float(current),
                               profile_velocity=0.0)
        message.header.stamp = self.get_clock().now().to_msg()
        self._command.publish(message)

    def finish(self, folder: Path) -> tuple[bool, str]:
        """Judge the recording and write the outputs; returns (passed, report)."""
        phases = phases_from_boundaries(self.steps[:len(self.boundaries)], self.boundaries,
                                        self.recorder.next_sequence)
        context = {'date': datetime.now().isoformat(timespec='seconds'),
                   'mode': 'headless (bench twin presses)' if self.headless
                   else 'operator presses', 'sensor driver': self.driver_status,
                   'output': str(folder)}
        result, report = write_outputs(self.recorder.recording(phases), folder, context)
        return result.passed and not result.findings, report


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog='forte_commission', description=(
        'Sensor commissioning of a FORTE gripper: rest, guided presses, leak test; writes '
        'report.txt, report.png and recording.npz.'))
    parser.add_argument('--output', '-o', type=Path, default=None,
                        help='output folder (default commissioning_<date-time>)')
    parser.add_argument('--headless', action='store_true',
                        help='the bench twin presses (sim/operator_press); no prompts')
    parser.add_argument('--yes', '-y', action='store_true',
                        help='start without waiting for Enter')
    parser.add_argument('--press-force', type=float, default=4.0,
                        help='force of the bench twin\'s presses [N] (--headless)')
    parser.add_argument('--squeeze-current', type=float, default=SQUEEZE_CURRENT,
                        help='servo current limit of the leak test\'s squeeze [A]')
    parser.add_argument('--squeeze-seconds', type=float, default=12.0,
                        help='hold of the leak test [s]')
    parser.add_argument('--press-seconds', type=float, default=None,
                        help='time given to each press [s] (default 1.5 headless, 3 with '
                             'an operator)')
    parser.add_argument('--timeout', type=float, default=60.0,
                        help='give up when no readings arrive for this long [s]')
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point ``forte_commission``."""
    arguments = _arguments(rclpy.utilities.remove_ros_args(
        sys.argv if argv is None else ['forte_commission', *argv])[1:])
    folder = arguments.output or Path(f'commissioning_{datetime.now():%Y%m%d_%H%M%S}')
    press = arguments.press_seconds or (1.5 if arguments.headless else 3.0)
    steps = protocol(gap=1.0 if arguments.headless else 3.0, press=press,
                     squeeze=arguments.squeeze_seconds)
    if not (arguments.headless or arguments.yes):
        input('Commissioning: open gripper, the indentor between the fingers, hands off. '
              'Enter to start. ')
    rclpy.init(args=sys.argv if argv is None else None)
    node = CommissionNode(steps, arguments.headless, arguments.press_force,
                          arguments.squeeze_current)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        if not _spin(node, executor, arguments.timeout):
            return 2
        passed, report = node.finish(folder)
        print(report, flush=True)
        return 0 if passed else 1
    finally:
        executor.remove_node(node)
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


def _spin(node: CommissionNode, executor: SingleThreadedExecutor, timeout: float) -> bool:
    """Spin until the protocol is over (or Ctrl-C: judge what was recorded); False when
    no readings or joint states came within ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    try:
        while rclpy.ok() and not node.done:
            executor.spin_once(timeout_sec=0.1)
            if not node.schedule.started and time.monotonic() > deadline:
                node.get_logger().fatal(f'no readings or joint states within {timeout:g} s: '
                                        'is the hardware graph (both drivers) active?')
                return False
    except (KeyboardInterrupt, ExternalShutdownException):
        node.get_logger().warning('interrupted: judging what was recorded')
    return True


if __name__ == '__main__':
    raise SystemExit(main())
