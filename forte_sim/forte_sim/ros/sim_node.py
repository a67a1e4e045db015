"""Lifecycle node standing in for the FORTE hardware: a simulated scene (forte_sim).

Thin ROS shell over :func:`forte_sim.make_scene`:

* publishes ``tactile/frames`` (forte_msgs/TactileFrames, batches of ``batch_size`` raw
  samples, the contract's sensor-data QoS or reliable with ``reliable:=true``), stamped with
  the sample time of the first row (simulation start + sample index / 2 kHz);
* publishes ``joint_states`` (sensor_msgs/JointState: forte_left_finger_joint,
  forte_right_finger_joint, each with ``prefix`` prepended; position [rad], velocity
  [rad/s], effort = joint torque [N m] along theta, the servo current x the torque constant
  of ``forte_ros.contract``, as the gripper driver reports it: negative while squeezing) and
  ``sim/ground_truth`` (forte_msgs/SimGroundTruth) once per batch;
* subscribes ``gripper/command`` (forte_msgs/ServoCommand) and ``arm/cmd_vel``
  (geometry_msgs/TwistStamped, only ``twist.linear.z`` is used: the arm lifts vertically);
  the arm stops when no velocity command arrived for ``cmd_vel_timeout`` simulated seconds;
* in the ``calibration`` scene, publishes ``load_cell/wrench`` (geometry_msgs/WrenchStamped,
  reliable, frame ``<prefix>forte_load_cell``): the rig's load cell, one message per
  ``load_cell_decimation`` samples (default 20: 100 Hz at 2 kHz), at the sample indices
  divisible by it, each stamped with the time of the sample it reports; the squeeze (the
  mean of the two finger forces plus the cell's noise, forte_sim's ``load_cell_force``) is
  ``+wrench.force.z`` [N], every other component 0;
* publishes ``tactile/sensor_info`` (forte_msgs/SensorInfo, latched) once: the simulator's
  sensor identity (``forte_ros.sensor_identity.SIMULATED_SENSOR``);
* optionally publishes ``/clock`` (rosgraph_msgs/Clock) so other nodes can run on the
  simulation clock (``use_sim_time:=true``), required for ``real_time_factor`` != 1 (a
  namespaced graph remaps it to ``<namespace>/clock`` for all its nodes);
* ``/diagnostics`` once per wall second.

``prefix`` (TF / joint-name prefix, e.g. ``right_`` for a second gripper) is prepended to
``frame_id``, the load cell's frame and the joint names (``forte_ros.contract.prefixed``).

``real_time_factor``: 1 = real time, > 1 faster, 0 = as fast as possible. The scene is
stepped in whole batches; in real time the node produces, at every timer tick, the batches
whose simulated time has come (catching up after a late tick, up to 0.5 s; a larger lag
is dropped from the schedule and counted as an overrun, never invented).

Configure builds the scene (unknown scene / object refused with a reason); activate starts
the clock; ``autostart`` (default true, this is a simulator) does both at start-up.
"""
from __future__ import annotations

import math
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped, WrenchStamped
from rcl_interfaces.msg import (
    SetParametersResult,
)
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from forte_msgs.msg import SensorInfo, ServoCommand, SimGroundTruth, TactileFrames
from forte_ros import ForteLifecycleNode, run_node
from forte_ros.contract import (
    BASE_FRAME,
    CHANNEL_NAMES,
    LEFT_FINGER_JOINT,
    LOAD_CELL_FRAME,
    RIGHT_FINGER_JOINT,
    SAMPLE_PERIOD,
    current_to_effort,
    joint_names,
    prefixed,
)
from forte_ros.diagnostics import OK, diagnostic_array, diagnostic_status, node_path
from forte_ros.parameter_table import ParameterSpec, parameter_table
from forte_ros.parameters import declare_table, parameter_update
from forte_ros.qos import (
    COMMANDS,
    DIAGNOSTICS,
    GROUND_TRUTH,
    LOAD_CELL,
    SENSOR_FRAMES,
    SENSOR_INFO,
    reliable,
)
from forte_ros.sensor_identity import SIMULATED_SENSOR
from forte_sim import SCENE_NAMES, Scene, make_scene
from forte_sim.ros.ground_truth import (
    ground_truth_message,
    load_cell_messages,
)

