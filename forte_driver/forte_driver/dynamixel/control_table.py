"""Control table of the ROBOTIS XM430-W350 (DYNAMIXEL protocol 2.0), as data.

One source of truth for addresses, sizes, access rights, value ranges and factory
defaults, shared by the gripper driver (which talks to real servos through
dynamixel-sdk) and by the simulated servo (which answers like a real one).

Facts from the XM430-W350 e-manual (ROBOTIS): EEPROM area 0..63 (writable only while
Torque Enable(64) is 0), RAM area from 64; Max/Min Position Limit(48/52) are only used in
Position Control Mode (operating mode 3), not in Extended Position (4) nor in
Current-based Position Control Mode (5); Goal Current(102) is limited to
+-Current Limit(38); Hardware Error Status(70) bits: 0 input voltage, 2 overheating,
3 motor encoder, 4 electrical shock, 5 overload.
"""
from __future__ import annotations

from dataclasses import dataclass

MODEL_NUMBER_XM430_W350 = 1020
"""Value of Model Number(0) of an XM430-W350, returned by PING."""

FIRMWARE_VERSION_SIMULATED = 48
"""Firmware Version(6) reported by the simulated servo."""

PULSES_PER_REVOLUTION = 4096
"""Encoder counts per output revolution (position unit 0.088 deg)."""

# Operating Mode(11) values.
OPERATING_MODE_CURRENT = 0
OPERATING_MODE_VELOCITY = 1
OPERATING_MODE_POSITION = 3
OPERATING_MODE_EXTENDED_POSITION = 4
OPERATING_MODE_CURRENT_BASED_POSITION = 5
OPERATING_MODE_PWM = 16
OPERATING_MODES = (0, 1, 3, 4, 5, 16)

EXTENDED_POSITION_RANGE = 1_048_575
"""Goal Position range (+-) in modes 4 and 5 [pulse] (-256..256 revolutions)."""

# Hardware Error Status(70) / Shutdown(63) bits.
HW_ERROR_INPUT_VOLTAGE = 0x01
HW_ERROR_OVERHEATING = 0x04
HW_ERROR_MOTOR_ENCODER = 0x08
HW_ERROR_ELECTRICAL_SHOCK = 0x10
HW_ERROR_OVERLOAD = 0x20
HARDWARE_ERROR_NAMES = {
    HW_ERROR_INPUT_VOLTAGE: 'input voltage error',
    HW_ERROR_OVERHEATING: 'overheating error',
    HW_ERROR_MOTOR_ENCODER: 'motor encoder error',
    HW_ERROR_ELECTRICAL_SHOCK: 'electrical shock error',
    HW_ERROR_OVERLOAD: 'overload error',
}

# Status packet error byte (protocol 2.0): bit 7 = alert (a hardware error is latched,
# read Hardware Error Status), bits 0..6 = error number.
STATUS_ALERT_BIT = 0x80
STATUS_ERROR_RESULT_FAIL = 0x01
STATUS_ERROR_INSTRUCTION = 0x02
STATUS_ERROR_CRC = 0x03
STATUS_ERROR_DATA_RANGE = 0x04
STATUS_ERROR_DATA_LENGTH = 0x05
STATUS_ERROR_DATA_LIMIT = 0x06
STATUS_ERROR_ACCESS = 0x07
STATUS_ERROR_NAMES = {
    STATUS_ERROR_RESULT_FAIL: 'result fail',
    STATUS_ERROR_INSTRUCTION: 'instruction error',
    STATUS_ERROR_CRC: 'CRC error',
    STATUS_ERROR_DATA_RANGE: 'data range error',
    STATUS_ERROR_DATA_LENGTH: 'data length error',
    STATUS_ERROR_DATA_LIMIT: 'data limit error',
    STATUS_ERROR_ACCESS: 'access error',
}

# Baud Rate(8) register value -> bits per second.
BAUD_RATE_BY_REGISTER = {
    0: 9_600,
    1: 57_600,
    2: 115_200,
    3: 1_000_000,
    4: 2_000_000,
    5: 3_000_000,
    6: 4_000_000,
    7: 4_500_000,
}
REGISTER_BY_BAUD_RATE = {baud: value for value, baud in BAUD_RATE_BY_REGISTER.items()}

EEPROM_END = 64
"""First address of the RAM area; addresses below are EEPROM."""


