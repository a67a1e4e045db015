"""Gripper limits and the validation of one command against them (pure, no I/O).

Non-finite values and negative current or velocity are refused (nothing is sent); 0
current / velocity mean "driver default"; values beyond the limits are clipped to them,
with the reason. :mod:`forte_driver.dynamixel.gripper` re-exports every name.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class GripperLimits:
    """Limits written into both servos' EEPROM at configure.

    Attributes
    ----------
    theta_min, theta_max : float
        Allowed gripper angle range [rad] (0 = fully closed).
    current_limit : float
        Current Limit [A] (the servo refuses larger Goal Currents); 0.00269..3.209 A.
    velocity_limit : float
        Velocity Limit [rad/s] (the servo refuses larger Profile Velocities); <= 24.5 rad/s.
    temperature_limit : int
        Temperature Limit [degC] (overheating error above it); 0..100.
    """

    theta_min: float = 0.0
    theta_max: float = 1.0
    current_limit: float = 1.0
    velocity_limit: float = 4.796
    temperature_limit: int = 70


@dataclass
class CommandCheck:
    """Outcome of validating one gripper command.

    Attributes
    ----------
    accepted : bool
        False if the command must not be sent (``reasons`` says why).
    theta : float
        Goal angle after clipping [rad].
    current : float
        Goal Current after defaulting/clipping [A].
    profile_velocity : float
        Profile Velocity after defaulting/clipping [rad/s].
    clipped : bool
        True if a value was changed to fit the limits.
    reasons : list of str
        Why the command was refused or clipped (empty if sent as given).
    hardware_error : bool
        True if refused because a servo has a latched hardware error with its torque off
        (or not known to be on): a command would not move it, so none is sent.
    """

    accepted: bool
    theta: float = 0.0
    current: float = 0.0
    profile_velocity: float = 0.0
    clipped: bool = False
    reasons: list[str] = field(default_factory=list)
    hardware_error: bool = False


def check_command(theta: float, current: float, profile_velocity: float,
                  limits: GripperLimits, default_current: float,
                  default_profile_velocity: float) -> CommandCheck:
    """Validate a command against the limits (pure; known-answer tested).

    Non-finite values and negative current or velocity are refused (nothing is sent);
    0 current / velocity mean "driver default"; values beyond the limits are clipped
    to them, with the reason.

    Parameters
    ----------
    theta : float
        Requested gripper angle [rad].
    current : float
        Requested current limit for the move [A]; 0 = default.
    profile_velocity : float
        Requested maximum speed [rad/s]; 0 = default.
    limits : GripperLimits
        Limits (normally as read back from the servos).
    default_current, default_profile_velocity : float
        Defaults [A], [rad/s].

    Returns
    -------
    CommandCheck
        The values to send, or a refusal.
    """
    names = {'position': theta, 'max_current': current, 'profile_velocity': profile_velocity}
    bad = [f'{name}={value} is not finite' for name, value in names.items()
           if not math.isfinite(value)]
    if bad:
        return CommandCheck(False, reasons=bad)
    if current < 0.0:
        return CommandCheck(False, reasons=[f'max_current={current} A is negative'])
    if profile_velocity < 0.0:
        return CommandCheck(False, reasons=[
            f'profile_velocity={profile_velocity} rad/s is negative'])
    check = CommandCheck(True, theta, current or default_current,
                         profile_velocity or default_profile_velocity)
    if theta < limits.theta_min or theta > limits.theta_max:
        check.theta = min(max(theta, limits.theta_min), limits.theta_max)
        check.reasons.append(f'position {theta:.4f} rad clipped to {check.theta:.4f} rad '
                             f'(limits {limits.theta_min:.4f}..{limits.theta_max:.4f})')
    if check.current > limits.current_limit:
        check.reasons.append(f'max_current {check.current:.3f} A clipped to current_limit '
                             f'{limits.current_limit:.3f} A')
        check.current = limits.current_limit
    if check.profile_velocity > limits.velocity_limit:
        check.reasons.append(f'profile_velocity {check.profile_velocity:.3f} rad/s clipped '
                             f'to velocity_limit {limits.velocity_limit:.3f} rad/s')
        check.profile_velocity = limits.velocity_limit
    check.clipped = bool(check.reasons)
    return check
