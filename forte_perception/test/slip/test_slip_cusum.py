"""The band-power CUSUM (forte_perception.slip.cusum): known answers from its derivation
(delay of a step, quiet channels, slipping state, missing data, chunking, veto)."""
import math
from dataclasses import replace

import numpy as np
import pytest

from forte_perception.evaluation.benchmark import MODES, cusum_mode, prepare
from forte_perception.evaluation.scenes import make_scene
from forte_perception.slip.cusum import BandPowerCusum, CusumParams, expected_delay

DT = 4 / 2000.0        # hop 4 at 2 kHz
LEVEL = -80.0          # quiet level of every channel [dB]
BLOCK = 100            # updates per level block at the default 0.2 s
#: drift 8 dB, h 0.05 dB s (the sequential mode's); weak-change test 6 dB, 0.1 dB s
WEAK = CusumParams(drift=8.0, threshold=0.05, weak_drift=6.0, weak_threshold=0.1)


def constant(m, value=LEVEL):
    return np.full((m, 6), value)


def test_noise_free_step_alarms_after_the_expected_number_of_updates():
    params = CusumParams()
    for step_db in (8.0, 14.0, 20.0, 40.0):
        y = constant(600)
        y[300:, :3] += step_db                      # left finger only: leading-finger slip
        out = BandPowerCusum(DT, params).update(y)
        n = expected_delay(step_db, params, DT)
        assert n == math.floor(params.threshold / ((step_db - params.drift) * DT)) + 1
        np.testing.assert_array_equal(np.flatnonzero(out.slip), [300 + n - 1])
        assert out.alarm[300 + n - 1, 0] and not out.alarm[:, 1].any()
    assert expected_delay(20.0, params, DT) == 2       # 0.05 / (14 dB x 2 ms) = 1.8
    assert expected_delay(6.0, params, DT) == math.inf  # at the drift: never


def test_noisy_step_alarms_within_two_updates_of_walds_delay():
    params = CusumParams(threshold=0.5)
    rng = np.random.default_rng(3)
    n = expected_delay(20.0, params, DT)                # 0.5 / (14 dB x 2 ms) -> 18
    assert n == 18
    for trial in range(5):
        y = LEVEL + rng.standard_normal((800, 6))       # 1 dB per channel, independent
        y[400:, 3:] += 20.0
        out = BandPowerCusum(DT, params).update(y)
        first = np.flatnonzero(out.slip)
        assert first.size and abs(first[0] - (400 + n - 1)) <= 2, (trial, first[:3])


def test_quiet_channels_at_their_level_never_alarm():
    rng = np.random.default_rng(0)
    m = 200_000                                         # 400 s of updates
    y = LEVEL + rng.standard_normal((m, 6))             # 1 dB spread, drift 6 dB
    out = BandPowerCusum(DT).update(y)
    assert not out.slip.any() and not out.slipping.any()
    assert out.active[BLOCK:].all() and not out.active[:BLOCK].any()
    np.testing.assert_allclose(BandPowerCusum(DT).update(constant(300)).statistic, 0.0)


def test_slipping_is_held_while_the_excess_lasts_and_cleared_after_clear_time():
    params = CusumParams(margin=3.0, clear_time=0.01)   # 5 updates
    y = constant(1000)
    y[300:700, :] += 20.0
    y[500:510, :] -= 18.0                               # 10 updates only 2 dB above: clears
    out = BandPowerCusum(DT, params).update(y)
    slipping = out.any_slipping
    alarms = np.flatnonzero(out.slip)
    assert alarms[0] == 301
    assert slipping[301:504].all() and not slipping[504]   # 5th update below the margin
    assert alarms[1] == 511                                  # back at 20 dB: a new event
    assert slipping[511:704].all() and not slipping[704:].any()
    assert np.isnan(out.statistic[slipping]).all()


def test_nan_channels_are_left_out_and_a_blind_finger_holds_its_statistic():
    y = constant(700)
    y[300:, :3] += 20.0
    y[300:, 1] = np.nan                                # the other two still see the step
    out = BandPowerCusum(DT).update(y)
    assert np.flatnonzero(out.slip)[0] == 301
    assert out.excess[305, 0] == pytest.approx(20.0)
    blind = constant(700)
    blind[250:, :3] = np.nan                           # the whole left finger masked
    blind[300:, :3] = np.nan
    out = BandPowerCusum(DT).update(blind)
    assert not out.slip.any() and np.isnan(out.excess[250:, 0]).all()
    assert (out.statistic[250:, 0] == 0.0).all()       # no evidence: held, not invented
    assert out.active.sum() == 700 - BLOCK


