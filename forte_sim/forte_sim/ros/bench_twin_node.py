"""The bench twin as a process: both bench devices on ptys, one scene, the arm on ROS.

Thin ROS shell over :class:`forte_sim.bench_twin.BenchTwin`: the emulated
sensor board appears at ``sensor_link`` and the simulated XM430 pair at ``servo_link``
(symlinks to the ptys, what ``hardware.launch.py``'s ``sensor_port`` and ``gripper_port``
open), so the real serial sensor and gripper driver nodes talk to them exactly as to the
devices on a robot. The node itself stands in only for what cannot exist on the bench, the
robot arm:

* subscribes ``arm/cmd_vel`` (geometry_msgs/TwistStamped, ``twist.linear.z`` [m/s]: the
  arm lifts vertically); the arm stops when no command arrived for ``cmd_vel_timeout`` s
  (as MoveIt Servo stops on a command timeout);
* publishes ``sim/ground_truth`` (forte_msgs/SimGroundTruth, evaluation only) at
  ``truth_rate``, the truth at the newest simulated sample;
* in the ``calibration`` scene (``object`` = the indentor), publishes ``load_cell/wrench``
  (geometry_msgs/WrenchStamped, reliable) as the sim node does: the rig's load cell at the
  sample indices divisible by ``load_cell_decimation``, each stamped with the time the board
  sampled it (the driver's time base), squeeze on ``+force.z`` [N]; so the force
  calibration procedure runs on the bench twin through the real drivers;
* subscribes ``sim/operator_press`` (std_msgs/String, commissioning's guided press test
  without an operator): ``'<finger> <place> [force_N] [hold_s]'`` with finger ``left`` /
  ``right`` and place ``tip`` / ``root`` or a number 0 (tip) .. 1 (root), e.g.
  ``'left tip'`` or ``'right root 3.5 1.0'`` (defaults 4 N, 1 s); a scripted operator
  presses that finger (:meth:`BenchTwin.press`); a malformed request is logged and ignored.

``sensor_fault`` injects sensor faults into the board's readings
(:mod:`forte_sim.channel_faults`, e.g. ``reversed:left_middle``, several
separated by ``;``): commissioning is tested against them. An unreadable value stops the
node at start-up with one fatal line (exit code 2).

Run: ``ros2 run forte_sim bench_twin_node --ros-args -p object:=raspberry`` beside
``ros2 launch forte_bringup hardware.launch.py sensor_port:=/tmp/forte_bench/sensor
gripper_port:=/tmp/forte_bench/gripper`` (``bench_twin:=true`` starts both; docs/bringup.md).
"""
from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from geometry_msgs.msg import TwistStamped, WrenchStamped
from rclpy.node import Node
from std_msgs.msg import String

from forte_msgs.msg import SimGroundTruth
from forte_ros import run_node
from forte_ros.contract import BASE_FRAME, FINGER_NAMES, LOAD_CELL_FRAME, prefixed
from forte_ros.parameter_table import ParameterSpec, parameter_table
from forte_ros.parameters import declare_table, read_table
from forte_ros.qos import COMMANDS, GROUND_TRUTH, LOAD_CELL
from forte_sim import SCENE_NAMES, make_scene
from forte_sim.bench_twin import BenchTwin
from forte_sim.channel_faults import parse_faults
from forte_sim.operator_press import PRESS_LOCATIONS
from forte_sim.ros.ground_truth import (
    ground_truth_message,
    load_cell_messages,
)
from forte_sim.truth import SceneTruth

#: Every parameter of the node (all node-only; the scene's apply at start-up).
PARAMETERS = parameter_table([
    ParameterSpec('sensor_link', str, 'symlink created to the emulated sensor board\'s pty '
                  '(the serial sensor node\'s port)', default='/tmp/forte_bench/sensor',
                  read_only=True),
    ParameterSpec('servo_link', str, 'symlink created to the simulated servo bus\'s pty (the '
                  'gripper driver node\'s port)', default='/tmp/forte_bench/gripper',
                  read_only=True),
    ParameterSpec('scene', str, 'scene name', choices=SCENE_NAMES, default='grasp',
                  read_only=True),
    ParameterSpec('object', str, 'object type (grasp scenes, see forte_sim.OBJECTS) or '
                  'indentor name (calibration scene)', default='soda_can', read_only=True),
    ParameterSpec('seed', int, 'seed of every random draw of the scene', low=0,
                  high=2 ** 31 - 1, default=0, read_only=True),
    ParameterSpec('cmd_vel_timeout', float, 'the arm stops when no arm/cmd_vel arrived for '
                  'this long', 's', 0.01, 60.0, default=0.5),
    ParameterSpec('truth_rate', float, 'sim/ground_truth messages per second', 'Hz', 1.0,
                  500.0, default=100.0, read_only=True),
    ParameterSpec('frame_id', str, 'frame_id of sim/ground_truth (prefix prepended)',
                  default=BASE_FRAME, read_only=True),
    ParameterSpec('prefix', str, "TF prefix of frame_id and of load_cell/wrench's frame (e.g. "
                  "right_; '' = none)", default='', read_only=True),
    ParameterSpec('load_cell_decimation', int, 'samples per load_cell/wrench message in the '
                  'calibration scene (each stamped with its sample time)', low=1, high=2000,
                  default=20, read_only=True),
    ParameterSpec('sensor_fault', str, 'sensor faults injected into the board\'s readings, '
                  '"kind:channel[,channel][:parameter=value]" separated by ";" (kinds '
                  'swapped_pair, swapped_fingers, reversed, dead, noisy, leaking; e.g. '
                  '"reversed:left_middle", "leaking:left_root:tau=8"); empty: none',
                  default='', read_only=True),
])


