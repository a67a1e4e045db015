"""The signal-level slip scenes (forte_perception.evaluation.scenes) produce what their
labels say: noise levels, the 11-bit grid, stick-slip power in 10-50 Hz, one finger only for
leading-finger slip, smooth monotone gross slip, distractors in their frequency ranges;
the split is disjoint; scenes are determined by their seed."""
import numpy as np
import pytest
from scipy.signal import periodogram

from forte_perception.evaluation.labels import EVALUATE_FROM, FINGER_BOTH, SPLITS
from forte_perception.evaluation.scenes import (
    FAMILIES,
    FS,
    LSB,
    PROFILES,
    burst_component,
    make_scene,
    scene_keys,
)

#: stick-slip families and their strength ranges [LSB] (issue 14: weak 1-3 to strong >= 30)
STICK_SLIP = {'stick_slip_1_3lsb': (1, 3), 'stick_slip_3_10lsb': (3, 10),
              'stick_slip_10_30lsb': (10, 30), 'stick_slip_30_100lsb': (30, 100),
              'leading_finger': (2, 100)}


def band_fraction(x, low, high):
    """Share of the (linearly detrended) power of ``x`` in [low, high] Hz."""
    f, p = periodogram(x, fs=FS, detrend='linear', window='hann')
    return p[(f >= low) & (f <= high)].sum() / p[1:].sum()


@pytest.mark.parametrize('family, low, high', [('quiet_sub_lsb', 0.15, 0.95),
                                               ('quiet_above_lsb', 1.0, 3.0)])
def test_quiet_hold_noise_is_the_requested_level(family, low, high):
    for key in scene_keys('tune', [family])[:6]:
        analog = make_scene(*key, quantised=False)
        sigma = analog.params['noise_lsb']
        assert low <= sigma <= high
        # white noise: first differences have variance 2 sigma^2 (the drift adds < 0.1 %)
        measured = np.diff(analog.frames, axis=0).std(axis=0) / np.sqrt(2) / LSB
        np.testing.assert_allclose(measured, sigma, rtol=0.03)
        assert analog.events.shape == (0, 2)
        np.testing.assert_array_equal(analog.holding, [[EVALUATE_FROM, analog.n_samples]])


def test_quantised_scenes_are_11_bit_readings():
    for family in FAMILIES:
        frames = make_scene(family, 'p1', 1).frames
        codes = frames / (2.0 / 2048.0)
        np.testing.assert_array_equal(codes, np.rint(codes))
        assert frames.min() >= -1.0 and frames.max() <= 1.0 - 2.0 / 2048.0
        steps = np.abs(np.diff(frames, axis=0))
        assert steps[steps > 0].min() == 2.0 / 2048.0


def test_above_one_lsb_the_quantised_noise_adds_a_twelfth_of_a_step():
    scene = make_scene('quiet_above_lsb', 'p2', 4)
    sigma = scene.params['noise_lsb']
    measured = np.diff(scene.frames, axis=0).std(axis=0) / np.sqrt(2) / LSB
    np.testing.assert_allclose(measured, np.sqrt(sigma ** 2 + 1 / 12), rtol=0.04)


def test_burst_component_strength_and_static_steps():
    rng = np.random.default_rng(0)
    ringing, static, last = burst_component(8000, 1000, 0.3, 25.0, 20.0, 0.1, 7.0, rng)
    assert np.abs(ringing).max() == pytest.approx(7.0)
    assert np.all(ringing[:1000] == 0.0) and np.all(static[:1000] == 0.0)
    assert np.all(np.diff(static) <= 0.0) and static[-1] < 0.0   # the shear steps down
    assert 1000 + 0.3 * FS - FS / 10 <= last < 1000 + 0.3 * FS


@pytest.mark.parametrize('family', STICK_SLIP)
def test_stick_slip_bursts_have_their_power_in_10_to_50_hz(family):
    fractions = []
    for key in scene_keys(None, [family])[::4]:
        scene = make_scene(*key, quantised=False, noise_free=True)
        for (onset, end), strength in zip(scene.events, scene.event_strength, strict=True):
            burst = scene.frames[onset:end + 600] / LSB
            strongest = np.argmax(np.ptp(burst, axis=0))
            fractions.append(band_fraction(burst[:, strongest], 10.0, 50.0))
            low, high = STICK_SLIP[family]
            assert low <= strength <= high
    assert min(fractions) > 0.5
    assert np.median(fractions) > 0.8


def test_leading_finger_slip_is_on_one_finger_only():
    for key in scene_keys(None, ['leading_finger'])[::3]:
        scene = make_scene(*key, noise_free=True)
        for (onset, end), fingers in zip(scene.events, scene.event_fingers, strict=True):
            assert fingers in (1, 2)
            slipping = fingers - 1
            window = scene.frames[onset:end + 200]
            assert np.ptp(window[:, 3 * slipping:3 * slipping + 3]) > 0
            other = 1 - slipping
            assert np.ptp(window[:, 3 * other:3 * other + 3], axis=0).max() == 0