#: Joint names without prefix (forte_ros.contract), kept here for the node's importers.
LEFT_JOINT = LEFT_FINGER_JOINT
RIGHT_JOINT = RIGHT_FINGER_JOINT
#: Parameters that define the scene, read at configure (settable while unconfigured).
SCENE_PARAMETERS = ('scene', 'object', 'seed', 'trial')
MAX_CATCH_UP = 0.5          # largest simulated lag made up in one timer tick [s]
FAST_PERIOD = 1e-4          # timer period at real_time_factor 0 (free running) [s]
RELIABLE_FRAMES_DEPTH = 1000    # reliable frames queue: 10 s of batches for slow readers


#: Every parameter of the node, in the order of declaration (all node-only: their defaults
#: are here). The scene's parameters (:data:`SCENE_PARAMETERS`) apply at the next configure
#: (cleanup + configure = a new scene).
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('scene', str, f'scene name, one of {", ".join(SCENE_NAMES)} (applies at '
                  'configure)', default='grasp'),
    ParameterSpec('object', str, 'object type (grasp scenes, see forte_sim.OBJECTS) or '
                  'indentor name (calibration scene) (applies at configure)', default='apple'),
    ParameterSpec('seed', int, 'seed of every random draw of the scene (applies at configure)',
                  low=0, high=2 ** 31 - 1, default=0),
    ParameterSpec('trial', int, 'trial index reported in sim/ground_truth (applies at '
                  'configure)', low=0, high=2 ** 31 - 1, default=0),
    ParameterSpec('real_time_factor', float, 'simulated seconds per wall second; 0 = as fast '
                  'as possible', low=0.0, high=1000.0, default=1.0),
    ParameterSpec('publish_clock', bool, 'publish /clock (rosgraph_msgs/Clock) with the '
                  'simulation time', default=False, read_only=True),
    ParameterSpec('clock_rate', float, '/clock messages per simulated second (at most one per '
                  'batch): every /clock message wakes every node on the simulation clock, so '
                  'it is kept low; nodes that need finer time read the sample stamps', 'Hz',
                  1.0, 2000.0, default=20.0, read_only=True),
    ParameterSpec('reliable', bool, 'reliable QoS on tactile/frames (for recording); default '
                  'sensor data QoS', default=False, read_only=True),
    ParameterSpec('batch_size', int, 'samples per TactileFrames message', low=1, high=2000,
                  default=20, read_only=True),
    ParameterSpec('frame_id', str, 'frame_id of tactile/frames, tactile/sensor_info and '
                  'sim/ground_truth (prefix prepended)', default=BASE_FRAME, read_only=True),
    ParameterSpec('prefix', str, 'TF / joint-name prefix prepended to frame_id, the load '
                  "cell's frame and the joint names of joint_states (e.g. right_ for a second "
                  "gripper; '' = none)", default='', read_only=True),
    ParameterSpec('timer_period', float, 'wall period of the production timer in real time',
                  's', 0.001, 0.1, default=0.01, read_only=True),
    ParameterSpec('cmd_vel_timeout', float, 'the arm stops when no arm/cmd_vel arrived for '
                  'this long (simulated)', 's', 0.01, 60.0, default=0.5),
    ParameterSpec('load_cell_decimation', int, 'samples per load_cell/wrench message in the '
                  'calibration scene (each stamped with its sample time)', low=1, high=2000,
                  default=20, read_only=True),
    ParameterSpec('autostart', bool, 'configure and activate at start-up without a lifecycle '
                  'manager', default=True, read_only=True),
])