@dataclass(frozen=True)
class Register:
    """One item of the control table.

    Attributes
    ----------
    name : str
        Name of the item in the e-manual.
    address : int
        First byte address.
    size : int
        Size in bytes (1, 2 or 4), little-endian.
    writable : bool
        True if the host may write it (RW), False if read-only.
    signed : bool
        True if the value is a two's complement signed integer.
    minimum, maximum : int
        Valid range of written values (checked by the servo; Data Range Error).
    default : int
        Factory default.
    """

    name: str
    address: int
    size: int
    writable: bool
    signed: bool = False
    minimum: int = 0
    maximum: int = 0
    default: int = 0

    @property
    def eeprom(self) -> bool:
        """True if the item lies in the EEPROM area (written only with torque off)."""
        return self.address < EEPROM_END


def _rw(name, address, size, minimum, maximum, default, signed=False) -> Register:
    return Register(name, address, size, True, signed, minimum, maximum, default)


def _ro(name, address, size, default=0, signed=False) -> Register:
    return Register(name, address, size, False, signed, default=default)


GAIN_MAXIMUM = 16383
"""Largest value of every PID and feedforward gain item (all are 2 bytes, 0..16383)."""


def _gain(name, address, default) -> Register:
    return _rw(name, address, 2, 0, GAIN_MAXIMUM, default)


MODEL_NUMBER = _ro('Model Number', 0, 2, MODEL_NUMBER_XM430_W350)
MODEL_INFORMATION = _ro('Model Information', 2, 4)
FIRMWARE_VERSION = _ro('Firmware Version', 6, 1, FIRMWARE_VERSION_SIMULATED)
ID = _rw('ID', 7, 1, 0, 252, 1)
BAUD_RATE = _rw('Baud Rate', 8, 1, 0, 7, 1)
RETURN_DELAY_TIME = _rw('Return Delay Time', 9, 1, 0, 254, 250)
DRIVE_MODE = _rw('Drive Mode', 10, 1, 0, 13, 0)
OPERATING_MODE = _rw('Operating Mode', 11, 1, 0, 16, 3)
SECONDARY_ID = _rw('Secondary(Shadow) ID', 12, 1, 0, 255, 255)
PROTOCOL_TYPE = _rw('Protocol Type', 13, 1, 1, 2, 2)
HOMING_OFFSET = _rw('Homing Offset', 20, 4, -1_044_479, 1_044_479, 0, signed=True)
MOVING_THRESHOLD = _rw('Moving Threshold', 24, 4, 0, 1023, 10)
TEMPERATURE_LIMIT = _rw('Temperature Limit', 31, 1, 0, 100, 80)
MAX_VOLTAGE_LIMIT = _rw('Max Voltage Limit', 32, 2, 95, 160, 160)
MIN_VOLTAGE_LIMIT = _rw('Min Voltage Limit', 34, 2, 95, 160, 95)
PWM_LIMIT = _rw('PWM Limit', 36, 2, 0, 885, 885)
CURRENT_LIMIT = _rw('Current Limit', 38, 2, 0, 1193, 1193)
VELOCITY_LIMIT = _rw('Velocity Limit', 44, 4, 0, 1023, 200)
MAX_POSITION_LIMIT = _rw('Max Position Limit', 48, 4, 0, 4095, 4095)
MIN_POSITION_LIMIT = _rw('Min Position Limit', 52, 4, 0, 4095, 0)
STARTUP_CONFIGURATION = _rw('Startup Configuration', 60, 1, 0, 3, 0)
SHUTDOWN = _rw('Shutdown', 63, 1, 0, 255, 0x34)

TORQUE_ENABLE = _rw('Torque Enable', 64, 1, 0, 1, 0)
LED = _rw('LED', 65, 1, 0, 1, 0)
STATUS_RETURN_LEVEL = _rw('Status Return Level', 68, 1, 0, 2, 2)
REGISTERED_INSTRUCTION = _ro('Registered Instruction', 69, 1)
HARDWARE_ERROR_STATUS = _ro('Hardware Error Status', 70, 1)
VELOCITY_I_GAIN = _gain('Velocity I Gain', 76, 1920)
VELOCITY_P_GAIN = _gain('Velocity P Gain', 78, 100)
POSITION_D_GAIN = _gain('Position D Gain', 80, 0)
POSITION_I_GAIN = _gain('Position I Gain', 82, 0)
POSITION_P_GAIN = _gain('Position P Gain', 84, 800)
FEEDFORWARD_2ND_GAIN = _gain('Feedforward 2nd Gain', 88, 0)
FEEDFORWARD_1ST_GAIN = _gain('Feedforward 1st Gain', 90, 0)
BUS_WATCHDOG = _rw('Bus Watchdog', 98, 1, 0, 127, 0)
GOAL_PWM = _rw('Goal PWM', 100, 2, -885, 885, 0, signed=True)
GOAL_CURRENT = _rw('Goal Current', 102, 2, -1193, 1193, 0, signed=True)
GOAL_VELOCITY = _rw('Goal Velocity', 104, 4, -1023, 1023, 0, signed=True)
PROFILE_ACCELERATION = _rw('Profile Acceleration', 108, 4, 0, 32767, 0)
PROFILE_VELOCITY = _rw('Profile Velocity', 112, 4, 0, 32767, 0)
GOAL_POSITION = _rw('Goal Position', 116, 4, -EXTENDED_POSITION_RANGE,
                    EXTENDED_POSITION_RANGE, 0, signed=True)
