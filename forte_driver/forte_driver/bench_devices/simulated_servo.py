"""Simulated pair of XM430-W350 servos speaking DYNAMIXEL protocol 2.0 on a pseudo-terminal.

The real dynamixel-sdk (``PortHandler`` on :attr:`SimulatedServoBus.device_path`) talks
to it exactly as to a U2D2 with two servos on the bus: instruction packets in, status
packets out, with CRC-16, byte stuffing, the status error byte, the return delay time and
the transmission time of the configured baud rate. Modelled: PING, READ, WRITE, SYNC READ,
SYNC WRITE, REBOOT; the XM430-W350 control table rules (EEPROM, access, length, range and
limit errors; a refused write changes nothing); Status Return Level, Return Delay Time,
Baud Rate; motion, current, temperature; hardware errors (overheating, input voltage,
overload, injected ones) with the alert bit in every status and, for bits in Shutdown(63),
torque off until REBOOT; error numbers injected in the status of a given instruction
(:mod:`forte_driver.bench_devices.servo_faults`). The full list, and what is not modelled, is
in docs/gripper_driver.md.

Run ``forte_simulated_servo`` to get a bus on a pty from the command line; it prints the
device path (and can symlink it to a stable name with ``--link``).
"""
from __future__ import annotations

import argparse
import collections
import json
import math
import os
import select
import signal
import subprocess
import sys
import termios
import threading
import time
import tty
from dataclasses import dataclass

from forte_driver.bench_devices.servo_faults import StatusFaults
from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto

NO_LOAD_SPEED_UNITS = 200
"""No-load speed of the XM430-W350 at 12 V (46 rev/min) in velocity units (0.229 rpm)."""
FREE_MOTION_CURRENT_UNITS = 15
"""Present Current while moving freely [2.69 mA units] (friction of the gear train)."""
AMBIENT_TEMPERATURE_C = 30.0
HEATING_C_PER_A2 = 15.0
"""Steady-state temperature rise per squared ampere [degC/A^2]."""
THERMAL_TIME_CONSTANT_S = 60.0
OVERLOAD_DELAY_S = 2.0
"""Saturated current held this long sets the overload error."""
PHYSICAL_CURRENT_MAX_UNITS = 1193
"""Largest current the servo can drive [2.69 mA units] (3.2 A)."""


def _pulses_per_second(velocity_units: float) -> float:
    return velocity_units * 0.229 / 60.0 * ct.PULSES_PER_REVOLUTION


