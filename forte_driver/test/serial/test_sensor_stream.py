"""Reader-side robustness without ROS: the byte stream -> stamped batches path
(SensorStream), the clock estimator's range checks and the reader-health rules, on
known-answer inputs (docs/serial_driver.md, "Reader errors" and "Diagnostics")."""
from __future__ import annotations

import pytest

from forte_driver.serial import protocol
from forte_driver.serial.clock_sync import ClockSync
from forte_driver.serial.protocol import Ack, Command, Sample, Status
from forte_driver.serial.reader_health import ERROR, OK, WARN, ReaderHealth, diagnostics_level
from forte_driver.serial.sensor_stream import SensorStream

PERIOD_US = 500
#: The frame seen in the fault-injection campaign: a corrupt candidate whose CRC matched
#: by chance (readings up to 28158, undefined flag bits, device time ~4.9e17 us).
FIELD_IMPOSTOR = Sample(0x3A91F2C4, 490_000_000_000_000_000,
                        (28158, -3, 0, 12, 9000, -20000), 7, 0xB8, 0x40)
LATENCY_NS = 1_000_000


def scans(first_sequence: int, count: int, first_time_us: int, session_start: bool = False):
    return [Sample(first_sequence + i, first_time_us + PERIOD_US * i, (i % 50, -7, 0, 3, 1, 2),
                   0, protocol.FLAG_SESSION_START if session_start and i == 0 else 0)
            for i in range(count)]


def encode(samples) -> bytes:
    return b''.join(protocol.encode_sample(sample) for sample in samples)


def started_stream(batch_size: int = 20) -> SensorStream:
    stream = SensorStream(True, batch_size, PERIOD_US, 20.0, ReaderHealth())
    stream.assembler.start_session()
    stream.feed(protocol.encode_ack(Ack(Command.START, 1, Status.OK, 2000)), 0,
                lambda item: stream.assembler.start_session(from_zero=True))
    return stream


def test_the_field_impostor_as_first_frame_neither_raises_nor_reaches_the_clock():
    stream = started_stream()
    host_origin_ns = 1_700_000_000 * 10**9
    stamped = stream.feed(protocol.encode_sample(FIELD_IMPOSTOR), host_origin_ns, print)
    assert stamped == []
    assert stream.assembler.implausible_frames == stream.assembler.corrupt_frames == 1
    assert stream.clock_sync.model is None  # nothing observed
    truth = scans(1, 40, 5_000_000)
    stamped = stream.feed(encode(truth), host_origin_ns + LATENCY_NS, print)
    assert [batch.first_sequence for batch, _ in stamped] == [1, 21]
    # the newest scan of the chunk was received 1 ms after it was taken: stamps = true
    # sample instants + 1 ms, with the device clock anchored by that observation
    newest_us = truth[-1].time_us
    for batch, stamp_ns in stamped:
        assert stamp_ns == host_origin_ns + LATENCY_NS - (newest_us - batch.device_time_us) * 1000
    assert stream.unstamped_samples == 0 and stream.health.reader_errors == 0


def test_an_impostor_after_a_completed_batch_is_rejected_and_the_next_batch_is_true():
    stream = started_stream()
    truth = scans(0, 60, 5_000_000, session_start=True)
    data = encode(truth[:20]) + protocol.encode_sample(
        FIELD_IMPOSTOR._replace(sequence=20)) + encode(truth[21:])
    stamped = stream.feed(data, 1_700_000_000 * 10**9, print)
    assert [(batch.first_sequence, len(batch.values)) for batch, _ in stamped] == [
        (0, 20), (21, 20)]
    assert stream.assembler.implausible_frames == 1
    assert stream.flush()[0][0].first_sequence == 41


def test_clock_sync_rejects_unrepresentable_times_and_never_raises():
    sync = ClockSync()
    assert sync.add(-5, 10**18) is False
    assert sync.add(5_000_000, 2**63) is False  # host time beyond signed 64-bit ns
    assert sync.rejected_observations == 2 and sync.model is None
    assert sync.add(5_000_000, 10**9) is True  # device 5 s <-> host 1 s after 1970
    assert sync.to_host_ns(5_000_000) == 10**9
    # 4.9e17 us after that is ~1.6e4 years: beyond signed 64-bit ROS time
    assert sync.to_host_ns(FIELD_IMPOSTOR.time_us) is None
    assert sync.to_host_ns(0) is None  # would be before 1970: not a valid ROS time
    assert sync.resets == 0


def test_clock_sync_maps_device_times_of_any_size():
    # a device clock far beyond 2**62 us (e.g. one that started near the u64 limit): only
    # differences matter, so the mapping is as exact as near zero
    sync = ClockSync()
    base_us = 2**64 - 3_000_000
    assert sync.add(base_us, 10**9) is True
    assert sync.to_host_ns(base_us + 2_000_000) == 10**9 + 2_000_000_000


