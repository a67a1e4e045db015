"""The error byte of DYNAMIXEL protocol 2.0 status packets: judged, counted, named.

Every status packet a servo sends carries one error byte (e-manual, protocol 2.0):

* bits 0..6, the error number: 1 result fail, 2 instruction error, 3 CRC error, 4 data
  range error, 5 data length error, 6 data limit error, 7 access error. A reply with a
  non-zero error number is a refused or failed instruction: its data are not state and
  are never used (:class:`StatusError` is raised);
* bit 7, the alert bit: a hardware error is latched in the servo (read Hardware Error
  Status(70) to know which). The instruction itself was executed and the data of the
  reply are the servo's readings, so the alert bit alone does not invalidate a reply; it
  is counted and reported (and, with torque switched off by the servo's shutdown, the
  gripper refuses commands: see :mod:`forte_driver.dynamixel.gripper`).

dynamixel-sdk 4.1.0 (Python) drops the error byte of each servo's reply inside
``GroupSyncRead.rxPacket`` (the C++ SDK has ``getError(id)``, the installed Python one does
not), so :func:`sync_read_with_status` receives the replies itself, one status packet per
servo as ``rxPacket`` does, keeps each error byte and checks each packet's length (the
SDK's ``readRx`` checks only the id, so a late reply of another instruction of that servo
would be sliced into data).

Pure Python apart from dynamixel-sdk (no rclpy).
"""
from __future__ import annotations

import collections
from dataclasses import dataclass

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PacketHandler, PortHandler
from dynamixel_sdk.protocol2_packet_handler import (
    PKT_ERROR,
    PKT_ID,
    PKT_LENGTH_H,
    PKT_LENGTH_L,
    PKT_PARAMETER0,
)

from forte_driver.dynamixel import control_table as ct

ERROR_NUMBER_MASK = 0x7F
"""Bits 0..6 of the status error byte: the error number."""
ALERT_KIND = 'alert'
"""Counter name of status packets with the alert bit (bit 7) set."""
STATUS_ERROR_KINDS: tuple[str, ...] = (*ct.STATUS_ERROR_NAMES.values(), ALERT_KIND)
"""Every named kind, in error-number order, then the alert bit."""


class DynamixelError(RuntimeError):
    """A transaction with a servo failed (no answer, corrupt answer, or error in status)."""


class StatusError(DynamixelError):
    """One or more servos answered with a non-zero error number: the reply is not state.

    Attributes
    ----------
    what : str
        The transaction (e.g. ``'sync read of state'``, ``'write Torque Enable=1'``).
    errors : dict
        servo id -> error byte of its status packet (error number non-zero).
    """

    def __init__(self, what: str, errors: dict[int, int]):
        self.what = what
        self.errors = dict(errors)
        described = '; '.join(f'servo {servo_id}: {what}: {ct.status_error_text(error)} '
                              f'(status error byte 0x{error:02x})'
                              for servo_id, error in self.errors.items())
        super().__init__(described)


def status_error_kinds(error: int) -> list[str]:
    """Counter names of one status error byte (empty if the byte is 0).

    Parameters
    ----------
    error : int
        Status error byte (bit 7 alert, bits 0..6 error number).

    Returns
    -------
    list of str
        The error number's name (``'unknown error N'`` for numbers above 7), then
        ``'alert'`` if bit 7 is set.
    """
    kinds = []
    number = error & ERROR_NUMBER_MASK
    if number:
        kinds.append(ct.STATUS_ERROR_NAMES.get(number, f'unknown error {number}'))
    if error & ct.STATUS_ALERT_BIT:
        kinds.append(ALERT_KIND)
    return kinds


class StatusErrorCounts:
    """Status packets with a non-zero error byte, per servo and per kind.

    A packet with an error number and the alert bit counts once under each.
    """

    def __init__(self) -> None:
        self._counts: dict[int, collections.Counter[str]] = collections.defaultdict(
            collections.Counter)
        self.last_error: dict[int, str] = {}
        """servo id -> description of its last reply with an error number."""

    def record(self, servo_id: int, error: int, what: str = '') -> None:
        """Count the error byte ``error`` of one status packet from ``servo_id``."""
        if not error:
            return
        for kind in status_error_kinds(error):
            self._counts[servo_id][kind] += 1
        if error & ERROR_NUMBER_MASK:
            self.last_error[servo_id] = f'{what}: {ct.status_error_text(error)}'

    def of(self, servo_id: int) -> dict[str, int]:
        """kind -> count for one servo (kinds never seen are absent)."""
        return dict(self._counts.get(servo_id, {}))

    def error_replies(self, servo_id: int) -> int:
        """Replies of ``servo_id`` with a non-zero error number (alert not included)."""
        return sum(count for kind, count in self._counts.get(servo_id, {}).items()
                   if kind != ALERT_KIND)


