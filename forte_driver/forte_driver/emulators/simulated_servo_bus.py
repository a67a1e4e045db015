"""XM430-W350 servos speaking DYNAMIXEL protocol 2.0 on a pseudo-terminal (serving thread).

The real dynamixel-sdk (``PortHandler`` on :attr:`SimulatedServoBus.device_path`) talks
to it exactly as to a U2D2 with servos on the bus: instruction packets in, status packets
out, with CRC-16, byte stuffing, the status error byte, the return delay time and the
transmission time of the configured baud rate. Modelled instructions: PING, READ, WRITE,
SYNC READ, SYNC WRITE, REBOOT; Status Return Level, Return Delay Time and Baud Rate are
obeyed; error numbers can be injected in the status of a given instruction
(:mod:`forte_driver.emulators.servo_faults`). Each servo is a
:class:`~forte_driver.emulators.simulated_xm430.SimulatedXM430`.
"""
from __future__ import annotations

import collections
import os
import select
import termios
import threading
import time
import tty
from dataclasses import dataclass

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto
from forte_driver.emulators.servo_faults import StatusFaults
from forte_driver.emulators.simulated_xm430 import SimulatedXM430


@dataclass
class ReceivedPacket:
    """One instruction packet seen on the bus (for tests and statistics)."""

    time: float
    device_id: int
    instruction: int
    parameters: bytes
    size: int


def _termios_speeds() -> dict[int, int]:
    speeds = {}
    for baud in ct.BAUD_RATE_BY_REGISTER.values():
        constant = getattr(termios, f'B{baud}', None)
        if constant is not None:
            speeds[constant] = baud
    return speeds


