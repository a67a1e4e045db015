"""The robust slip detector mode (issue 14): the scenes it answers, streaming equals batch, and
the paper mode untouched by its parameters."""
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from forte_perception.evaluation.scenes import make_scene
from forte_perception.median import running_median
from forte_perception.pipeline import PipelineConfig
from forte_perception.slip.detector import (
    SlipDetector,
    SlipFeatures,
    SlipParams,
    slip_features,
    slip_features_reference,
)
from forte_perception.slip.params import RECOMMENDED_MODE

FS = 2000.0
LSB = 2.0 / 2048.0
PAPER = SlipParams(mode='paper')
ROBUST = SlipParams(mode='robust')


def quantised(x_lsb: np.ndarray, offset: float = 0.2) -> np.ndarray:
    """11-bit readings of ``offset + x_lsb * LSB`` (normalised units)."""
    return np.clip(np.round(offset / LSB + x_lsb) * LSB, -1.0, 1.0 - LSB)


def burst(n: int, rng: np.random.Generator, onset: int, amplitude_lsb: float,
          duration: float = 0.25) -> np.ndarray:
    """10-50 Hz noise whose envelope rises exponentially (60 dB/s) to ``amplitude_lsb``
    over ``duration`` s, then stops: a stick-slip-like rise of band power, (n,) [LSB]."""
    b, a = signal.butter(4, [10.0, 50.0], btype='band', fs=FS)
    x = signal.lfilter(b, a, rng.normal(size=n))
    x /= x.std()
    k = np.arange(n) - onset
    live = (k >= 0) & (k < duration * FS)
    env = np.where(live, amplitude_lsb * 10.0 ** ((k - duration * FS) / FS * 60.0 / 20.0), 0.0)
    return x * env


