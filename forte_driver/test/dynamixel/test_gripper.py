"""Gripper core on the real dynamixel-sdk against the simulated servo pair on a pty."""
import math

import pytest

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto
from forte_driver.dynamixel import units
from forte_driver.dynamixel.gripper import (
    DynamixelError,
    Gripper,
    GripperConfig,
    GripperLimits,
    check_command,
)
from forte_driver.emulators.simulated_servo import SimulatedServoProcess
from forte_ros.testing import wait_until

LIMITS = GripperLimits(theta_min=0.0, theta_max=1.0, current_limit=1.0,
                       velocity_limit=4.796, temperature_limit=70)


@pytest.fixture
def bus():
    with SimulatedServoProcess(ids=(1, 2), positions=(2200, 1900)) as simulated:
        yield simulated


@pytest.fixture
def gripper(bus):
    device = Gripper(GripperConfig(port=bus.device_path, limits=LIMITS))
    device.open()
    yield device
    device.close()


def _read_state(gripper, attempts=3):
    """read_state, retried if the loaded test machine missed the SDK's 34 ms timeout."""
    for attempt in range(attempts):
        try:
            return gripper.read_state()
        except DynamixelError:
            if attempt == attempts - 1:
                raise



# -- pure command validation ------------------------------------------------------------


def test_check_command_known_answers():
    ok = check_command(0.5, 0.3, 2.0, LIMITS, 0.5, 1.0)
    assert ok.accepted and not ok.clipped
    assert (ok.theta, ok.current, ok.profile_velocity) == (0.5, 0.3, 2.0)
    defaults = check_command(0.5, 0.0, 0.0, LIMITS, 0.5, 1.0)
    assert (defaults.current, defaults.profile_velocity) == (0.5, 1.0)
    clipped = check_command(1.7, 9.0, 99.0, LIMITS, 0.5, 1.0)
    assert clipped.accepted and clipped.clipped
    assert (clipped.theta, clipped.current, clipped.profile_velocity) == (1.0, 1.0, 4.796)
    assert len(clipped.reasons) == 3
    below = check_command(-0.2, 0.0, 0.0, LIMITS, 0.5, 1.0)
    assert below.theta == 0.0 and 'clipped' in below.reasons[0]
    for bad in ((math.nan, 0.0, 0.0), (0.5, math.inf, 0.0), (0.5, 0.0, -math.inf),
                (0.5, -0.1, 0.0), (0.5, 0.0, -1.0)):
        refused = check_command(*bad, LIMITS, 0.5, 1.0)
        assert not refused.accepted and refused.reasons


# -- configuration ------------------------------------------------------------------------


def test_configure_writes_limits_into_the_servos_and_reads_them_back(bus, gripper):
    assert gripper.ping() == {1: 1020, 2: 1020}
    report = gripper.configure()
    expected = {
        1: {'Operating Mode': 5, 'Current Limit': 371, 'Velocity Limit': 200,
            'Max Position Limit': 2700, 'Min Position Limit': 2048, 'Temperature Limit': 70},
        2: {'Operating Mode': 5, 'Current Limit': 371, 'Velocity Limit': 200,
            'Max Position Limit': 2048, 'Min Position Limit': 1396, 'Temperature Limit': 70},
    }
    assert report.read_back == expected
    # Independently of the driver: the servos' own registers hold the limits.
    for servo_id, items in expected.items():
        for name, value in items.items():
            assert bus.register_value(servo_id, name) == value, (servo_id, name)
    assert set(report.written[1]) == {'Operating Mode', 'Current Limit', 'Max Position Limit',
                                      'Min Position Limit', 'Temperature Limit'}
    assert report.torque_was_disabled == []
    # The limits in force come from the registers (quantised to the register units).
    assert gripper.limits.current_limit == pytest.approx(371 * 0.00269)
    assert gripper.limits.theta_min == 0.0
    assert gripper.limits.theta_max == pytest.approx(652 * 2 * math.pi / 4096)


