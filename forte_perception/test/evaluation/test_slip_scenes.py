"""The signal-level slip scenes (forte_perception.evaluation.scenes) produce what their
labels say: noise levels, the 11-bit grid, stick-slip power in 10-50 Hz, the leading finger
carrying the ringing of leading-finger slip, smooth monotone gross slip, distractors in their
frequency ranges; the split is disjoint; scenes are determined by their seed. Issue 38's
physical stick-slip families honour every range they state (over all their scenes), their
sawtooth, release train and channel spread follow the mechanics the module docstring
derives."""
import math

import numpy as np
import pytest
from scipy.signal import periodogram

from forte_perception.evaluation.labels import EVALUATE_FROM, FINGER_BOTH, SPLITS
from forte_perception.evaluation.scenes import (
    FAMILIES,
    FS,
    LSB,
    PHYSICAL,
    PROFILES,
    SET_VERSION,
    burst_component,
    make_scene,
    release_train,
    scene_keys,
    shear_sawtooth,
    stick_slip_train,
    vibration_pattern,
)

#: stick-slip families and their strength ranges [LSB] (issue 14: weak 1-3 to strong >= 30;
#: issue 38: the leading finger 1-150)
STICK_SLIP = {'stick_slip_1_3lsb': (1, 3), 'stick_slip_3_10lsb': (3, 10),
              'stick_slip_10_30lsb': (10, 30), 'stick_slip_30_100lsb': (30, 100),
              'leading_finger': (1, 150)}
#: issue 38's families, re-derived from the finger's mechanics
PHYSICAL_FAMILIES = ('stick_slip_1_3lsb', 'stick_slip_3_10lsb', 'leading_finger')
_CENTRES = np.array([0.15, 0.50, 0.85])


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
    """Issue 14's families: nearly all power in the band. Issue 38's: the ringing is in the
    band, but a static sawtooth of up to twice the ringing at 3-60 Hz releases and modes
    down to 10.5 Hz put part of a burst's power below it (legitimately: so do real ones)."""
    fractions = []
    for key in scene_keys(None, [family])[::4]:
        scene = make_scene(*key, quantised=False, noise_free=True)
        for (onset, end), strength in zip(scene.events, scene.event_strength, strict=True):
            burst = scene.frames[onset:end + 600] / LSB
            strongest = np.argmax(np.ptp(burst, axis=0))
            fractions.append(band_fraction(burst[:, strongest], 10.0, 50.0))
            low, high = STICK_SLIP[family]
            assert low <= strength <= high
    if family in PHYSICAL_FAMILIES:
        assert np.median(fractions) > 0.75
    else:
        assert min(fractions) > 0.5
        assert np.median(fractions) > 0.8


def test_the_ringing_of_a_stick_slip_train_is_at_the_bending_mode():
    """Releases slower than the mode ring it freely: the power lies within a few half-power
    bandwidths of its frequency. Faster releases force the finger at the release rate
    (the mode cannot follow: the dynamic deviation is the sawtooth itself, with its
    harmonics); either way the power is in 8-250 Hz, nothing slow."""
    rng = np.random.default_rng(3)
    free = 0
    for _ in range(60):
        resonance = math.exp(rng.uniform(math.log(12.0), math.log(48.0)))
        damping, rate = rng.uniform(0.035, 0.3), rng.uniform(3, 60)
        train = stick_slip_train(8000, 2000, rng.uniform(0.05, 1.0), rate,
                                 rng.uniform(0.05, 0.6), rng.uniform(0.0005, 0.008),
                                 resonance, damping, 5.0, 1.0, rng)
        assert np.abs(train.ringing).max() == pytest.approx(5.0)
        segment = train.ringing[1500:train.releases[-1] + 1000]
        assert band_fraction(segment, 8.0, 250.0) > 0.7
        if rate < resonance:
            width = max(4.0 * damping * resonance, 6.0)
            assert band_fraction(segment, resonance - width, resonance + width) > 0.5
            free += 1
    assert free >= 15


