"""The serial sensor node survives any byte stream: CRC-valid implausible frames,
duplicated and reordered frames, a device restart without START, and internal errors of
its reader thread. Real rclpy node and subscriber over DDS, emulated device on a real pty.

Known answers come from the emulator's fault log (docs/serial_driver.md, "The emulated
device and fault accounting") and the diagnostics rules ("Diagnostics", "Reader errors").
"""
from __future__ import annotations

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from serial_node_harness import Harness, check_batches_are_gap_free_and_true, diagnostic_records

from forte_driver.emulators.emulated_sensor import EmulatedSensor, FaultPlan
from forte_driver.serial.protocol import Command

#: Published diagnostics counters named after the StreamAssembler attributes.
COUNTER_KEYS = ('samples', 'dropped_frames', 'corrupt_frames', 'implausible_frames',
                'duplicate_frames', 'late_frames', 'device_overruns', 'restarts')


@pytest.fixture
def link(tmp_path):
    return str(tmp_path / 'forte_sensor')


def run_finite_session(harness: Harness, sensor: EmulatedSensor, scans: int) -> None:
    """Activate, wait until every scan of the device is accounted for, deactivate and
    wait until every published message arrived."""
    node = harness.activate()
    assert harness.wait(lambda: sensor.scans_generated >= scans, 30.0)
    log = sensor.log
    # every scan sent (all but the log's dropped ones) was received or counted late; the
    # gaps still inside the reorder window are counted as dropped at deactivation
    assert harness.wait(lambda: node.counters['received_samples'] + log.late
                        >= scans - log.dropped, 10.0)
    node.trigger_deactivate()
    assert harness.wait(lambda: sum(m.sample_count for m in harness.frames)
                        == node.counters['published_samples'], 10.0)


def final_counters(harness: Harness) -> dict[str, str]:
    """Diagnostics values of the first report after the deactivation."""
    def after_deactivation() -> list[dict[str, str]]:
        records = [values for *_, values in diagnostic_records(harness)]
        last_active = max(i for i, values in enumerate(records) if values['state'] == 'active')
        return [values for values in records[last_active:] if values['state'] == 'inactive']

    assert harness.wait(lambda: after_deactivation(), 10.0)
    return after_deactivation()[0]


def test_crc_valid_implausible_frames_are_counted_and_never_published(link):
    plan = FaultPlan(implausible=0.03)
    with EmulatedSensor(link, faults=plan, seed=31, max_scans=3000) as sensor:
        # known positions first (batch size 20, START at sequence 0): the first frame of
        # the stream (random payload, the field case), then the first frame after each
        # completed batch: 21 (device time ~2**58 us+), 42 (a value beyond 1024 counts),
        # 63 (an undefined flag bit), 84 (random payload again)
        sensor.inject('implausible', kind='random')
        for kind in ('time', 'values', 'flags', 'random'):
            sensor.inject('implausible', kind=kind, after=20)
        with Harness(link, reliable=True, diagnostics_period=0.2) as harness:
            run_finite_session(harness, sensor, 3000)
            log, counters = sensor.log, harness.node.counters
            assert log.implausible > 60
            # every intact scan is published exactly as sent; impostors never are
            assert check_batches_are_gap_free_and_true(harness, sensor) == len(sensor.delivered)
            assert counters['published_samples'] == len(sensor.delivered)
            assert counters['corrupt_frames'] == log.corrupt == log.implausible
            assert counters['dropped_frames'] == log.dropped
            assert harness.frames[0].first_sequence == 1  # sequence 0 was the impostor
            for message in harness.frames:
                assert np.all(np.abs(np.asarray(message.data)) <= 1.0)
                assert message.device_time_us < 1 << 40
                assert message.header.stamp.sec > 0
            assert harness.frames[-1].corrupt_frames == log.corrupt
            values = final_counters(harness)
            assert int(values['implausible_frames']) == log.implausible
            assert int(values['corrupt_frames']) == log.corrupt
            assert int(values['dropped_frames']) == log.dropped
            assert values['reader_errors'] == '0' and values['unstamped_samples'] == '0'
            assert values['last_rejection'] != ''
            assert all(level != DiagnosticStatus.ERROR
                       for level, _, values in diagnostic_records(harness)
                       if values.get('state') == 'active')


def test_duplicated_and_reordered_frames_are_published_once_in_order(link):
    plan = FaultPlan(duplicate=0.03, reorder=0.03)
    with (EmulatedSensor(link, faults=plan, seed=32, max_scans=3000) as sensor,
          Harness(link, reliable=True, diagnostics_period=0.2) as harness):
        run_finite_session(harness, sensor, 3000)
        log, counters = sensor.log, harness.node.counters
        assert log.duplicate > 50 and log.late > 50
        rows = harness.rows()
        sequences = [sequence for sequence, _, _ in rows]
        assert sequences == sorted(set(sequences))  # strictly increasing: no repeat
        times = [time_us for _, time_us, _ in rows]
        assert times == sorted(set(times))
        assert check_batches_are_gap_free_and_true(harness, sensor) == len(rows)
        # a late frame cannot be placed after its successor: counted, not published;
        # nothing was lost on the line
        assert counters['published_samples'] + log.late == len(sensor.delivered)
        values = final_counters(harness)
        assert int(values['duplicate_frames']) == log.duplicate
        assert int(values['late_frames']) == log.late
        assert int(values['dropped_frames']) == log.dropped == 0
        assert int(values['corrupt_frames']) == 0
        assert set(COUNTER_KEYS) <= set(values)