def test_device_time_wrapping_at_2_pow_64_is_stamped_without_a_jump():
    # docs/firmware.md: time_us is a u64 counter; a session that crosses its wrap is one
    # continuous clock (the assembler judges time mod 2**64), so stamps keep advancing by
    # one period per scan
    stream = started_stream()
    first_us = 2**64 - 10 * PERIOD_US - 116  # 2**64 = 116 (mod 500)
    truth = [sample._replace(time_us=sample.time_us % 2**64)
             for sample in scans(0, 60, first_us, session_start=True)]
    host_origin_ns = 1_700_000_000 * 10**9
    stamped = stream.feed(encode(truth), host_origin_ns, print) + stream.flush()
    assert [len(batch.values) for batch, _ in stamped] == [20, 20, 20]
    assert stream.assembler.implausible_frames == 0
    stamps = [stamp_ns for _, stamp_ns in stamped]
    assert stamps[1] - stamps[0] == stamps[2] - stamps[1] == 20 * PERIOD_US * 1000
    assert stamps[2] + 19 * PERIOD_US * 1000 == host_origin_ns  # newest scan at reception
    assert stream.unstamped_samples == 0 and stream.clock_sync.resets == 0


def test_a_device_restart_stamps_each_session_with_its_own_clock():
    stream = started_stream()
    host_origin_ns = 1_700_000_000 * 10**9  # host time of device time 5 s (session A)
    session_a = scans(0, 100, 5_000_000, session_start=True)

    def host_a(time_us):  # reception of session A's scans: 1 ms after they are taken
        return host_origin_ns + (time_us - 5_000_000) * 1000 + LATENCY_NS

    first = stream.feed(encode(session_a[:80]), host_a(session_a[79].time_us), print)
    # the device resets 0.2 s later: its clock restarts at 1 s, sequence at 0, flagged
    restart_host_ns = host_a(session_a[-1].time_us) + 200_000_000
    session_b = scans(0, 30, 1_000_000, session_start=True)
    second = stream.feed(encode(session_a[80:]) + encode(session_b),
                         restart_host_ns + (session_b[-1].time_us - 1_000_000) * 1000, print)
    assert stream.assembler.restarts == 1 and stream.clock_sync.resets == 1
    batches = first + second
    assert [(b.first_sequence, len(b.values)) for b, _ in batches] == [
        (0, 20), (20, 20), (40, 20), (60, 20), (80, 20), (100, 20)]
    for batch, stamp_ns in batches[:5]:  # session A: its own clock
        assert stamp_ns == host_a(batch.device_time_us)
    batch, stamp_ns = batches[5]  # session B: the new clock, never A's
    assert batch.device_time_us == 1_000_000
    assert stamp_ns == restart_host_ns


def test_unstampable_batches_are_counted_and_reported_not_raised():
    stream = started_stream()
    # a session whose clock maps before 1970 cannot be stamped in ROS time
    stamped = stream.feed(encode(scans(0, 40, 5_000_000, session_start=True)), 1_000, print)
    assert stamped == []
    assert stream.unstamped_samples == 40
    assert stream.health.reader_errors == 2
    assert 'cannot be mapped to ROS time' in stream.health.last_error


def test_reader_health_holds_errors_and_limits_restarts():
    health = ReaderHealth(error_hold_s=5.0, max_restarts=2, restart_window_s=60.0)
    assert not health.error_active(0.0)
    text = health.record_error('decode', OverflowError('int too big'), now_s=100.0)
    assert text == 'decode: OverflowError: int too big'
    assert health.error_active(104.9) and not health.error_active(105.0)
    assert health.allow_restart(200.0) and health.allow_restart(210.0)
    assert not health.allow_restart(220.0) and health.failed
    assert health.reader_restarts == 2
    health.clear_failure()
    assert health.allow_restart(221.0) and not health.failed
    assert health.reader_errors == 1


@pytest.mark.parametrize(('state', 'connected', 'rate', 'error_at', 'failed', 'expected'), [
    ('active', False, 0.0, None, False, (ERROR, 'device lost, reconnecting')),
    ('inactive', False, 0.0, None, False, (ERROR, 'device not connected')),
    ('active', True, 2000.0, 9.0, False, (ERROR, 'reader error: decode: ValueError: x')),
    ('active', True, 2000.0, 4.0, False, (OK, 'active')),  # held 5 s, then OK again
    ('active', True, 1000.0, 4.0, False, (WARN, 'rate 1000 Hz below nominal 2000 Hz')),
    ('inactive', True, 0.0, None, True, (ERROR, 'reader thread keeps failing, deactivated: '
                                                'decode: ValueError: x')),
    ('inactive', True, 0.0, None, False, (OK, 'inactive')),
])
def test_diagnostics_level_rules(state, connected, rate, error_at, failed, expected):
    health = ReaderHealth(error_hold_s=5.0)
    health.last_error = 'decode: ValueError: x'
    if error_at is not None:
        health.record_error('decode', ValueError('x'), error_at)
    health.failed = failed
    assert diagnostics_level(state, connected, rate, 2000, health, now_s=10.0) == expected