class SimNode(ForteLifecycleNode):
    """The simulated FORTE scene as a ROS 2 lifecycle node (see the module docstring)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('forte_sim', **kwargs)
        declare_table(self, PARAMETERS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        prefix = str(self.get_parameter('prefix').value)   # read-only: fixed for the node
        self._frame_id = prefixed(str(self.get_parameter('frame_id').value), prefix)
        self._load_cell_frame = prefixed(LOAD_CELL_FRAME, prefix)
        self._joint_names = list(joint_names(prefix))
        self._scene: Scene | None = None
        # transitions may be triggered from another thread than the executor's: they and
        # the production of a batch exclude each other, so no batch is half published
        self._production_lock = threading.Lock()
        self._frames_publisher = None
        self._joint_publisher = None
        self._truth_publisher = None
        self._clock_publisher = None
        self._load_cell_publisher = None
        self._clock_tick = 1  # samples per /clock message, from clock_rate at configure
        self._timer = None
        self._origin_ns = 0
        self._anchor_wall = 0.0
        self._anchor_samples = 0
        self._servo_command = 0.0
        self._max_current: float | None = None
        self._profile_velocity: float | None = None
        self._arm_velocity = 0.0
        self._last_cmd_vel_sample = -10 ** 12
        self._rejected_commands = 0
        self._overruns = 0
        self._batches = 0
        self._diagnostics_publisher = self.create_publisher(
            DiagnosticArray, '/diagnostics', DIAGNOSTICS)
        self._diagnostics_timer = self.create_timer(1.0, self._publish_diagnostics)
        # the simulator's sensor identity, latched for late subscribers (perception)
        self._sensor_info_publisher = self.create_publisher(
            SensorInfo, 'tactile/sensor_info', SENSOR_INFO)
        sensor_info = SensorInfo(**SIMULATED_SENSOR.to_dict())
        sensor_info.header.stamp = self.get_clock().now().to_msg()
        sensor_info.header.frame_id = self._frame_id
        self._sensor_info_publisher.publish(sensor_info)
        self._rate_window = (time.monotonic(), 0)
        self._achieved_factor = 0.0
        self.create_subscription(ServoCommand, 'gripper/command', self._on_servo_command,
                                 COMMANDS)
        self.create_subscription(TwistStamped, 'arm/cmd_vel', self._on_cmd_vel, COMMANDS)
        if self.get_parameter('autostart').value:
            if self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
                self.trigger_activate()

    # ------------------------------------------------------------------ parameters
    def _on_set_parameters(self, parameters) -> SetParametersResult:
        values, reason = parameter_update(parameters, PARAMETERS)  # ranges and kinds
        if reason:
            return SetParametersResult(successful=False, reason=reason)
        for name in values:
            if name in SCENE_PARAMETERS and getattr(self, '_scene', None) is not None:
                return SetParametersResult(
                    successful=False, reason=f'{name} applies at configure: '
                    'deactivate and clean up the node first')
        if 'real_time_factor' in values and self._timer is not None:
            # re-anchor the schedule so the new factor applies from now on
            self._anchor_wall = time.monotonic()
            self._anchor_samples = self._scene.sample_index if self._scene else 0
            self._restart_timer(values['real_time_factor'])
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ lifecycle
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        scene_name = self.get_parameter('scene').value
        object_name = self.get_parameter('object').value
        try:
            if scene_name == 'calibration':
                self._scene = make_scene(scene_name, seed=self.get_parameter('seed').value,
                                         indentor=object_name,
                                         trial=self.get_parameter('trial').value)
            else:
                self._scene = make_scene(scene_name, object_name=object_name,
                                         seed=self.get_parameter('seed').value,
                                         trial=self.get_parameter('trial').value)
        except ValueError as error:
            self.get_logger().error(f'cannot build the scene: {error}')
            return TransitionCallbackReturn.FAILURE
        self._servo_command = self._scene.initial_angle
        # reliable frames (recording) keep a deeper queue than the contract's 50, so slow
        # readers of a free-running simulation lose nothing
        frames_qos = (reliable(RELIABLE_FRAMES_DEPTH) if self.get_parameter('reliable').value
                      else SENSOR_FRAMES)
        self._frames_publisher = self.create_lifecycle_publisher(
            TactileFrames, 'tactile/frames', frames_qos)
        self._joint_publisher = self.create_lifecycle_publisher(
            JointState, 'joint_states', COMMANDS)
        self._truth_publisher = self.create_lifecycle_publisher(
            SimGroundTruth, 'sim/ground_truth', GROUND_TRUTH)
        if scene_name == 'calibration':
            self._load_cell_publisher = self.create_lifecycle_publisher(
                WrenchStamped, 'load_cell/wrench', LOAD_CELL)
        if self.get_parameter('publish_clock').value:
            self._clock_publisher = self.create_lifecycle_publisher(
                Clock, '/clock', reliable(10))
            # samples per /clock message (clock_rate is read-only)
            self._clock_tick = max(1, round(1.0 / (float(self.get_parameter('clock_rate').value)
                                                   * SAMPLE_PERIOD)))
        self.get_logger().info(
            f'scene {scene_name!r} object {object_name!r} seed '
            f'{self.get_parameter("seed").value}: theta_zeroF '
            f'{self._scene.theta_zero_force:.3f} rad, start {self._scene.initial_angle:.3f} rad')
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        with self._production_lock:
            return self._activate(state)

    def _activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        now_ns = self.get_clock().now().nanoseconds
        if self._origin_ns == 0:
            self._origin_ns = now_ns
        elif self._clock_publisher is None:
            # resumed on the wall clock: the next sample is stamped now (the pause is not
            # simulated); with /clock the simulation time simply paused
            self._origin_ns = now_ns - round(self._scene.sample_index * SAMPLE_PERIOD * 1e9)
        self._anchor_wall = time.monotonic()
        self._anchor_samples = self._scene.sample_index
        self._restart_timer(float(self.get_parameter('real_time_factor').value))
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        with self._production_lock:
            self._stop_timer()
            return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._stop_timer()
        self._destroy_publishers()
        self._scene = None
        self._origin_ns = 0
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        with self._production_lock:
            self._stop_timer()
            self._destroy_publishers()
        self.get_logger().info(f'shut down from {state.label}: production stopped after '
                               f'{self._batches} batches')
        return TransitionCallbackReturn.SUCCESS

    def _destroy_publishers(self) -> None:
        for name in ('_frames_publisher', '_joint_publisher', '_truth_publisher',
                     '_clock_publisher', '_load_cell_publisher'):
            publisher = getattr(self, name)
            if publisher is not None:
                self.destroy_lifecycle_publisher(publisher)
                setattr(self, name, None)

    def _restart_timer(self, factor: float) -> None:
        self._stop_timer()
        period = (FAST_PERIOD if factor == 0.0
                  else float(self.get_parameter('timer_period').value))
        self._timer = self.create_timer(period, self._produce)

    def _stop_timer(self) -> None:
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None

    # ------------------------------------------------------------------ commands
    def _on_servo_command(self, message: ServoCommand) -> None:
        values = (message.position, message.max_current, message.profile_velocity)
        if not all(math.isfinite(value) for value in values):
            self._reject('gripper/command with a non-finite value')
            return
        if message.max_current < 0.0 or message.profile_velocity < 0.0:
            self._reject('gripper/command with a negative current limit or velocity')
            return
        self._servo_command = float(message.position)
        self._max_current = float(message.max_current) or None
        self._profile_velocity = float(message.profile_velocity) or None

    def _on_cmd_vel(self, message: TwistStamped) -> None:
        value = message.twist.linear.z
        if not math.isfinite(value):
            self._reject('arm/cmd_vel with a non-finite linear.z')
            return
        self._arm_velocity = float(value)
        if self._scene is not None:
            self._last_cmd_vel_sample = self._scene.sample_index

    def _reject(self, reason: str) -> None:
        self._rejected_commands += 1
        self.get_logger().warning(f'refused {reason} ({self._rejected_commands} so far)',
                                  throttle_duration_sec=1.0)

    # ------------------------------------------------------------------ production
    def _produce(self) -> None:
        with self._production_lock:
            self._produce_due()

    def _produce_due(self) -> None:
        if self._scene is None or self._frames_publisher is None or self._timer is None:
            return
        batch = int(self.get_parameter('batch_size').value)
        factor = float(self.get_parameter('real_time_factor').value)
        if factor == 0.0:
            # as fast as possible: one batch per callback of a free-running timer, so the
            # executor services subscriptions (commands, readers in the same process)
            # between batches
            self._step_batch(batch)
            return
        elapsed = time.monotonic() - self._anchor_wall
        due = self._anchor_samples + int(elapsed * factor / SAMPLE_PERIOD)
        lag = due - self._scene.sample_index
        limit = int(MAX_CATCH_UP / SAMPLE_PERIOD)
        if lag > limit:
            # too far behind (e.g. the process was suspended): skip ahead in the schedule
            self._overruns += 1
            self._anchor_samples += lag - limit
        while due - self._scene.sample_index >= batch:
            self._step_batch(batch)

    def _step_batch(self, batch: int) -> None:
        scene = self._scene
        first = scene.sample_index
        timeout = float(self.get_parameter('cmd_vel_timeout').value)
        velocity = self._arm_velocity
        if (first - self._last_cmd_vel_sample) * SAMPLE_PERIOD > timeout:
            velocity = 0.0
        frames, truth = scene.step(batch, self._servo_command, velocity,
                                   max_current=self._max_current,
                                   profile_velocity=self._profile_velocity)
        self._batches += 1
        first_stamp = Time(nanoseconds=self._origin_ns + round(first * SAMPLE_PERIOD * 1e9))
        last_stamp = Time(nanoseconds=self._origin_ns
                          + round((first + batch - 1) * SAMPLE_PERIOD * 1e9)).to_msg()
        message = TactileFrames()
        message.header.stamp = first_stamp.to_msg()
        message.header.frame_id = self._frame_id
        message.first_sequence = first
        message.device_time_us = round(first * SAMPLE_PERIOD * 1e6)
        message.sample_period = SAMPLE_PERIOD
        message.channel_names = list(CHANNEL_NAMES)
        message.sample_count = batch
        message.data = frames.ravel()
        self._frames_publisher.publish(message)
        joints = JointState()
        joints.header.stamp = last_stamp
        joints.name = self._joint_names
        position = scene.joint_position
        joints.position = [position, position]
        joints.velocity = [scene.joint_velocity, scene.joint_velocity]
        joints.effort = [current_to_effort(current)
                         for current in scene.joint_current_along_theta]
        self._joint_publisher.publish(joints)
        self._truth_publisher.publish(ground_truth_message(
            truth, scene, self.get_parameter('object').value, last_stamp, self._frame_id))
        if self._load_cell_publisher is not None:
            step = int(self.get_parameter('load_cell_decimation').value)
            for message in load_cell_messages(truth, step, self._sample_time_ns,
                                              self._load_cell_frame):
                self._load_cell_publisher.publish(message)
        if self._clock_publisher is not None:
            self._publish_clock(first, scene.sample_index)

    def _sample_time_ns(self, index: int) -> int:
        """Time of scene sample ``index`` on the simulation clock [ns]."""
        return self._origin_ns + round(index * SAMPLE_PERIOD * 1e9)

    def _publish_clock(self, first: int, end: int) -> None:
        """Publish /clock = the end of the batch [first, end) when a tick of ``clock_rate``
        falls in it (a batch longer than a tick publishes once)."""
        tick = self._clock_tick
        if first != 0 and first // tick == end // tick:
            return
        clock = Clock()
        clock.clock = Time(nanoseconds=self._origin_ns
                           + round(end * SAMPLE_PERIOD * 1e9)).to_msg()
        self._clock_publisher.publish(clock)

    # ------------------------------------------------------------------ diagnostics
    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        samples = self._scene.sample_index if self._scene is not None else 0
        started, count = self._rate_window
        if now > started:
            self._achieved_factor = (samples - count) * SAMPLE_PERIOD / (now - started)
        self._rate_window = (now, samples)
        values = {
            'scene': self.get_parameter('scene').value,
            'object': self.get_parameter('object').value,
            'simulated_seconds': f'{samples * SAMPLE_PERIOD:.3f}',
            'achieved_real_time_factor': f'{self._achieved_factor:.2f}',
            'requested_real_time_factor': self.get_parameter('real_time_factor').value,
            'batches': self._batches,
            'schedule_overruns': self._overruns,
            'rejected_commands': self._rejected_commands,
            'clamped_commands': self._scene.clamped_commands if self._scene else 0,
        }
        status = diagnostic_status(f'{node_path(self)}: simulated scene', OK,
                                   'running' if self._timer is not None else 'inactive',
                                   values, hardware_id='forte_sim')
        self._diagnostics_publisher.publish(
            diagnostic_array(self.get_clock().now().to_msg(), [status]))


def main(args: list[str] | None = None) -> int:
    """Run the simulated scene node until SIGINT/SIGTERM (autostart: active at start-up)."""
    return run_node(SimNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
