"""Single-servo transactions on one DYNAMIXEL bus through dynamixel-sdk (no rclpy).

The bus I/O under :class:`forte_driver.dynamixel.gripper.Gripper`: opening the serial port,
one read, write or ping of one servo with retries of a lost or corrupt status packet, and
the judgement of every status packet's error byte.

Status error byte (see :mod:`forte_driver.dynamixel.status_errors`): every status packet
of every transaction (ping, read, write, each servo's reply to a sync read) is counted in
:attr:`ServoBus.status_errors`; a non-zero error number raises :class:`StatusError` and
its data are never used; the alert bit alone does not invalidate the data but makes the
bus read Hardware Error Status and Torque Enable of that servo (:attr:`ServoBus.alerts`).
"""
from __future__ import annotations

from dynamixel_sdk import (
    COMM_RX_CORRUPT,
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    PacketHandler,
    PortHandler,
)

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel.status_errors import (
    ERROR_NUMBER_MASK,
    DynamixelError,
    HardwareAlert,
    StatusError,
    StatusErrorCounts,
)

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


def check_no_stuffing_needed(data: bytes, what: str) -> None:
    """Raise DynamixelError if ``data`` holds :data:`HEADER_PATTERN` (see there)."""
    if HEADER_PATTERN in data:
        raise DynamixelError(f'{what}: data {data.hex()} contains FF FF FD, which needs '
                             'byte stuffing that dynamixel-sdk 4.1.0 does not transmit')


class ServoBus:
    """Servos on one serial port, one transaction at a time, through dynamixel-sdk.

    Not thread-safe: call it from one thread (the node's executor thread).

    Parameters
    ----------
    port_name, baud_rate, retries
        As ``port``, ``baud_rate`` and ``retries`` of
        :class:`~forte_driver.dynamixel.gripper_config.GripperConfig`.
    """

    def __init__(self, port_name: str, baud_rate: int, retries: int):
        self.port_name = port_name
        self.baud_rate = baud_rate
        self.retries = retries
        self.port: PortHandler | None = None
        self.packet_handler = PacketHandler(PROTOCOL_VERSION)
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
        port = PortHandler(self.port_name)
        try:
            opened = port.openPort()
        except Exception as error:  # pyserial raises SerialException / OSError
            raise DynamixelError(f'cannot open {self.port_name}: {error}') from error
        if not opened:
            raise DynamixelError(f'cannot open {self.port_name}')
        if not port.setBaudRate(self.baud_rate):
            port.closePort()
            raise DynamixelError(f'{self.port_name}: baud rate {self.baud_rate} refused')
        port.ser.timeout = SERIAL_READ_BLOCK_S
        self.port = port

    def close(self) -> None:
        """Close the serial port (torque is left as it is)."""
        if self.port is not None and self.port.is_open:
            self.port.closePort()
        self.port = None

    def _require_port(self) -> PortHandler:
        if self.port is None or not self.port.is_open:
            raise DynamixelError('port is not open')
        return self.port

    # -- status packets ----------------------------------------------------------------
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

    # -- single-servo transactions -------------------------------------------------
    def _transaction(self, function, *args):
        """Run an idempotent SDK transaction, retrying a lost or corrupt status packet."""
        for attempt in range(self.retries + 1):
            outcome = function(self._require_port(), *args)
            if outcome[-2] not in RETRIED_RESULTS:
                break
            if attempt < self.retries:
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
        check_no_stuffing_needed(bytes([register.address & 0xFF, register.address >> 8])
                                 + ct.encode_value(register, value),
                                 f'servo {servo_id}: write {register.name}')
        result, error = self._transaction(
            self.packet_handler.writeTxRx, servo_id, register.address, register.size,
            list(ct.encode_value(register, value)))
        self._check(servo_id, f'write {register.name}={value}', result, error)

    def ping_model(self, servo_id: int) -> int:
        """Ping one servo; returns its model number (DynamixelError if it does not answer)."""
        model, result, error = self._transaction(self.packet_handler.ping, servo_id)
        self._check(servo_id, 'ping', result, error)
        return model