def test_silence_and_saturation_never_alarm():
    floor = 10 * np.log10(4 * (2 / 2048) ** 2 / (6 * 2000.0))   # the robust floor [dB]
    silent = constant(2000, floor)
    out = BandPowerCusum(DT).update(silent)
    assert not out.slip.any() and np.allclose(BandPowerCusum(DT).update(silent).statistic, 0)
    railed = LEVEL + np.random.default_rng(1).standard_normal((3000, 6))
    railed[1000:, 2] = floor                            # a channel rails: its PSD vanishes
    det = BandPowerCusum(DT)
    out = det.update(railed)
    assert not out.slip.any() and det.level[2] < LEVEL  # the level follows it down


@pytest.mark.parametrize('params', [replace(WEAK, weak_threshold=math.inf), WEAK],
                         ids=['one test', 'weak test'])
def test_chunks_of_any_size_give_the_batch_result_bit_for_bit(params):
    rng = np.random.default_rng(7)
    y = LEVEL + 2.0 * rng.standard_normal((3000, 6))
    y[800:1100, :3] += 15.0
    y[1200:1400, 3:] += 7.0                             # heard by the weak test only
    y[2000:2300] += 25.0
    y[1500:1600, 4] = np.nan
    whole = BandPowerCusum(DT, params).update(y)
    assert whole.slip[1200:1400].any() == params.weak
    for sizes in ([1] * 3000, [7] * 429, rng.integers(1, 300, 40).tolist()):
        det = BandPowerCusum(DT, params)
        parts, pos = [], 0
        for size in sizes:
            parts.append(det.update(y[pos:pos + size]))
            pos += size
        parts.append(det.update(y[pos:]))
        for name in ('statistic', 'excess', 'alarm', 'slipping', 'active'):
            np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                          getattr(whole, name), err_msg=name)


def test_a_vetoed_alarm_raises_nothing_and_the_statistic_restarts():
    y = constant(600)
    y[300:, :3] += 20.0
    asked = []

    def veto(i):
        asked.append(i)
        return len(asked) == 1                           # drop the first alarm only

    out = BandPowerCusum(DT).update(y, veto)
    assert out.vetoed == 1 and asked[0] == 301
    assert np.flatnonzero(out.slip)[0] == 303           # two more updates from S = 0


def test_a_step_on_one_channel_alarms_only_with_the_single_channel_route():
    """20 dB on one channel: its finger's mean rises 6.7 dB, under the 8 dB drift, so the
    mean alone never alarms; less a 4 dB offset the channel gives 16 dB, which alarms after
    expected_delay(16) updates."""
    y = constant(600)
    y[300:, 4] += 20.0
    mean_only = CusumParams(drift=8.0)
    assert not BandPowerCusum(DT, mean_only).update(y).slip.any()
    pooled = CusumParams(drift=8.0, single_offset=4.0)
    out = BandPowerCusum(DT, pooled).update(y)
    n = expected_delay(16.0, pooled, DT)
    np.testing.assert_array_equal(np.flatnonzero(out.slip), [300 + n - 1])
    assert out.alarm[300 + n - 1, 1] and not out.alarm[:, 0].any()


def test_quiet_channels_never_alarm_through_the_single_channel_route():
    rng = np.random.default_rng(1)
    y = LEVEL + rng.standard_normal((200_000, 6))        # 1 dB spread, as above
    out = BandPowerCusum(DT, CusumParams(drift=8.0, single_offset=4.0)).update(y)
    assert not out.slip.any()


def test_the_weak_change_test_hears_a_step_under_the_drift():
    """A noise-free step of 7.5 dB lies under the 8 dB drift: only the weak-change test (6 dB,
    0.1 dB s) hears it, after floor(0.1 / (1.5 dB x 2 ms)) + 1 = 34 updates. Where both hear
    a step, the sooner alarm counts: 20 dB, 3 updates (the test; the weak one needs 4)."""
    for step_db, n in ((7.5, 34), (10.0, 13), (20.0, 3)):
        y = constant(600)
        y[300:, 3:] += step_db
        out = BandPowerCusum(DT, WEAK).update(y)
        assert expected_delay(step_db, WEAK, DT) == n
        np.testing.assert_array_equal(np.flatnonzero(out.slip), [300 + n - 1])
        assert out.alarm[300 + n - 1, 1] and not out.alarm[:, 0].any()
    y = constant(600)
    y[300:, 3:] += 7.5
    assert not BandPowerCusum(DT, CusumParams(drift=8.0, threshold=0.05)).update(y).slip.any()
    assert expected_delay(5.9, WEAK, DT) == math.inf


