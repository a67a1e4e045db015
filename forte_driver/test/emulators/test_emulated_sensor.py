"""The emulated sensor over a real pty, driven with pyserial and the protocol decoder."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
import serial

from forte_driver.emulators.emulated_sensor import EmulatedSensor, FaultPlan
from forte_driver.emulators.serial_host import Host
from forte_driver.serial import protocol
from forte_driver.serial.protocol import (
    AsciiLineDecoder,
    AsciiSample,
    Command,
    Sample,
    Status,
)
from forte_driver.serial.stream import SequenceTracker
from forte_ros.contract import COUNTS_PER_FULL_SCALE


@pytest.fixture
def link(tmp_path):
    return str(tmp_path / 'forte_sensor')


def test_commands_are_acknowledged_like_the_firmware(link):
    with EmulatedSensor(link, seed=1) as sensor:
        host = Host(link)
        ack = host.command(Command.IDENTIFY)
        assert (ack.status, ack.value) == (Status.OK, 2000)
        host.pump(2.0, until=lambda: host.infos)
        assert host.infos[0].device_id == sensor.device_id
        assert host.infos[0].counts_per_full_scale == 1024
        assert host.command(Command.SET_RATE, 3).status == Status.BAD_ARGUMENT
        assert host.command(Command.SET_RATE, 5000).status == Status.BAD_ARGUMENT
        ack = host.command(Command.SET_RATE, 1000)
        assert (ack.status, ack.value) == (Status.OK, 1000)
        assert host.command(0x55).status == Status.UNKNOWN_COMMAND
        assert host.samples == []  # nothing streams before START
        ack = host.command(Command.START)
        assert (ack.status, ack.value) == (Status.OK, 1000)
        assert host.command(Command.START).status == Status.BUSY
        assert host.command(Command.SET_RATE, 2000).status == Status.BUSY
        host.pump(5.0, until=lambda: len(host.samples) >= 200)
        ack = host.command(Command.STOP)
        host.pump(0.2)
        received = host.samples
        assert ack.status == Status.OK
        assert [s.sequence for s in received] == list(range(len(received)))
        assert len(received) == ack.value  # everything sampled before STOP arrived
        assert received[0].flags & protocol.FLAG_SESSION_START
        steps = {b.time_us - a.time_us for a, b in zip(received, received[1:])}
        assert steps == {1000}  # exactly 1 kHz on the device clock
        host.close()


def test_fault_injection_gives_exact_counts_and_only_delivered_samples(link):
    plan = FaultPlan(garbage=0.03, truncate=0.03, bitflip=0.03, gap=0.03, burst=0.01)
    with EmulatedSensor(link, faults=plan, seed=11, max_scans=3000) as sensor:
        host = Host(link)
        host.command(Command.START)
        host.pump(20.0, until=lambda: host.samples and host.samples[-1].sequence == 2999)
        tracker = SequenceTracker()
        tracker.start_session(from_zero=True)
        for sample in host.samples:
            tracker.update(sample.sequence)
        log = sensor.log
        assert min(log.counts[name] for name in ('garbage', 'truncate', 'bitflip', 'gap')) > 30
        assert host.decoder.corrupt_frames == log.corrupt
        assert tracker.dropped_frames == log.dropped
        delivered = [(seq, values) for _, seq, _, values in sensor.delivered]
        assert [(s.sequence, s.normalised()) for s in host.samples] == delivered
        assert len(host.samples) + log.dropped == 3000
        host.close()


def test_slow_host_causes_counted_device_overruns_not_blocking(link):
    with EmulatedSensor(link, seed=2, ring_capacity=64) as sensor:
        host = Host(link)
        host.command(Command.START)
        deadline = time.monotonic() + 30.0
        while sensor.device_overruns == 0 and time.monotonic() < deadline:
            time.sleep(0.05)  # the host does not read: pty and device ring fill up
        assert sensor.device_overruns > 0
        host.pump(1.0)  # the host catches up while the device keeps streaming
        host.command(Command.STOP)
        host.pump(1.0)
        tracker = SequenceTracker()
        tracker.start_session(from_zero=True)
        for sample in host.samples:
            tracker.update(sample.sequence)
        last = host.samples[-1]
        # every gap is a scan the device dropped and reported in its overrun counter
        assert tracker.dropped_frames == last.overruns == sensor.device_overruns
        assert any(s.flags & protocol.FLAG_OVERRUN for s in host.samples)
        host.close()


def test_unplug_and_replug_behind_the_same_link(link):
    with EmulatedSensor(link, seed=3) as sensor:
        host = Host(link)
        host.command(Command.START)
        host.pump(5.0, until=lambda: len(host.samples) > 100)
        sensor.unplug()
        assert not os.path.lexists(link)
        with pytest.raises((serial.SerialException, OSError)):  # EIO: the pty is gone
            host.pump(2.0)
        host.port.close()
        sensor.replug()
        assert os.path.islink(link)
        host = Host(link)
        ack = host.command(Command.START)
        assert ack.status == Status.OK  # a power-cycled device is stopped
        host.pump(5.0, until=lambda: len(host.samples) > 10)
        assert host.samples[0].sequence == 0
        assert sensor.sessions == 2
        host.close()


def test_ascii_mode_streams_legacy_lines_with_exact_corrupt_counts(link):
    plan = FaultPlan(garbage=0.03, truncate=0.03, bitflip=0.03, gap=0.03)
    with EmulatedSensor(link, 'ascii', faults=plan, seed=5, max_scans=2000,
                        stream_on_power_up=False) as sensor:
        port = serial.Serial(link, timeout=0.02)
        decoder = AsciiLineDecoder()
        sensor.set_ascii_streaming(True)
        received = []
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and sensor.scans_generated < 2000:
            received += decoder.feed(port.read(max(1, port.in_waiting)))
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            received += decoder.feed(port.read(max(1, port.in_waiting)))
        samples = [item.values for item in received if isinstance(item, AsciiSample)]
        assert decoder.corrupt_lines == sensor.log.corrupt > 50
        assert samples == [values for *_, values in sensor.delivered]
        assert len(samples) + sensor.log.dropped == 2000
        port.close()


def test_command_line_emulator_runs_until_interrupted(link):
    process = subprocess.Popen(
        [sys.executable, '-m', 'forte_driver.emulators.emulated_sensor', '--link', link,
         '--rate', '500', '--gap', '0.5', '--seed', '4'], stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20.0
        while not os.path.lexists(link) and time.monotonic() < deadline:
            time.sleep(0.05)
        host = Host(link)
        assert host.command(Command.START).value == 500
        host.pump(5.0, until=lambda: len(host.samples) > 50)
        tracker = SequenceTracker()
        for sample in host.samples:
            tracker.update(sample.sequence)
        assert tracker.dropped_frames > 10  # about half the scans are gaps
        host.close()
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=10)
    assert process.returncode == 0
    assert 'expected dropped' in output
    assert not os.path.lexists(link)


def plausible(sample: Sample) -> bool:
    """The documented ranges: |value| <= 1024 counts, flag bits 0..2 only, and a device
    time far below the 2**58 us of an implausible frame."""
    return (all(abs(v) <= COUNTS_PER_FULL_SCALE for v in sample.values)
            and not sample.flags & ~0x07 and sample.time_us < 1 << 58)


def test_sequence_faults_are_sent_exactly_as_logged(link):
    plan = FaultPlan(duplicate=0.02, reorder=0.02, implausible=0.02, restart=0.004)
    with EmulatedSensor(link, faults=plan, seed=12, max_scans=3000) as sensor:
        host = Host(link)
        host.command(Command.START)
        host.pump(20.0, until=lambda: sensor.scans_generated >= 3000)
        host.pump(0.5)
        log = sensor.log
        assert min(log.counts[name] for name in ('duplicate', 'reorder', 'implausible')) > 30
        assert log.counts['restart'] >= 2
        impostors = [s for s in host.samples if not plausible(s)]
        assert len(impostors) == log.implausible == log.counts['implausible'] == log.corrupt
        assert host.decoder.corrupt_frames == 0  # every impostor has a valid CRC
        # the host sees: sessions begin with a flagged sequence 0 (START, then restarts)
        session, received, duplicates, late = 0, [], 0, 0
        previous = None
        for sample in filter(plausible, host.samples):
            if sample.flags & protocol.FLAG_SESSION_START:
                assert sample.sequence == 0
                session += 1
            elif previous is not None and sample.sequence == previous.sequence:
                assert sample == previous
                duplicates += 1
                continue
            elif previous is not None and sample.sequence == previous.sequence - 1:
                late += 1
            received.append((session, sample.sequence, sample.time_us, sample.normalised()))
            previous = sample
        assert session == 1 + log.restarts == sensor.sessions
        assert sum(c.command == Command.START for c in sensor.commands) == 1
        assert (duplicates, late) == (log.duplicate, log.late) == (
            log.counts['duplicate'], log.counts['reorder'])
        assert received == sensor.delivered  # each intact scan once, in transmission order
        assert len(received) + log.dropped == 3000  # only impostors replaced scans
        restarted = [s for s in host.samples if plausible(s) and s.sequence == 0][1:]
        assert all(1_000_000 <= s.time_us < 1_100_000 for s in restarted)  # clock rebooted
        host.close()


def test_sequence_faults_exist_only_in_binary_mode(link):
    with pytest.raises(ValueError, match='binary'):
        EmulatedSensor(link, 'ascii', faults=FaultPlan(duplicate=0.1))
    with pytest.raises(ValueError, match='implausible'):
        EmulatedSensor(link).inject('gap', kind='time')
    result = subprocess.run(
        [sys.executable, '-m', 'forte_driver.emulators.emulated_sensor', '--protocol', 'ascii',
         '--restart', '0.1', '--link', link], capture_output=True, text=True, timeout=30)
    assert result.returncode == 2 and 'binary' in result.stderr
    help_text = subprocess.run([sys.executable, '-m', 'forte_driver.emulators.emulated_sensor',
                                '--help'], capture_output=True, text=True, timeout=30).stdout
    for name in ('--duplicate', '--reorder', '--implausible', '--restart'):
        assert name in help_text
