"""Configuration of the FORTE gripper: its two finger servos and the limits it writes.

Pure (no I/O, no rclpy). Angle convention (paper, docs/contracts.md): theta = 0 rad is fully
closed, larger opens. Each finger maps theta to its servo's raw position with its own zero
(raw position at theta = 0) and direction (+1 or -1; the left finger is mirrored)::

    raw = zero_position + direction * theta / (2 pi / 4096)

:meth:`GripperConfig.validate` refuses a configuration that cannot be used, and
:meth:`GripperConfig.eeprom_targets` gives the register values written to each servo's
EEPROM at configure (operating mode 5 and the limits; see
:mod:`forte_driver.dynamixel.gripper` for how each limit is enforced).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.commands import GripperLimits
from forte_ros.contract import LEFT_FINGER_JOINT, RIGHT_FINGER_JOINT


@dataclass(frozen=True)
class FingerConfig:
    """One finger servo.

    Attributes
    ----------
    name : str
        ``'left'`` or ``'right'``.
    joint_name : str
        JointState name of the finger joint (``forte_ros.contract``, with the driver's
        ``prefix``).
    servo_id : int
        DYNAMIXEL id (0..252).
    zero_position : int
        Raw position [pulse] of the servo at theta = 0 (gripper fully closed).
    direction : int
        +1 if theta grows with the raw position, -1 if mirrored.
    """

    name: str
    joint_name: str
    servo_id: int
    zero_position: int = 2048
    direction: int = 1

    def theta_to_raw(self, theta: float) -> int:
        """Raw Goal Position [pulse] of gripper angle ``theta`` [rad]."""
        return self.zero_position + self.direction * units.radians_to_pulses(theta)

    def raw_to_theta(self, raw: float) -> float:
        """Gripper angle [rad] of raw position ``raw`` [pulse]."""
        return self.direction * units.pulses_to_radians(raw - self.zero_position)


@dataclass(frozen=True)
class GripperConfig:
    """Everything the gripper core needs; validated by :meth:`validate`.

    Attributes
    ----------
    port : str
        Serial device (e.g. ``/dev/ttyUSB0`` or a udev name).
    baud_rate : int
        Bus speed [bit/s]; must match the servos' Baud Rate register.
    right, left : FingerConfig
        Finger servos.
    limits : GripperLimits
        Limits written to the servos.
    default_current : float
        Goal Current [A] used when a command gives 0.
    default_profile_velocity : float
        Profile Velocity [rad/s] used when a command gives 0.
    profile_acceleration : int
        Profile Acceleration register value (214.577 rev/min^2 units; 0 = unlimited).
    retries : int
        Extra attempts of a single-servo transaction (ping, read, write: all idempotent)
        whose status packet was lost or corrupt. Sync reads of the state are not retried
        (the next sample follows); sync writes have no status packet.
    """

    port: str = '/dev/ttyUSB0'
    baud_rate: int = 4_000_000
    right: FingerConfig = field(default_factory=lambda: FingerConfig(
        'right', RIGHT_FINGER_JOINT, 1, 2048, 1))
    left: FingerConfig = field(default_factory=lambda: FingerConfig(
        'left', LEFT_FINGER_JOINT, 2, 2048, -1))
    limits: GripperLimits = field(default_factory=GripperLimits)
    default_current: float = 0.5
    default_profile_velocity: float = 1.0
    profile_acceleration: int = 0
    retries: int = 2

    @property
    def fingers(self) -> tuple[FingerConfig, FingerConfig]:
        """(left, right), the joint order of JointState."""
        return (self.left, self.right)

    def validate(self) -> None:
        """Raise ValueError with the reason if the configuration cannot be used."""
        problems = []
        if self.baud_rate not in ct.REGISTER_BY_BAUD_RATE:
            problems.append(f'baud_rate {self.baud_rate} is not a DYNAMIXEL rate '
                            f'({sorted(ct.REGISTER_BY_BAUD_RATE)})')
        if self.left.servo_id == self.right.servo_id:
            problems.append(f'both fingers have id {self.left.servo_id}')
        limits = self.limits
        if not (math.isfinite(limits.theta_min) and math.isfinite(limits.theta_max)
                and limits.theta_min < limits.theta_max):
            problems.append(f'theta range [{limits.theta_min}, {limits.theta_max}] rad is empty')
        for finger in self.fingers:
            if not 0 <= finger.servo_id <= 252:
                problems.append(f'{finger.name} id {finger.servo_id} outside 0..252')
            if finger.direction not in (-1, 1):
                problems.append(f'{finger.name} direction must be +1 or -1')
            if math.isfinite(limits.theta_min) and math.isfinite(limits.theta_max):
                low, high = self.position_limits(finger)
                if low < 0 or high > 4095:
                    problems.append(
                        f'{finger.name} theta range maps to raw {low}..{high}, outside the '
                        f'position limit registers 0..4095 (check zero_position/direction)')
        current_units = units.amperes_to_current_units(limits.current_limit)
        if not 1 <= current_units <= ct.CURRENT_LIMIT.maximum:
            problems.append(f'current_limit {limits.current_limit} A outside '
                            f'0.00269..{ct.CURRENT_LIMIT.maximum * 2.69e-3:.3f} A')
        velocity_units = units.radians_per_second_to_velocity_units(limits.velocity_limit)
        if not 1 <= velocity_units <= ct.VELOCITY_LIMIT.maximum:
            problems.append(f'velocity_limit {limits.velocity_limit} rad/s outside '
                            f'0.024..{ct.VELOCITY_LIMIT.maximum * 0.0239809:.2f} rad/s')
        if not 0 <= limits.temperature_limit <= 100:
            problems.append(f'temperature_limit {limits.temperature_limit} outside 0..100 degC')
        if not 0 < self.default_current <= limits.current_limit:
            problems.append(f'default_current {self.default_current} A not in '
                            f'(0, current_limit={limits.current_limit}]')
        if not 0 < self.default_profile_velocity <= limits.velocity_limit:
            problems.append(f'default_profile_velocity {self.default_profile_velocity} rad/s '
                            f'not in (0, velocity_limit={limits.velocity_limit}]')
        if not 0 <= self.profile_acceleration <= ct.PROFILE_ACCELERATION.maximum:
            problems.append('profile_acceleration outside 0..32767')
        if not 0 <= self.retries <= 10:
            problems.append(f'retries {self.retries} outside 0..10')
        if problems:
            raise ValueError('; '.join(problems))

    def position_limits(self, finger: FingerConfig) -> tuple[int, int]:
        """(Min, Max) Position Limit register values [pulse] of ``finger``."""
        a = finger.theta_to_raw(self.limits.theta_min)
        b = finger.theta_to_raw(self.limits.theta_max)
        return min(a, b), max(a, b)

    def eeprom_targets(self, finger: FingerConfig) -> dict[ct.Register, int]:
        """Register values written to ``finger``'s EEPROM at configure."""
        low, high = self.position_limits(finger)
        return {
            ct.OPERATING_MODE: ct.OPERATING_MODE_CURRENT_BASED_POSITION,
            ct.CURRENT_LIMIT: units.amperes_to_current_units(self.limits.current_limit),
            ct.VELOCITY_LIMIT: units.radians_per_second_to_velocity_units(
                self.limits.velocity_limit),
            ct.MAX_POSITION_LIMIT: high,
            ct.MIN_POSITION_LIMIT: low,
            ct.TEMPERATURE_LIMIT: int(self.limits.temperature_limit),
        }
