"""Status error injection for the simulated XM430-W350 bus (:mod:`.simulated_servo_bus`).

A test asks for an error number (1 result fail .. 7 access error, or any other 1..127) in
the status packets one servo sends in reply to one instruction (``'ping'``, ``'read'``,
``'write'``, ``'sync read'``, ``'reboot'``, or its number), optionally only for one start
address, for the next ``count`` replies or until cleared. The servo then answers that
instruction as it does when it refuses it: the instruction is not executed (a refused WRITE
changes nothing, a refused REBOOT does not reboot) and the status carries the error number,
OR-ed with the alert bit while a hardware error is latched, like every status. By default
the reply still carries the data a successful READ / SYNC READ / PING would carry, so the
host must reject it for its error byte alone, not for a short packet; ``keep_data=False``
sends the status without data.

The alert bit itself is injected with a hardware error (``inject_hardware_error`` of the
bus): the servo latches Hardware Error Status, switches torque off for bits in
Shutdown(63), and sets the alert bit in every status until REBOOT.
"""
from __future__ import annotations

from dataclasses import dataclass

from forte_driver.dynamixel import protocol as proto

INSTRUCTION_BY_NAME = {name: number for number, name in proto.INSTRUCTION_NAMES.items()}
INJECTABLE_INSTRUCTIONS = (proto.INSTRUCTION_PING, proto.INSTRUCTION_READ,
                           proto.INSTRUCTION_WRITE, proto.INSTRUCTION_SYNC_READ,
                           proto.INSTRUCTION_REBOOT)


@dataclass
class StatusFault:
    """One pending injected error.

    Attributes
    ----------
    device_id : int
        Servo that answers with the error.
    error_number : int
        Error number (1..127) put in bits 0..6 of the status error byte.
    instruction : int
        Instruction whose replies carry it.
    address : int or None
        Start address the instruction must name (READ, WRITE, SYNC READ); None = any.
    remaining : int or None
        Replies still to spoil; None = until cleared.
    keep_data : bool
        True: the reply carries the data of a successful READ / SYNC READ / PING.
    """

    device_id: int
    error_number: int
    instruction: int
    address: int | None = None
    remaining: int | None = 1
    keep_data: bool = True

    def spoiled(self, data: bytes) -> tuple[int, bytes]:
        """(error number, data) of the spoiled reply whose data would be ``data``."""
        return self.error_number, data if self.keep_data else b''

    def as_dict(self) -> dict:
        """JSON-friendly description (for the control channel)."""
        return {'device_id': self.device_id, 'error_number': self.error_number,
                'instruction': proto.INSTRUCTION_NAMES[self.instruction],
                'address': self.address, 'remaining': self.remaining,
                'keep_data': self.keep_data}


class StatusFaults:
    """Pending status error injections of a bus, and how many replies each spoiled.

    Not thread-safe: the bus calls it under its lock.
    """

    def __init__(self) -> None:
        self._faults: list[StatusFault] = []
        self.spoiled = 0
        """Status packets sent with an injected error number."""

    def inject(self, device_id: int, error_number: int, instruction: str | int = 'sync read',
               count: int | None = 1, address: int | None = None,
               keep_data: bool = True) -> None:
        """Queue an injected error (see the module docstring).

        Raises
        ------
        ValueError
            For an error number outside 1..127, an instruction that has no modelled
            status, or a count below 1.
        """
        number = INSTRUCTION_BY_NAME.get(instruction, instruction)
        if number not in INJECTABLE_INSTRUCTIONS:
            raise ValueError(f'instruction {instruction!r} is not one of '
                             f'{[proto.INSTRUCTION_NAMES[i] for i in INJECTABLE_INSTRUCTIONS]}')
        if not 1 <= int(error_number) <= 0x7F:
            raise ValueError(f'error number {error_number} outside 1..127')
        if count is not None and count < 1:
            raise ValueError(f'count {count} < 1 (None: until cleared)')
        self._faults.append(StatusFault(int(device_id), int(error_number), number, address,
                                        count, keep_data))

    def clear(self, device_id: int | None = None) -> int:
        """Drop pending injections (of one servo, or all); returns how many were dropped."""
        kept = [f for f in self._faults if device_id is not None and f.device_id != device_id]
        dropped = len(self._faults) - len(kept)
        self._faults = kept
        return dropped

    def pending(self) -> list[dict]:
        """The pending injections, oldest first."""
        return [fault.as_dict() for fault in self._faults]

    def spoil(self, device_id: int, instruction: int, address: int | None, error: int,
              data: bytes) -> tuple[int, bytes]:
        """(error number, data) of a reply after the injection for it, if any."""
        fault = self.take(device_id, instruction, address)
        return (error, data) if fault is None else fault.spoiled(data)

    def take(self, device_id: int, instruction: int, address: int | None) -> StatusFault | None:
        """The injection that spoils this reply, if any (its count is consumed)."""
        for fault in self._faults:
            if (fault.device_id == device_id and fault.instruction == instruction
                    and (fault.address is None or fault.address == address)):
                if fault.remaining is not None:
                    fault.remaining -= 1
                    if fault.remaining == 0:
                        self._faults.remove(fault)
                self.spoiled += 1
                return fault
        return None
