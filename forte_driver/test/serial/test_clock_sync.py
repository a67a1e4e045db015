"""Tests of the device-clock to host-time estimator on synthetic clocks with known answers."""
from __future__ import annotations

import numpy as np
import pytest

from forte_driver.serial.clock_sync import ClockSync


def simulate(sync: ClockSync, seconds: float, drift_ppm: float, offset_s: float,
             seed: int = 0, start_device_us: int = 3_000_000, latency_scale_s: float = 0.002,
             chunk_s: float = 0.005):
    """Feed observations: every chunk_s, the newest sample (device time) is received with a
    positive random latency (0.2 ms floor + exponential). Returns the true map."""
    rng = np.random.default_rng(seed)

    def true_host_ns(device_us: float) -> float:
        return (offset_s + (device_us - start_device_us) * 1e-6 * (1 + drift_ppm * 1e-6)) * 1e9

    for k in range(int(seconds / chunk_s)):
        device_us = start_device_us + int(k * chunk_s * 1e6)
        latency = 0.0002 + rng.exponential(latency_scale_s)
        sync.add(device_us, int(true_host_ns(device_us) + latency * 1e9))
    return true_host_ns


@pytest.mark.parametrize('drift_ppm', [-80.0, 0.0, 35.0, 120.0])
def test_offset_and_drift_recovered(drift_ppm):
    sync = ClockSync(window_s=20.0, bin_s=0.5)
    truth = simulate(sync, 30.0, drift_ppm, offset_s=1_700_000_000.0)
    assert sync.drift_ppm == pytest.approx(drift_ppm, abs=3.0)
    # mapped time = true sample time + the minimum latency (0.2 ms floor), within 0.3 ms
    for device_us in (3_000_000 + 29_000_000, 3_000_000 + 25_000_000):
        error_s = (sync.to_host_ns(device_us) - truth(device_us)) * 1e-9
        assert 0.0 <= error_s + 1e-5 and error_s < 0.0005


def test_before_any_observation_there_is_no_mapping():
    sync = ClockSync()
    assert sync.to_host_ns(123) is None
    assert sync.model is None
    assert sync.drift_ppm == 0.0


def test_single_bin_uses_minimum_latency_and_no_drift():
    sync = ClockSync(bin_s=0.5)
    sync.add(1_000_000, 10_000_000_000 + 3_000_000)   # 3 ms latency
    sync.add(1_100_000, 10_100_000_000 + 1_000_000)   # 1 ms latency (the minimum)
    sync.add(1_200_000, 10_200_000_000 + 5_000_000)
    assert sync.drift_ppm == 0.0
    assert sync.to_host_ns(1_000_000) == 10_000_000_000 + 1_000_000
    assert sync.last_latency_s == pytest.approx(0.004)


def test_mapping_is_never_later_than_the_best_observation():
    """The line is the lower envelope: no bin minimum lies below it."""
    sync = ClockSync(window_s=10.0, bin_s=0.25)
    observations = []
    rng = np.random.default_rng(3)
    for k in range(2000):
        device_us = 1_000_000 + 5000 * k
        host_ns = int(device_us * 1000 * (1 + 50e-6) + 2e6 + rng.exponential(1e6))
        observations.append((device_us, host_ns))
        sync.add(device_us, host_ns)
    recent = [o for o in observations if o[0] >= observations[-1][0] - 9_000_000]
    assert min(h - sync.to_host_ns(d) for d, h in recent) >= -1000  # >= -1 us


def test_device_clock_jump_resets_the_estimator():
    sync = ClockSync()
    simulate(sync, 5.0, 0.0, offset_s=100.0)
    assert sync.resets == 0
    # the device restarts: its clock is back near zero while host time moves on
    for k in range(10):
        sync.add(10_000 + 5000 * k, int((105.0 + 0.005 * k) * 1e9) + 300_000)
    assert sync.resets == 1
    assert sync.to_host_ns(10_000) == pytest.approx(105.0e9 + 300_000, abs=1e6)


def test_a_single_host_stall_does_not_reset():
    sync = ClockSync()
    truth = simulate(sync, 5.0, 0.0, offset_s=100.0)
    sync.add(3_000_000 + 5_000_000, int(truth(8_000_000) + 2.5e9))  # read 2.5 s late once
    assert sync.resets == 0


def test_invalid_configuration_is_refused():
    with pytest.raises(ValueError):
        ClockSync(window_s=1.0, bin_s=2.0)