class SimulatedServoBus:
    """XM430-W350 servos on a pseudo-terminal, served by a background thread.

    Parameters
    ----------
    ids : sequence of int
        IDs of the servos on the bus.
    baud_rate : int
        Baud Rate register of every servo [bit/s]; the host must open the port at it.
    positions : sequence of int, optional
        Initial present positions [pulse], one per id (default 2048).
    check_baud : bool
        If True, servos ignore packets when the host's termios speed differs from their
        Baud Rate register (as real servos would see garbage).
    timing : bool
        If True, status packets are delayed by the Return Delay Time plus the
        transmission time of instruction and status at ``baud_rate``.
    """

    def __init__(self, ids=(1, 2), baud_rate: int = 4_000_000, positions=None,
                 check_baud: bool = True, timing: bool = True):
        positions = list(positions) if positions is not None else [2048] * len(ids)
        self.servos: dict[int, SimulatedXM430] = {
            device_id: SimulatedXM430(device_id, baud_rate, position)
            for device_id, position in zip(ids, positions, strict=True)}
        self.lock = threading.RLock()
        """Hold while touching :attr:`servos` from another thread."""
        self.check_baud = check_baud
        self.timing = timing
        self.packets: list[ReceivedPacket] = []
        """Every instruction packet with a valid CRC, in order of reception."""
        self.instruction_counts: collections.Counter[int] = collections.Counter()
        self.ignored_wrong_baud = 0
        self.faults = StatusFaults()  # injected error numbers in status packets
        self._parser = proto.PacketParser()
        self._master = -1
        self._slave = -1
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._speeds = _termios_speeds()
        self.device_path = ''
        """Path of the pty's slave side; open it with dynamixel-sdk's PortHandler."""

    # -- lifecycle -------------------------------------------------------------------
    def start(self) -> SimulatedServoBus:
        """Create the pty and start serving; returns self."""
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.device_path = os.ttyname(self._slave)
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, name='simulated-servo-bus',
                                        daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the pty."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> SimulatedServoBus:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()

    # -- statistics ------------------------------------------------------------------
    @property
    def crc_errors(self) -> int:
        """Instruction packets dropped for a wrong CRC."""
        return self._parser.crc_errors

    def count(self, instruction: int) -> int:
        """Number of packets received with ``instruction``."""
        with self.lock:
            return self.instruction_counts[instruction]

    def packet_log(self) -> list[tuple[int, int, bytes]]:
        """(instruction, id, parameters) of every packet received so far."""
        with self.lock:
            return [(p.instruction, p.device_id, p.parameters) for p in self.packets]

    def register_value(self, device_id: int, name: str) -> int:
        """Value of the control table item named ``name`` (e-manual name) of a servo."""
        register = next(r for r in ct.REGISTERS if r.name == name)
        with self.lock:
            return self.servos[device_id].get(register)

    def inject_hardware_error(self, device_id: int, bits: int) -> None:
        """Latch hardware error ``bits`` in a servo (see control_table.HW_ERROR_*)."""
        with self.lock:
            self.servos[device_id].inject_hardware_error(bits)

    def inject_status_error(self, device_id: int, error_number: int, *args, **kwargs) -> None:
        """Answer an instruction with ``error_number``: see ``StatusFaults.inject``."""
        with self.lock:
            self.faults.inject(device_id, error_number, *args, **kwargs)

    def clear_status_errors(self, device_id: int | None = None) -> int:
        """Drop pending status error injections; returns how many were pending."""
        with self.lock:
            return self.faults.clear(device_id)

    def set_servo(self, device_id: int, **attributes) -> None:
        """Set physical attributes of a servo (position, temperature, input_voltage_units,
        obstacle, obstacle_blocks_increasing, responding)."""
        allowed = {'position', 'temperature', 'input_voltage_units', 'obstacle',
                   'obstacle_blocks_increasing', 'responding'}
        unknown = set(attributes) - allowed
        if unknown:
            raise AttributeError(f'cannot set {sorted(unknown)}; allowed: {sorted(allowed)}')
        with self.lock:
            servo = self.servos[device_id]
            for name, value in attributes.items():
                setattr(servo, name, value)
            servo.step(1e-6)

    def exchange(self, drives: dict) -> dict:
        """The hook of a coupled simulation (the bench twin): set each servo's physical
        state and return what the host commands it.

        Parameters
        ----------
        drives : dict
            ``{servo id: (position [pulse], velocity [pulse/s], current [2.69 mA units])}``;
            those servos become :attr:`SimulatedXM430.externally_driven`. Ids may be given
            as text (JSON keys).

        Returns
        -------
        dict
            ``{servo id: {'torque': bool, 'goal_position', 'goal_current', 'current_limit',
            'profile_velocity': register values}}`` of every servo on the bus.
        """
        with self.lock:
            for device_id, (position, velocity, current) in drives.items():
                servo = self.servos[int(device_id)]
                servo.externally_driven = True
                servo.drive(position, velocity, current)
            return {device_id: {'torque': servo.torque_enabled,
                                'goal_position': servo.get(ct.GOAL_POSITION),
                                'goal_current': servo.get(ct.GOAL_CURRENT),
                                'current_limit': servo.get(ct.CURRENT_LIMIT),
                                'profile_velocity': servo.get(ct.PROFILE_VELOCITY)}
                    for device_id, servo in self.servos.items()}

    # -- serving ---------------------------------------------------------------------
    def _host_baud(self) -> int | None:
        try:
            speed = termios.tcgetattr(self._master)[4]
        except termios.error:
            return None
        return self._speeds.get(speed)

    def _serve(self) -> None:
        last = time.monotonic()
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.001)
            except (OSError, ValueError):
                return
            now = time.monotonic()
            with self.lock:
                for servo in self.servos.values():
                    servo.step(now - last)
            last = now
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                continue
            for packet in self._parser.feed(data):
                self._handle(packet)

    def _reply(self, servo: SimulatedXM430, status: bytes, request_size: int,
               deadline: float) -> float:
        """Send ``status`` from ``servo`` no earlier than the bus timing allows."""
        if self.timing:
            baud = ct.BAUD_RATE_BY_REGISTER[servo.get(ct.BAUD_RATE)]
            delay = (2e-6 * servo.get(ct.RETURN_DELAY_TIME)
                     + 10.0 * (request_size + len(status)) / baud)
            deadline = max(deadline, time.monotonic()) + delay
            while True:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                time.sleep(remaining if remaining > 2e-4 else 0)
        os.write(self._master, status)
        return deadline

    def _handle(self, packet: proto.Packet) -> None:
        with self.lock:
            listening = {i: s for i, s in self.servos.items() if s.responding}
        with self.lock:
            self.packets.append(ReceivedPacket(time.monotonic(), packet.device_id,
                                               packet.instruction, packet.parameters,
                                               len(packet.raw)))
            self.instruction_counts[packet.instruction] += 1
        if self.check_baud:
            host = self._host_baud()
            if host is not None and any(
                    ct.BAUD_RATE_BY_REGISTER[s.get(ct.BAUD_RATE)] != host
                    for s in listening.values()):
                self.ignored_wrong_baud += 1
                return
        instruction = packet.instruction
        params = packet.parameters
        size = len(packet.raw)
        broadcast = packet.device_id == proto.BROADCAST_ID
        if instruction == proto.INSTRUCTION_SYNC_WRITE and broadcast:
            self._sync_write(params, listening)
        elif instruction == proto.INSTRUCTION_SYNC_READ and broadcast:
            self._sync_read(params, size, listening)
        elif instruction == proto.INSTRUCTION_PING:
            targets = (sorted(listening) if broadcast
                       else [packet.device_id] if packet.device_id in listening else [])
            deadline = 0.0
            for device_id in targets:
                servo = listening[device_id]
                with self.lock:
                    body = (ct.encode_value(ct.MODEL_NUMBER, servo.get(ct.MODEL_NUMBER))
                            + bytes([servo.get(ct.FIRMWARE_VERSION)]))
                    error, body = self.faults.spoil(device_id, instruction, None, 0, body)
                    status = proto.build_status(device_id, error | servo.alert_bit(), body)
                deadline = self._reply(servo, status, size, deadline)
        elif broadcast:
            if instruction == proto.INSTRUCTION_WRITE and len(params) >= 3:
                with self.lock:
                    for servo in listening.values():
                        servo.write(params[0] | params[1] << 8, params[2:])
        elif packet.device_id in listening:
            self._unicast(listening[packet.device_id], instruction, params, size)

    def _unicast(self, servo: SimulatedXM430, instruction: int, params: bytes,
                 size: int) -> None:
        data = b''
        with self.lock:
            level = servo.get(ct.STATUS_RETURN_LEVEL)
            fault = self.faults.take(servo.device_id, instruction,
                                     params[0] | params[1] << 8 if len(params) >= 2 else None)
            executes = fault is None  # an injected error: refused, not executed
            if instruction == proto.INSTRUCTION_READ:
                if len(params) != 4:
                    error = ct.STATUS_ERROR_DATA_LENGTH
                else:
                    error, data = servo.read(params[0] | params[1] << 8,
                                             params[2] | params[3] << 8)
                respond = level >= 1
            elif instruction == proto.INSTRUCTION_WRITE:
                error = ((servo.write(params[0] | params[1] << 8, params[2:]) if executes
                          else 0) if len(params) >= 3 else ct.STATUS_ERROR_DATA_LENGTH)
                respond = level >= 2
            elif instruction == proto.INSTRUCTION_REBOOT:
                error, respond = 0, level >= 2
            else:
                error, respond = ct.STATUS_ERROR_INSTRUCTION, level >= 2
            if fault is not None:
                error, data = fault.spoiled(data)
            status = proto.build_status(servo.device_id, error | servo.alert_bit(), data)
        if respond:
            self._reply(servo, status, size, 0.0)
        if instruction == proto.INSTRUCTION_REBOOT and executes:
            with self.lock:
                servo.reboot()

    def _sync_write(self, params: bytes, listening: dict[int, SimulatedXM430]) -> None:
        if len(params) < 4:
            return
        address = params[0] | params[1] << 8
        length = params[2] | params[3] << 8
        chunk = 1 + length
        with self.lock:
            for offset in range(4, len(params) - chunk + 1, chunk):
                servo = listening.get(params[offset])
                if servo is not None:
                    servo.write(address, params[offset + 1: offset + chunk])

    def _sync_read(self, params: bytes, size: int,
                   listening: dict[int, SimulatedXM430]) -> None:
        if len(params) < 5:
            return
        address = params[0] | params[1] << 8
        length = params[2] | params[3] << 8
        deadline = 0.0
        for device_id in params[4:]:
            servo = listening.get(device_id)
            if servo is None:
                continue  # an absent servo does not answer; later ones still do
            with self.lock:
                error, data = self.faults.spoil(device_id, proto.INSTRUCTION_SYNC_READ, address,
                                                *servo.read(address, length))
                status = proto.build_status(device_id, error | servo.alert_bit(), data)
            deadline = self._reply(servo, status, size, deadline)
