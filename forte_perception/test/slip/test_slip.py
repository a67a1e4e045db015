"""Slip detector: known answers against scipy.signal.welch, fast == reference, batch ==
streaming bit for bit, and the numerically hard cases."""
import numpy as np
import pytest
from scipy import signal

from forte_perception.slip.detector import (
    NonFiniteInputError,
    SlipDetector,
    SlipFeatures,
    SlipParams,
    decide_slip,
    reference_psd_max_db,
    slip_features,
    slip_features_reference,
)
from forte_perception.testing import FS, quantise, random_walk, slip_bursts

TOL_DB = 1e-6
#: This module tests the paper's algorithm (the derivation in forte_perception.slip.detector).
PAPER = SlipParams(mode='paper')


def chunked(frames, sizes, params=None):
    """Feed a detector with chunks of the given sizes (cycled) and join the results."""
    det = SlipDetector(FS, params)
    parts, i, k = [], 0, 0
    while i < frames.shape[0]:
        c = int(sizes[k % len(sizes)])
        parts.append(det.update(frames[i:i + c]))
        i += c
        k += 1
    return SlipFeatures.concatenate(parts), det


def assert_same(a: SlipFeatures, b: SlipFeatures):
    for name in ('sample_index', 'psd_max_db', 'channel_variance', 'finger_variance', 'slip',
                 'active'):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_defaults_are_the_papers():
    p = PAPER
    assert (p.window, p.hop, p.f_min, p.f_max, p.history) == (400, 4, 10.0, 50.0, 15)
    assert (p.delta, p.alpha, p.threshold, p.eps) == (0.1, 0.6, 2.0, 1e-12)


def test_sine_psd_equals_scipy_welch():
    t = np.arange(4000) / FS
    x = np.zeros((4000, 6))
    for c, f in enumerate((12.0, 20.0, 25.0, 33.3, 45.0, 80.0)):
        x[:, c] = 0.1 * (c + 1) * np.sin(2 * np.pi * f * t + c) + 0.01 * c
    res = slip_features(x, params=PAPER)
    for u in (0, 17, 500, len(res) - 1):
        end = res.sample_index[u]
        f, p = signal.welch(x[end - 399:end + 1], fs=FS, window='hann', nperseg=400,
                            axis=0)
        band = (f >= 10) & (f <= 50)
        expected = (10 * np.log10(p[band] + 1e-12)).max(axis=0)
        np.testing.assert_allclose(res.psd_max_db[u], expected, rtol=0, atol=TOL_DB)
    # the 80 Hz channel only leaks into the band: far below the in-band tones
    assert res.psd_max_db[-1, 5] < res.psd_max_db[-1, 4] - 40


def test_update_indices():
    res = slip_features(np.zeros((1000, 6)), params=PAPER)
    np.testing.assert_array_equal(res.sample_index, np.arange(399, 1000, 4))
    assert len(slip_features(np.zeros((399, 6)), params=PAPER)) == 0
    assert len(slip_features(np.zeros((400, 6)), params=PAPER)) == 1
    res1 = slip_features(np.zeros((1000, 6)), params=SlipParams(mode='paper', hop=1))
    np.testing.assert_array_equal(res1.sample_index, np.arange(399, 1000))


@pytest.mark.parametrize('make', [
    lambda: random_walk(30000, seed=1),
    lambda: slip_bursts(30000, seed=2, onsets=(3000, 12000, 21000)),
    lambda: quantise(0.3 + random_walk(30000, seed=3, scale=3e-3)),
])
def test_fast_equals_reference(make):
    x = make()
    fast = slip_features(x, params=PAPER)
    ref = slip_features_reference(x, params=PAPER, vectorized=True)
    np.testing.assert_array_equal(fast.sample_index, ref.sample_index)
    assert np.abs(fast.psd_max_db - ref.psd_max_db).max() <= TOL_DB
    np.testing.assert_array_equal(fast.slip, ref.slip)
    np.testing.assert_array_equal(fast.active, ref.active)
    np.testing.assert_allclose(fast.finger_variance, ref.finger_variance, rtol=1e-6, atol=1e-6)


