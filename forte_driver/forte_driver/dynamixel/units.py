"""Unit conversions of the XM430-W350 control table (pure functions, SI in and out).

Units (XM430-W350 e-manual): position 0.088 deg per pulse (exactly 360/4096 deg,
4096 pulses per revolution); current 2.69 mA per unit; velocity 0.229 rev/min per unit
(= 0.0239809 rad/s); temperature 1 degC; input voltage 0.1 V.
"""
from __future__ import annotations

import math

from forte_driver.dynamixel.control_table import PULSES_PER_REVOLUTION

RADIANS_PER_PULSE = 2.0 * math.pi / PULSES_PER_REVOLUTION
"""Position unit [rad] (0.08789 deg = 1.5340e-3 rad)."""
AMPERES_PER_CURRENT_UNIT = 2.69e-3
"""Current unit [A]."""
RPM_PER_VELOCITY_UNIT = 0.229
"""Velocity unit [rev/min]."""
RADIANS_PER_SECOND_PER_VELOCITY_UNIT = RPM_PER_VELOCITY_UNIT * 2.0 * math.pi / 60.0
"""Velocity unit [rad/s] (0.0239809)."""
VOLTS_PER_VOLTAGE_UNIT = 0.1
"""Input voltage unit [V]."""


def pulses_to_radians(pulses: float) -> float:
    """Servo angle [rad] of a position in pulses."""
    return pulses * RADIANS_PER_PULSE


def radians_to_pulses(radians: float) -> int:
    """Nearest position [pulse] to an angle [rad]."""
    return int(round(radians / RADIANS_PER_PULSE))


def current_units_to_amperes(units: float) -> float:
    """Current [A] of a Present/Goal Current value."""
    return units * AMPERES_PER_CURRENT_UNIT


def amperes_to_current_units(amperes: float) -> int:
    """Nearest current register value to a current [A] (rounded toward zero).

    Rounded toward zero so that a commanded current never exceeds the requested one.
    """
    return int(math.trunc(amperes / AMPERES_PER_CURRENT_UNIT + math.copysign(1e-9, amperes)))


def velocity_units_to_radians_per_second(units: float) -> float:
    """Angular velocity [rad/s] of a Present Velocity / Profile Velocity value."""
    return units * RADIANS_PER_SECOND_PER_VELOCITY_UNIT


def radians_per_second_to_velocity_units(radians_per_second: float) -> int:
    """Nearest velocity register value to an angular velocity [rad/s]."""
    return int(round(radians_per_second / RADIANS_PER_SECOND_PER_VELOCITY_UNIT))


def voltage_units_to_volts(units: float) -> float:
    """Input voltage [V] of a Present Input Voltage / voltage limit value."""
    return units * VOLTS_PER_VOLTAGE_UNIT
