"""The slipping state (forte_perception.slip.state): known-answer inputs from its definition.

Signals are in normalised units on the 11-bit grid (q = QUANTUM) at 2 kHz; detector updates
every 4 samples. Tolerances are stated at each assertion.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import sosfilt, sosfilt_zi

from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.slip.params import SlipParams
from forte_perception.slip.state import BandPower, QuietLevels, SlippingParams, SlippingState
from forte_ros.contract import QUANTUM

FS = 2000.0
HOP = 4
BAND = (10.0, 50.0)
#: A vibration that stops leaves the averaging window after ``window``, is then below the
#: margin for ``clear_time``, plus the band-pass's ringing (about 30 ms to fall 30 dB at
#: 10 Hz, second order): the state must be down this long after the end [samples]
CLEAR_BOUND = (SlippingParams().window + SlippingParams().clear_time + 0.03) * FS


def noisy(n: int, noise_lsb: float = 1.0, seed: int = 0) -> np.ndarray:
    """Quantised white noise on six channels, (n, 6)."""
    rng = np.random.default_rng(seed)
    return np.round(rng.normal(0.0, noise_lsb, (n, 6))) * QUANTUM


def with_burst(x: np.ndarray, start: int, stop: int, amplitude_lsb: float,
               frequency: float = 25.0, channels=(0, 1, 2)) -> np.ndarray:
    """``x`` plus a sinusoid of ``amplitude_lsb`` on ``channels`` during [start, stop)."""
    y = x.copy()
    t = np.arange(start, stop) / FS
    for c in channels:
        y[start:stop, c] += np.round(amplitude_lsb * np.sin(2 * np.pi * frequency * t)) * QUANTUM
    return y


def run(x: np.ndarray, event_samples=(), params: SlippingParams | None = None,
        usable: np.ndarray | None = None):
    """Feed ``x`` in one call; events at the first update at or after each sample."""
    state = SlippingState(FS, BAND, HOP / FS, params)
    ends = np.arange(HOP - 1, x.shape[0], HOP)
    events = np.zeros(ends.size, bool)
    for sample in event_samples:
        events[np.searchsorted(ends, sample)] = True
    power = state.feed(x, ends)
    return ends, state.decide(power, events, usable), state


def test_band_power_of_a_sine_in_the_band_is_its_mean_square():
    # 25 Hz is in the middle of the band (gain 1 within 0.1 dB): power = A^2 / 2
    amplitude = 50 * QUANTUM
    t = np.arange(4000) / FS
    x = np.tile((amplitude * np.sin(2 * np.pi * 25 * t))[:, None], (1, 6))
    state = SlippingState(FS, BAND, HOP / FS)
    power = state.feed(x, np.array([3999]))
    assert power[0] == pytest.approx(np.full(6, 10 * np.log10(amplitude ** 2 / 2)), abs=0.5)


def test_out_of_band_vibration_and_silence_stay_at_the_floor():
    t = np.arange(6000) / FS
    hum = np.tile((20 * QUANTUM * np.sin(2 * np.pi * 300 * t))[:, None], (1, 6))
    silence = np.zeros((6000, 6))
    state = SlippingState(FS, BAND, HOP / FS)
    quiet = state.feed(silence, np.array([5999]))[0]
    assert np.isfinite(quiet).all()  # the floor, never -inf
    state.reset()
    humming = state.feed(hum, np.array([5999]))[0]
    # 300 Hz through a second-order 10-50 Hz band-pass: about -22 dB of 20 LSB amplitude
    in_band = 10 * np.log10((20 * QUANTUM) ** 2 / 2)  # the same sine inside the band
    assert (humming - quiet < 30).all() and (humming < in_band - 15).all()


def test_raised_at_the_event_held_while_sliding_cleared_soon_after():
    on, off = 3000, 5000  # 1 s of 10 LSB vibration at 25 Hz on the left finger
    x = with_burst(noisy(8000), on, off, 10.0)
    ends, update, _ = run(x, event_samples=[on + 120])
    left = update.slipping[:, 0]
    raised = ends[left]
    assert raised.min() == ends[np.searchsorted(ends, on + 120)]  # at the event
    during = (ends >= raised.min()) & (ends < off)
    assert left[during].all()  # held the whole slide
    assert 0 < raised.max() - off <= CLEAR_BOUND  # cleared soon after the end
    assert not update.slipping[:, 1].any()  # the quiet right finger is never raised


def test_no_event_no_state_and_a_quiet_event_raises_nothing():
    x = with_burst(noisy(8000), 3000, 5000, 10.0)
    _, update, _ = run(x)
    assert not update.slipping.any()  # vibration alone is not an event
    _, update, _ = run(noisy(8000), event_samples=[4000])
    assert not update.slipping.any()  # an event on a quiet hold: no excess, nothing raised


def test_quiet_level_tracks_each_channel():
    x = noisy(8000, noise_lsb=4.0)
    x[:, 3:] = noisy(8000, noise_lsb=1.0, seed=1)[:, 3:]
    _, update, state = run(x)
    # in-band power = variance x 2 x ENBW / fs (second-order band-pass: ENBW = pi / 2 x 40 Hz)
    # + floor (4 x q^2 / 12 x 80 / 2000); rounded normal noise has variance sigma^2 + 1 / 12
    fraction, floor = 2 * np.pi / 2 * 40 / FS, 4 / 12 * 80 / FS
    expected = 10 * np.log10((16.08 * fraction + floor) / (1.08 * fraction + floor))
    level = state.level
    assert level[:3].mean() - level[3:].mean() == pytest.approx(expected, abs=1.5)
    assert np.nanmax(np.abs(update.excess[-1000:])) < 6.0  # quiet: inside the margin


def test_unusable_channels_are_left_out_and_a_blind_finger_keeps_its_state():
    on, off = 3000, 5000
    x = with_burst(noisy(8000), on, off, 10.0)
    ends = np.arange(HOP - 1, 8000, HOP)
    usable = np.ones((ends.size, 6), bool)
    blind = (ends > 4000) & (ends < 6000)
    usable[blind, :3] = False
    _, update, _ = run(x, event_samples=[on + 120], usable=usable)
    assert np.isnan(update.excess[blind, 0]).all()
    assert update.slipping[blind, 0].all()  # unknown is not "stopped"
    assert not update.slipping[ends > 6500, 0].any()  # seen quiet again: cleared


@pytest.mark.parametrize('train', [False, True])
def test_any_chunking_gives_the_batch_result_bit_for_bit(train):
    # a sine burst, or a stick-slip train (releases, free decay, a clear and a raise again)
    x = stick_slip(14.0, 0.07, 12.0, 30.0)[0] if train else with_burst(noisy(6000), 2500,
                                                                         4000, 30.0)
    ends, batch, _ = run(x, event_samples=[2600, 3120])
    events = np.isin(ends, ends[np.searchsorted(ends, [2600, 3120])])
    rng = np.random.default_rng(3)
    state = SlippingState(FS, BAND, HOP / FS)
    start, excess, slipping = 0, [], []
    while start < x.shape[0]:
        stop = min(x.shape[0], start + int(rng.integers(1, 60)))
        mine = (ends >= start) & (ends < stop)
        power = state.feed(x[start:stop], ends[mine])
        update = state.decide(power, events[mine])
        excess.append(update.excess)
        slipping.append(update.slipping)
        start = stop
    assert np.array_equal(np.concatenate(excess), batch.excess, equal_nan=True)
    assert np.array_equal(np.concatenate(slipping), batch.slipping)


def test_one_band_pass_serves_several_windows_bit_for_bit():
    """BandPower with windows (60, 100) gives, from one filter, what two single-window
    estimates give (the sequential detector's CUSUM window and the state's)."""
    x = with_burst(noisy(3000, seed=4), 1000, 2000, 12.0)
    ends = np.arange(HOP - 1, x.shape[0], HOP)
    floor = SlippingState(FS, BAND, HOP / FS).floor
    both = BandPower(FS, BAND, 1, (60, 100), floor)
    short = BandPower(FS, BAND, 1, (60,), floor)
    long = BandPower(FS, BAND, 1, (100,), floor)
    got = [both.feed(x[i:i + 37], ends[(ends >= i) & (ends < i + 37)])
           for i in range(0, x.shape[0], 37)]
    assert np.array_equal(np.concatenate([g[0] for g in got]), short.feed(x, ends)[0])
    assert np.array_equal(np.concatenate([g[1] for g in got]), long.feed(x, ends)[0])


def test_the_window_moments_are_the_band_passed_means_and_pair_products_bit_for_bit():
    """BandPower's moments over its window: the means of the band-passed outputs and of the
    finger pairs' products, the same under any chunking as in one call, and equal to the
    window means of a band-pass run on the whole record (to rounding)."""
    x = with_burst(noisy(3000, seed=8), 1000, 2000, 12.0)
    ends = np.arange(HOP - 1, x.shape[0], HOP)
    floor = SlippingState(FS, BAND, HOP / FS).floor
    whole = BandPower(FS, BAND, 1, (60,), floor, moments=60)
    whole.feed(x, ends)
    means, products = whole.moments
    assert means.shape == products.shape == (ends.size, 6)
    parts = BandPower(FS, BAND, 1, (60,), floor, moments=60)
    got = []
    for i in range(0, x.shape[0], 37):
        parts.feed(x[i:i + 37], ends[(ends >= i) & (ends < i + 37)])
        got.append(parts.moments)
    assert np.array_equal(np.concatenate([g[0] for g in got]), means)
    assert np.array_equal(np.concatenate([g[1] for g in got]), products)
    y = sosfilt(whole.sos, x, axis=0, zi=sosfilt_zi(whole.sos)[:, :, None] * x[0])[0]
    for i in (0, 5, 100, ends.size - 1):
        run = y[max(ends[i] - 59, 0):ends[i] + 1]
        np.testing.assert_allclose(means[i], run.mean(axis=0), rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(
            products[i], [(run[:, a] * run[:, b]).mean() for a, b in
                          ((0, 1), (0, 2), (1, 2), (3, 4), (3, 5), (4, 5))],
            rtol=1e-9, atol=1e-18)
    assert BandPower(FS, BAND, 1, (60,), floor).moments is None


def test_quiet_levels_alone_are_the_states_levels_without_events():
    """Without events no finger is ever raised, so every finite value is quiet: the
    levels-only path gives the levels decide() reports (blocks of 0.2 s = 100 updates)."""
    x = noisy(8000, noise_lsb=2.0, seed=5)
    x[4000:] += noisy(4000, noise_lsb=6.0, seed=6)  # the quiet level moves up
    ends, update, state = run(x)
    levels = QuietLevels(state.levels.block, state.levels.beta)
    tracked = np.concatenate([levels.track(update.power_db[i:i + 7])
                              for i in range(0, ends.size, 7)])
    assert np.array_equal(tracked, update.level, equal_nan=True)
    block = state.levels.block
    assert block == 100
    assert np.isnan(tracked[:block]).all() and np.isfinite(tracked[block:]).all()
    # noise x3.2 at update 1000: +10 dB; after 2 s the EMA (tau 5 s) has moved 1 - e^-0.4
    # = 33 % of it (3.3 dB), less the first block's lag: at least 2 dB on every channel
    assert (tracked[-1] - tracked[990] > 2.0).all()


def test_bad_values_are_refused_with_a_reason():
    with pytest.raises(ValueError, match='window'):
        SlippingState(FS, BAND, HOP / FS, SlippingParams(window=0.0))
    with pytest.raises(ValueError, match='order'):
        SlippingState(FS, BAND, HOP / FS, SlippingParams(order=0))
    with pytest.raises(ValueError, match='band'):
        SlippingState(FS, (10.0, 1500.0), HOP / FS)
    state = SlippingState(FS, BAND, HOP / FS)
    with pytest.raises(ValueError, match='finite'):
        state.feed(np.full((10, 6), np.nan), np.array([9]))


@pytest.mark.parametrize('mode', ['robust', 'sequential'])
def test_pipeline_reports_the_state_of_its_last_update(mode):
    # a sustained 30 LSB, 25 Hz slide after the tare: the detector (the robust mode's PSD
    # rule, or the sequential CUSUM) flags its onset, the state stays raised while it lasts
    # and is cleared after it
    on, off = 6000, 8000
    x = with_burst(noisy(12000, noise_lsb=1.0), on, off, 30.0)
    pipeline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode=mode)))
    states = [pipeline.process(x[i:i + 20]) for i in range(0, x.shape[0], 20)]
    index = np.array([s.sample_index for s in states])
    slipping = np.array([s.slipping for s in states])
    events = np.array([s.slip for s in states])
    assert events[(index > on) & (index < on + 400)].any()
    first = index[slipping].min()
    assert first < on + 400
    assert slipping[(index >= first) & (index < off)].mean() >= 0.9
    assert not slipping[index > off + CLEAR_BOUND].any()
    assert not slipping[index < on].any()
    assert all(s.finger_slipping[0] == s.slipping for s in states)


def stick_slip(resonance_hz: float, damping: float, rate_hz: float, strength_lsb: float,
               seed: int = 0, on: int = 3000, duration: float = 1.0):
    """Quiet noise plus a stick-slip train on the left finger (the slip set's releases:
    steps of drive ringing a lightly damped mode), (8000, 6); and the last release."""
    from forte_perception.evaluation.scenes import burst_component
    x = noisy(8000, seed=seed)
    ringing, _, last = burst_component(8000, on, duration, rate_hz, resonance_hz, damping,
                                       strength_lsb, np.random.default_rng(seed))
    x[:, :3] += np.round(ringing)[:, None] * QUANTUM
    return x, last


def held_and_cleared(resonance_hz, damping, rate_hz, params=None, seed=0):
    """(share of [event, last release + 0.1 s) held, clear time after the last release [s])."""
    x, last = stick_slip(resonance_hz, damping, rate_hz, 30.0, seed)
    ends, update, _ = run(x, event_samples=[3120], params=params)
    left = update.slipping[:, 0]
    sliding = (ends >= 3120) & (ends < last + 0.1 * FS)
    after = ends[(ends >= last) & ~left]
    return left[sliding].mean(), (after[0] - last) / FS


@pytest.mark.parametrize('seed', range(4))
@pytest.mark.parametrize('resonance_hz, damping, rate_hz', [(25.0, 0.1, 12.0), (25.0, 0.1, 40.0),
                                                            (38.0, 0.12, 20.0), (20.0, 0.1, 10.0)])
def test_a_stick_slip_train_is_held_and_cleared_within_100_ms_of_its_end(resonance_hz, damping,
                                                                         rate_hz, seed):
    """The slip set's sliding ends 0.1 s after its last release. Between releases (gaps up to
    1.2 / rate: 120 ms at 10 Hz) the state holds: a release lifts the excess by more than
    release_rise, and one that damps the ringing instead is followed by one that lifts it.
    After the last one the ringing decays freely (25 Hz, damping 0.1: 2 zeta omega = 31 /s,
    136 dB/s): 10 dB below its peak within 75 ms, so the state clears at decay_time (0.15 s)
    plus at most a window (0.05 s) after the last release. Below the margin alone (30 dB of
    excess to fall by 26 dB, then clear_time) takes 0.24 s or more."""
    held, cleared = held_and_cleared(resonance_hz, damping, rate_hz, seed=seed)
    assert held >= 0.9
    assert cleared <= 0.2  # within 100 ms of the sliding's end
    _, margin_only = held_and_cleared(resonance_hz, damping, rate_hz,
                                      SlippingParams(decay_time=0.0), seed)
    assert margin_only > cleared


@pytest.mark.parametrize('seed', range(4))
def test_a_slowly_ringing_finger_clears_sooner_than_by_the_margin_alone(seed):
    """14 Hz, damping 0.07 (the slowest mode of the slip set): 53 dB/s. The excess needs
    about 0.6 s to fall from its 30 dB to the margin, but only 0.19 s (plus the window) to
    fall 10 dB: the free-decay rule clears at least 0.3 s sooner. Releases at 12 Hz, close to
    the mode, can damp the ringing as much as a free decay would; a finger cleared so is
    raised again by the next release within decay_time + window, and holds >= 90 %."""
    held, cleared = held_and_cleared(14.0, 0.07, 12.0, seed=seed)
    _, margin_only = held_and_cleared(14.0, 0.07, 12.0, SlippingParams(decay_time=0.0), seed)
    assert held >= 0.9
    assert margin_only - cleared >= 0.3


@pytest.mark.parametrize('seed', range(3))
def test_the_ringing_after_a_clear_by_free_decay_is_not_taken_for_quiet(seed):
    """After a 60 LSB slide at 14 Hz (damping 0.07) the state clears while the excess is
    still 20-30 dB: the tail decays for another 0.5 s. Recorded as quiet, its updates would
    lift the quiet level by 1.6-2.1 dB (measured); left out, the level stays within 0.5 dB
    of its value before the slide."""
    x, _ = stick_slip(14.0, 0.07, 40.0, 60.0, seed)
    ends, update, _ = run(x, event_samples=[3120])
    before = update.level[np.searchsorted(ends, 2990), :3]
    assert np.abs(update.level[-1, :3] - before).max() < 0.5