def test_leading_finger_ringing_is_on_the_leading_finger():
    """The trailing finger feels nothing (1/3 of the bursts) or 0.02-0.3 of the leading
    finger's ringing; where it does not also unload, its largest excursion is that share of
    the strength: never the ringing on both fingers equally."""
    checked = silent = 0
    for key in scene_keys(None, ['leading_finger']):
        scene = make_scene(*key, quantised=False, noise_free=True)
        x = scene.frames / LSB
        for (onset, end), fingers, burst, strength in zip(
                scene.events, scene.event_fingers, scene.params['bursts'],
                scene.event_strength, strict=True):
            leading = burst['finger']
            assert fingers == leading + 1                 # FINGER_LEFT = 1, FINGER_RIGHT = 2
            share = burst['trailing_share']
            assert share == 0.0 or PHYSICAL.trailing_share[0] <= share <= 0.3
            assert share <= 0.3 < 1.0
            trailing = x[onset - 1:end + 600, 3 * (1 - leading):3 * (1 - leading) + 3]
            excursion = np.abs(trailing - trailing[0]).max()
            if burst['trailing_unload_lsb'] == 0.0:
                # the ringing's share (the residue of the burst before decays to < 5 %)
                assert excursion == pytest.approx(share * strength, abs=0.05 * strength)
                checked += 1
                silent += share == 0.0
            else:
                # a smooth unload: the shear pattern's strongest channel falls by the depth
                assert excursion >= 0.9 * burst['trailing_unload_lsb']
    assert checked >= 40 and 0.2 < silent / checked < 0.5


def test_trailing_unload_is_smooth_and_monotone():
    seen = 0
    for key in scene_keys(None, ['leading_finger']):
        scene = make_scene(*key, quantised=False, noise_free=True)
        x = scene.frames / LSB
        for (onset, _end), burst in zip(scene.events, scene.params['bursts'], strict=True):
            if burst['trailing_share'] != 0.0 or burst['trailing_unload_lsb'] == 0.0:
                continue
            col = 3 * (1 - burst['finger'])            # distal: shear pattern's strongest
            y = x[onset - 1:onset + int(burst['duration_s'] * FS) + 2, col]
            assert np.all(np.diff(y) <= 1e-4)     # (the residue of an earlier burst)
            assert y[0] - y[-1] == pytest.approx(burst['trailing_unload_lsb'], rel=0.1)
            seen += 1
    assert seen >= 5
def test_both_finger_stick_slip_moves_both_fingers():
    scene = make_scene('stick_slip_10_30lsb', 'p0', 0, noise_free=True)
    assert list(scene.event_fingers) == [FINGER_BOTH] * 3
    onset, end = scene.events[0]
    ptp = np.ptp(scene.frames[onset:end], axis=0) / LSB
    assert ptp[:3].max() > 5 and ptp[3:].max() > 5


@pytest.mark.parametrize('family', ['stick_slip_1_3lsb', 'stick_slip_3_10lsb'])
def test_weak_stick_slip_rings_both_fingers_by_the_coupling(family):
    """The other finger releases too (0-5 ms later, its own mode) with 0.3-1 of the
    slipping finger's ringing: its excursion is at least 0.3 of the strength where the
    static sawtooth is small (a large one offsets the ringing at each release: with equal
    static and dynamic gains the channel sees the mode's smooth response)."""
    checked = 0
    for key in scene_keys(None, [family]):
        scene = make_scene(*key, quantised=False, noise_free=True)
        x = scene.frames / LSB
        assert list(scene.event_fingers) == [FINGER_BOTH] * 3
        for (onset, end), burst, strength in zip(scene.events, scene.params['bursts'],
                                                 scene.event_strength, strict=True):
            assert 0.3 <= burst['coupling'] <= 1.0
            assert 0.0 <= burst['other_delay_s'] <= 0.005
            assert 0.9 <= burst['other_resonance_hz'] / burst['resonance_hz'] <= 1.1
            if burst['static_share'] > 0.2:
                continue
            other = 1 - burst['finger']
            window = x[onset - 1:end + 600, 3 * other:3 * other + 3]
            assert np.abs(window - window[0]).max() >= 0.3 * 0.75 * strength
            checked += 1
    assert checked >= 20


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


# ------------------------------------------------------------- issue 38: the ranges
def _bursts(family):
    for key in scene_keys(None, [family]):
        scene = make_scene(*key, quantised=False, noise_free=True)
        for burst in scene.params['bursts']:
            yield scene, burst


def _within(values, low, high, log=True, cover=0.15):
    """All values in [low, high] and the draws reach near both ends (the range is used)."""
    v = np.asarray(values, float)
    assert v.min() >= low * (1 - 1e-9) and v.max() <= high * (1 + 1e-9)
    if log:
        span = math.log(high / low)
        assert math.log(v.min() / low) < cover * span and math.log(high / v.max()) < cover * span
    else:
        span = high - low
        assert v.min() - low < cover * span and high - v.max() < cover * span


