"""The serial sensor lifecycle node with real rclpy, a real subscriber and an emulated
device on a real pty."""
from __future__ import annotations

import time

import numpy as np
import pytest
from rclpy.parameter import Parameter
from serial_node_harness import Harness, check_batches_are_gap_free_and_true

from forte_driver.emulators.emulated_sensor import EmulatedSensor, FaultPlan
from forte_msgs.msg import SensorInfo
from forte_ros.contract import CHANNEL_NAMES
from forte_ros.qos import SENSOR_INFO
from forte_ros.sensor_identity import SensorIdentity


@pytest.fixture
def link(tmp_path):
    return str(tmp_path / 'forte_sensor')


def test_exact_counts_and_no_invented_samples_under_faults(link):
    plan = FaultPlan(garbage=0.02, truncate=0.02, bitflip=0.02, gap=0.02, burst=0.01)
    with (EmulatedSensor(link, faults=plan, seed=21, max_scans=4000, drift_ppm=60.0) as sensor,
          Harness(link, reliable=True) as harness):
        node = harness.activate()
        # every scan the device sent intact was received; the gaps still inside the
        # reorder window are counted as dropped at deactivation
        assert harness.wait(lambda: sensor.scans_generated == 4000
                            and node.counters['received_samples']
                            == 4000 - sensor.log.dropped, 30.0)
        node.trigger_deactivate()  # publishes the last partial batch
        expected_rows = len(sensor.delivered)
        assert harness.wait(lambda: sum(m.sample_count for m in harness.frames)
                            == node.counters['published_samples'], 10.0)
        counters = node.counters
        assert counters['dropped_frames'] == sensor.log.dropped > 100
        assert counters['corrupt_frames'] == sensor.log.corrupt > 100
        assert counters['published_samples'] == expected_rows
        assert check_batches_are_gap_free_and_true(harness, sensor) == expected_rows
        last = harness.frames[-1]
        assert (last.dropped_frames, last.corrupt_frames) == (sensor.log.dropped,
                                                              sensor.log.corrupt)
        for message in harness.frames:
            assert message.header.frame_id == 'forte_base_link'
            assert list(message.channel_names) == list(CHANNEL_NAMES)
            assert message.sample_period == pytest.approx(0.0005)
            assert 1 <= message.sample_count <= 20
            assert len(message.data) == 6 * message.sample_count
        # a batch is cut short only by a gap (here every corrupt frame is also a gap)
        for current, following in zip(harness.frames, harness.frames[1:]):
            if current.sample_count < 20:
                last_row_us = current.device_time_us + 500 * (current.sample_count - 1)
                assert following.device_time_us != last_row_us + 500