def test_slip_bursts_are_detected_and_quiet_is_not():
    onsets = (6000, 16000)
    x = slip_bursts(26000, seed=4, onsets=onsets)
    res = slip_features(x, params=PAPER)
    flagged = res.sample_index[res.slip]
    assert flagged.size > 0
    for onset in onsets:
        near = flagged[(flagged >= onset) & (flagged < onset + 0.2 * FS)]
        assert near.size > 0, f'burst at {onset} not detected'
        assert near[0] - onset < 0.1 * FS  # paper: latency below 100 ms
    quiet = (flagged < onsets[0]) | ((flagged > onsets[0] + 0.4 * FS) & (flagged < onsets[1]))
    assert not quiet.any()


@pytest.mark.parametrize('params', [
    PAPER,
    SlipParams(mode='paper', hop=1),
    SlipParams(mode='paper', hop=7, window=256, f_min=0.0, f_max=1000.0, history=5),
    SlipParams(mode='paper', hop=3, window=401, f_min=4.0, f_max=60.0, resync_interval=7),
])
def test_streaming_equals_batch_bit_for_bit(params):
    x = slip_bursts(9000, seed=5, onsets=(2000, 6000)) + random_walk(9000, seed=6)
    batch = slip_features(x, params=params)
    rng = np.random.default_rng(7)
    for sizes in ([1], [20], [3, 1, 400, 17], rng.integers(1, 900, size=50)):
        stream, _ = chunked(x, sizes, params)
        assert_same(stream, batch)


def test_other_params_match_reference():
    x = slip_bursts(6000, seed=8, onsets=(2500,)) + random_walk(6000, seed=9)
    for params in (SlipParams(mode='paper', hop=1),
                   SlipParams(mode='paper', hop=5, window=256, f_min=0.0, f_max=1000.0),
                   SlipParams(mode='paper', window=401, f_min=4.0, f_max=60.0, hop=3)):
        fast = slip_features(x, params=params)
        ref = slip_features_reference(x, params=params, vectorized=True)
        assert np.abs(fast.psd_max_db - ref.psd_max_db).max() <= TOL_DB
        np.testing.assert_array_equal(fast.slip, ref.slip)


def test_exact_silence_is_minus_120_db():
    for level in (0.0, 0.123456789, 2048.0, -1.0):
        res = slip_features(np.full((3000, 6), level), params=PAPER)
        assert np.all(res.psd_max_db == -120.0), level
        assert not res.slip.any()
    # silence after activity: the running sums hold only rounding residue
    x = np.concatenate([random_walk(3000, seed=10), np.full((3000, 6), 0.5)])
    res = slip_features(x, params=PAPER)
    ref = slip_features_reference(x, params=PAPER, vectorized=True)
    tail = res.sample_index >= 3000 + 400
    assert np.all(ref.psd_max_db[tail] == -120.0)
    assert np.abs(res.psd_max_db[tail] + 120.0).max() <= TOL_DB


def test_hard_cases_dc_offset_steps_saturation_impulses():
    rng = np.random.default_rng(11)
    n = 40000
    counts = 2048.0 + np.round(rng.normal(size=(n, 6)) * 2)  # raw ADC counts
    counts[10000:, :3] += 300.0  # step
    counts[25000:26000] = 4095.0  # saturation
    counts[30000::997, 2] += 1500.0  # impulses
    sat = np.clip(random_walk(n, seed=12, scale=0.05), -1.0, 1.0)  # long saturated runs
    small = 2048.0 + 1e-4 * np.sin(2 * np.pi * 30 * np.arange(n) / FS)[:, None] * np.ones(6)
    for x in (counts, sat, small):
        fast = slip_features(x, params=PAPER)
        ref = slip_features_reference(x, params=PAPER, vectorized=True)
        assert np.abs(fast.psd_max_db - ref.psd_max_db).max() <= TOL_DB
        np.testing.assert_array_equal(fast.slip, ref.slip)