@pytest.mark.parametrize('family', PHYSICAL_FAMILIES)
def test_every_stated_range_is_honoured_over_all_scenes(family):
    r = PHYSICAL
    bursts = [(scene, b) for scene, b in _bursts(family)]
    profile = {p.name: p for p in PROFILES}
    get = {key: [b[key] for _, b in bursts] for key in bursts[0][1]}
    _within(get['duration_s'], *r.duration_s)
    _within(get['rate_hz'], *r.rate_hz)
    _within(get['irregularity'], *r.irregularity, log=False)
    _within(get['release_s'], *r.release_s)
    _within(get['static_share'], *r.static_share)
    for _, b in bursts:              # the mean static drop: share x strength, at most 30 LSB
        assert b['static_drop_lsb'] == pytest.approx(
            min(b['static_share'] * b['strength_lsb'], r.max_static_lsb))
    _within(get['vibration_width'], *r.vibration_width, log=False)
    _within(get['vibration_floor'], *r.vibration_floor, log=False)
    _within([b['resonance_hz'] / profile[s.object_name].resonance_hz for s, b in bursts],
            *r.resonance_factor)
    _within([b['damping'] / profile[s.object_name].damping for s, b in bursts],
            *r.damping_factor)
    assert 10.0 <= min(get['resonance_hz']) and max(get['resonance_hz']) <= 48.0
    assert 0.035 - 1e-9 <= min(get['damping']) and max(get['damping']) <= 0.3
    jitter = [b['contact'] - profile[s.object_name].contact for s, b in bursts]
    assert max(np.abs(jitter)) <= r.contact_jitter + 1e-9
    low, high = STICK_SLIP[family]
    _within(get['strength_lsb'], low, high, cover=0.2)
    assert min(get['releases']) >= 1 and max(get['releases']) >= 20
    if family == 'leading_finger':
        shares = np.array(get['trailing_share'])
        _within(shares[shares > 0], *r.trailing_share)
        unload = np.array(get['trailing_unload_lsb'])
        _within(unload[unload > 0], *r.trailing_unload_lsb)
        assert 0.35 < np.mean(unload > 0) < 0.65
        _within(get['trailing_delay_s'], *r.trailing_delay_s, log=False, cover=0.3)
    else:
        _within(get['coupling'], *r.coupling)
        _within(get['other_delay_s'], *r.other_delay_s, log=False, cover=0.3)
    scenes = list(dict.fromkeys(id(s) for s, _ in bursts))
    assert len(scenes) == 32
    by_scene = {id(s): s for s, _ in bursts}.values()
    _within([s.params['noise_lsb'] for s in by_scene], *r.noise_lsb)
    hum = [s.params['mains_hum'] for s in by_scene if 'mains_hum' in s.params]
    assert 0.3 < len(hum) / 32 < 0.7
    assert {h['frequency_hz'] for h in hum} == {50.0, 60.0}
    _within([h['amplitude_lsb'] for h in hum], *r.hum_lsb, cover=0.3)
    assert all(0 <= h['second_harmonic'] <= 0.3 and 0 <= h['third_harmonic'] <= 0.5
               for h in hum)
    drift = [s.params['drift'] for s in by_scene]
    _within([d['walk_lsb_per_sqrt_s'] for d in drift], *r.walk_lsb_per_sqrt_s, cover=0.3)
    _within([abs(d['thermal_lsb']) for d in drift], *r.thermal_lsb, cover=0.3)
    _within([d['thermal_tau_s'] for d in drift], *r.thermal_tau_s, cover=0.3)


def test_the_release_train_builds_between_releases_and_drops_at_them():
    """Sawtooth: the shear rises at the loading rate while stuck and drops at each release;
    the mean drop is the static share of the strength; the stick before a release is as
    long as the excesses say (texture), at least 5 ms."""
    rng = np.random.default_rng(7)
    for _ in range(30):
        rate, sigma = rng.uniform(3, 60), rng.uniform(0.05, 0.6)
        share, release = math.exp(rng.uniform(math.log(1 / 30), math.log(2))), 0.001
        train = stick_slip_train(12000, 3000, 0.8, rate, sigma, release, 25.0, 0.1, 4.0,
                                 share, rng)
        t = train.releases
        assert t[0] == 3000 and t[-1] < 3000 + 0.8 * FS
        assert np.all(np.diff(t) >= PHYSICAL.min_interval_s * FS - 1)
        drops = train.static[t - 1] - train.static[t + 2]        # release lasts 2 samples
        slope = rate / FS * share * 4.0                          # loading [LSB/sample]
        np.testing.assert_allclose(drops.mean(), share * 4.0, rtol=0.05, atol=3 * slope)
        assert np.all(drops > 0)
        for a, b in zip(t[:-1], t[1:], strict=True):             # stuck: rises
            assert np.all(np.diff(train.static[a + 3:b]) > 0)
        after = train.static[t[-1] + 3:]
        np.testing.assert_allclose(after, after[0])              # stuck again after it


