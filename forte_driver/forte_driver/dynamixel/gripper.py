"""The FORTE gripper (two XM430-W350 finger servos) on top of dynamixel-sdk.

Pure core of the gripper driver (no rclpy): configuration and validation, the mapping
between the gripper angle theta and each servo's raw position, the limits written to
the servos' own EEPROM, one sync write per command and one sync read per state sample.

Angle convention (paper, docs/contracts.md): theta = 0 rad is fully closed, larger opens.
Each finger maps theta to its servo's raw position with its own zero (raw position at
theta = 0) and direction (+1 or -1; the left finger is mirrored)::

    raw = zero_position + direction * theta / (2 pi / 4096)

Velocities and currents are reported along theta too (positive = opening), so a finger
squeezing an object reports a negative effort on both fingers.

Note on position limits: the XM430-W350 applies Min/Max Position Limit(52/48) only in
Position Control Mode (3); in Current-based Position Control Mode (5), which this driver
uses, the servo firmware ignores them (e-manual). The driver therefore writes them (so the
servo's EEPROM is the single record of the allowed range, also used if someone switches
the servo to mode 3), reads them back, and clips every goal position to the read-back
registers itself. Current Limit(38) and Velocity Limit(44) are enforced by the servo in
mode 5: Goal Current beyond Current Limit and Profile Velocity beyond Velocity Limit are
refused by the firmware.

Status error byte (see :mod:`forte_driver.dynamixel.status_errors`): every status packet
of every transaction (ping, read, write, each servo's reply to a sync read) is counted in
:attr:`Gripper.status_errors`; a non-zero error number raises :class:`StatusError` and
its data are never used; the alert bit alone does not invalidate the data but makes the
gripper read Hardware Error Status and Torque Enable of that servo (:attr:`Gripper.alerts`)
and refuse commands while that servo's torque is not known to be on.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from dynamixel_sdk import (
    COMM_RX_CORRUPT,
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
    PortHandler,
)

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.commands import CommandCheck, GripperLimits, check_command
from forte_driver.dynamixel.status_errors import (
    ERROR_NUMBER_MASK,
    DynamixelError,
    HardwareAlert,
    StatusError,
    StatusErrorCounts,
    sync_read_with_status,
)

__all__ = ['CommandCheck', 'ConfigureReport', 'DynamixelError', 'FingerConfig', 'FingerState',
           'Gripper', 'GripperConfig', 'GripperLimits', 'StatusError', 'check_command']

PROTOCOL_VERSION = 2.0
SERIAL_READ_BLOCK_S = 0.001
"""pyserial read timeout set on the SDK's port [s]. dynamixel-sdk opens the port with
timeout 0 and polls it in a busy loop while waiting for a status packet (100 % of a core);
with a 1 ms blocking read the SDK's own packet timeouts are unchanged (they are checked
between reads) but the waiting thread sleeps in the kernel instead of spinning."""
RETRIED_RESULTS = (COMM_RX_TIMEOUT, COMM_RX_CORRUPT)
HEADER_PATTERN = b'\xff\xff\xfd'
"""Bytes that protocol 2.0 requires to be stuffed inside a packet. dynamixel-sdk 4.1.0
(Python) computes the stuffed packet but transmits the unstuffed one, so the driver
refuses to send data containing this pattern (its own values never do: positions,
currents and velocities it writes are small and non-negative)."""


def _check_no_stuffing_needed(data: bytes, what: str) -> None:
    if HEADER_PATTERN in data:
        raise DynamixelError(f'{what}: data {data.hex()} contains FF FF FD, which needs '
                             'byte stuffing that dynamixel-sdk 4.1.0 does not transmit')


@dataclass(frozen=True)
class FingerConfig:
    """One finger servo.

    Attributes
    ----------
    name : str
        ``'left'`` or ``'right'``.
    joint_name : str
        JointState name of the finger joint.
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
        'right', 'forte_right_finger_joint', 1, 2048, 1))
    left: FingerConfig = field(default_factory=lambda: FingerConfig(
        'left', 'forte_left_finger_joint', 2, 2048, -1))
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
    temperature: float
    input_voltage: float
    raw_position: int
    raw_current: int
    raw_velocity: int


@dataclass(frozen=True)
class ConfigureReport:
    """What :meth:`Gripper.configure` did.

    Attributes
    ----------
    written : dict
        servo id -> names of the EEPROM items that had to be written.
    read_back : dict
        servo id -> {item name: value read back after writing}.
    torque_was_disabled : list of int
        Ids whose torque had to be switched off to write EEPROM.
    """

    written: dict[int, list[str]]
    read_back: dict[int, dict[str, int]]
    torque_was_disabled: list[int]


