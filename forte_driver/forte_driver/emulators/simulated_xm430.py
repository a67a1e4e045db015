"""One simulated ROBOTIS XM430-W350: its control table rules and its physics (no I/O).

:class:`SimulatedXM430` answers READ and WRITE as the servo does (EEPROM write-protected
with torque on; access, data length, data range and data limit errors; a refused write
changes nothing), models motion, current and temperature, and latches hardware errors
(overheating, input voltage, overload, injected ones) with torque off for the bits in
Shutdown(63) until REBOOT. The bus that carries its packets on a pseudo-terminal is
:mod:`.simulated_servo_bus`; what is modelled and what is not is listed in
docs/gripper_driver.md.
"""
from __future__ import annotations

import math
import time

from forte_driver.dynamixel import control_table as ct

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
        self.externally_driven = False
        """True: position, velocity and current are set by :meth:`drive` (a coupled simulation
        such as the bench twin's scene moves the horn); :meth:`step` then only runs the
        thermal and error model."""
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
    def drive(self, position: float, velocity: float, current: float) -> None:
        """Set the physical state from a coupled simulation (:attr:`externally_driven`).

        Parameters
        ----------
        position : float
            Horn position [pulse].
        velocity : float
            Horn velocity [pulse/s].
        current : float
            Motor current [2.69 mA units], signed along the position axis; clipped to what
            the servo can drive.
        """
        self.position = float(position)
        self.velocity = float(velocity)
        self.current = max(-PHYSICAL_CURRENT_MAX_UNITS, min(PHYSICAL_CURRENT_MAX_UNITS,
                                                            float(current)))
        self._publish_state()

    def step(self, dt: float) -> None:
        """Advance the motion, current and temperature model by ``dt`` seconds."""
        if dt <= 0.0:
            return
        if self.externally_driven:
            self._step_thermal_and_errors(dt)
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
        self._step_thermal_and_errors(dt)

    def _step_thermal_and_errors(self, dt: float) -> None:
        """Temperature, overload timing and latched hardware errors over ``dt`` seconds."""
        current = self.current
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