def test_device_restart_without_start_is_a_new_session_with_a_new_clock(link):
    with (EmulatedSensor(link, seed=33) as sensor,
          Harness(link, diagnostics_period=0.2) as harness):
        node = harness.activate()
        assert harness.wait_published(1000)
        starts = sum(c.command == Command.START for c in sensor.commands)
        sensor.inject('restart')
        assert harness.wait(lambda: sensor.log.restarts == 1)
        before = len(harness.frames)
        assert harness.wait(lambda: sum(m.sample_count for m in harness.frames[before:])
                            > 2000, 20.0)
        node.trigger_deactivate()
        assert sensor.sessions == 2
        assert sum(c.command == Command.START for c in sensor.commands) == starts
        sequences = [m.first_sequence for m in harness.frames]
        assert sequences == sorted(sequences)  # monotonic across the restart
        check_batches_are_gap_free_and_true(harness, sensor)
        # the restarted clock (1 s after boot) is mapped afresh: stamps of the new
        # session = true sample instant + transport latency
        system_minus_monotonic = harness.system_minus_monotonic_ns()
        restarted = [m for m in harness.frames if m.device_time_us < 4_000_000]
        assert len(restarted) > 50
        for message in restarted[len(restarted) // 2:]:
            stamp_ns = message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
            error_s = (stamp_ns - system_minus_monotonic
                       - sensor.host_ns_of_device_time(message.device_time_us)) * 1e-9
            assert -0.001 < error_s < 0.020
        values = final_counters(harness)
        assert values['restarts'] == '1'
        assert values['dropped_frames'] == '0' and values['reader_errors'] == '0'


def level_sequence(harness: Harness, start: int) -> list[tuple[bytes, str, dict[str, str]]]:
    return [record for record in diagnostic_records(harness)[start:]
            if record[2].get('state') == 'active']


def test_reader_error_is_reported_and_the_stream_goes_on(link):
    with (EmulatedSensor(link, seed=34) as sensor,
          Harness(link, diagnostics_period=0.2, error_hold=1.0) as harness):
        node = harness.activate()
        assert harness.wait_published(1000)
        start = len(diagnostic_records(harness))
        node.inject_reader_fault(RuntimeError('injected decoder failure'))
        assert harness.wait(lambda: any(
            level == DiagnosticStatus.ERROR and 'injected decoder failure' in message
            for level, message, _ in level_sequence(harness, start)), 10.0)
        published = node.counters['published_samples']
        assert harness.wait_published(published + 1000)
        # after error_hold the level returns to OK (or WARN for a low rate in a short
        # period); the count and the text stay
        error_at = next(i for i, (level, _, _) in enumerate(level_sequence(harness, start))
                        if level == DiagnosticStatus.ERROR)
        assert harness.wait(lambda: any(
            level != DiagnosticStatus.ERROR
            for level, _, _ in level_sequence(harness, start)[error_at:]), 10.0)
        node.trigger_deactivate()
        level, message, values = next(
            record for record in level_sequence(harness, start)[error_at:]
            if record[0] != DiagnosticStatus.ERROR)
        assert level in (DiagnosticStatus.OK, DiagnosticStatus.WARN)
        assert 'reader error' not in message
        assert values['reader_errors'] == '1'
        assert 'decode: RuntimeError: injected decoder failure' in values['last_reader_error']
        # the chunk lost to the error is a counted sequence gap, nothing else is lost
        assert node.counters['dropped_frames'] > 0
        check_batches_are_gap_free_and_true(harness, sensor)


def test_a_dead_reader_thread_is_restarted_never_active_and_silent(link):
    with (EmulatedSensor(link, seed=35),
          Harness(link, diagnostics_period=0.2, error_hold=1.0) as harness):
        node = harness.activate()
        assert harness.wait_published(500)
        start = len(diagnostic_records(harness))
        node.inject_reader_fault(SystemExit('injected thread death'))  # passes the guard
        assert harness.wait(lambda: any(
            values.get('reader_restarts') == '1' and level == DiagnosticStatus.ERROR
            and 'reader thread ended: SystemExit' in message
            for level, message, values in level_sequence(harness, start)), 10.0)
        published = node.counters['published_samples']
        assert harness.wait_published(published + 1000)
        assert node.lifecycle_state == 'active'