class Gripper:
    """Two finger servos on one bus, through dynamixel-sdk.

    Not thread-safe: call it from one thread (the node's executor thread).

    Parameters
    ----------
    config : GripperConfig
        Validated on construction.
    """

    def __init__(self, config: GripperConfig):
        config.validate()
        self.config = config
        self.port: PortHandler | None = None
        self.packet_handler = PacketHandler(PROTOCOL_VERSION)
        self.limits = config.limits
        """Limits as read back from the servos (set by :meth:`configure`)."""
        self._sync_write: GroupSyncWrite | None = None
        self._state_read: GroupSyncRead | None = None
        self._error_read: GroupSyncRead | None = None
        self.retried_transactions = 0
        """Single-servo transactions that needed a retry (lost or corrupt status)."""
        self.status_errors = StatusErrorCounts()
        """Status packets with a non-zero error byte, per servo and per kind."""
        self.alerts: dict[int, HardwareAlert] = {}
        """Servos whose latest status packet had the alert bit (absent: no alert)."""
        self.alert_read_failures = 0
        """Reads of Hardware Error Status / Torque Enable after an alert bit that failed."""
        self._reading_alert = False

    # -- port --------------------------------------------------------------------
    @property
    def is_open(self) -> bool:
        """True while the serial port is open."""
        return self.port is not None and self.port.is_open

    def open(self) -> None:
        """Open the serial port at the configured baud rate (DynamixelError if impossible)."""
        port = PortHandler(self.config.port)
        try:
            opened = port.openPort()
        except Exception as error:  # pyserial raises SerialException / OSError
            raise DynamixelError(f'cannot open {self.config.port}: {error}') from error
        if not opened:
            raise DynamixelError(f'cannot open {self.config.port}')
        if not port.setBaudRate(self.config.baud_rate):
            port.closePort()
            raise DynamixelError(f'{self.config.port}: baud rate {self.config.baud_rate} refused')
        port.ser.timeout = SERIAL_READ_BLOCK_S
        self.port = port
        handler = self.packet_handler
        self._sync_write = GroupSyncWrite(port, handler, ct.COMMAND_BLOCK_START,
                                          ct.COMMAND_BLOCK_LENGTH)
        self._state_read = GroupSyncRead(port, handler, ct.STATE_BLOCK_START,
                                         ct.STATE_BLOCK_LENGTH)
        self._error_read = GroupSyncRead(port, handler, ct.HARDWARE_ERROR_STATUS.address,
                                         ct.HARDWARE_ERROR_STATUS.size)
        for finger in self.config.fingers:
            self._state_read.addParam(finger.servo_id)
            self._error_read.addParam(finger.servo_id)

    def close(self) -> None:
        """Close the serial port (torque is left as it is)."""
        if self.port is not None and self.port.is_open:
            self.port.closePort()
        self.port = None

    def _require_port(self) -> PortHandler:
        if self.port is None or not self.port.is_open:
            raise DynamixelError('port is not open')
        return self.port

    # -- single-servo transactions -------------------------------------------------
    def _check(self, servo_id: int, what: str, result: int, error: int) -> None:
        if result != COMM_SUCCESS:
            raise DynamixelError(f'servo {servo_id}: {what}: '
                                 f'{self.packet_handler.getTxRxResult(result)}')
        self._judge({servo_id: error}, what)

    def _judge(self, errors: dict[int, int], what: str) -> None:
        """Count each servo's status error byte, follow its alert bit, and raise
        :class:`StatusError` if any error number is non-zero (that reply is not used)."""
        for servo_id, error in errors.items():
            self.status_errors.record(servo_id, error, what)
            self._follow_alert(servo_id, bool(error & ct.STATUS_ALERT_BIT))
        failed = {servo_id: error for servo_id, error in errors.items()
                  if error & ERROR_NUMBER_MASK}
        if failed:
            raise StatusError(what, failed)

    def _follow_alert(self, servo_id: int, alert: bool) -> None:
        """On the first status with the alert bit, read Hardware Error Status and Torque
        Enable of that servo (once per alert, not every sample); forget it when a status
        comes without the alert bit (after a reboot)."""
        if not alert:
            self.alerts.pop(servo_id, None)
            return
        known = self.alerts.get(servo_id)
        if self._reading_alert or (known is not None and known.bits is not None):
            return
        self._reading_alert = True
        self.alerts[servo_id] = HardwareAlert()
        try:
            bits = self.read_register(servo_id, ct.HARDWARE_ERROR_STATUS)
            torque = bool(self.read_register(servo_id, ct.TORQUE_ENABLE))
            self.alerts[servo_id] = HardwareAlert(bits, torque)
        except DynamixelError:
            self.alert_read_failures += 1  # bits stay unknown: retried at the next alert
        finally:
            self._reading_alert = False

    def _transaction(self, function, *args):
        """Run an idempotent SDK transaction, retrying a lost or corrupt status packet."""
        for attempt in range(self.config.retries + 1):
            outcome = function(self._require_port(), *args)
            if outcome[-2] not in RETRIED_RESULTS:
                break
            if attempt < self.config.retries:
                self.retried_transactions += 1
        return outcome

    def read_register(self, servo_id: int, register: ct.Register) -> int:
        """Read one item of one servo (DynamixelError on failure)."""
        data, result, error = self._transaction(
            self.packet_handler.readTxRx, servo_id, register.address, register.size)
        self._check(servo_id, f'read {register.name}', result, error)
        return ct.decode_value(register, data)

    def write_register(self, servo_id: int, register: ct.Register, value: int) -> None:
        """Write one item of one servo and check its status packet."""
        _check_no_stuffing_needed(bytes([register.address & 0xFF, register.address >> 8])
                                  + ct.encode_value(register, value),
                                  f'servo {servo_id}: write {register.name}')
        result, error = self._transaction(
            self.packet_handler.writeTxRx, servo_id, register.address, register.size,
            list(ct.encode_value(register, value)))
        self._check(servo_id, f'write {register.name}={value}', result, error)

    def ping(self) -> dict[int, int]:
        """Ping both servos; returns id -> model number. DynamixelError if one is missing
        or is not an XM430-W350."""
        models = {}
        for finger in self.config.fingers:
            model, result, error = self._transaction(self.packet_handler.ping,
                                                     finger.servo_id)
            self._check(finger.servo_id, 'ping', result, error)
            if model != ct.MODEL_NUMBER_XM430_W350:
                raise DynamixelError(f'servo {finger.servo_id} ({finger.name}) is model '
                                     f'{model}, expected XM430-W350 '
                                     f'({ct.MODEL_NUMBER_XM430_W350})')
            models[finger.servo_id] = model
        return models

    # -- configuration -------------------------------------------------------------
    def configure(self) -> ConfigureReport:
        """Write operating mode 5 and the limits into both servos' EEPROM, read them back.

        Items that already hold the wanted value are not rewritten (EEPROM wear, and a
        servo that is holding an object keeps its torque if nothing needs writing). If an
        item must change while torque is on, torque is switched off first (EEPROM is
        write-protected with torque on) and the id is listed in the report.

        Raises
        ------
        DynamixelError
            On communication failure, a refused write, a read-back mismatch, or a latched
            hardware error (which only a reboot or power cycle clears).
        """
        written: dict[int, list[str]] = {}
        read_back: dict[int, dict[str, int]] = {}
        torque_disabled = []
        for finger in self.config.fingers:
            servo_id = finger.servo_id
            errors = self.read_register(servo_id, ct.HARDWARE_ERROR_STATUS)
            if errors:
                raise DynamixelError(
                    f'servo {servo_id} ({finger.name}) has a latched hardware error: '
                    f'{ct.hardware_error_text(errors)}; remove the cause, then reboot or '
                    f'power-cycle the servo')
            targets = self.config.eeprom_targets(finger)
            present = {register: self.read_register(servo_id, register)
                       for register in targets}
            changes = {r: v for r, v in targets.items() if present[r] != v}
            if changes and self.read_register(servo_id, ct.TORQUE_ENABLE):
                self.write_register(servo_id, ct.TORQUE_ENABLE, 0)
                torque_disabled.append(servo_id)
            for register, value in changes.items():
                self.write_register(servo_id, register, value)
            written[servo_id] = [register.name for register in changes]
            values = {register: self.read_register(servo_id, register) for register in targets}
            mismatched = [f'{r.name}: wrote {targets[r]}, read {v}'
                          for r, v in values.items() if v != targets[r]]
            if mismatched:
                raise DynamixelError(f'servo {servo_id} read-back mismatch: '
                                     + '; '.join(mismatched))
            read_back[servo_id] = {register.name: value for register, value in values.items()}
        self.limits = self.limits_from_registers(read_back)
        return ConfigureReport(written, read_back, torque_disabled)

    def limits_from_registers(self, read_back: dict[int, dict[str, int]]) -> GripperLimits:
        """Gripper limits implied by the registers read back (the tightest of both servos).

        The theta range is the intersection of both fingers' Min/Max Position Limit
        mapped back through zero and direction, so the driver clips to exactly what is in
        the servos' EEPROM.
        """
        theta_low, theta_high = -math.inf, math.inf
        current, velocity, temperature = math.inf, math.inf, 100
        for finger in self.config.fingers:
            values = read_back[finger.servo_id]
            ends = sorted(finger.raw_to_theta(values[name]) + 0.0
                          for name in (ct.MIN_POSITION_LIMIT.name, ct.MAX_POSITION_LIMIT.name))
            theta_low, theta_high = max(theta_low, ends[0]), min(theta_high, ends[1])
            current = min(current, units.current_units_to_amperes(
                values[ct.CURRENT_LIMIT.name]))
            velocity = min(velocity, units.velocity_units_to_radians_per_second(
                values[ct.VELOCITY_LIMIT.name]))
            temperature = min(temperature, values[ct.TEMPERATURE_LIMIT.name])
        return GripperLimits(theta_low, theta_high, current, velocity, temperature)

    # -- torque ---------------------------------------------------------------------
    def torque_enabled(self) -> dict[int, bool]:
        """id -> Torque Enable(64) (also updates :attr:`alerts`)."""
        return {f.servo_id: self.read_torque(f.servo_id) for f in self.config.fingers}

    def read_torque(self, servo_id: int) -> bool:
        """Torque Enable(64) of one servo (also updates its entry in :attr:`alerts`)."""
        enabled = bool(self.read_register(servo_id, ct.TORQUE_ENABLE))
        if servo_id in self.alerts:
            self.alerts[servo_id] = HardwareAlert(self.alerts[servo_id].bits, enabled)
        return enabled

    def set_torque(self, enabled: bool) -> None:
        """Switch both servos' torque on or off (checked per servo)."""
        for finger in self.config.fingers:
            self.write_register(finger.servo_id, ct.TORQUE_ENABLE, int(enabled))
        if enabled:
            # A servo with a latched shutdown error silently keeps torque off.
            refused = [i for i, on in self.torque_enabled().items() if not on]
            if refused:
                raise DynamixelError(f'servo(s) {refused} refused torque on (hardware error '
                                     f'latched; reboot required)')

    def hold_present_position(self) -> CommandCheck:
        """Command each finger to stay where it is (before torque on: no jump)."""
        state = self.read_state()
        by_name = {finger.name: state[finger.name] for finger in self.config.fingers}
        raw = {finger.servo_id: by_name[finger.name].raw_position
               for finger in self.config.fingers}
        check = CommandCheck(True, sum(s.theta for s in by_name.values()) / 2.0,
                             self.config.default_current,
                             self.config.default_profile_velocity)
        self._send(check, raw)
        return check

    # -- command and state -------------------------------------------------------------
    def check(self, theta: float, current: float, profile_velocity: float) -> CommandCheck:
        """:func:`check_command` against the limits read back from the servos."""
        return check_command(theta, current, profile_velocity, self.limits,
                             min(self.config.default_current, self.limits.current_limit),
                             min(self.config.default_profile_velocity,
                                 self.limits.velocity_limit))

    def command(self, theta: float, current: float = 0.0,
                profile_velocity: float = 0.0) -> CommandCheck:
        """Validate and send one command to both fingers in ONE sync write packet.

        Parameters
        ----------
        theta : float
            Gripper angle [rad].
        current : float
            Goal Current [A] (0 = default).
        profile_velocity : float
            Profile Velocity [rad/s] (0 = default).

        Returns
        -------
        CommandCheck
            What was sent (or why nothing was sent: ``accepted`` False; with
            ``hardware_error`` True if a servo has a latched hardware error and its torque
            is not known to be on, since a sync write has no status to tell it failed).
        """
        blocked = [f'servo {servo_id}: hardware error latched ({alert.text}), torque '
                   f'{"off" if alert.torque_enabled is False else "state unknown"}; remove '
                   'the cause, reboot or power-cycle the servo, then configure and activate'
                   for servo_id, alert in sorted(self.alerts.items()) if alert.blocks_commands]
        if blocked:
            return CommandCheck(False, reasons=blocked, hardware_error=True)
        check = self.check(theta, current, profile_velocity)
        if check.accepted:
            raw = {f.servo_id: f.theta_to_raw(check.theta) for f in self.config.fingers}
            self._send(check, raw)
        return check

    def _send(self, check: CommandCheck, raw_positions: dict[int, int]) -> None:
        sync_write = self._sync_write
        if sync_write is None:
            raise DynamixelError('port is not open')
        current_units = min(units.amperes_to_current_units(check.current),
                            units.amperes_to_current_units(self.limits.current_limit))
        velocity_units = min(units.radians_per_second_to_velocity_units(
            check.profile_velocity), units.radians_per_second_to_velocity_units(
            self.limits.velocity_limit))
        sync_write.clearParam()
        for finger in self.config.fingers:
            block = (ct.encode_value(ct.GOAL_CURRENT, current_units)
                     + ct.encode_value(ct.GOAL_VELOCITY, 0)
                     + ct.encode_value(ct.PROFILE_ACCELERATION,
                                       self.config.profile_acceleration)
                     + ct.encode_value(ct.PROFILE_VELOCITY, velocity_units)
                     + ct.encode_value(ct.GOAL_POSITION, raw_positions[finger.servo_id]))
            sync_write.addParam(finger.servo_id, list(block))
        payload = b''.join(bytes([i]) + bytes(d) for i, d in sync_write.data_dict.items())
        _check_no_stuffing_needed(payload, 'sync write')
        result = sync_write.txPacket()
        if result != COMM_SUCCESS:
            raise DynamixelError(f'sync write: {self.packet_handler.getTxRxResult(result)}')

    def read_state(self) -> dict[str, FingerState]:
        """One sync read of both fingers; ``{'left': FingerState, 'right': FingerState}``.

        Raises DynamixelError if any servo does not answer (no value is ever invented), and
        StatusError if any reply has a non-zero error number (its data are not used). A
        reply with the alert bit alone is used (see :attr:`alerts`).
        """
        reader = self._state_read
        if reader is None:
            raise DynamixelError('port is not open')
        replies = sync_read_with_status(reader, self.packet_handler, self._require_port(),
                                        'sync read of state')
        self._judge({servo_id: error for servo_id, (_, error) in replies.items()},
                    'sync read of state')
        states = {}
        for finger in self.config.fingers:
            data = replies[finger.servo_id][0]
            if len(data) != ct.STATE_BLOCK_LENGTH:
                raise DynamixelError(f'servo {finger.servo_id}: short state block')

            def item(register: ct.Register, block: bytes = data) -> int:
                return ct.decode_value(register, block[register.address - ct.STATE_BLOCK_START:])

            raw_position = item(ct.PRESENT_POSITION)
            raw_velocity = item(ct.PRESENT_VELOCITY)
            raw_current = item(ct.PRESENT_CURRENT)
            states[finger.name] = FingerState(
                theta=finger.raw_to_theta(raw_position) + 0.0,  # + 0.0: no negative zero
                velocity=finger.direction * units.velocity_units_to_radians_per_second(
                    raw_velocity) + 0.0,
                effort=finger.direction * units.current_units_to_amperes(raw_current) + 0.0,
                temperature=float(item(ct.PRESENT_TEMPERATURE)),
                input_voltage=units.voltage_units_to_volts(item(ct.PRESENT_INPUT_VOLTAGE)),
                raw_position=raw_position,
                raw_current=raw_current,
                raw_velocity=raw_velocity,
            )
        return states

    def read_hardware_errors(self) -> dict[int, int]:
        """One sync read of Hardware Error Status(70): id -> error bits (status checked)."""
        reader = self._error_read
        if reader is None:
            raise DynamixelError('port is not open')
        what = 'sync read of hardware error status'
        replies = sync_read_with_status(reader, self.packet_handler, self._require_port(), what)
        self._judge({servo_id: error for servo_id, (_, error) in replies.items()}, what)
        if any(len(data) != 1 for data, _ in replies.values()):
            raise DynamixelError(f'{what}: short reply')
        bits = {servo_id: data[0] for servo_id, (data, _) in replies.items()}
        for servo_id, alert in list(self.alerts.items()):
            self.alerts[servo_id] = HardwareAlert(bits.get(servo_id), alert.torque_enabled)
        return bits

    def shutdown(self, release: bool) -> None:
        """End of use: keep holding the grip (torque on) unless ``release``; close the port."""
        try:
            if release and self.is_open:
                self.set_torque(False)
        finally:
            self.close()
