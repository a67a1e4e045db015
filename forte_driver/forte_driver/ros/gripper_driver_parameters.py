"""Parameters of the gripper driver node: declarations (descriptors, ranges) and the
:class:`~forte_driver.dynamixel.gripper.GripperConfig` they make.

Used by :mod:`forte_driver.ros.gripper_driver_node`; the parameter table of
docs/gripper_driver.md lists the same names. One table (:data:`PARAMETERS`) holds every
parameter's name, default, description and range; hardware parameters
(:data:`HARDWARE_PARAMETERS`) can change only while the node is unconfigured.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel.commands import GripperLimits
from forte_driver.dynamixel.gripper_config import FingerConfig, GripperConfig
from forte_ros.parameters import parameter_descriptor

LEFT_JOINT = 'forte_left_finger_joint'
RIGHT_JOINT = 'forte_right_finger_joint'

#: Parameters that describe the hardware; changeable only while unconfigured.
HARDWARE_PARAMETERS = (
    'port', 'baud_rate', 'right_id', 'left_id', 'right_zero_position', 'left_zero_position',
    'right_direction', 'left_direction', 'theta_min', 'theta_max', 'current_limit',
    'velocity_limit', 'temperature_limit', 'profile_acceleration', 'publish_rate',
    'diagnostics_rate',
)
HARDWARE_NOTE = ' (hardware parameter: change it only while unconfigured)'
"""Appended to the description of every hardware parameter."""
THETA_RANGE_RAD = (-math.pi, math.pi)
"""Allowed gripper angles [rad] of ``theta_min`` / ``theta_max``."""
CURRENT_RANGE_A = (0.00269, 3.20917)
"""Currents [A] the Current Limit register can hold (1..1193 x 2.69 mA)."""
VELOCITY_RANGE_RAD_S = (0.024, 24.5)
"""Velocities [rad/s] the Velocity Limit register can hold (about 1..1023 x 0.0239809)."""


@dataclass(frozen=True)
class DriverParameter:
    """One ROS parameter of the driver: name, default, description and allowed range.

    Attributes
    ----------
    name : str
        Parameter name.
    default : bool, int, float or str
        Default value; its type is the parameter's type.
    description : str
        What it sets; a hardware parameter (:data:`HARDWARE_PARAMETERS`) gets
        :data:`HARDWARE_NOTE` appended.
    value_range : tuple
        ``(low, high)`` or ``(low, high, step)``: an integer range for an int default, a
        floating point range for a float default; empty for none.
    read_only : bool
        Settable only at start.
    """

    name: str
    default: Any
    description: str
    value_range: tuple = ()
    read_only: bool = False

    def descriptor(self) -> ParameterDescriptor:
        """The descriptor declared with the parameter."""
        hardware = HARDWARE_NOTE if self.name in HARDWARE_PARAMETERS else ''
        bounds = self.value_range[:2] or None
        step = self.value_range[2] if len(self.value_range) > 2 else 1
        return parameter_descriptor(self.description + hardware, self.default, bounds,
                                    self.read_only, integer_step=step)


def _finger_parameters(side: str, servo_id: int, direction: int) -> tuple[DriverParameter, ...]:
    """The id, zero position and direction parameters of one finger servo."""
    return (
        DriverParameter(f'{side}_id', servo_id, f'DYNAMIXEL id of the {side} finger servo',
                        (0, 252)),
        DriverParameter(f'{side}_zero_position', 2048,
                        f'raw position [pulse, 0.088 deg] of the {side} servo when the '
                        'gripper is fully closed (theta = 0)', (0, 4095)),
        DriverParameter(f'{side}_direction', direction,
                        f'+1 if the {side} servo\'s raw position grows as theta opens, '
                        '-1 if mirrored', (-1, 1, 2)),
    )


#: Every parameter of the driver, in declaration order.
PARAMETERS: tuple[DriverParameter, ...] = (
    DriverParameter('port', '/dev/ttyUSB0',
                    'serial device of the U2D2 / DYNAMIXEL bus (use a udev name)'),
    DriverParameter('baud_rate', 4_000_000,
                    'bus speed [bit/s]; must equal the servos\' Baud Rate register; one of '
                    f'{sorted(ct.REGISTER_BY_BAUD_RATE)}', (9_600, 4_500_000)),
    *_finger_parameters('right', 1, 1),
    *_finger_parameters('left', 2, -1),
    DriverParameter('theta_min', 0.0,
                    'smallest gripper angle [rad] (0 = fully closed); written to the '
                    'servos\' position limit registers', THETA_RANGE_RAD),
    DriverParameter('theta_max', 1.0,
                    'largest gripper angle [rad] (open); written to the servos\' position '
                    'limit registers', THETA_RANGE_RAD),
    DriverParameter('current_limit', 1.0,
                    'Current Limit written to both servos [A] (2.69 mA units, max '
                    '3.209 A); the servos refuse larger goal currents', CURRENT_RANGE_A),
    DriverParameter('velocity_limit', 4.796,
                    'Velocity Limit written to both servos [rad/s] (0.229 rpm units)',
                    VELOCITY_RANGE_RAD_S),
    DriverParameter('temperature_limit', 70,
                    'Temperature Limit written to both servos [degC]; overheating '
                    'error above it', (0, 100)),
    DriverParameter('profile_acceleration', 0,
                    'Profile Acceleration register [214.577 rev/min^2 units]; '
                    '0 = unlimited', (0, 32767)),
    DriverParameter('publish_rate', 100.0,
                    'joint_states rate [Hz] (one sync read of both servos each)',
                    (1.0, 500.0)),
    DriverParameter('diagnostics_rate', 1.0, '/diagnostics rate [Hz]', (0.1, 10.0)),
    DriverParameter('default_current', 0.5,
                    'Goal Current [A] used when a command has max_current = 0 '
                    '(must not exceed current_limit)', CURRENT_RANGE_A),
    DriverParameter('default_profile_velocity', 1.0,
                    'Profile Velocity [rad/s] used when a command has '
                    'profile_velocity = 0 (must not exceed velocity_limit)', VELOCITY_RANGE_RAD_S),
    DriverParameter('release_on_shutdown', False,
                    'switch torque off on deactivate/shutdown (drops a held object); '
                    'false keeps holding the grip'),
    DriverParameter('autostart', False,
                    'configure and activate at start (no lifecycle manager needed)',
                    read_only=True),
)


def gripper_config(values: dict[str, Any]) -> GripperConfig:
    """The gripper configuration of the parameter values ``values`` (name -> value; every
    hardware parameter plus ``default_current`` and ``default_profile_velocity``)."""
    return GripperConfig(
        port=values['port'],
        baud_rate=values['baud_rate'],
        right=FingerConfig('right', RIGHT_JOINT, values['right_id'],
                           values['right_zero_position'], values['right_direction']),
        left=FingerConfig('left', LEFT_JOINT, values['left_id'],
                          values['left_zero_position'], values['left_direction']),
        limits=GripperLimits(values['theta_min'], values['theta_max'],
                             values['current_limit'], values['velocity_limit'],
                             values['temperature_limit']),
        default_current=values['default_current'],
        default_profile_velocity=values['default_profile_velocity'],
        profile_acceleration=values['profile_acceleration'],
    )
