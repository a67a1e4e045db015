"""forte_ros.contract against docs/contracts.md, read as an outsider reads the document.

The channel table (index, name, finger), the sampling rate and period and the value range
with its 11-bit quantisation are parsed from the text, so a contract module that drifts from
the document fails here, whichever side changed.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from forte_ros import contract

CONTRACTS = (Path(__file__).resolve().parents[2] / 'docs' / 'contracts.md').read_text()


def channel_rows() -> list[tuple[int, str, str]]:
    """``(index, name, finger)`` of each row of the "Channels, fingers, units" table."""
    rows = []
    for line in CONTRACTS.splitlines():
        match = re.match(r'\|\s*(\d+)\s*\|\s*`(\w+)`\s*\|\s*(left|right)\b', line)
        if match:
            rows.append((int(match.group(1)), match.group(2), match.group(3)))
    return rows


def test_channel_names_and_order_are_the_documented_ones():
    rows = channel_rows()
    assert [index for index, _, _ in rows] == list(range(6))
    assert contract.CHANNEL_NAMES == tuple(name for _, name, _ in rows)
    assert contract.N_CHANNELS == 6


def test_finger_groups_are_the_documented_ones():
    rows = channel_rows()
    for finger_index, finger in enumerate(contract.FINGER_NAMES):
        documented = tuple(index for index, _, name in rows if name == finger)
        assert contract.FINGER_CHANNELS[finger_index] == documented
    # every channel on exactly one finger, and distal / middle / root in that order
    assert sorted(sum(contract.FINGER_CHANNELS, ())) == list(range(contract.N_CHANNELS))
    for channels in contract.FINGER_CHANNELS:
        names = [contract.CHANNEL_NAMES[channel] for channel in channels]
        assert names[contract.DISTAL].endswith('_distal')
        assert names[contract.MIDDLE].endswith('_middle')
        assert names[contract.ROOT].endswith('_root')


def test_sampling_is_the_documented_one():
    rate, period = re.search(r'Sampling: (\d+) Hz, sample period ([\d.]+) s', CONTRACTS).groups()
    assert contract.SAMPLE_RATE == float(rate) == 2000.0
    assert contract.SAMPLE_PERIOD == float(period) == 1.0 / contract.SAMPLE_RATE


def test_value_range_and_quantisation_are_the_documented_ones():
    assert 'normalised to -1..1' in CONTRACTS
    assert contract.VALUE_RANGE == (-1.0, 1.0)
    step = re.search(r'11-bit quantisation \(step 2/(\d+)\)', CONTRACTS).group(1)
    assert contract.QUANTUM == 2.0 / float(step) == 2.0 ** -10  # exact in binary
    # the sensor board's counts (docs/firmware.md): one count is one quantum
    assert contract.COUNTS_PER_FULL_SCALE * contract.QUANTUM == contract.VALUE_RANGE[1]


def test_importing_the_contract_loads_no_ros():
    """The pure cores import the contract; it must not drag rclpy in (checked in a fresh
    interpreter, since this test process may have loaded rclpy for other tests)."""
    import subprocess
    import sys
    code = ('import sys, forte_ros.contract, forte_ros.isolation, forte_ros.parameter_table; '
            'loaded = [m for m in sys.modules if m.split(".")[0] in ("rclpy", "rcl_interfaces")]; '
            'print(loaded); sys.exit(bool(loaded))')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_stamp_ns_is_exact_integer_nanoseconds():
    """builtin_interfaces/Time (sec, nanosec) -> ns without float rounding: at 1.8e9 s a
    double has a 256 ns step, so a float conversion would lose the last digits."""
    from builtin_interfaces.msg import Time

    assert contract.stamp_ns(Time(sec=0, nanosec=0)) == 0
    assert contract.stamp_ns(Time(sec=104, nanosec=500_000)) == 104_000_500_000
    assert contract.stamp_ns(Time(sec=1_800_000_000, nanosec=999_999_999)) \
        == 1_800_000_000_999_999_999


def test_stamp_seconds_is_sec_plus_nanosec():
    from builtin_interfaces.msg import Time

    assert contract.stamp_seconds(Time(sec=104, nanosec=500_000)) == 104.0005
    assert contract.stamp_seconds(Time(sec=0, nanosec=0)) == 0.0


def test_split_ns_inverts_stamp_ns():
    """(sec, nanosec) of integer nanoseconds, exact at 1.8e9 s. builtin_interfaces/Time has
    a signed sec and an unsigned nanosec below 1e9, so a time before the epoch (a simulated
    clock's origin can lie there) keeps nanosec in range and carries the sign in sec."""
    from builtin_interfaces.msg import Time

    for nanoseconds in (0, 999_999_999, 1_000_000_000, 104_000_500_000,
                        1_800_000_000_999_999_999, -1, -1_000_000_000, -1_500_000_000):
        sec, nanosec = contract.split_ns(nanoseconds)
        assert 0 <= nanosec < 1_000_000_000
        assert contract.stamp_ns(Time(sec=sec, nanosec=nanosec)) == nanoseconds
    assert contract.split_ns(-1) == (-1, 999_999_999)


def test_servo_torque_constant_is_the_documented_one():
    """k = stall torque / stall current of the XM430-W350 at 12 V (e-manual: 4.1 N m at
    2.3 A), the one conversion between servo current and joint effort."""
    torque, current = re.search(r'k = ([\d.]+) N m / ([\d.]+) A = ([\d.]+) N m/A',
                                CONTRACTS).groups()[:2]
    assert contract.SERVO_TORQUE_CONSTANT == float(torque) / float(current)
    assert contract.SERVO_TORQUE_CONSTANT == pytest.approx(1.7826, abs=1e-4)
    # the other supply voltages of the same table agree within 2 %: 3.8 / 2.1 (+1.5 %), 4.8 / 2.7
    for stall_torque, stall_current in ((3.8, 2.1), (4.8, 2.7)):
        assert stall_torque / stall_current == pytest.approx(
            contract.SERVO_TORQUE_CONSTANT, rel=0.02)
    # known answers, sign kept (along theta: squeezing is negative)
    assert contract.current_to_effort(2.3) == pytest.approx(4.1, rel=1e-12)
    assert contract.current_to_effort(-0.39812) == pytest.approx(-0.709692, abs=1e-6)
    assert contract.effort_to_current(1.0) == pytest.approx(0.560976, abs=1e-6)
    assert contract.effort_to_current(contract.current_to_effort(0.123)) == \
        pytest.approx(0.123, rel=1e-12)