def test_the_weak_change_test_needs_every_channel_of_its_finger():
    """With one channel of the right finger unusable, a 7.5 dB step there is not heard (the
    weak test's spread grows as fewer channels are pooled); a 20 dB step still is, by the
    test, after its own delay."""
    for step_db, heard in ((7.5, False), (20.0, True)):
        y = constant(600)
        y[300:, 3:] += step_db
        y[:, 4] = np.nan
        out = BandPowerCusum(DT, WEAK).update(y)
        assert out.slip.any() == heard
        if heard:
            n = expected_delay(step_db, CusumParams(drift=8.0, threshold=0.05), DT)
            assert np.flatnonzero(out.slip)[0] == 300 + n - 1


def test_quiet_channels_never_alarm_through_the_weak_change_test():
    rng = np.random.default_rng(2)
    y = LEVEL + rng.standard_normal((200_000, 6))        # 1 dB spread, 400 s
    out = BandPowerCusum(DT, replace(WEAK, single_offset=4.0)).update(y)
    assert not out.slip.any()


def test_parameters_are_validated():
    for bad in (dict(drift=0.0), dict(threshold=-1.0), dict(margin=math.nan),
                dict(clear_time=-0.1), dict(level_tau=math.inf), dict(single_offset=-1.0),
                dict(single_offset=math.nan), dict(weak_threshold=0.0),
                dict(weak_threshold=math.nan), dict(weak_drift=0.0),
                dict(drift=6.0, weak_drift=6.0, weak_threshold=0.1),
                dict(coherent_offset=-1.0), dict(coherent_offset=math.nan)):
        with pytest.raises(ValueError):
            CusumParams(**bad).validate()
    with pytest.raises(ValueError):
        BandPowerCusum(0.0)


def test_the_cusum_mode_finds_strong_stick_slip_and_ignores_a_quiet_hold():
    assert MODES['cusum'] is cusum_mode
    slip, quiet = prepare([make_scene('stick_slip_30_100lsb', 'p0', 0),
                           make_scene('quiet_above_lsb', 'p2', 2)])
    scene = make_scene('stick_slip_30_100lsb', 'p0', 0)
    free = cusum_mode(slip, veto=False)
    vetoed = cusum_mode(slip)
    for det, reach in ((free, 200), (vetoed, 1000)):   # 100 ms without the veto, 0.5 s with
        flags = det.sample_index[det.slip]
        for onset, _ in scene.events:
            assert ((flags >= onset) & (flags <= onset + reach)).any(), (onset, flags)
    assert not cusum_mode(quiet).slip.any()


def test_the_weak_change_test_hears_only_what_varies_within_the_window():
    """A 7.5 dB step that only the weak-change test hears (34 updates, above): when the
    window moments say its power is a window mean (a ramp through the band-pass is a
    constant), the test hears nothing; with zero means (a ring), it alarms as before. The
    first test, the excess and the levels keep the whole power either way."""
    y = constant(600)
    y[300:, 3:] += 7.5
    power = 10.0 ** (0.1 * y)
    for means, alarm in ((np.zeros_like(y), [333]), (np.sqrt(power), [])):
        out = BandPowerCusum(DT, WEAK).update(y, moments=lambda means=means: (means, means))
        np.testing.assert_array_equal(np.flatnonzero(out.slip), alarm)
        np.testing.assert_allclose(out.excess[300:400, 1], 7.5, atol=1e-9)  # next block: 7.2
    y[300:, 3:] += 12.5                                  # 20 dB: the first test hears it
    out = BandPowerCusum(DT, WEAK).update(y, moments=lambda: (np.sqrt(10.0 ** (0.1 * y)),) * 2)
    np.testing.assert_array_equal(np.flatnonzero(out.slip), [300 + expected_delay(
        20.0, CusumParams(drift=8.0, threshold=0.05), DT) - 1])