def one_finger(amplitude_lsb: float, channels=(0, 1, 2), seed: int = 0, n: int = 8000
               ) -> np.ndarray:
    """Median-filtered 11-bit readings: 1.5 LSB noise, bursts on ``channels`` only."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 6)) * 1.5
    for onset in (2500, 5500):
        for c in channels:
            x[:, c] += burst(n, rng, onset, amplitude_lsb)
    return running_median(quantised(x), 11)


def flags(x: np.ndarray, params: SlipParams) -> int:
    return int(slip_features(x, FS, params).slip.sum())


def test_quantised_quiet_hold_below_one_lsb_flags_in_paper_mode_only():
    scene = make_scene('quiet_sub_lsb', 'p0', 0)
    x = running_median(scene.frames, 11)
    assert flags(x, PAPER) > 0  # the staircase lifts the feature from -120 dB
    assert flags(x, ROBUST) == 0
    assert ROBUST.psd_floor(FS) == pytest.approx(4.0 * LSB ** 2 / (6.0 * FS))
    assert PAPER.psd_floor(FS) == PAPER.eps == 1e-12


def test_one_finger_burst_flags_only_when_strong_and_on_two_channels():
    weak = one_finger(3.0)
    strong = one_finger(40.0)
    assert flags(weak, ROBUST) == 0  # below single_threshold
    assert flags(strong, PAPER) == 0  # the alpha gate needs both fingers
    res = slip_features(strong, FS, ROBUST)
    assert res.slip.any()
    flagged = res.finger_variance[res.slip]
    assert (flagged[:, 0] > ROBUST.single_threshold).all() and (flagged[:, 1] == 0).all()
    # one channel alone rising is not a finger slipping
    assert flags(one_finger(40.0, channels=(1,)), ROBUST) == 0


def test_slow_level_shift_and_ramp_do_not_flag_in_robust_mode():
    n = 10000
    rng = np.random.default_rng(3)
    t = np.arange(n)
    step = 120.0 * (1.0 - np.exp(-np.clip(t - 3000, 0, None) / 300.0)) * (t >= 3000)
    ramp = np.clip((t - 6000) / 2000.0, 0.0, 1.0) * 150.0
    x = rng.normal(size=(n, 6)) * 1.5 + (step + ramp)[:, None] * np.linspace(0.6, 1.2, 6)
    x = running_median(quantised(x, offset=-0.1), 11)
    assert flags(x, PAPER) > 0
    assert flags(x, ROBUST) == 0


def test_both_finger_stick_slip_still_flags():
    x = one_finger(30.0, channels=range(6), seed=4)
    assert flags(x, ROBUST) > 0 and flags(x, PAPER) > 0


@pytest.mark.parametrize('sizes', [(1,), (7, 13, 333, 2), (1999, 5, 11)])
def test_streaming_equals_batch_bit_for_bit(sizes):
    x = np.concatenate([one_finger(40.0, seed=5), one_finger(30.0, range(6), seed=6)[2000:]])
    whole = slip_features(x, FS, ROBUST)
    assert whole.slip.any()
    det = SlipDetector(FS, ROBUST)
    parts, i, k = [], 0, 0
    while i < x.shape[0]:
        step = sizes[k % len(sizes)]
        parts.append(det.update(x[i:i + step]))
        i, k = i + step, k + 1
    got = SlipFeatures.concatenate(parts)
    for name in ('sample_index', 'psd_max_db', 'channel_variance', 'finger_variance', 'slip',
                 'active'):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name), err_msg=name)


def test_fast_decisions_equal_the_reference():
    x = np.concatenate([one_finger(40.0, seed=7)[:6000], one_finger(3.0, seed=8)[:4000]])
    fast = slip_features(x, FS, ROBUST)
    ref = slip_features_reference(x, FS, ROBUST)
    np.testing.assert_array_equal(fast.slip, ref.slip)
    np.testing.assert_allclose(fast.psd_max_db, ref.psd_max_db, atol=1e-9)
    np.testing.assert_allclose(fast.finger_variance, ref.finger_variance, atol=1e-7)


def test_paper_mode_ignores_the_robust_parameters():
    x = one_finger(40.0, range(6), seed=9)
    odd = replace(PAPER, floor_factor=100.0, single_threshold=2.5, single_min_rising=1,
                  veto_level=3, veto_span=5, veto_ratio=1e-3)
    a, b = slip_features(x, FS, PAPER), slip_features(x, FS, odd)
    for name in ('psd_max_db', 'channel_variance', 'finger_variance', 'slip'):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_the_default_mode_is_the_recommended_one():
    """One default for one choice: a bare SlipParams (hence a bare PipelineConfig) runs the
    detector the perception node and the closed loop run."""
    assert SlipParams().mode == RECOMMENDED_MODE == 'sequential'  # issue 38
    assert PipelineConfig().slip.mode == RECOMMENDED_MODE


@pytest.mark.parametrize('bad', [dict(mode='fast'), dict(floor_factor=0.0),
                                 dict(single_threshold=1.0), dict(single_min_rising=4),
                                 dict(veto_level=0), dict(veto_ratio=float('nan'))])
def test_robust_parameters_are_validated(bad):
    with pytest.raises(ValueError):
        replace(ROBUST, **bad).validate(FS)


def rising_history(rising_channels, m: int = 1, slope: float = 1.0) -> np.ndarray:
    """(m, V, 6) psd_max_db histories: the given channels rise by ``slope`` dB per update
    (moving variance slope^2 (V^2 - 1) / 12 = 18.7 dB^2 for V = 15), the others flat."""
    v = ROBUST.history
    h = np.full((m, v, 6), -60.0)
    for c in rising_channels:
        h[:, :, c] += slope * np.arange(v)
    return h


@pytest.mark.parametrize('rising, robust_flags', [((0, 1), True), ((0,), False)])
def test_masked_updates_let_one_finger_flag_alone_in_robust_mode(rising, robust_flags):
    """Right root channel masked, left finger bursting: two left channels rising by 1 dB per
    update give a left average of 12.4 dB^2 > 3 (single_threshold) with two channels above
    alpha: the robust rule flags, the paper's alpha gate (right finger at 0) does not; one
    rising channel (6.2 dB^2) is not enough in either mode."""
    from forte_perception.slip.mask import decide_slip_masked

    usable = np.ones((1, 6), bool)
    usable[0, 5] = False
    history = rising_history(rising)
    assert decide_slip_masked(history, usable, ROBUST)[2][0] == robust_flags
    assert not decide_slip_masked(history, usable, PAPER)[2][0]


@pytest.mark.parametrize('params', [PAPER, ROBUST], ids=['paper', 'robust'])
def test_masked_rule_with_every_channel_usable_is_the_detectors_rule(params):
    """Random rising patterns and slopes: the masked decision with all six channels usable
    equals the detector's decision (slip_decision.decide_slip) in both modes."""
    from forte_perception.slip.decision import decide_slip
    from forte_perception.slip.mask import decide_slip_masked

    rng = np.random.default_rng(7)
    m = 400
    history = np.full((m, params.history, 6), -60.0)
    steps = np.arange(params.history)
    for i in range(m):
        for c in np.flatnonzero(rng.random(6) < 0.4):
            history[i, :, c] += rng.uniform(0.05, 1.5) * steps
    history += rng.normal(scale=0.01, size=history.shape)
    usable = np.ones((m, 6), bool)
    masked = decide_slip_masked(history, usable, params)[2]
    unmasked = decide_slip(history, params)[2]
    assert masked.any() and not masked.all()
    np.testing.assert_array_equal(masked, unmasked)


def test_masked_updates_get_the_level_shift_veto_from_their_usable_channels():
    # a 40 LSB step on every channel 300 samples before the update explains a band maximum
    # of -70 dB (a sinusoid of peak-to-peak 2A = 2.5 LSB); the same band maximum without a
    # shift is not explained; a finger with no usable channel has no say
    from forte_perception.slip.robust import level_shift_veto, veto_reach
    from forte_ros.contract import QUANTUM

    params = SlipParams(mode='robust')
    end = veto_reach(params) + 100
    step = np.zeros((end + 1, 6))
    step[end - 300:] = 40 * QUANTUM
    psd = np.full((1, 6), -70.0)
    ends = np.array([end])
    lost = np.ones((1, 6), bool)
    lost[0, 0] = False
    flag = np.ones(1, bool)

    def veto(buf, at, usable):
        return level_shift_veto(buf, 0, at, psd, flag, params, 2000.0, usable=usable)[0]

    assert veto(step, ends, lost)
    assert not veto(np.zeros_like(step), ends, lost)
    one_finger = np.zeros((1, 6), bool)
    one_finger[0, 3:] = True
    assert veto(step, ends, one_finger)
    assert not veto(step, ends - end + veto_reach(params) - 1, lost)  # too young: no veto