def test_reconfigure_with_same_limits_keeps_holding(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    report = gripper.configure()
    assert report.written == {1: [], 2: []} and report.torque_was_disabled == []
    assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(2, 'Torque Enable')


def test_configure_with_new_limits_switches_torque_off_to_write_eeprom(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    tighter = Gripper(GripperConfig(port=bus.device_path, limits=GripperLimits(
        current_limit=0.8, theta_max=0.8), default_current=0.4, default_profile_velocity=1.0))
    gripper.close()
    tighter.open()
    try:
        report = tighter.configure()
        assert sorted(report.torque_was_disabled) == [1, 2]
        assert bus.register_value(1, 'Current Limit') == 297
        assert bus.register_value(1, 'Max Position Limit') == 2048 + 522
    finally:
        tighter.close()


def test_configure_refuses_a_servo_with_a_latched_hardware_error(bus, gripper):
    bus.inject_hardware_error(2, ct.HW_ERROR_OVERLOAD)
    with pytest.raises(DynamixelError, match='servo 2 .*overload error'):
        gripper.configure()


def test_missing_servo_is_reported_by_ping():
    with SimulatedServoProcess(ids=(1,)) as single:
        device = Gripper(GripperConfig(port=single.device_path))
        device.open()
        try:
            with pytest.raises(DynamixelError, match='servo 2: ping'):
                device.ping()
            with pytest.raises(DynamixelError, match='sync read'):
                device.read_state()  # never a made-up value for the missing finger
        finally:
            device.close()


def test_open_fails_clearly_without_device():
    device = Gripper(GripperConfig(port='/dev/forte-no-such-device'))
    with pytest.raises(DynamixelError, match='cannot open /dev/forte-no-such-device'):
        device.open()


# -- command and state --------------------------------------------------------------------


def test_command_is_one_sync_write_packet_for_both_servos(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    check = gripper.command(0.5, 0.3, 2.0)
    assert check.accepted and not check.clipped
    assert wait_until(lambda: bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1)
    sync_writes = [p for p in bus.packet_log() if p[0] == proto.INSTRUCTION_SYNC_WRITE]
    instruction, device_id, parameters = sync_writes[-1]
    assert device_id == proto.BROADCAST_ID
    assert parameters[:4] == bytes([102, 0, 18, 0])
    assert {parameters[4], parameters[4 + 19]} == {1, 2}  # both ids in the one packet
    assert bus.register_value(1, 'Goal Position') == 2048 + 326
    assert bus.register_value(2, 'Goal Position') == 2048 - 326
    assert bus.register_value(1, 'Goal Current') == 111  # 0.3 A / 2.69 mA, toward zero
    assert bus.register_value(2, 'Profile Velocity') == 83  # 2 rad/s / 0.0239809
    # Both fingers arrive; state reports theta in rad on both (mirrored) fingers.
    state = wait_until(lambda: (lambda s: s if abs(s['left'].theta - 0.5) < 2e-3
                               and abs(s['right'].theta - 0.5) < 2e-3
                               and s['left'].raw_velocity == 0 == s['right'].raw_velocity
                               else None)(_read_state(gripper)))
    assert state['right'].raw_position == 2374 and state['left'].raw_position == 1722
    assert state['left'].theta == pytest.approx(326 * 2 * math.pi / 4096)
    assert state['right'].temperature == 30.0 and state['right'].input_voltage == 12.0


def test_velocity_and_effort_units_along_theta(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    gripper.command(1.0, 0.5, 1.0)  # open slowly: 42 velocity units
    state = wait_until(lambda: (lambda s: s if s['right'].raw_velocity else None)(
        _read_state(gripper)))
    assert state['right'].raw_velocity == 42 and state['left'].raw_velocity == -42
    assert state['right'].velocity == pytest.approx(42 * 0.0239809, rel=1e-5)
    assert state['left'].velocity == pytest.approx(42 * 0.0239809, rel=1e-5)  # opening, +
    # Close onto an object: the right horn is stopped at raw 2100, the left at 1996.
    bus.set_servo(1, obstacle=2100, obstacle_blocks_increasing=False)
    bus.set_servo(2, obstacle=1996, obstacle_blocks_increasing=True)
    gripper.command(0.0, 0.4, 4.0)
    squeeze = wait_until(lambda: (lambda s: s if s['right'].raw_current == -148
                                 and s['left'].raw_current == 148 else None)(
        _read_state(gripper)))
    assert squeeze, 'the fingers never squeezed the obstacle'
    expected = -148 * units.AMPERES_PER_CURRENT_UNIT  # 0.4 A -> 148 units -> 0.39812 A
    assert squeeze['right'].current == pytest.approx(expected, rel=1e-9)
    assert squeeze['left'].current == pytest.approx(expected, rel=1e-9)
    # effort = joint torque along theta: -0.39812 A x (4.1 / 2.3) N m/A = -0.70969 N m
    assert squeeze['right'].effort == pytest.approx(-0.70969, abs=1e-5)
    assert squeeze['left'].effort == pytest.approx(-0.70969, abs=1e-5)
    assert squeeze['right'].raw_position == 2100


def test_out_of_range_command_is_clipped_to_the_registers_and_nan_refused(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    check = gripper.command(3.0, 5.0, 0.0)
    assert check.accepted and check.clipped and len(check.reasons) == 2
    assert wait_until(lambda: bus.register_value(1, 'Goal Position') == 2700)
    assert bus.register_value(2, 'Goal Position') == 1396
    assert bus.register_value(1, 'Goal Current') == 371  # Current Limit, not 5 A
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    refused = gripper.command(math.nan, 0.0, 0.0)
    assert not refused.accepted and 'not finite' in refused.reasons[0]
    gripper.command(0.2)  # a valid one afterwards, to know the bus has been flushed
    assert wait_until(lambda: bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1)


def test_hardware_errors_are_read_per_servo(bus, gripper):
    gripper.configure()
    assert gripper.read_hardware_errors() == {1: 0, 2: 0}
    bus.set_servo(1, temperature=90.0)
    bus.set_servo(2, input_voltage_units=170)
    errors = wait_until(lambda: (lambda e: e if e[1] and e[2] else None)(
        gripper.read_hardware_errors()))
    assert errors == {1: ct.HW_ERROR_OVERHEATING, 2: ct.HW_ERROR_INPUT_VOLTAGE}


def test_shutdown_holds_torque_unless_told_to_release(bus):
    config = GripperConfig(port=bus.device_path, limits=LIMITS)
    holding = Gripper(config)
    holding.open()
    holding.configure()
    holding.hold_present_position()
    holding.set_torque(True)
    holding.shutdown(release=False)
    assert not holding.is_open
    assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(2, 'Torque Enable')
    releasing = Gripper(config)
    releasing.open()
    releasing.shutdown(release=True)
    assert bus.register_value(1, 'Torque Enable') == 0 == bus.register_value(2, 'Torque Enable')


def test_data_needing_byte_stuffing_is_refused_before_it_reaches_the_bus(bus, gripper):
    """dynamixel-sdk 4.1.0 transmits FF FF FD unstuffed; the driver never sends such data."""
    before = len(bus.packet_log())
    with pytest.raises(DynamixelError, match='byte stuffing'):
        gripper.write_register(1, ct.HOMING_OFFSET, -131073)  # bytes FF FF FD FF
    assert len(bus.packet_log()) == before


def test_long_run_every_command_is_exactly_one_packet(bus, gripper):
    gripper.configure()
    gripper.hold_present_position()
    gripper.set_torque(True)
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    thetas = [0.1 + 0.8 * (index % 97) / 96.0 for index in range(1000)]
    for index, theta in enumerate(thetas):
        assert gripper.command(theta).accepted
        if index % 100 == 0:
            _read_state(gripper)  # interleaved reads, as in the node
    goals = (gripper.config.right.theta_to_raw(thetas[-1]),
             gripper.config.left.theta_to_raw(thetas[-1]))
    # the bus counts a packet when it arrives and applies it after: wait for both, the count
    # exact (an extra packet never satisfies it) and the last goal applied
    assert wait_until(lambda: bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1000 and (
        bus.register_value(1, 'Goal Position'), bus.register_value(2, 'Goal Position')) == goals)
