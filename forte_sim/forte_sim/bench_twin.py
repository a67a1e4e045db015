"""The bench twin: one simulated scene behind both bench devices (no rclpy).

A robot's FORTE gripper is two devices on two cables: the sensor board (binary protocol of
docs/firmware.md on a USB serial port) and an XM430-W350 pair on a Dynamixel bus. The twin
gives the bench the same two devices, coupled through one physical scene
(:func:`forte_sim.make_scene`), so the hardware graph (``hardware.launch.py``: the real
serial driver, the real gripper driver over dynamixel-sdk) grasps a simulated object:

- **servos -> scene**: the gripper angle the scene's servo is commanded to is the mean of
  the two servos' Goal Position (converted with the driver's finger configuration: zero
  position and direction, :class:`forte_driver.dynamixel.gripper_config.FingerConfig`);
  Goal Current (capped by Current Limit) is the scene's current limit and Profile Velocity
  its servo speed. Torque off leaves the fingers where they are.
- **scene -> servos**: each servo's Present Position, Velocity and Current are the scene's
  finger angle, angular velocity and servo current, converted back (currents signed along
  the position axis: a finger squeezing its object pushes toward closing);
- **scene -> sensor board**: the board's scan ``k`` after the twin started is the scene's
  sample ``k``, 11-bit readings scaled to counts (1024 counts = 1.0).

Time: the scene advances in real time, driven by the sensor board's scan clock (a scan due
at device time ``t`` needs the scene's sample at ``t``) and by a background thread (every
:data:`STEP_PERIOD`) so that the servos move even while the sensor is not streaming. Both
advance it under one lock, in steps of at most one mechanics tick, so a servo command takes
effect within 5 ms of scene time, as on a servo whose position loop runs at kHz.

The servo bus runs in a process of its own (:class:`SimulatedServoProcess`), as the
emulated servos of the driver's tests do: its status packets must not wait for this
process's interpreter lock (a late status packet is a lost one for dynamixel-sdk, and the
next read would take it for its answer). The background thread exchanges with it every
:data:`STEP_PERIOD` (:meth:`SimulatedServoBus.exchange`): the servos' physical state after
the latest scene step in, their commanded registers out, used by the following steps. So a
command reaches the scene within about 5 ms, and the sensor board's thread never waits for
the other process.

The arm is the one part that cannot exist on the bench: :meth:`BenchTwin.set_arm_velocity`
takes the commanded vertical velocity (the bench twin node feeds it from ``arm/cmd_vel``).
The scene's ground truth of every step goes to the ``on_truth`` callback (evaluation only).

Commissioning (issue 24): :meth:`BenchTwin.press` has a scripted operator press one finger
(:mod:`forte_sim.operator_press`; its pressure adds to the scene's readings), and the
optional ``faults`` (:mod:`forte_sim.channel_faults`: swapped channels or
fingers, a reversed, dead, noisy or leaking channel) are applied to the readings before the
sensor board sends them, as a miswired or damaged sensor would.
"""
from __future__ import annotations

import math
import threading
import time
import traceback
from collections.abc import Callable, Sequence

import numpy as np

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.gripper_config import FingerConfig, GripperConfig
from forte_driver.emulators.emulated_sensor import EmulatedSensor
from forte_driver.emulators.simulated_servo import SimulatedServoProcess
from forte_ros.contract import COUNTS_PER_FULL_SCALE, N_CHANNELS, SAMPLE_PERIOD
from forte_sim.channel_faults import ChannelFault, ChannelFaultInjector
from forte_sim.model import quantise
from forte_sim.operator_press import OperatorPress, ScriptedOperator
from forte_sim.scene import Scene, make_scene
from forte_sim.state import TICK_SAMPLES
from forte_sim.truth import SceneTruth

__all__ = ['BenchTwin', 'STEP_PERIOD']

#: Period of the background thread that keeps the scene at real time [s].
STEP_PERIOD = 0.005
#: Scene samples kept for scans that read late [samples] (4 s at 2 kHz).
HISTORY_SAMPLES = 8192
_PULSES_PER_RADIAN = ct.PULSES_PER_REVOLUTION / (2.0 * math.pi)
_PERIOD_US = int(round(SAMPLE_PERIOD * 1e6))