def test_both_finger_stick_slip_moves_both_fingers():
    scene = make_scene('stick_slip_10_30lsb', 'p0', 0, noise_free=True)
    assert list(scene.event_fingers) == [FINGER_BOTH] * 3
    onset, end = scene.events[0]
    ptp = np.ptp(scene.frames[onset:end], axis=0) / LSB
    assert ptp[:3].max() > 5 and ptp[3:].max() > 5


def test_smooth_gross_slip_decays_monotonically_without_vibration():
    for key in scene_keys(None, ['gross_smooth'])[::5]:
        scene = make_scene(*key, quantised=False, noise_free=True)
        assert scene.event_kinds == ('gross', 'gross')
        for (onset, end), strength in zip(scene.events, scene.event_strength, strict=True):
            x = scene.frames[onset - 200:end + 200] / LSB
            strongest = np.argmax(np.ptp(x, axis=0))
            change = np.diff(x[:, strongest]) * np.sign(x[-1, strongest] - x[0, strongest])
            assert np.all(change >= -1e-9)                      # monotone
            assert np.ptp(x[:, strongest]) == pytest.approx(strength, rel=1e-6)
            # a raised-cosine decay of 0.5-3 s has almost no power in 10-50 Hz
            assert band_fraction(x[:, strongest], 10.0, 50.0) < 1e-3


def test_distractors_are_where_the_family_says():
    high = make_scene('high_frequency', 'p3', 3, quantised=False, noise_free=True)
    x = high.frames / LSB
    assert band_fraction(x[:, np.argmax(np.ptp(x, axis=0))], 60.0, 1000.0) > 0.95
    assert high.params['frequency_hz'] > 60
    np.testing.assert_array_equal(high.holding, [[EVALUATE_FROM, high.n_samples]])
    low = make_scene('low_frequency', 'p4', 2, quantised=False, noise_free=True)
    x = low.frames / LSB
    assert band_fraction(x[:, np.argmax(np.ptp(x, axis=0))], 0.0, 6.0) > 0.95


def test_closing_steps_rise_by_their_amplitude_then_relax():
    scene = make_scene('closing_step', 'p6', 6, quantised=False, noise_free=True)
    x = scene.frames / LSB
    strongest = np.argmax(np.ptp(x, axis=0))
    for step in scene.params['steps']:
        assert 3.0 <= step['amplitude_lsb'] <= 300.0 and 0.01 <= step['rise_s'] <= 0.1
    first = scene.params['steps'][0]
    t0 = int(first['time_s'] * FS)
    top = t0 + int(first['rise_s'] * FS) + 1
    assert x[top, strongest] - x[t0 - 1, strongest] == pytest.approx(
        first['amplitude_lsb'], rel=0.02)
    relaxing = x[top:top + int(FS), strongest]
    assert np.all(np.diff(relaxing) <= 1e-9) and relaxing[0] > relaxing[-1]
    # the rise is busy time, not holding still
    busy = np.ones(scene.n_samples, bool)
    for a, b in scene.holding:
        busy[a:b] = False
    assert busy[t0:top].all()


def test_labels_are_consistent_in_every_family():
    for family in FAMILIES:
        scene = make_scene(family, 'p5', 5)
        n = scene.n_samples
        assert np.all(scene.events[:, 0] < scene.events[:, 1])
        assert np.all(scene.events[:, 1] <= n) and np.all(np.diff(scene.events[:, 0]) > 0)
        holding = np.zeros(n, bool)
        for a, b in scene.holding:
            assert EVALUATE_FROM <= a < b <= n and not holding[a:b].any()
            holding[a:b] = True
        for onset, end in scene.events:
            assert not holding[onset:end + 1000].any()
        assert set(scene.context) == {'servo_command', 'arm_velocity'}


def test_the_split_is_disjoint_by_profile_and_seed():
    tune, held = scene_keys('tune'), scene_keys('held_out')
    assert set(tune).isdisjoint(held)
    assert {k[1] for k in tune}.isdisjoint({k[1] for k in held})
    assert {k[2] for k in tune}.isdisjoint({k[2] for k in held})
    assert sorted(tune + held) == sorted(scene_keys())
    assert {p.split for p in PROFILES} == set(SPLITS)
    for family in FAMILIES:
        assert sum(k[0] == family for k in tune) == sum(k[0] == family for k in held) == 16
    with pytest.raises(ValueError, match='other split'):
        make_scene('ramp', 'p0', 1)
    with pytest.raises(ValueError, match='unknown'):
        make_scene('wobble', 'p0', 0)


def test_scenes_are_determined_by_their_seed():
    a = make_scene('stick_slip_3_10lsb', 'p2', 2)
    b = make_scene('stick_slip_3_10lsb', 'p2', 2)
    c = make_scene('stick_slip_3_10lsb', 'p2', 4)
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.events, b.events)
    assert a.params == b.params
    assert not np.array_equal(a.frames, c.frames)
