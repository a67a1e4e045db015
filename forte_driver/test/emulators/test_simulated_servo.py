"""The simulated XM430-W350: control table rules (pure model) and protocol 2.0 on a pty with
the real dynamixel-sdk as the host."""
import os
import select
import termios
import time
import tty

import pytest
from dynamixel_sdk import (
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
    PortHandler,
)

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto
from forte_driver.emulators.simulated_servo import SimulatedServoProcess, SimulatedXM430
from forte_ros.testing import wait_until

# -- the servo model alone (no I/O) --------------------------------------------------


def test_factory_defaults_and_model_number():
    servo = SimulatedXM430(7)
    assert servo.get(ct.MODEL_NUMBER) == 1020
    assert servo.get(ct.ID) == 7
    assert servo.get(ct.OPERATING_MODE) == ct.OPERATING_MODE_POSITION
    assert servo.get(ct.CURRENT_LIMIT) == 1193
    assert servo.get(ct.SHUTDOWN) == 0x34
    assert servo.get(ct.BAUD_RATE) == 6  # constructed at 4 Mbaud


def test_eeprom_write_refused_with_access_error_while_torque_on():
    servo = SimulatedXM430(1)
    assert servo.write(ct.TORQUE_ENABLE.address, b'\x01') == 0
    error = servo.write(ct.CURRENT_LIMIT.address, ct.encode_value(ct.CURRENT_LIMIT, 300))
    assert error == ct.STATUS_ERROR_ACCESS
    assert servo.get(ct.CURRENT_LIMIT) == 1193  # unchanged
    assert servo.write(ct.TORQUE_ENABLE.address, b'\x00') == 0
    assert servo.write(ct.CURRENT_LIMIT.address, ct.encode_value(ct.CURRENT_LIMIT, 300)) == 0
    assert servo.get(ct.CURRENT_LIMIT) == 300


def test_write_rules_range_length_access():
    servo = SimulatedXM430(1)
    assert servo.write(38, ct.encode_value(ct.CURRENT_LIMIT, 2000)) == ct.STATUS_ERROR_DATA_RANGE
    assert servo.write(38, b'\x10') == ct.STATUS_ERROR_DATA_LENGTH  # half an item
    assert servo.write(39, b'\x10') == ct.STATUS_ERROR_DATA_LENGTH  # middle of an item
    assert servo.write(132, b'\x00\x00\x00\x00') == ct.STATUS_ERROR_ACCESS  # read-only
    assert servo.write(14, b'\x00') == ct.STATUS_ERROR_ACCESS  # undefined address
    assert servo.write(11, bytes([2])) == ct.STATUS_ERROR_DATA_RANGE  # no mode 2
    assert servo.read(146, 1) == (0, bytes([30]))
    assert servo.read(146, 2)[0] == ct.STATUS_ERROR_ACCESS  # beyond the modelled table


def test_goal_current_beyond_current_limit_is_a_data_limit_error():
    servo = SimulatedXM430(1)
    servo.write(38, ct.encode_value(ct.CURRENT_LIMIT, 300))
    assert servo.write(102, ct.encode_value(ct.GOAL_CURRENT, 301)) == ct.STATUS_ERROR_DATA_LIMIT
    assert servo.write(102, ct.encode_value(ct.GOAL_CURRENT, -301)) == ct.STATUS_ERROR_DATA_LIMIT
    assert servo.write(102, ct.encode_value(ct.GOAL_CURRENT, -300)) == 0
    assert servo.write(112, ct.encode_value(ct.PROFILE_VELOCITY, 201)) == \
        ct.STATUS_ERROR_DATA_LIMIT  # Velocity Limit 200


def test_position_limits_apply_in_mode_3_only():
    servo = SimulatedXM430(1)
    servo.write(48, ct.encode_value(ct.MAX_POSITION_LIMIT, 2700))
    servo.write(52, ct.encode_value(ct.MIN_POSITION_LIMIT, 2048))
    goal = ct.encode_value(ct.GOAL_POSITION, 3000)
    assert servo.get(ct.OPERATING_MODE) == 3
    assert servo.write(116, goal) == ct.STATUS_ERROR_DATA_LIMIT
    assert servo.write(116, ct.encode_value(ct.GOAL_POSITION, 2500)) == 0
    servo.write(11, bytes([5]))  # current-based position: limits not used (e-manual)
    assert servo.write(116, goal) == 0
    assert servo.write(116, ct.encode_value(ct.GOAL_POSITION, 1_048_576)) == \
        ct.STATUS_ERROR_DATA_RANGE


def test_refused_block_write_changes_nothing():
    servo = SimulatedXM430(1)
    servo.write(38, ct.encode_value(ct.CURRENT_LIMIT, 100))
    block = (ct.encode_value(ct.GOAL_CURRENT, 200) + bytes(12)
             + ct.encode_value(ct.GOAL_POSITION, 2100))
    assert servo.write(102, block) == ct.STATUS_ERROR_DATA_LIMIT
    assert servo.get(ct.GOAL_POSITION) == 0 and servo.get(ct.GOAL_CURRENT) == 0