def test_release_intervals_follow_the_texture():
    """Interval before release i = (e_{i-1} + e_i) / 2 / rate: the drops (e_i) and the
    intervals are correlated; their spread grows with the irregularity."""
    rng = np.random.default_rng(11)
    spreads = []
    for sigma in (0.05, 0.6):
        times, excess = release_train(0, 200.0, 20.0, sigma, rng)
        intervals = np.diff(times) / FS
        expected = 0.5 * (excess[:-1] + excess[1:]) / 20.0
        np.testing.assert_allclose(intervals, np.maximum(expected, 0.005), atol=1 / FS)
        assert excess.mean() == pytest.approx(1.0, rel=0.05)
        spreads.append(np.std(np.log(excess)))
        assert spreads[-1] == pytest.approx(sigma, rel=0.1)
        assert intervals.mean() == pytest.approx(1 / 20.0, rel=0.05)
    shear = shear_sawtooth(int(3 * FS), np.array([int(FS), int(1.5 * FS)]),
                           np.array([1.2, 0.8]), 4.0, 0.004)
    np.testing.assert_array_equal(shear[:int(FS)], 0.0)       # stuck at its limit before
    assert shear[int(FS) + 8] == pytest.approx(-1.2 + 4.0 * 8 / FS, abs=1e-9)  # dropped
    assert shear[int(1.5 * FS) - 1] == pytest.approx(-1.2 + 2.0, abs=0.01)  # rebuilt 0.5 s
    np.testing.assert_allclose(shear[int(1.5 * FS) + 8:], 0.0, atol=1e-12)  # constant after


def test_the_channel_nearest_the_contact_carries_most_of_the_ringing():
    rng = np.random.default_rng(5)
    for _ in range(500):
        contact, width = rng.uniform(0.05, 0.95), rng.uniform(0.15, 0.4)
        floor = rng.uniform(0.05, 0.5)
        p = vibration_pattern(contact, width, floor)
        nearest = np.argmin(np.abs(contact - _CENTRES))
        assert p[nearest] == 1.0 and np.all(p >= floor - 1e-12)
        assert np.all(np.diff(p[np.argsort(np.abs(contact - _CENTRES))]) <= 1e-12)
    # in the scenes: the slipping finger's largest excursion at the burst is on (or within
    # the transducers' trim of) the channel nearest the contact, where the ringing dominates
    checked = 0
    for scene, b in _bursts('stick_slip_3_10lsb'):
        if b['static_share'] > 0.05:
            continue
        x = scene.frames / LSB
        onset = int(round(b['onset_s'] * FS))
        cols = slice(3 * b['finger'], 3 * b['finger'] + 3)
        window = x[onset - 1:onset + int(0.1 * FS), cols]
        excursion = np.abs(window - window[0]).max(axis=0)
        nearest = np.argmin(np.abs(b['contact'] - _CENTRES))
        assert excursion[nearest] >= 0.85 * excursion.max()
        checked += 1
    assert checked >= 5


def test_noise_free_physical_scenes_have_no_hum_or_drift_and_noisy_ones_do():
    keys = scene_keys('held_out', ['stick_slip_3_10lsb'])
    found = 0
    for key in keys:
        quiet = make_scene(*key, quantised=False, noise_free=True)
        early = quiet.frames[:int(1.5 * FS)]
        assert np.ptp(early, axis=0).max() == 0.0             # constant before any burst
        hum = quiet.params.get('mains_hum')
        if hum is None:
            continue
        noisy = make_scene(*key, quantised=False)
        d = (noisy.frames - quiet.frames) / LSB
        t = np.arange(d.shape[0]) / FS
        basis = np.stack([np.sin(2 * np.pi * hum['frequency_hz'] * t),
                          np.cos(2 * np.pi * hum['frequency_hz'] * t)], axis=1)
        coef, *_ = np.linalg.lstsq(basis, d - d.mean(axis=0), rcond=None)
        amplitude = np.hypot(coef[0], coef[1]).max()
        assert amplitude == pytest.approx(hum['amplitude_lsb'], rel=0.05, abs=0.05)
        found += 1
    assert found >= 3


def test_the_set_version_names_issue_38():
    assert SET_VERSION == 2