REALTIME_TICK = _ro('Realtime Tick', 120, 2)
MOVING = _ro('Moving', 122, 1)
MOVING_STATUS = _ro('Moving Status', 123, 1)
PRESENT_PWM = _ro('Present PWM', 124, 2, signed=True)
PRESENT_CURRENT = _ro('Present Current', 126, 2, signed=True)
PRESENT_VELOCITY = _ro('Present Velocity', 128, 4, signed=True)
PRESENT_POSITION = _ro('Present Position', 132, 4, signed=True)
VELOCITY_TRAJECTORY = _ro('Velocity Trajectory', 136, 4, signed=True)
POSITION_TRAJECTORY = _ro('Position Trajectory', 140, 4, signed=True)
PRESENT_INPUT_VOLTAGE = _ro('Present Input Voltage', 144, 2)
PRESENT_TEMPERATURE = _ro('Present Temperature', 146, 1)

REGISTERS: tuple[Register, ...] = tuple(
    value for value in list(globals().values()) if isinstance(value, Register)
)
"""Every modelled item, in address order."""

REGISTER_BY_ADDRESS: dict[int, Register] = {r.address: r for r in REGISTERS}

CONTROL_TABLE_SIZE = 147
"""Bytes of the modelled table (0 .. Present Temperature(146)); indirect data not modelled."""

# Blocks the gripper driver moves in one packet.
COMMAND_BLOCK_START = GOAL_CURRENT.address
"""Sync write block: Goal Current(102) .. Goal Position(116), 18 bytes."""
COMMAND_BLOCK_LENGTH = GOAL_POSITION.address + GOAL_POSITION.size - GOAL_CURRENT.address
STATE_BLOCK_START = PRESENT_CURRENT.address
"""Sync read block: Present Current(126) .. Present Temperature(146), 21 bytes."""
STATE_BLOCK_LENGTH = (PRESENT_TEMPERATURE.address + PRESENT_TEMPERATURE.size
                      - PRESENT_CURRENT.address)


def hardware_error_text(bits: int) -> str:
    """Human-readable list of the Hardware Error Status bits set in ``bits``.

    Parameters
    ----------
    bits : int
        Value of Hardware Error Status(70).

    Returns
    -------
    str
        Comma-separated error names, ``'none'`` if no bit is set.
    """
    names = [name for bit, name in HARDWARE_ERROR_NAMES.items() if bits & bit]
    unknown = bits & ~sum(HARDWARE_ERROR_NAMES)
    if unknown:
        names.append(f'unknown bits 0x{unknown:02x}')
    return ', '.join(names) if names else 'none'


def status_error_text(error: int) -> str:
    """Human-readable meaning of the error byte of a status packet.

    Parameters
    ----------
    error : int
        Error byte (bit 7 alert, bits 0..6 error number).

    Returns
    -------
    str
        Description, ``'none'`` if zero.
    """
    parts = []
    number = error & 0x7F
    if number:
        parts.append(STATUS_ERROR_NAMES.get(number, f'unknown error {number}'))
    if error & STATUS_ALERT_BIT:
        parts.append('alert (hardware error latched)')
    return ', '.join(parts) if parts else 'none'


def encode_value(register: Register, value: int) -> bytes:
    """Little-endian bytes of ``value`` for ``register`` (two's complement if signed)."""
    return int(value).to_bytes(register.size, 'little', signed=register.signed)


def decode_value(register: Register, data: bytes | bytearray | list[int]) -> int:
    """Integer value of ``register`` from its little-endian bytes."""
    return int.from_bytes(bytes(data[: register.size]), 'little', signed=register.signed)