def _enable_mode_5(servo, goal_current=100, profile_velocity=42):
    servo.write(11, bytes([5]))
    servo.write(64, b'\x01')
    servo.write(102, ct.encode_value(ct.GOAL_CURRENT, goal_current))
    servo.write(112, ct.encode_value(ct.PROFILE_VELOCITY, profile_velocity))


def test_moves_toward_goal_at_profile_velocity_and_stops_there():
    servo = SimulatedXM430(1, position=2048)
    _enable_mode_5(servo)
    assert servo.get(ct.GOAL_POSITION) == 2048  # torque on holds the present position
    servo.write(116, ct.encode_value(ct.GOAL_POSITION, 2348))
    speed = 42 * 0.229 / 60.0 * 4096  # pulses/s
    servo.step(0.1)
    assert servo.position == pytest.approx(2048 + speed * 0.1)
    assert servo.get(ct.PRESENT_VELOCITY) == 42
    assert servo.get(ct.MOVING) == 1
    for _ in range(100):
        servo.step(0.01)
    assert servo.get(ct.PRESENT_POSITION) == 2348
    assert servo.get(ct.PRESENT_VELOCITY) == 0 and servo.get(ct.MOVING) == 0


def test_mode_5_without_goal_current_does_not_move():
    servo = SimulatedXM430(1, position=2048)
    _enable_mode_5(servo, goal_current=0)
    servo.write(116, ct.encode_value(ct.GOAL_POSITION, 2348))
    servo.step(0.5)
    assert servo.get(ct.PRESENT_POSITION) == 2048


def test_squeezing_an_obstacle_saturates_current_at_goal_current():
    servo = SimulatedXM430(1, position=2048)
    _enable_mode_5(servo, goal_current=150)
    servo.obstacle, servo.obstacle_blocks_increasing = 2100, True
    servo.write(116, ct.encode_value(ct.GOAL_POSITION, 2300))
    for _ in range(100):
        servo.step(0.01)
    assert servo.get(ct.PRESENT_POSITION) == 2100
    assert servo.get(ct.PRESENT_CURRENT) == 150
    assert servo.temperature > 30.0  # heating with current


def test_overheating_latches_error_switches_torque_off_until_reboot():
    servo = SimulatedXM430(1)
    _enable_mode_5(servo)
    servo.temperature = 85.0  # above the default Temperature Limit 80
    servo.step(0.001)
    assert servo.hardware_error_status == ct.HW_ERROR_OVERHEATING
    assert servo.alert_bit() == 0x80
    assert not servo.torque_enabled  # overheating is in the default Shutdown mask
    servo.write(64, b'\x01')
    assert not servo.torque_enabled  # only a reboot re-enables torque
    servo.temperature = 40.0
    servo.reboot()
    assert servo.hardware_error_status == 0
    servo.write(64, b'\x01')
    assert servo.torque_enabled


def test_input_voltage_error_is_reported_but_not_a_shutdown_by_default():
    servo = SimulatedXM430(1)
    servo.write(64, b'\x01')
    servo.input_voltage_units = 90  # 9.0 V < Min Voltage Limit 9.5 V
    servo.step(0.001)
    assert servo.hardware_error_status == ct.HW_ERROR_INPUT_VOLTAGE
    assert servo.torque_enabled  # bit 0 is not in the default Shutdown(63) = 0x34


# -- protocol over a pty with the real dynamixel-sdk ----------------------------------


@pytest.fixture(scope='module')
def bus():
    with SimulatedServoProcess(ids=(1, 2), positions=(2048, 2048)) as simulated:
        yield simulated


def _retry(function, attempts=3):
    """Run an idempotent SDK read; retry if the loaded test machine missed the SDK's
    34 ms timeout (a real bus can time out too)."""
    for _ in range(attempts):
        value = function()
        if value[-2] != COMM_RX_TIMEOUT:
            return value
    return value


def test_ping_returns_model_number_and_absent_id_times_out(port):
    handler = PacketHandler(2.0)
    for servo_id in (1, 2):
        model, result, error = _retry(lambda i=servo_id: handler.ping(port, i))
        assert (model, result, error) == (1020, COMM_SUCCESS, 0)
    _, result, _ = handler.ping(port, 3)
    assert result == COMM_RX_TIMEOUT


def test_eeprom_write_refused_over_the_bus_with_torque_on(bus, port):
    handler = PacketHandler(2.0)
    assert handler.write1ByteTxRx(port, 2, 64, 1) == (COMM_SUCCESS, 0)
    result, error = handler.write2ByteTxRx(port, 2, 38, 200)
    assert (result, error) == (COMM_SUCCESS, ct.STATUS_ERROR_ACCESS)
    assert bus.register_value(2, 'Current Limit') == 1193
    assert handler.write1ByteTxRx(port, 2, 64, 0) == (COMM_SUCCESS, 0)
    assert handler.write2ByteTxRx(port, 2, 38, 1193) == (COMM_SUCCESS, 0)


