"""One finger's state in SI units, decoded from the state block a sync read returns (pure).

Velocities, currents and efforts are reported along theta (positive = opening), so a finger
squeezing an object reports a negative current and effort on both fingers. The effort is the
joint torque [N m] = servo current x :data:`forte_ros.contract.SERVO_TORQUE_CONSTANT` (the
finger joint is the servo horn, 1:1).
"""
from __future__ import annotations

from dataclasses import dataclass

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.gripper_config import FingerConfig
from forte_driver.dynamixel.status_errors import DynamixelError
from forte_ros.contract import current_to_effort


@dataclass(frozen=True)
class FingerState:
    """One finger at one instant, in SI units along theta (positive = opening).

    Attributes
    ----------
    theta : float
        Angle [rad].
    velocity : float
        Angular velocity [rad/s].
    effort : float
        Joint torque [N m]: ``current`` x the servo torque constant (linear model,
        :data:`forte_ros.contract.SERVO_TORQUE_CONSTANT`), sign along theta.
    current : float
        Motor current [A] (Present Current x 2.69 mA, sign along theta).
    temperature : float
        Internal temperature [degC].
    input_voltage : float
        Supply voltage [V].
    raw_position : int
        Present Position [pulse].
    raw_current : int
        Present Current [2.69 mA units], servo sign.
    raw_velocity : int
        Present Velocity [0.229 rpm units], servo sign.
    """

    theta: float
    velocity: float
    effort: float
    current: float
    temperature: float
    input_voltage: float
    raw_position: int
    raw_current: int
    raw_velocity: int


def decode_finger_state(finger: FingerConfig, block: bytes) -> FingerState:
    """The state of ``finger`` from its reply to the state sync read.

    Parameters
    ----------
    finger : FingerConfig
        The finger whose servo sent ``block`` (zero and direction map it to theta).
    block : bytes
        Present Current(126) .. Present Temperature(146), :data:`ct.STATE_BLOCK_LENGTH`
        bytes.

    Returns
    -------
    FingerState

    Raises
    ------
    DynamixelError
        If ``block`` is shorter than the state block.
    """
    if len(block) != ct.STATE_BLOCK_LENGTH:
        raise DynamixelError(f'servo {finger.servo_id}: short state block')

    def item(register: ct.Register) -> int:
        return ct.decode_value(register, block[register.address - ct.STATE_BLOCK_START:])

    raw_position = item(ct.PRESENT_POSITION)
    raw_velocity = item(ct.PRESENT_VELOCITY)
    raw_current = item(ct.PRESENT_CURRENT)
    current = finger.direction * units.current_units_to_amperes(raw_current) + 0.0
    return FingerState(
        theta=finger.raw_to_theta(raw_position) + 0.0,  # + 0.0: no negative zero
        velocity=finger.direction * units.velocity_units_to_radians_per_second(
            raw_velocity) + 0.0,
        effort=current_to_effort(current) + 0.0,
        current=current,
        temperature=float(item(ct.PRESENT_TEMPERATURE)),
        input_voltage=units.voltage_units_to_volts(item(ct.PRESENT_INPUT_VOLTAGE)),
        raw_position=raw_position,
        raw_current=raw_current,
        raw_velocity=raw_velocity,
    )
