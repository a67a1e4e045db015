"""DYNAMIXEL protocol 2.0 packet codec (pure Python, no I/O).

Used by the simulated servo to parse instruction packets and build status packets, and
by tests to build packets independently of dynamixel-sdk.

Packet layout (all multi-byte fields little-endian)::

    FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAM ... | CRC_L CRC_H

``LEN`` counts the bytes after itself (instruction, parameters, CRC), after byte
stuffing. The CRC is CRC-16 with polynomial 0x8005, initial value 0, no reflection,
no final XOR, over every byte from the first header byte to the last parameter.
Byte stuffing: inside the instruction+parameter field, every ``FF FF FD`` gets an
extra ``FD`` appended, so that the header pattern never appears in a packet body.
A status packet uses instruction 0x55 and carries the error byte as its first parameter.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

HEADER = b'\xff\xff\xfd\x00'
BROADCAST_ID = 0xFE
MAX_ID = 0xFC

INSTRUCTION_PING = 0x01
INSTRUCTION_READ = 0x02
INSTRUCTION_WRITE = 0x03
INSTRUCTION_REG_WRITE = 0x04
INSTRUCTION_ACTION = 0x05
INSTRUCTION_FACTORY_RESET = 0x06
INSTRUCTION_REBOOT = 0x08
INSTRUCTION_CLEAR = 0x10
INSTRUCTION_STATUS = 0x55
INSTRUCTION_SYNC_READ = 0x82
INSTRUCTION_SYNC_WRITE = 0x83
INSTRUCTION_FAST_SYNC_READ = 0x8A
INSTRUCTION_BULK_READ = 0x92
INSTRUCTION_BULK_WRITE = 0x93
INSTRUCTION_NAMES = {
    INSTRUCTION_PING: 'ping',
    INSTRUCTION_READ: 'read',
    INSTRUCTION_WRITE: 'write',
    INSTRUCTION_REG_WRITE: 'reg write',
    INSTRUCTION_ACTION: 'action',
    INSTRUCTION_FACTORY_RESET: 'factory reset',
    INSTRUCTION_REBOOT: 'reboot',
    INSTRUCTION_CLEAR: 'clear',
    INSTRUCTION_STATUS: 'status',
    INSTRUCTION_SYNC_READ: 'sync read',
    INSTRUCTION_SYNC_WRITE: 'sync write',
    INSTRUCTION_FAST_SYNC_READ: 'fast sync read',
    INSTRUCTION_BULK_READ: 'bulk read',
    INSTRUCTION_BULK_WRITE: 'bulk write',
}

_MAX_PACKET_LENGTH_FIELD = 1024
"""Largest LEN accepted by the parser (longer claims are treated as garbage)."""


def _make_crc_table() -> tuple[int, ...]:
    table = []
    for index in range(256):
        value = index << 8
        for _ in range(8):
            value = ((value << 1) ^ 0x8005) if value & 0x8000 else (value << 1)
        table.append(value & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _make_crc_table()


def crc16(data: bytes | bytearray, crc: int = 0) -> int:
    """CRC-16 of protocol 2.0 (polynomial 0x8005, MSB first, initial value ``crc``).

    Parameters
    ----------
    data : bytes
        Bytes to checksum.
    crc : int
        Running value to continue from (0 to start).

    Returns
    -------
    int
        16-bit CRC.
    """
    for byte in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Apply byte stuffing to an instruction+parameter field.

    The 3 header bytes before the field are ``FF FF FD 00 ID LEN``; only patterns
    wholly inside the field are stuffed (as the protocol specifies).
    """
    out = bytearray()
    for byte in body:
        out.append(byte)
        if byte == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Remove byte stuffing (``FF FF FD FD`` -> ``FF FF FD``) from a packet field."""
    out = bytearray()
    index = 0
    while index < len(body):
        byte = body[index]
        out.append(byte)
        if (byte == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF
                and index + 1 < len(body) and body[index + 1] == 0xFD):
            index += 1  # drop the stuffing byte
        index += 1
    return bytes(out)


def build_packet(device_id: int, instruction: int, parameters: bytes = b'') -> bytes:
    """Complete, stuffed, CRC-protected packet.

    Parameters
    ----------
    device_id : int
        Target id (0..252) or 254 for broadcast; for a status packet the sender's id.
    instruction : int
        Instruction byte (0x55 for a status packet).
    parameters : bytes
        Parameters (for a status packet: error byte first).

    Returns
    -------
    bytes
        The packet as sent on the wire.
    """
    body = stuff(bytes([instruction]) + bytes(parameters))
    length = len(body) + 2
    head = HEADER + bytes([device_id, length & 0xFF, length >> 8])
    packet = head + body
    crc = crc16(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


def build_status(device_id: int, error: int, parameters: bytes = b'') -> bytes:
    """Status packet of ``device_id`` with error byte ``error`` and ``parameters``."""
    return build_packet(device_id, INSTRUCTION_STATUS, bytes([error]) + bytes(parameters))


@dataclass
class Packet:
    """A received packet with a valid CRC.

    Attributes
    ----------
    device_id : int
        ID field.
    instruction : int
        Instruction byte.
    parameters : bytes
        Parameters after removal of byte stuffing (status: error byte first).
    raw : bytes
        The packet as received.
    """

    device_id: int
    instruction: int
    parameters: bytes
    raw: bytes = field(repr=False, default=b'')


class PacketParser:
    """Incremental parser: bytes in, packets out; resynchronises after garbage.

    Counts what it throws away: ``crc_errors`` (complete packets with a wrong CRC) and
    ``discarded_bytes`` (bytes that are not part of any valid packet).
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.crc_errors = 0
        self.discarded_bytes = 0

    def feed(self, data: bytes) -> Iterator[Packet]:
        """Append ``data`` and yield every complete packet it finishes."""
        self._buffer.extend(data)
        while True:
            start = self._buffer.find(HEADER[:3])
            if start < 0:
                keep = 2 if self._buffer.endswith(b'\xff\xff') else (
                    1 if self._buffer.endswith(b'\xff') else 0)
                self.discarded_bytes += len(self._buffer) - keep
                del self._buffer[: len(self._buffer) - keep]
                return
            if start:
                self.discarded_bytes += start
                del self._buffer[:start]
            if len(self._buffer) < 7:
                return
            length = self._buffer[5] | (self._buffer[6] << 8)
            if self._buffer[3] != 0x00 or length < 3 or length > _MAX_PACKET_LENGTH_FIELD:
                self.discarded_bytes += 1
                del self._buffer[:1]
                continue
            total = 7 + length
            if len(self._buffer) < total:
                return
            raw = bytes(self._buffer[:total])
            received_crc = raw[-2] | (raw[-1] << 8)
            if crc16(raw[:-2]) != received_crc:
                self.crc_errors += 1
                self.discarded_bytes += 1
                del self._buffer[:1]
                continue
            del self._buffer[:total]
            body = unstuff(raw[7:-2])
            yield Packet(raw[4], body[0], bytes(body[1:]), raw)
