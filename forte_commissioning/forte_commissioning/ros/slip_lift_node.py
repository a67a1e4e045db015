"""One lift of the slip characterisation protocol as a ROS node (the procedure on a graph).

The ROS side of :mod:`forte_commissioning.slip_characterization`: it publishes the
commands that the offline procedure gives the simulator scene, on the graph's topics, so the
same lift runs on the sim graph or on the robot:

- ``gripper/command`` (forte_msgs/ServoCommand, reliable): ``open_angle`` during the open
  phase, then ``grip_angle`` (profile velocity 0.5 rad/s);
- ``arm/cmd_vel`` (geometry_msgs/TwistStamped, reliable): ``linear.z = lift_velocity``
  (1 mm/s) during the lift, 0 otherwise;

both at ``command_rate`` (20 Hz, the paper's arm control) from a timer; the phase times come
from :meth:`~forte_commissioning.slip_characterization.Timing.command_at` on the node's
clock (``use_sim_time`` follows /clock). After the last phase the node publishes the grip
and a stopped arm once more and finishes (the process exits 0). Bags: run the graph with
``record:=true`` (forte_record records the commands, the tactile frames and, in simulation,
``sim/ground_truth`` with the slip onsets); the onsets of a robot's bag come from a label
file (:mod:`forte_perception.evaluation.onset_labels`).

theta_grasp search on a robot: run one lift per angle that
:class:`~forte_commissioning.slip_characterization.GraspSearch` proposes, judge
whether the object came up without slipping, record the answer, repeat (the object put back
between lifts). Then N trials at angles drawn in ``[theta_grasp, theta_zeroF)``.

Usage::

    ros2 run forte_commissioning forte_slip_lift --ros-args -p grip_angle:=0.535 \\
        -p open_angle:=0.64 -p use_sim_time:=true
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import TwistStamped
from rclpy.node import Node

from forte_commissioning.slip_characterization import PROFILE_VELOCITY, Timing
from forte_msgs.msg import ServoCommand
from forte_ros.parameter_table import ParameterSpec, parameter_table, replace_fields
from forte_ros.parameters import declare_table, read_table
from forte_ros.qos import COMMANDS

__all__ = ['PARAMETERS', 'SlipLiftNode', 'main']

#: Parameters of the node: the grip, the open pose, the command rate (node-only) and the
#: phases of :class:`Timing` (defaults there).
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('grip_angle', float, 'servo angle of the grip (0 = closed); required',
                  'rad', -1.0, 3.2, default=-1.0, read_only=True),
    ParameterSpec('open_angle', float, 'servo angle of the open phase (fingers clear of the '
                  'object)', 'rad', 0.0, 3.2, default=0.64, read_only=True),
    ParameterSpec('command_rate', float, 'commands per second on both topics', 'Hz', 1.0,
                  1000.0, default=20.0, read_only=True),
    ParameterSpec('frame_id', str, 'frame_id of the arm velocity commands',
                  default='forte_base_link', read_only=True),
    ParameterSpec('open_s', float, 'open and still before closing', 's', 0.0, 600.0,
                  field='open_s', read_only=True),
    ParameterSpec('hold_s', float, 'close and hold before lifting', 's', 0.0, 600.0,
                  field='hold_s', read_only=True),
    ParameterSpec('lift_s', float, 'lift duration', 's', 0.0, 600.0, field='lift_s',
                  read_only=True),
    ParameterSpec('rest_s', float, 'arm stopped, grip held, after the lift', 's', 0.0, 600.0,
                  field='rest_s', read_only=True),
    ParameterSpec('lift_velocity', float, 'upward arm velocity while lifting', 'm/s', 0.0,
                  0.05, field='lift_velocity', read_only=True),
])


class SlipLiftNode(Node):
    """Publishes one lift's commands (module docstring); :attr:`done` once it is over.

    Raises
    ------
    ValueError
        ``grip_angle`` not given (negative).
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('slip_lift', **kwargs)
        declare_table(self, PARAMETERS, Timing())
        values = read_table(self, PARAMETERS)
        if values['grip_angle'] < 0.0:
            raise ValueError('slip_lift: set grip_angle (rad, 0 = closed), e.g. -p '
                             'grip_angle:=0.535')
        self.timing: Timing = replace_fields(Timing(), PARAMETERS, values)
        self.grip_angle = values['grip_angle']
        self.open_angle = values['open_angle']
        self.frame_id = values['frame_id']
        self.done = False
        self.phase = ''
        self._servo_pub = self.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        self._arm_pub = self.create_publisher(TwistStamped, 'arm/cmd_vel', COMMANDS)
        self._start = None               # the first tick starts the lift
        self._timer = self.create_timer(1.0 / values['command_rate'], self._tick)
        self.get_logger().info(
            f'slip lift: grip {self.grip_angle:.4f} rad, lift '
            f'{1e3 * self.timing.lift_velocity:.1f} mm/s for {self.timing.lift_s:g} s')

    def _publish(self, servo: float, velocity: float) -> None:
        stamp = self.get_clock().now().to_msg()
        command = ServoCommand(position=float(servo), profile_velocity=PROFILE_VELOCITY)
        command.header.stamp = stamp
        twist = TwistStamped()
        twist.header.stamp = stamp
        twist.header.frame_id = self.frame_id
        twist.twist.linear.z = float(velocity)
        self._servo_pub.publish(command)
        self._arm_pub.publish(twist)

    def _tick(self) -> None:
        """Timer callback: the commands of the current phase (never blocks)."""
        if self.done:
            return
        now = self.get_clock().now()
        if self._start is None:
            self._start = now
        elapsed = (now - self._start).nanoseconds * 1e-9
        command = self.timing.command_at(max(elapsed, 0.0), self.open_angle, self.grip_angle)
        if command is None:
            self._publish(self.grip_angle, 0.0)
            self.done = True
            self._timer.cancel()
            self.get_logger().info('slip lift done: arm stopped, grip held')
            return
        phase, servo, velocity = command
        if phase != self.phase:
            self.phase = phase
            self.get_logger().info(f'phase {phase} at {elapsed:.2f} s')
        self._publish(servo, velocity)


def main(args: list[str] | None = None) -> int:
    """Run one lift (exit 0 when done or stopped; 2 without ``grip_angle``)."""
    from forte_ros import run_node

    return run_node(SlipLiftNode, args, until=lambda node: node.done,
                    fatal_errors=(ValueError,), name='slip_lift')


if __name__ == '__main__':
    sys.exit(main())