@dataclass(frozen=True)
class HardwareAlert:
    """What the driver knows about a servo whose status packets carry the alert bit.

    Attributes
    ----------
    bits : int or None
        Hardware Error Status(70) read after the alert bit appeared (None: not read yet,
        the read failed; retried at the next status with the alert bit).
    torque_enabled : bool or None
        Torque Enable(64) read at the same time (None: unknown). False means the servo's
        shutdown switched the torque off: commands would not move it.
    """

    bits: int | None = None
    torque_enabled: bool | None = None

    @property
    def text(self) -> str:
        """Decoded Hardware Error Status, e.g. ``'overload error'``."""
        if self.bits is None:
            return 'Hardware Error Status not read'
        if self.bits == 0:
            return 'alert bit set but Hardware Error Status reads 0x00'
        return ct.hardware_error_text(self.bits)

    @property
    def blocks_commands(self) -> bool:
        """True unless torque is known to be still on (a non-shutdown error)."""
        return self.torque_enabled is not True


def sync_read_with_status(reader: GroupSyncRead, packet_handler: PacketHandler,
                          port: PortHandler, what: str) -> dict[int, tuple[bytes, int]]:
    """One SYNC READ: send the instruction, receive every servo's reply with its error byte.

    Parameters
    ----------
    reader : GroupSyncRead
        Its ids (``data_dict`` keys, in order) and block (``data_length`` bytes).
    packet_handler : PacketHandler
        Protocol 2.0 handler.
    port : PortHandler
        The open port.
    what : str
        Name of the transaction for error messages (e.g. ``'sync read of state'``).

    Returns
    -------
    dict
        servo id -> (data bytes, status error byte). The error byte is NOT judged here.

    Raises
    ------
    DynamixelError
        If the instruction cannot be sent or a servo's reply is lost or corrupt (no
        reply, no data: the servos after it are not waited for, as in the SDK).
    """
    result = reader.txPacket()
    if result != COMM_SUCCESS:
        raise DynamixelError(f'{what}: {packet_handler.getTxRxResult(result)}')
    replies = {}
    for servo_id in reader.data_dict:
        replies[servo_id] = _status_packet(packet_handler, port, servo_id,
                                           reader.data_length, what)
    return replies


#: Bytes a status packet's LENGTH field counts besides its data: instruction, error, CRC.
STATUS_LENGTH_OVERHEAD = 4


def _status_packet(packet_handler: PacketHandler, port: PortHandler, servo_id: int,
                   data_length: int, what: str) -> tuple[bytes, int]:
    """The next status packet of ``servo_id``: (its ``data_length`` data bytes, error byte).
    Packets of other ids are skipped (as the SDK does); one of another length without an
    error number is the late reply of another instruction and raises DynamixelError (its
    bytes are not data)."""
    while True:
        packet, result = packet_handler.rxPacket(port, False)
        if result != COMM_SUCCESS:
            raise DynamixelError(f'{what}: servo {servo_id}: '
                                 f'{packet_handler.getTxRxResult(result)}')
        if packet[PKT_ID] == servo_id:
            break
    length = packet[PKT_LENGTH_L] | packet[PKT_LENGTH_H] << 8
    refused = packet[PKT_ERROR] & ERROR_NUMBER_MASK  # a refusal may carry no data
    if length != data_length + STATUS_LENGTH_OVERHEAD and not refused:
        raise DynamixelError(f'{what}: servo {servo_id}: a status packet of '
                             f'{length - STATUS_LENGTH_OVERHEAD} data bytes, expected '
                             f'{data_length} (the late reply of another instruction)')
    data = bytes(packet[PKT_PARAMETER0 + 1:PKT_PARAMETER0 + 1 + data_length])
    return data, packet[PKT_ERROR]
