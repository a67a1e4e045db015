"""The FORTE gripper (two XM430-W350 finger servos) on top of dynamixel-sdk.

Pure core of the gripper driver (no rclpy): the limits written to the servos' own EEPROM,
one sync write per command and one sync read per state sample. The configuration and the
theta <-> raw position mapping are in :mod:`.gripper_config`, the single-servo transactions
and the status error byte in :mod:`.servo_bus`, the decoding of a state sample in
:mod:`.finger_state`; this module re-exports their public names (and those of
:mod:`.commands` and :mod:`.status_errors`), so ``from forte_driver.dynamixel.gripper
import ...`` keeps working for all of them.

Angle convention (paper, docs/contracts.md): theta = 0 rad is fully closed, larger opens.
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

Status error byte: every status packet is judged by :class:`.servo_bus.ServoBus` (a
non-zero error number raises :class:`StatusError`, the alert bit fills
:attr:`Gripper.alerts`); the gripper refuses commands while a servo with the alert bit
does not have its torque known to be on.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, GroupSyncWrite

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.commands import CommandCheck, GripperLimits, check_command
from forte_driver.dynamixel.finger_state import FingerState, decode_finger_state
from forte_driver.dynamixel.gripper_config import FingerConfig, GripperConfig
from forte_driver.dynamixel.servo_bus import ServoBus, check_no_stuffing_needed
from forte_driver.dynamixel.status_errors import (
    DynamixelError,
    HardwareAlert,
    StatusError,
    sync_read_with_status,
)

__all__ = ['CommandCheck', 'ConfigureReport', 'DynamixelError', 'FingerConfig', 'FingerState',
           'Gripper', 'GripperConfig', 'GripperLimits', 'StatusError', 'check_command']


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


class Gripper(ServoBus):
    """Two finger servos on one bus, through dynamixel-sdk.

    Not thread-safe: call it from one thread (the node's executor thread). The port, the
    single-servo transactions (:meth:`read_register`, :meth:`write_register`) and the
    status counters (:attr:`status_errors`, :attr:`alerts`, :attr:`retried_transactions`,
    :attr:`alert_read_failures`) come from :class:`.servo_bus.ServoBus`.

    Parameters
    ----------
    config : GripperConfig
        Validated on construction.
    """

    def __init__(self, config: GripperConfig):
        config.validate()
        super().__init__(config.port, config.baud_rate, config.retries)
        self.config = config
        self.limits = config.limits
        """Limits as read back from the servos (set by :meth:`configure`)."""
        self._sync_write: GroupSyncWrite | None = None
        self._state_read: GroupSyncRead | None = None
        self._error_read: GroupSyncRead | None = None

    def open(self) -> None:
        """Open the serial port at the configured baud rate (DynamixelError if impossible)."""
        super().open()
        port, handler = self.port, self.packet_handler
        self._sync_write = GroupSyncWrite(port, handler, ct.COMMAND_BLOCK_START,
                                          ct.COMMAND_BLOCK_LENGTH)
        self._state_read = GroupSyncRead(port, handler, ct.STATE_BLOCK_START,
                                         ct.STATE_BLOCK_LENGTH)
        self._error_read = GroupSyncRead(port, handler, ct.HARDWARE_ERROR_STATUS.address,
                                         ct.HARDWARE_ERROR_STATUS.size)
        for finger in self.config.fingers:
            self._state_read.addParam(finger.servo_id)
            self._error_read.addParam(finger.servo_id)

    def ping(self) -> dict[int, int]:
        """Ping both servos; returns id -> model number. DynamixelError if one is missing
        or is not an XM430-W350."""
        models = {}
        for finger in self.config.fingers:
            model = self.ping_model(finger.servo_id)
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
        check_no_stuffing_needed(payload, 'sync write')
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
        return {finger.name: decode_finger_state(finger, replies[finger.servo_id][0])
                for finger in self.config.fingers}

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
