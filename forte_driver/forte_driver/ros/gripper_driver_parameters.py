"""Parameters of the gripper driver node: declarations (descriptors, ranges) and the
:class:`~forte_driver.dynamixel.gripper.GripperConfig` they make.

Used by :mod:`forte_driver.ros.gripper_driver_node`; the parameter table of
docs/gripper_driver.md lists the same names. One table (:data:`PARAMETERS`) holds every
parameter's name, default, description and range; hardware parameters
(:data:`HARDWARE_PARAMETERS`) can change only while the node is unconfigured.
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import replace
from typing import Any

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel.gripper_config import GripperConfig
from forte_ros.contract import LEFT_FINGER_JOINT, RIGHT_FINGER_JOINT, prefixed
from forte_ros.parameter_table import ParameterSpec, parameter_table, replace_fields

#: Joint names without prefix (forte_ros.contract), kept here for the driver's importers.
LEFT_JOINT = LEFT_FINGER_JOINT
RIGHT_JOINT = RIGHT_FINGER_JOINT

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


def _finger_parameters(side: str) -> tuple[ParameterSpec, ...]:
    """The id, zero position and direction parameters of one finger servo (defaults: the
    :class:`~forte_driver.dynamixel.gripper_config.FingerConfig` of that side)."""
    return (
        ParameterSpec(f'{side}_id', int, f'DYNAMIXEL id of the {side} finger servo', low=0,
                      high=252, field=f'{side}.servo_id'),
        ParameterSpec(f'{side}_zero_position', int, f'raw position [pulse, 0.088 deg] of the '
                      f'{side} servo when the gripper is fully closed (theta = 0)', low=0,
                      high=4095, field=f'{side}.zero_position'),
        ParameterSpec(f'{side}_direction', int, f"+1 if the {side} servo's raw position grows "
                      'as theta opens, -1 if mirrored', low=-1, high=1, integer_step=2,
                      field=f'{side}.direction'),
    )


def _with_hardware_note(specs: Iterable[ParameterSpec]) -> list[ParameterSpec]:
    """``specs`` with :data:`HARDWARE_NOTE` appended to the hardware parameters'
    descriptions."""
    return [replace(spec, description=spec.description + HARDWARE_NOTE)
            if spec.name in HARDWARE_PARAMETERS else spec for spec in specs]


#: Every parameter of the driver, in declaration order. Defaults: the fields of
#: :class:`~forte_driver.dynamixel.gripper_config.GripperConfig` (``field``), the node-only
#: ones here.
PARAMETERS: dict[str, ParameterSpec] = parameter_table(_with_hardware_note([
    ParameterSpec('port', str, 'serial device of the U2D2 / DYNAMIXEL bus (use a udev name)',
                  field='port'),
    ParameterSpec('baud_rate', int, "bus speed [bit/s]; must equal the servos' Baud Rate "
                  f'register; one of {sorted(ct.REGISTER_BY_BAUD_RATE)}', low=9_600,
                  high=4_500_000, field='baud_rate'),
    *_finger_parameters('right'),
    *_finger_parameters('left'),
    ParameterSpec('theta_min', float, 'smallest gripper angle [rad] (0 = fully closed); '
                  "written to the servos' position limit registers", low=THETA_RANGE_RAD[0],
                  high=THETA_RANGE_RAD[1], field='limits.theta_min'),
    ParameterSpec('theta_max', float, "largest gripper angle [rad] (open); written to the "
                  "servos' position limit registers", low=THETA_RANGE_RAD[0],
                  high=THETA_RANGE_RAD[1], field='limits.theta_max'),
    ParameterSpec('current_limit', float, 'Current Limit written to both servos [A] (2.69 mA '
                  'units, max 3.209 A); the servos refuse larger goal currents',
                  low=CURRENT_RANGE_A[0], high=CURRENT_RANGE_A[1], field='limits.current_limit'),
    ParameterSpec('velocity_limit', float, 'Velocity Limit written to both servos [rad/s] '
                  '(0.229 rpm units)', low=VELOCITY_RANGE_RAD_S[0], high=VELOCITY_RANGE_RAD_S[1],
                  field='limits.velocity_limit'),
    ParameterSpec('temperature_limit', int, 'Temperature Limit written to both servos [degC]; '
                  'overheating error above it', low=0, high=100,
                  field='limits.temperature_limit'),
    ParameterSpec('profile_acceleration', int, 'Profile Acceleration register [214.577 '
                  'rev/min^2 units]; 0 = unlimited', low=0, high=32767,
                  field='profile_acceleration'),
    ParameterSpec('publish_rate', float, 'joint_states rate [Hz] (one sync read of both servos '
                  'each)', low=1.0, high=500.0, default=100.0),
    ParameterSpec('diagnostics_rate', float, '/diagnostics rate [Hz]', low=0.1, high=10.0,
                  default=1.0),
    ParameterSpec('default_current', float, 'Goal Current [A] used when a command has '
                  'max_current = 0 (must not exceed current_limit)', low=CURRENT_RANGE_A[0],
                  high=CURRENT_RANGE_A[1], field='default_current'),
    ParameterSpec('default_profile_velocity', float, 'Profile Velocity [rad/s] used when a '
                  'command has profile_velocity = 0 (must not exceed velocity_limit)',
                  low=VELOCITY_RANGE_RAD_S[0], high=VELOCITY_RANGE_RAD_S[1],
                  field='default_profile_velocity'),
    ParameterSpec('release_on_shutdown', bool, 'switch torque off on deactivate/shutdown '
                  '(drops a held object); false keeps holding the grip', default=False),
    ParameterSpec('autostart', bool, 'configure and activate at start (no lifecycle manager '
                  'needed)', default=False, read_only=True),
    ParameterSpec('prefix', str, 'TF / joint-name prefix prepended to the joint names of '
                  "joint_states (e.g. right_ for a second gripper; '' = none)", default='',
                  read_only=True),
    ParameterSpec('grasp_state_timeout', float, 'a grasp/state older than this no longer '
                  'gives the grasp controller the servos (gripper/joint_commands act again; '
                  'the controller publishes it at least once a second)', 's', 0.5, 60.0,
                  default=3.0),
]))


def gripper_config(values: dict[str, Any]) -> GripperConfig:
    """The gripper configuration of the parameter values ``values`` (name -> value): the
    default :class:`GripperConfig` with the field of every parameter in ``values`` replaced
    (node-only parameters are ignored), its finger joint names with ``values['prefix']``
    prepended."""
    config = replace_fields(GripperConfig(), PARAMETERS, values)
    prefix = str(values.get('prefix', ''))
    if not prefix:
        return config
    return replace(config, **{side: replace(finger, joint_name=prefixed(finger.joint_name,
                                                                         prefix))
                              for side, finger in (('left', config.left),
                                                   ('right', config.right))})