class BenchTwin:
    """An emulated sensor board and a simulated XM430 pair driven by one scene.

    Parameters
    ----------
    sensor_link : str
        Symlink of the sensor board's pty (what the serial driver's ``port`` opens).
    scene : Scene, optional
        The scene (default: ``make_scene('grasp', 'soda_can', seed=0)``).
    gripper : GripperConfig, optional
        The servos' ids, zero positions and directions, as the gripper driver is configured
        (default: the driver's defaults).
    on_truth : callable, optional
        ``on_truth(truth)`` with the :class:`forte_sim.truth.SceneTruth` of every scene step
        (called from the thread that advanced the scene, with the twin's lock held).
    sensor_seed : int
        Seed of the sensor board (its device id is derived from it, as IDENTIFY reports).
    faults : sequence of ChannelFault
        Sensor faults applied to the readings (default none: a healthy sensor); their
        injected noise is seeded with ``sensor_seed``.
    """

    def __init__(self, sensor_link: str, scene: Scene | None = None,
                 gripper: GripperConfig | None = None,
                 on_truth: Callable[[SceneTruth], None] | None = None,
                 sensor_seed: int = 0, faults: Sequence[ChannelFault] = ()) -> None:
        self.scene = scene if scene is not None else make_scene('grasp', 'soda_can', seed=0)
        self.gripper = gripper or GripperConfig()
        self.on_truth = on_truth
        fingers = self.gripper.fingers
        start = self.scene.joint_position
        self.servos = SimulatedServoProcess(
            ids=tuple(finger.servo_id for finger in fingers),
            baud_rate=self.gripper.baud_rate,
            positions=[int(round(self._raw_position(finger, start))) for finger in fingers])
        self.sensor = EmulatedSensor(sensor_link, signal_fn=self._scan_counts,
                                     seed=sensor_seed)
        self._lock = threading.RLock()
        self._arm_velocity = 0.0
        self._history = np.zeros((HISTORY_SAMPLES, N_CHANNELS), np.int64)
        self._produced = 0  # scene samples produced so far
        self._origin_us = 0  # device time of scene sample 0 [us]
        self._stop = threading.Event()
        self.failure = ''
        """Why the scene thread stopped (empty while it runs): from then on the servos no
        longer follow the scene and the scene advances only with the sensor's scans."""
        self._thread: threading.Thread | None = None
        self._drives = self._servo_drives()
        self._registers: dict[int, dict] = {}
        self.faults = tuple(faults)
        self._injector = ChannelFaultInjector(self.faults, seed=sensor_seed)
        self._operator = ScriptedOperator(self.scene.model)

    # ---- lifecycle ------------------------------------------------------------------
    def start(self) -> BenchTwin:
        """Open both ptys and start the devices and the real-time scene; returns self."""
        self.servos.start()  # a process: about a second, not simulated
        self._exchange()  # the horns at the scene's angle, driven from now on
        now_us = self.sensor.device_time_us()
        self._origin_us = now_us - now_us % _PERIOD_US  # scene time 0 is now
        self.sensor.start()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name='bench-twin', daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the scene thread and both devices."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        self.sensor.close()
        self.servos.stop()

    def __enter__(self) -> BenchTwin:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.close()

    @property
    def servo_device(self) -> str:
        """Path of the servo bus's pty (what the gripper driver's ``port`` opens)."""
        return self.servos.device_path

    # ---- inputs ---------------------------------------------------------------------
    def set_arm_velocity(self, velocity_z: float) -> None:
        """Commanded vertical arm velocity [m/s] (positive up); NaN/inf are refused."""
        if not math.isfinite(velocity_z):
            raise ValueError(f'arm velocity must be finite, got {velocity_z}')
        with self._lock:
            self._arm_velocity = float(velocity_z)

    def press(self, finger: int, location: float, force: float = 4.0, hold: float = 1.0,
              ramp: float = 0.25) -> tuple[int, int]:
        """A scripted operator presses one finger from the next scene sample on.

        Parameters
        ----------
        finger : int
            0 = left, 1 = right.
        location : float
            Pressed place, 0 = tip, 1 = root [-].
        force : float
            Peak force [N].
        hold, ramp : float
            Time at the peak force and rise / fall time [s].

        Returns
        -------
        tuple of int
            ``[start, stop)`` scene sample indices of the press.

        Raises
        ------
        ValueError
            On a finger, place or duration out of range.
        """
        with self._lock:
            press = OperatorPress(finger, location, force, self._produced, ramp, hold)
            self._operator.schedule(press)
            return press.start, press.stop

    @property
    def presses(self) -> tuple[OperatorPress, ...]:
        """The scripted operator's presses not yet over."""
        with self._lock:
            return self._operator.presses

    # ---- the scene in real time -----------------------------------------------------
    def sample_time_ns(self, index: int) -> int:
        """System (ROS) time at which the board sampled scene sample ``index`` [ns]: the
        time base of the driver's frame stamps (device clock mapped to host time), so a
        load cell stamped with it lines up with the frames."""
        device_us = self._origin_us + index * _PERIOD_US
        system_minus_monotonic = time.time_ns() - time.monotonic_ns()
        return self.sensor.host_ns_of_device_time(device_us) + system_minus_monotonic

    def sample_index_at(self, device_time_us: int) -> int:
        """Scene sample index of the sensor scan at ``device_time_us`` (device clock)."""
        return (device_time_us - self._origin_us) // _PERIOD_US

    def advance_to(self, index: int) -> None:
        """Advance the scene until its sample ``index`` exists (no-op if it does)."""
        with self._lock:
            while self._produced <= index:
                count = min(index + 1 - self._produced, TICK_SAMPLES)
                self._step(count)

    def _run(self) -> None:
        try:
            while not self._stop.wait(STEP_PERIOD):
                self._exchange()
                self.advance_to(self.sample_index_at(self.sensor.device_time_us()))
        except Exception as error:  # the servos stop following the scene: say so
            self.failure = f'{type(error).__name__}: {error}'
            traceback.print_exc()

    def _exchange(self) -> None:
        """One exchange with the servo process: the latest drives in, the registers out."""
        with self._lock:
            drives = self._drives
        registers = self.servos.exchange(drives)
        with self._lock:
            self._registers = {int(device_id): values for device_id, values in registers.items()}

    def _scan_counts(self, sequence: int, device_time_us: int) -> tuple[int, ...]:
        """The sensor board's signal: the scene's sample at the scan's time [counts]."""
        index = max(self.sample_index_at(device_time_us), 0)
        with self._lock:
            self.advance_to(index)
            oldest = self._produced - HISTORY_SAMPLES
            row = self._history[max(index, oldest) % HISTORY_SAMPLES]
            return tuple(int(value) for value in row)

    def _step(self, count: int) -> None:
        command, max_current, profile_velocity = self._servo_commands(self._registers)
        frames, truth = self.scene.step(count, command, self._arm_velocity,
                                        max_current=max_current,
                                        profile_velocity=profile_velocity)
        first = self._produced
        if self._operator.presses:
            frames = quantise(frames + self._operator.signal(first, count))
        frames = self._injector.apply(frames)
        counts = np.clip(np.rint(frames * COUNTS_PER_FULL_SCALE),
                         -COUNTS_PER_FULL_SCALE, COUNTS_PER_FULL_SCALE).astype(np.int64)
        rows = (self._produced + np.arange(count)) % HISTORY_SAMPLES
        self._history[rows] = counts
        self._produced += count
        self._drives = self._servo_drives()
        if self.on_truth is not None:
            self.on_truth(truth)

    # ---- servo registers <-> scene --------------------------------------------------
    @staticmethod
    def _raw_position(finger: FingerConfig, theta: float) -> float:
        """Servo position [pulse, fractional] of gripper angle ``theta`` [rad]."""
        return finger.zero_position + finger.direction * theta * _PULSES_PER_RADIAN

    def _servo_commands(self, registers: dict[int, dict]
                        ) -> tuple[float, float | None, float | None]:
        """(gripper angle [rad], current limit [A] or None, profile velocity [rad/s] or
        None) the servos' registers command; torque off holds the present angle."""
        servos = [registers[finger.servo_id] for finger in self.gripper.fingers]
        if not all(servo['torque'] for servo in servos):
            return self.scene.joint_position, None, None
        angles = [finger.raw_to_theta(servo['goal_position'])
                  for finger, servo in zip(self.gripper.fingers, servos)]
        current = min(min(abs(servo['goal_current']), servo['current_limit'])
                      for servo in servos)
        speed = min(servo['profile_velocity'] for servo in servos)
        max_current = units.current_units_to_amperes(current) or None
        profile = units.velocity_units_to_radians_per_second(speed) or None
        return sum(angles) / len(angles), max_current, profile

    def _servo_drives(self) -> dict[int, tuple[float, ...]]:
        """Present position [pulse], velocity [pulse/s] and current [2.69 mA units] of
        both servos from the scene (currents along theta, :attr:`Scene.joint_current_along_theta`:
        a finger squeezing, commanded at or below its angle, pushes closed)."""
        theta = self.scene.joint_position
        return {finger.servo_id: (
                    self._raw_position(finger, theta),
                    finger.direction * self.scene.joint_velocity * _PULSES_PER_RADIAN,
                    finger.direction * current / units.current_units_to_amperes(1))
                for finger, current in zip(self.gripper.fingers,
                                           self.scene.joint_current_along_theta)}