class SimulatedXM430:
    """Control table and physics of one XM430-W350 (no I/O; thread-unsafe).

    Parameters
    ----------
    device_id : int
        ID(7) of the servo.
    baud_rate : int
        Initial bus speed [bit/s]; stored in Baud Rate(8).
    position : int
        Initial present position [pulse].
    """

    def __init__(self, device_id: int, baud_rate: int = 4_000_000, position: int = 2048):
        self.table = bytearray(ct.CONTROL_TABLE_SIZE)
        for register in ct.REGISTERS:
            self._set(register, register.default)
        self._set(ct.ID, device_id)
        self._set(ct.BAUD_RATE, ct.REGISTER_BY_BAUD_RATE[baud_rate])
        self.position = float(position)
        """Present position [pulse] (float for sub-pulse integration)."""
        self.velocity = 0.0
        """Present velocity [pulse/s]."""
        self.current = 0.0
        """Present current [2.69 mA units]."""
        self.temperature = AMBIENT_TEMPERATURE_C
        """Internal temperature [degC]."""
        self.input_voltage_units = 120
        """Supply voltage [0.1 V]."""
        self.obstacle: int | None = None
        """Position [pulse] the horn cannot pass (None: free)."""
        self.obstacle_blocks_increasing = True
        """True: the obstacle stops motion toward larger positions; False: smaller."""
        self.responding = True
        """False: the servo ignores the bus (unplugged cable, no power to its logic)."""
        self._saturated_time = 0.0
        self._latched_errors = 0
        self._start_time = time.monotonic()
        self._publish_state()

    # -- table access --------------------------------------------------------------
    def _set(self, register: ct.Register, value: int) -> None:
        self.table[register.address: register.address + register.size] = ct.encode_value(
            register, value)

    def get(self, register: ct.Register) -> int:
        """Current value of ``register``."""
        return ct.decode_value(
            register, self.table[register.address: register.address + register.size])

    @property
    def device_id(self) -> int:
        """ID(7)."""
        return self.get(ct.ID)

    @property
    def torque_enabled(self) -> bool:
        """Torque Enable(64) is 1."""
        return self.get(ct.TORQUE_ENABLE) == 1

    @property
    def hardware_error_status(self) -> int:
        """Hardware Error Status(70)."""
        return self.get(ct.HARDWARE_ERROR_STATUS)

    def alert_bit(self) -> int:
        """0x80 if a hardware error is latched, else 0 (OR-ed into every status error byte)."""
        return ct.STATUS_ALERT_BIT if self.hardware_error_status else 0

    def read(self, address: int, length: int) -> tuple[int, bytes]:
        """READ instruction: ``(error number, data)``; data empty on error."""
        if length <= 0 or address < 0 or address + length > ct.CONTROL_TABLE_SIZE:
            return ct.STATUS_ERROR_ACCESS, b''
        self._publish_state()
        return 0, bytes(self.table[address: address + length])

    def write(self, address: int, data: bytes) -> int:
        """WRITE instruction: error number (0 = written); refused writes change nothing."""
        end = address + len(data)
        if not data or address < 0 or end > ct.CONTROL_TABLE_SIZE:
            return ct.STATUS_ERROR_ACCESS
        touched: list[ct.Register] = []
        position = address
        while position < end:
            register = ct.REGISTER_BY_ADDRESS.get(position)
            if register is None:
                owner = next((r for r in ct.REGISTERS
                              if r.address < position < r.address + r.size), None)
                return ct.STATUS_ERROR_DATA_LENGTH if owner else ct.STATUS_ERROR_ACCESS
            if not register.writable:
                return ct.STATUS_ERROR_ACCESS
            if position + register.size > end:
                return ct.STATUS_ERROR_DATA_LENGTH
            touched.append(register)
            position += register.size
        values = {r: ct.decode_value(r, data[r.address - address:]) for r in touched}
        torque_after = values.get(ct.TORQUE_ENABLE, self.get(ct.TORQUE_ENABLE))
        if any(r.eeprom for r in touched) and self.torque_enabled:
            return ct.STATUS_ERROR_ACCESS
        for register, value in values.items():
            if not register.minimum <= value <= register.maximum:
                return ct.STATUS_ERROR_DATA_RANGE
            if register is ct.OPERATING_MODE and value not in ct.OPERATING_MODES:
                return ct.STATUS_ERROR_DATA_RANGE
        error = self._check_limits(values)
        if error:
            return error
        was_enabled = self.torque_enabled
        for register, value in values.items():
            self._set(register, value)
        if torque_after == 1 and not was_enabled:
            if self._latched_errors & self.get(ct.SHUTDOWN):
                self._set(ct.TORQUE_ENABLE, 0)  # shutdown: only REBOOT re-enables torque
            else:
                # Torque on: the servo holds where it is (Goal Position := Present Position).
                self._set(ct.GOAL_POSITION, int(round(self.position)))
        return 0

    def _check_limits(self, values: dict[ct.Register, int]) -> int:
        def value_of(register: ct.Register) -> int:
            return values.get(register, self.get(register))

        if ct.GOAL_CURRENT in values and abs(values[ct.GOAL_CURRENT]) > value_of(
                ct.CURRENT_LIMIT):
            return ct.STATUS_ERROR_DATA_LIMIT
        for register in (ct.PROFILE_VELOCITY, ct.GOAL_VELOCITY):
            if register in values and abs(values[register]) > value_of(ct.VELOCITY_LIMIT):
                return ct.STATUS_ERROR_DATA_LIMIT
        if ct.GOAL_POSITION in values:
            goal = values[ct.GOAL_POSITION]
            if value_of(ct.OPERATING_MODE) == ct.OPERATING_MODE_POSITION:
                if not value_of(ct.MIN_POSITION_LIMIT) <= goal <= value_of(
                        ct.MAX_POSITION_LIMIT):
                    return ct.STATUS_ERROR_DATA_LIMIT
        return 0

    def reboot(self) -> None:
        """REBOOT: clear errors, torque off, RAM back to defaults (EEPROM kept)."""
        for register in ct.REGISTERS:
            if not register.eeprom:
                self._set(register, register.default)
        self._latched_errors = 0
        self._saturated_time = 0.0
        self.velocity = 0.0
        self.current = 0.0
        self._publish_state()

    # -- faults ----------------------------------------------------------------------
    def inject_hardware_error(self, bits: int) -> None:
        """Latch hardware error ``bits`` (e.g. electrical shock) as the servo would."""
        self._latch(bits)

    def _latch(self, bits: int) -> None:
        if not bits:
            return
        self._latched_errors |= bits
        if bits & self.get(ct.SHUTDOWN):
            self._set(ct.TORQUE_ENABLE, 0)
        self._publish_state()

    # -- physics ---------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance the motion, current and temperature model by ``dt`` seconds."""
        if dt <= 0.0:
            return
        mode = self.get(ct.OPERATING_MODE)
        velocity = 0.0
        current = 0.0
        if self.torque_enabled and mode in (ct.OPERATING_MODE_POSITION,
                                            ct.OPERATING_MODE_EXTENDED_POSITION,
                                            ct.OPERATING_MODE_CURRENT_BASED_POSITION):
            current_cap = self.get(ct.CURRENT_LIMIT)
            if mode == ct.OPERATING_MODE_CURRENT_BASED_POSITION:
                current_cap = min(current_cap, abs(self.get(ct.GOAL_CURRENT)))
            goal = float(self.get(ct.GOAL_POSITION))
            speed_units = self.get(ct.PROFILE_VELOCITY) or NO_LOAD_SPEED_UNITS
            velocity_limit = self.get(ct.VELOCITY_LIMIT)
            if velocity_limit:
                speed_units = min(speed_units, velocity_limit)
            speed = _pulses_per_second(speed_units)
            error = goal - self.position
            direction = math.copysign(1.0, error)
            if current_cap < FREE_MOTION_CURRENT_UNITS:
                speed = 0.0  # not enough torque to overcome the gear train
            step = min(abs(error), speed * dt)
            target = self.position + direction * step
            blocked = False
            if self.obstacle is not None:
                # The horn stops at the obstacle; the goal lies beyond it (squeezing).
                if self.obstacle_blocks_increasing and target > self.obstacle:
                    target, blocked = max(self.position, float(self.obstacle)), True
                elif not self.obstacle_blocks_increasing and target < self.obstacle:
                    target, blocked = min(self.position, float(self.obstacle)), True
            velocity = (target - self.position) / dt
            self.position = target
            if blocked:
                # Squeezing the obstacle: the position loop saturates at the current cap.
                current = direction * current_cap
            elif abs(velocity) > 0.0:
                current = direction * min(FREE_MOTION_CURRENT_UNITS, current_cap)
        self.velocity = velocity
        self.current = current
        amperes = current * 2.69e-3
        steady = AMBIENT_TEMPERATURE_C + HEATING_C_PER_A2 * amperes * amperes
        self.temperature += (steady - self.temperature) * min(1.0, dt / THERMAL_TIME_CONSTANT_S)
        if abs(current) >= 0.95 * PHYSICAL_CURRENT_MAX_UNITS:
            self._saturated_time += dt
        else:
            self._saturated_time = 0.0
        errors = 0
        if self.temperature > self.get(ct.TEMPERATURE_LIMIT):
            errors |= ct.HW_ERROR_OVERHEATING
        if not (self.get(ct.MIN_VOLTAGE_LIMIT) <= self.input_voltage_units
                <= self.get(ct.MAX_VOLTAGE_LIMIT)):
            errors |= ct.HW_ERROR_INPUT_VOLTAGE
        if self._saturated_time > OVERLOAD_DELAY_S:
            errors |= ct.HW_ERROR_OVERLOAD
        self._latch(errors & ~self._latched_errors)
        self._publish_state()

    def _publish_state(self) -> None:
        """Copy the physical state into the read-only RAM items."""
        position = int(round(self.position))
        velocity_units = int(round(self.velocity / _pulses_per_second(1.0)))
        current = int(round(self.current))
        temperature = int(round(self.temperature))
        self._set(ct.PRESENT_POSITION, position)
        self._set(ct.POSITION_TRAJECTORY, position)
        self._set(ct.PRESENT_VELOCITY, velocity_units)
        self._set(ct.VELOCITY_TRAJECTORY, velocity_units)
        self._set(ct.PRESENT_CURRENT, current)
        self._set(ct.PRESENT_PWM, int(round(current * 885 / PHYSICAL_CURRENT_MAX_UNITS)))
        self._set(ct.PRESENT_TEMPERATURE, max(0, min(255, temperature)))
        self._set(ct.PRESENT_INPUT_VOLTAGE, self.input_voltage_units)
        moving = abs(velocity_units) > self.get(ct.MOVING_THRESHOLD)
        self._set(ct.MOVING, int(moving))
        self._set(ct.HARDWARE_ERROR_STATUS, self._latched_errors)
        tick = int((time.monotonic() - self._start_time) * 1000.0) % 32768
        self._set(ct.REALTIME_TICK, tick)


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


