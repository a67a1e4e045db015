"""Known-answer tests of the XM430-W350 unit conversions and the theta <-> raw mapping."""
import math

import pytest

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import units
from forte_driver.dynamixel.gripper import FingerConfig, GripperConfig, GripperLimits


def test_position_unit_is_0_088_degree():
    assert units.pulses_to_radians(4096) == pytest.approx(2.0 * math.pi, abs=1e-12)
    assert units.pulses_to_radians(2048) == pytest.approx(math.pi, abs=1e-12)
    assert math.degrees(units.pulses_to_radians(1)) == pytest.approx(0.088, abs=2e-4)
    assert units.radians_to_pulses(math.pi / 2.0) == 1024
    # The paper's slip step, 0.88 deg = 0.015359 rad, is 10 pulses.
    assert units.radians_to_pulses(0.015359) == 10


def test_current_unit_is_2_69_milliampere():
    assert units.current_units_to_amperes(1) == pytest.approx(0.00269, abs=1e-12)
    assert units.current_units_to_amperes(1193) == pytest.approx(3.20917, abs=1e-9)
    assert units.current_units_to_amperes(-100) == pytest.approx(-0.269, abs=1e-12)
    assert units.amperes_to_current_units(0.269) == 100
    assert units.amperes_to_current_units(-0.269) == -100
    # Rounded toward zero: 1 A is 371.75 units, the servo gets 371 (never more than asked).
    assert units.amperes_to_current_units(1.0) == 371
    assert units.amperes_to_current_units(-1.0) == -371
    assert units.amperes_to_current_units(0.0) == 0


def test_velocity_unit_is_0_229_rpm():
    assert units.velocity_units_to_radians_per_second(1) == pytest.approx(0.0239809, abs=1e-7)
    assert units.velocity_units_to_radians_per_second(200) == pytest.approx(4.79616, abs=1e-5)
    assert units.radians_per_second_to_velocity_units(1.0) == 42  # 41.70 units
    assert units.radians_per_second_to_velocity_units(-0.0239809) == -1


def test_voltage_unit():
    assert units.voltage_units_to_volts(120) == pytest.approx(12.0)


def test_theta_maps_to_raw_with_zero_and_direction():
    right = FingerConfig('right', 'r', 1, zero_position=2048, direction=1)
    left = FingerConfig('left', 'l', 2, zero_position=2100, direction=-1)
    assert right.theta_to_raw(0.0) == 2048
    assert left.theta_to_raw(0.0) == 2100
    assert right.theta_to_raw(0.5) == 2048 + 326  # 0.5 rad = 325.95 pulses
    assert left.theta_to_raw(0.5) == 2100 - 326
    assert right.raw_to_theta(2374) == pytest.approx(326 * 2 * math.pi / 4096)
    assert left.raw_to_theta(1774) == pytest.approx(326 * 2 * math.pi / 4096)
    # Closing (smaller theta) moves the mirrored finger toward larger raw positions.
    assert left.theta_to_raw(0.4) > left.theta_to_raw(0.5)


def test_eeprom_targets_of_default_config():
    config = GripperConfig()
    right = config.eeprom_targets(config.right)
    left = config.eeprom_targets(config.left)
    assert right[ct.OPERATING_MODE] == 5
    assert right[ct.MIN_POSITION_LIMIT] == 2048 and right[ct.MAX_POSITION_LIMIT] == 2700
    assert left[ct.MIN_POSITION_LIMIT] == 1396 and left[ct.MAX_POSITION_LIMIT] == 2048
    assert right[ct.CURRENT_LIMIT] == 371 == left[ct.CURRENT_LIMIT]
    assert right[ct.VELOCITY_LIMIT] == 200
    assert right[ct.TEMPERATURE_LIMIT] == 70


@pytest.mark.parametrize('change, message', [
    (dict(baud_rate=115_201), 'not a DYNAMIXEL rate'),
    (dict(limits=GripperLimits(theta_min=0.5, theta_max=0.5)), 'is empty'),
    (dict(limits=GripperLimits(theta_max=4.0)), 'outside the position limit registers'),
    (dict(limits=GripperLimits(current_limit=4.0)), 'current_limit'),
    (dict(limits=GripperLimits(velocity_limit=30.0)), 'velocity_limit'),
    (dict(limits=GripperLimits(temperature_limit=120)), 'temperature_limit'),
    (dict(default_current=2.0), 'default_current'),
    (dict(default_profile_velocity=0.0), 'default_profile_velocity'),
    (dict(left=FingerConfig('left', 'l', 1)), 'both fingers have id 1'),
    (dict(left=FingerConfig('left', 'l', 2, direction=0)), 'direction must be'),
])
def test_invalid_configurations_are_refused_with_reason(change, message):
    config = GripperConfig(**change)
    with pytest.raises(ValueError, match=message):
        config.validate()


def test_default_configuration_is_valid():
    GripperConfig().validate()


def test_hardware_error_text():
    assert ct.hardware_error_text(0) == 'none'
    assert ct.hardware_error_text(0x24) == 'overheating error, overload error'
    assert 'unknown bits 0x40' in ct.hardware_error_text(0x40)
    assert ct.status_error_text(0x87) == 'access error, alert (hardware error latched)'


def test_control_table_addresses_match_the_e_manual():
    expected = {
        'Operating Mode': (11, 1), 'Temperature Limit': (31, 1), 'Current Limit': (38, 2),
        'Velocity Limit': (44, 4), 'Max Position Limit': (48, 4),
        'Min Position Limit': (52, 4), 'Torque Enable': (64, 1),
        'Hardware Error Status': (70, 1), 'Goal Current': (102, 2),
        'Profile Velocity': (112, 4), 'Goal Position': (116, 4), 'Present Current': (126, 2),
        'Present Velocity': (128, 4), 'Present Position': (132, 4),
        'Present Temperature': (146, 1),
    }
    actual = {r.name: (r.address, r.size) for r in ct.REGISTERS}
    for name, address_size in expected.items():
        assert actual[name] == address_size, name
    # Registers do not overlap.
    for first, second in zip(ct.REGISTERS, ct.REGISTERS[1:], strict=False):
        assert first.address + first.size <= second.address
    assert ct.COMMAND_BLOCK_LENGTH == 18 and ct.STATE_BLOCK_LENGTH == 21