def test_one_sync_write_packet_moves_both_servos(bus, port):
    handler = PacketHandler(2.0)
    for servo_id in (1, 2):
        assert handler.write1ByteTxRx(port, servo_id, 11, 5) == (COMM_SUCCESS, 0)
        assert handler.write1ByteTxRx(port, servo_id, 64, 1) == (COMM_SUCCESS, 0)
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    writer = GroupSyncWrite(port, handler, 102, 18)
    for servo_id, goal in ((1, 2148), (2, 1948)):
        block = (ct.encode_value(ct.GOAL_CURRENT, 200) + bytes(8)
                 + ct.encode_value(ct.PROFILE_VELOCITY, 100)
                 + ct.encode_value(ct.GOAL_POSITION, goal))
        assert writer.addParam(servo_id, list(block))
    assert writer.txPacket() == COMM_SUCCESS
    assert wait_until(lambda: bus.count(proto.INSTRUCTION_SYNC_WRITE) > before, 5.0)
    time.sleep(0.2)  # the window in which a second packet would show
    assert bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1
    assert bus.register_value(1, 'Goal Position') == 2148
    assert bus.register_value(2, 'Goal Position') == 1948
    assert bus.register_value(1, 'Goal Current') == 200
    # Sync read of both present positions: they reach the goals.
    reader = GroupSyncRead(port, handler, 132, 4)
    reader.addParam(1)
    reader.addParam(2)

    def present_positions() -> tuple[int, int] | None:
        if reader.txRxPacket() != COMM_SUCCESS:
            return None
        return reader.getData(1, 132, 4), reader.getData(2, 132, 4)

    assert wait_until(lambda: present_positions() == (2148, 1948), 5.0)
    for servo_id in (1, 2):
        handler.write1ByteTxRx(port, servo_id, 64, 0)


def test_alert_bit_in_status_packets_after_a_hardware_error(bus, port):
    handler = PacketHandler(2.0)
    bus.inject_hardware_error(1, ct.HW_ERROR_ELECTRICAL_SHOCK)
    _, result, error = _retry(lambda: handler.ping(port, 1))
    assert result == COMM_SUCCESS and error == 0x80
    value, result, error = _retry(lambda: handler.read1ByteTxRx(port, 1, 70))
    assert (value, result, error) == (ct.HW_ERROR_ELECTRICAL_SHOCK, COMM_SUCCESS, 0x80)
    _, result, error = _retry(lambda: handler.ping(port, 2))
    assert error == 0  # the other servo is fine
    result, error = handler.reboot(port, 1)
    assert result == COMM_SUCCESS
    time.sleep(0.05)
    value, result, error = _retry(lambda: handler.read1ByteTxRx(port, 1, 70))
    assert (value, result, error) == (0, COMM_SUCCESS, 0)


def test_servo_at_another_baud_rate_does_not_answer(bus):
    handler = PortHandler(bus.device_path)
    assert handler.openPort() and handler.setBaudRate(1_000_000)
    try:
        _, result, _ = PacketHandler(2.0).ping(handler, 1)
        assert result == COMM_RX_TIMEOUT
    finally:
        handler.closePort()


def _raw_port(path):
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    attributes = termios.tcgetattr(fd)
    attributes[4] = attributes[5] = termios.B4000000
    termios.tcsetattr(fd, termios.TCSANOW, attributes)
    return fd


def _read_packet(fd, timeout=1.0):
    parser = proto.PacketParser()
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if select.select([fd], [], [], 0.05)[0]:
            packets = list(parser.feed(os.read(fd, 1024)))
            if packets:
                return packets[0], time.monotonic()
    return None, time.monotonic()


def test_byte_stuffed_write_and_status_latency(bus):
    """A write whose data contains FF FF FD (stuffed on the wire) is stored unstuffed; the
    status packet comes no earlier than the Return Delay Time (250 x 2 us)."""
    fd = _raw_port(bus.device_path)
    try:
        value = -131073  # bytes FF FF FD FF
        data = ct.encode_value(ct.HOMING_OFFSET, value)
        assert data == bytes([0xFF, 0xFF, 0xFD, 0xFF])
        packet = proto.build_packet(2, proto.INSTRUCTION_WRITE, bytes([20, 0]) + data)
        assert b'\xff\xff\xfd\xfd' in packet[7:]  # stuffed on the wire
        sent = time.monotonic()
        os.write(fd, packet)
        status, received = _read_packet(fd)
        assert status is not None
        assert (status.device_id, status.instruction, status.parameters) == (2, 0x55, b'\x00')
        assert received - sent >= 500e-6
        assert bus.register_value(2, 'Homing Offset') == value
        # A packet with a broken CRC is dropped without an answer.
        broken = bytearray(proto.build_packet(2, proto.INSTRUCTION_PING))
        broken[-1] ^= 0xFF
        os.write(fd, bytes(broken))
        status, _ = _read_packet(fd, timeout=0.2)
        assert status is None
        os.write(fd, proto.build_packet(2, proto.INSTRUCTION_WRITE, bytes([20, 0]) + bytes(4)))
        assert _read_packet(fd)[0] is not None
    finally:
        os.close(fd)