def _serve_control(bus: SimulatedServoBus, stop: threading.Event) -> None:
    """Answer JSON-line calls on stdin (``{"call": name, "args": [...], "kwargs": {...}}``)
    with one JSON line each on stdout (``{"ok": true, "value": ...}``)."""
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            name = request['call']
            if name not in SimulatedServoProcess.FORWARDED:
                raise AttributeError(f'{name} is not a control call')
            value = getattr(bus, name)(*request.get('args', []), **request.get('kwargs', {}))
            if name == 'packet_log':
                value = [(i, d, p.hex()) for i, d, p in value]
            reply = {'ok': True, 'value': value}
        except Exception as error:  # report to the caller, keep serving
            reply = {'ok': False, 'value': f'{type(error).__name__}: {error}'}
        print(json.dumps(reply), flush=True)
    stop.set()


class SimulatedServoProcess:
    """A :class:`SimulatedServoBus` in its own process (``forte_simulated_servo
    --control``), so that its answer times do not depend on the host process's threads
    and interpreter lock, like a real device.

    The inspection and fault-injection methods of the bus (:attr:`FORWARDED`) are
    forwarded as JSON lines over the child's stdin/stdout.
    """

    FORWARDED = ('count', 'packet_log', 'register_value', 'inject_hardware_error',
                 'inject_status_error', 'clear_status_errors', 'set_servo')

    def __init__(self, ids=(1, 2), baud_rate: int = 4_000_000, positions=None):
        self._arguments = ['--ids', *map(str, ids), '--baud', str(baud_rate)]
        if positions is not None:
            self._arguments += ['--positions', *map(str, positions)]
        self._process: subprocess.Popen | None = None
        self._call_lock = threading.Lock()
        self.device_path = ''

    def start(self) -> SimulatedServoProcess:
        """Start the process and wait for its pty path."""
        self._process = subprocess.Popen(
            [sys.executable, '-m', 'forte_driver.bench_devices.simulated_servo', '--control',
             *self._arguments],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        self.device_path = self._process.stdout.readline().strip()
        if not self.device_path:
            self.stop()
            raise RuntimeError('simulated servo process did not start')
        return self

    def stop(self) -> None:
        """Stop the process (closes the pty)."""
        if self._process is None:
            return
        try:
            self._process.stdin.close()
            self._process.wait(timeout=5.0)
        except (OSError, subprocess.TimeoutExpired):
            self._process.kill()
            self._process.wait()
        self._process.stdout.close()
        self._process = None

    def __enter__(self) -> SimulatedServoProcess:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()

    def call(self, name: str, *args, **kwargs):
        """Call method ``name`` of the bus in the child process and return its result."""
        if name not in self.FORWARDED:
            raise AttributeError(name)
        with self._call_lock:
            self._process.stdin.write(json.dumps(
                {'call': name, 'args': list(args), 'kwargs': kwargs}) + '\n')
            self._process.stdin.flush()
            reply = json.loads(self._process.stdout.readline())
        if not reply['ok']:
            raise RuntimeError(reply['value'])
        if name == 'packet_log':
            return [(i, d, bytes.fromhex(p)) for i, d, p in reply['value']]
        return reply['value']

    def __getattr__(self, name: str):
        if name in SimulatedServoProcess.FORWARDED:
            return lambda *args, **kwargs: self.call(name, *args, **kwargs)
        raise AttributeError(name)


def main(argv: list[str] | None = None) -> int:
    """Command line: serve simulated XM430-W350 servos on a pty until interrupted."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--ids', type=int, nargs='+', default=[1, 2],
                        help='servo ids on the bus (default: 1 2)')
    parser.add_argument('--baud', type=int, default=4_000_000,
                        choices=sorted(ct.REGISTER_BY_BAUD_RATE),
                        help='Baud Rate register of the servos [bit/s] (default 4000000)')
    parser.add_argument('--positions', type=int, nargs='+', default=None,
                        help='initial present positions [pulse], one per id (default 2048)')
    parser.add_argument('--link', default='',
                        help='also create a symlink with this path to the pty device')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='stop after this many seconds (default: run until SIGINT)')
    parser.add_argument('--control', action='store_true',
                        help='answer JSON-line inspection/fault-injection calls on stdin '
                             '(used by SimulatedServoProcess); stops when stdin closes')
    args = parser.parse_args(argv)
    bus = SimulatedServoBus(args.ids, args.baud, args.positions)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):  # a clean stop, also during start-up
        signal.signal(signum, lambda *_: stop.set())
    bus.start()
    if args.link:
        if os.path.islink(args.link):
            os.unlink(args.link)
        os.symlink(bus.device_path, args.link)
    print(bus.device_path, flush=True)
    if args.control:
        threading.Thread(target=_serve_control, args=(bus, stop), daemon=True).start()
    try:
        stop.wait(args.duration if args.duration > 0 else None)
    except KeyboardInterrupt:
        pass
    finally:
        bus.stop()
        if args.link and os.path.islink(args.link):
            os.unlink(args.link)
        if not args.control:
            print(f'packets: {sum(bus.instruction_counts.values())}, '
                  f'crc errors: {bus.crc_errors}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