def test_stamps_follow_the_device_clock_not_the_receive_time(link):
    with (EmulatedSensor(link, seed=22, drift_ppm=-50.0, clock_offset_us=77_000_000) as sensor,
          Harness(link) as harness):
        harness.activate()
        assert harness.wait(lambda: sum(m.sample_count for m in harness.frames) > 6000, 30)
        harness.node.trigger_deactivate()
        # ROS time is system time; the emulator's true sample instants are monotonic
        system_minus_monotonic = time.time_ns() - time.monotonic_ns()
        errors = []
        for message in harness.frames[len(harness.frames) // 2:]:
            stamp_ns = message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
            true_ns = sensor.host_ns_of_device_time(message.device_time_us)
            errors.append((stamp_ns - true_ns - system_minus_monotonic) * 1e-9)
        errors = np.array(errors)
        # stamp = sample instant + the minimum transport latency of the window
        assert np.all(errors > -0.001) and np.all(errors < 0.010)
        # consecutive batch stamps advance by their device time, not by arrival jitter
        stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
                           for m in harness.frames[len(harness.frames) // 2:]])
        device = np.array([m.device_time_us * 1e-6
                           for m in harness.frames[len(harness.frames) // 2:]])
        assert np.max(np.abs(np.diff(stamps) - np.diff(device))) < 0.001


def test_unplug_deactivates_and_replug_reactivates(link):
    with (EmulatedSensor(link, seed=23) as sensor,
          Harness(link, reconnect_period=0.1) as harness):
        node = harness.activate()
        assert harness.wait(lambda: len(harness.frames) > 20)
        sensor.unplug()
        assert harness.wait(lambda: node.lifecycle_state == 'inactive', 10.0)
        count_while_unplugged = len(harness.frames)
        time.sleep(0.3)
        assert len(harness.frames) == count_while_unplugged  # nothing invented meanwhile
        sensor.replug()
        assert harness.wait(lambda: node.lifecycle_state == 'active', 10.0)
        assert harness.wait(lambda: len(harness.frames) > count_while_unplugged + 20)
        node.trigger_deactivate()
        counters = node.counters
        assert counters['reconnects'] == 1
        assert sensor.sessions == 2
        # the session change is not a drop; the in-flight bytes lost by the unplug
        # cannot be counted (no sequence spans the two device sessions)
        assert counters['dropped_frames'] == 0
        assert counters['corrupt_frames'] == 0
        check_batches_are_gap_free_and_true(harness, sensor)
        sequences = [m.first_sequence for m in harness.frames]
        assert sequences == sorted(sequences)  # monotonic across the reconnect


def test_ascii_mode_counts_corrupt_lines_and_never_reuses_samples(link):
    plan = FaultPlan(garbage=0.03, truncate=0.03, bitflip=0.03)
    with EmulatedSensor(link, 'ascii', faults=plan, seed=24, max_scans=3000,
                        stream_on_power_up=False) as sensor:
        with Harness(link, protocol='ascii', reliable=True) as harness:
            node = harness.activate()
            sensor.set_ascii_streaming(True)
            assert harness.wait(lambda: sensor._session_scans >= 3000, 30.0)
            assert harness.wait(lambda: node.counters['received_samples']
                                + sensor.log.dropped == 3000, 10.0)
            node.trigger_deactivate()
            assert harness.wait(lambda: sum(m.sample_count for m in harness.frames)
                                == node.counters['published_samples'])
            values = [tuple(row) for m in harness.frames
                      for row in np.asarray(m.data).reshape(-1, 6)]
            assert values == [v for *_, v in sensor.delivered]
            assert node.counters['corrupt_frames'] == sensor.log.corrupt > 100
            assert harness.frames[-1].dropped_frames == 0  # not countable without sequences
            assert all(m.device_time_us == 0 for m in harness.frames)


def test_parameters_are_validated_with_reasons(link):
    with (EmulatedSensor(link, seed=25),
          Harness(link) as harness):
        node = harness.node
        result = node.set_parameters([Parameter('protocol', value='morse')])[0]
        assert not result.successful and 'binary' in result.reason
        result = node.set_parameters([Parameter('sample_rate_hz', value=3)])[0]
        assert not result.successful and 'divid' in result.reason
        result = node.set_parameters([Parameter('batch_size', value=0)])[0]
        assert not result.successful
        assert node.set_parameters([Parameter('batch_size', value=10)])[0].successful
        node.trigger_configure()
        result = node.set_parameters([Parameter('batch_size', value=5)])[0]
        assert not result.successful and 'unconfigured' in result.reason
        node.trigger_activate()
        assert harness.wait(lambda: len(harness.frames) > 5)
        assert max(m.sample_count for m in harness.frames) == 10


def test_configure_fails_cleanly_without_a_device(tmp_path):
    with Harness(str(tmp_path / 'absent')) as harness:
        harness.node.trigger_configure()
        assert harness.node.lifecycle_state == 'unconfigured'


def test_diagnostics_report_rate_drops_and_corruption(link):
    plan = FaultPlan(gap=0.01, bitflip=0.01)
    with (EmulatedSensor(link, faults=plan, seed=26),
          Harness(link, diagnostics_period=0.5) as harness):
        harness.activate()

        def active() -> list:
            """(status, key -> value) of the active reports from the first with frames on
            (a later window without frames counts), oldest first."""
            found = []
            for array in list(harness.diagnostics):
                status = array.status[0]
                table = {kv.key: kv.value for kv in status.values}
                if table.get('state') == 'active' and (
                        found or float(table['achieved_rate_hz']) > 0):
                    found.append((status, table))
            return found

        assert harness.wait(lambda: len(active()) >= 4, 20.0)
        reports = active()
        status, table = reports[-1]
        assert status.name.endswith('tactile sensor')
        # the board's 2 kHz, less the injected gaps, over the reports' 0.5 s windows: one
        # window alone can exceed it (an emulator that stalled on a loaded machine delivers
        # the frames it owed in the next window: 2376 Hz seen once), their mean cannot
        rates = [float(table['achieved_rate_hz']) for _, table in reports]
        assert 500.0 < sum(rates) / len(rates) < 2100.0, rates
        assert int(table['dropped_frames']) > 0
        assert int(table['corrupt_frames']) > 0
        assert float(table['latency_mean_ms']) >= 0.0
        assert table['device_id'] == f'{0xF0E7E500 + 26:016x}'


def test_the_board_identity_is_latched_on_sensor_info(link):
    """IDENTIFY's answer becomes forte_msgs/SensorInfo on tactile/sensor_info: a subscriber
    that joins after it was sent still gets it (transient local), and a SET_RATE to another
    rate publishes it again with the acknowledged rate."""
    with (EmulatedSensor(link, seed=27),
          Harness(link, sample_rate_hz=1000) as harness):
        harness.node.trigger_configure()
        assert harness.wait(lambda: harness.node._info is not None, 10.0)
        time.sleep(0.2)
        late = harness.ros.collect(SensorInfo, 'tactile/sensor_info', SENSOR_INFO)
        assert harness.wait(lambda: len(late) >= 1, 10.0), 'no latched sensor info'
        first = SensorIdentity.from_message(late[0])
        assert first == SensorIdentity(
            source='serial', device_id=f'{0xF0E7E500 + 27:016x}', firmware='1.0.0',
            protocol_version=1, sample_rate=2000.0, channel_names=CHANNEL_NAMES,
            counts_per_full_scale=1024, adc_bits=12)
        harness.node.trigger_activate()
        assert harness.wait(lambda: len(late) >= 2, 10.0), 'no identity at the new rate'
        assert SensorIdentity.from_message(late[-1]).sample_rate == 1000.0