@pytest.mark.slow
def test_one_hour_is_stable():
    """One hour at 2 kHz (7.2 M samples): compare with the reference at spread updates."""
    n = int(3600 * FS)
    rng = np.random.default_rng(13)
    x = 2048.0 + np.cumsum(rng.normal(size=(n, 6)), axis=0) * 0.01
    x += np.sin(2 * np.pi * 20 * np.arange(n) / FS)[:, None] * np.linspace(0.001, 5, n)[:, None]
    det = SlipDetector(FS, PAPER)
    params = det.params
    worst = 0.0
    check = np.linspace(0, (n - 400) // 4, 150).astype(int)  # update numbers to verify
    pos = 0
    for i in range(0, n, 200000):
        res = det.update(x[i:i + 200000])
        upd = (res.sample_index - 399) // 4
        for u in check[(check >= upd[0]) & (check <= upd[-1])] if len(res) else []:
            row = u - upd[0]
            end = res.sample_index[row]
            ref = reference_psd_max_db(x[end - 399:end + 1], FS, params)
            worst = max(worst, np.abs(res.psd_max_db[row] - ref).max())
            pos += 1
    assert pos == check.size
    assert worst <= TOL_DB


def test_nan_and_inf_are_rejected_and_state_is_kept():
    x = slip_bursts(5000, seed=14, onsets=(2000,))
    det = SlipDetector(FS, PAPER)
    a = det.update(x[:2500])
    for bad in (np.nan, np.inf, -np.inf):
        chunk = x[2500:2600].copy()
        chunk[37, 4] = bad
        with pytest.raises(NonFiniteInputError, match='row 37, channel 4'):
            det.update(chunk)
    assert det.samples_seen == 2500
    b = det.update(x[2500:])
    assert_same(SlipFeatures.concatenate([a, b]), slip_features(x, params=PAPER))
    with pytest.raises(NonFiniteInputError):
        slip_features(np.full((500, 6), np.nan))


def test_reset_restarts_indices():
    x = random_walk(3000, seed=15)
    det = SlipDetector(FS, PAPER)
    det.update(x)
    det.reset()
    assert_same(det.update(x), slip_features(x, params=PAPER))


def test_guarded_decisions_use_the_reference():
    """With guard bands covering everything, every decision is re-made from Welch PSDs."""
    x = slip_bursts(5000, seed=16, onsets=(2000,))
    params = SlipParams(mode='paper', guard_db=1e9, guard_variance=1e9)
    det = SlipDetector(FS, params)
    res = det.update(x)
    ref = slip_features_reference(x, params=params)
    assert det.reference_recomputations == int(res.active.sum())
    np.testing.assert_array_equal(res.slip, ref.slip)
    np.testing.assert_array_equal(res.finger_variance, ref.finger_variance)
    assert res.slip.any()


def test_decision_rule_known_answers():
    params = PAPER
    ramp = np.tile(np.arange(15.0)[:, None] * 0.5, (1, 6))  # +0.5 dB per update
    cv, fv, slip, _ = decide_slip(ramp[None], params)
    expected = np.var(np.arange(15.0) * 0.5)
    np.testing.assert_allclose(cv[0], expected, rtol=1e-15)
    np.testing.assert_allclose(fv[0], [expected, expected], rtol=1e-15)
    assert slip[0] == (expected > 2.0)
    flat = ramp.copy()
    flat[7, :] = flat[6, :] + 0.05  # one difference below delta
    cv, fv, slip, _ = decide_slip(flat[None], params)
    assert np.all(cv == 0) and not slip[0]
    left_only = ramp.copy()
    left_only[:, 3:] = 0.0  # right group 0 < alpha: both zeroed
    cv, fv, slip, _ = decide_slip(left_only[None], params)
    assert np.all(fv == 0) and not slip[0]


def test_parameter_validation():
    for bad in (dict(window=4), dict(hop=0), dict(hop=500), dict(history=1),
                dict(f_min=60.0, f_max=50.0), dict(f_min=11.0, f_max=14.0),
                dict(eps=0.0), dict(resync_interval=0)):
        with pytest.raises(ValueError):
            SlipDetector(FS, SlipParams(mode='paper', **bad))
    with pytest.raises(ValueError):
        SlipDetector(0.0)
    with pytest.raises(ValueError):
        slip_features(np.zeros((500, 5)), params=PAPER)