def parse_press(text: str) -> tuple[int, float, float, float]:
    """Read an operator press request ``'<finger> <place> [force_N] [hold_s]'``.

    Returns
    -------
    tuple
        (finger index, location 0 = tip .. 1 = root, force [N], hold [s]).

    Raises
    ------
    ValueError
        On an unknown finger or place, or a malformed number.
    """
    words = text.split()
    if not 2 <= len(words) <= 4:
        raise ValueError(f'expected "<finger> <place> [force] [hold]", got {text!r}')
    if words[0] not in FINGER_NAMES:
        raise ValueError(f'finger must be one of {FINGER_NAMES}, got {words[0]!r}')
    place = PRESS_LOCATIONS.get(words[1])
    location = float(words[1]) if place is None else place
    numbers = [float(word) for word in words[2:]] + [4.0, 1.0][len(words) - 2:]
    return FINGER_NAMES.index(words[0]), location, numbers[0], numbers[1]


class BenchTwinNode(Node):
    """The bench twin's devices, scene and arm stand-in (see the module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('bench_twin', **kwargs)
        declare_table(self, PARAMETERS)
        self.values = read_table(self, PARAMETERS)
        self._latest: SceneTruth | None = None
        self._truth_lock = threading.Lock()
        self._last_cmd_vel = -float('inf')
        faults = parse_faults(self.values['sensor_fault'])
        scene = make_scene(self.values['scene'], self.values['object'], self.values['seed'])
        # everything _keep_truth touches exists before the twin's scene thread starts
        self._truth_publisher = self.create_publisher(SimGroundTruth, 'sim/ground_truth',
                                                      GROUND_TRUTH)
        self._load_cell_publisher = None
        self._load_cell_chunks: list[SceneTruth] = []  # guarded by _truth_lock
        if scene.name == 'calibration':
            self._load_cell_publisher = self.create_publisher(
                WrenchStamped, 'load_cell/wrench', LOAD_CELL)
        Path(self.values['sensor_link']).parent.mkdir(parents=True, exist_ok=True)
        self.twin = BenchTwin(self.values['sensor_link'], scene, on_truth=self._keep_truth,
                              faults=faults)
        self.twin.start()
        self._servo_link = Path(self.values['servo_link'])
        self._servo_link.parent.mkdir(parents=True, exist_ok=True)
        self._servo_link.unlink(missing_ok=True)
        os.symlink(self.twin.servo_device, self._servo_link)
        self.create_subscription(TwistStamped, 'arm/cmd_vel', self._on_cmd_vel, COMMANDS)
        self.create_subscription(String, 'sim/operator_press', self._on_press, COMMANDS)
        self.create_timer(1.0 / self.values['truth_rate'], self._tick)
        self.get_logger().info(
            f"bench twin up: scene {scene.name!r} object {self.values['object']!r} seed "
            f"{self.values['seed']}; sensor board at {self.values['sensor_link']}, servos "
            f'at {self._servo_link} -> {self.twin.servo_device}; sensor faults: '
            f"{', '.join(fault.label for fault in faults) or 'none'}")

    def _on_press(self, message: String) -> None:
        try:
            finger, location, force, hold = parse_press(message.data)
            start, stop = self.twin.press(finger, location, force, hold)
        except ValueError as error:
            self.get_logger().warning(f'sim/operator_press refused: {error}')
            return
        self.get_logger().info(f'operator presses {message.data!r}: scene samples '
                               f'[{start}, {stop})')

    def _keep_truth(self, truth: SceneTruth) -> None:
        with self._truth_lock:
            self._latest = truth
            if self._load_cell_publisher is not None:
                self._load_cell_chunks.append(truth)

    def _on_cmd_vel(self, message: TwistStamped) -> None:
        try:
            self.twin.set_arm_velocity(message.twist.linear.z)
        except ValueError as error:
            self.get_logger().warning(f'arm/cmd_vel refused: {error}')
            return
        self._last_cmd_vel = time.monotonic()

    def _tick(self) -> None:
        if self.twin.failure:
            self.get_logger().error(f'the bench twin\'s scene thread stopped '
                                    f'({self.twin.failure}): the servos no longer follow the '
                                    'scene; restart the bench twin', throttle_duration_sec=5.0)
        timeout = float(self.get_parameter('cmd_vel_timeout').value)
        if time.monotonic() - self._last_cmd_vel > timeout:
            self.twin.set_arm_velocity(0.0)
        with self._truth_lock:
            truth, self._latest = self._latest, None
            chunks, self._load_cell_chunks = self._load_cell_chunks, []
        step = int(self.values['load_cell_decimation'])
        for chunk in chunks:
            for message in load_cell_messages(chunk, step, self.twin.sample_time_ns,
                                              prefixed(LOAD_CELL_FRAME, self.values['prefix'])):
                self._load_cell_publisher.publish(message)
        if truth is not None:
            self._truth_publisher.publish(ground_truth_message(
                truth, self.twin.scene, self.values['object'],
                self.get_clock().now().to_msg(),
                prefixed(self.values['frame_id'], self.values['prefix'])))

    def prepare_shutdown(self) -> None:
        """Stop the scene and both devices, remove the servo symlink (the node runner calls
        this while the context is still valid)."""
        self.twin.close()
        if self._servo_link.is_symlink():
            self._servo_link.unlink()


def main(args: list[str] | None = None) -> int:
    """Entry point ``bench_twin_node``."""
    return run_node(BenchTwinNode, args, fatal_errors=(ValueError,), name='bench_twin')


if __name__ == '__main__':
    raise SystemExit(main())
