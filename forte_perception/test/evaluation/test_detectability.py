"""The detectability bound (forte_perception.evaluation.detectability): known answers of the
chi-square statistics, the band subspace's degrees of freedom, monotonicity, and Monte-Carlo
runs of the energy detector on synthetic noise (Gaussian and quantised to the 11-bit grid)
that agree with the chi-square formulas; a practical band-power detector does no better."""
import math

import numpy as np
import pytest
from scipy.stats import chi2, ncx2

from forte_perception.evaluation import detectability as det
from forte_perception.evaluation.detectability import (
    BAND,
    band_dof,
    band_energy,
    band_subspace,
    burst_ringing,
    detectability_bound,
    detection_probability,
    effective_noise,
    energy_statistic,
    miss_probability,
    scene_event_bounds,
    signal_bound,
    window_false_alarm,
)
from forte_perception.evaluation.scenes import FS


#: Monte-Carlo tolerance: 4 binomial standard deviations plus the Slepian approximation
def _tolerance(p, trials):
    return 4.0 * math.sqrt(max(p * (1 - p), 0.01) / trials) + 0.005


@pytest.mark.parametrize('delay', [0.02, 0.04, 0.08, 0.2, 0.5])
def test_the_band_subspace_has_2BT_degrees_of_freedom_and_is_orthonormal(delay):
    n = int(round(delay * FS))
    v = band_subspace(n)
    assert abs(v.shape[1] - band_dof(delay)) <= 1.0
    np.testing.assert_allclose(v.T @ v, np.eye(v.shape[1]), atol=1e-10)
    assert band_dof(0.08) == pytest.approx(6.4)


def test_band_energy_of_tones_inside_and_outside_the_band():
    t = np.arange(400) / FS
    inside = 3.0 * np.sin(2 * np.pi * 30.0 * t + 0.4)
    assert band_energy(inside) == pytest.approx(9.0 * 400 / 2, rel=0.02)
    outside = 3.0 * np.sin(2 * np.pi * 150.0 * t)
    assert band_energy(outside) < 5e-3 * 9.0 * 400 / 2        # the 1/2-concentrated leak
    # a constant cut to the window has in-band edges (a few %): signals are taken relative
    # to the level before the onset
    assert band_energy(np.full(400, 5.0)) < 0.05 * 25 * 400


def test_zero_amplitude_detects_with_the_false_alarm_probability():
    for far, delay in ((1 / 60, 0.08), (1.0, 0.5), (10.0, 0.02)):
        bound = detectability_bound(0.0, 1.0, delay_s=delay, far_per_minute=far)
        assert bound.p_detect == pytest.approx(window_false_alarm(far, delay), rel=1e-9)
        assert bound.p_false_alarm == pytest.approx(far * delay / 60)
    assert window_false_alarm(1 / 60, 0.08) == pytest.approx(0.08 / 3600)
    assert window_false_alarm(1e6, 1.0) == 1.0


@pytest.mark.parametrize('dof', [1, 2, 6, 16, 40])
@pytest.mark.parametrize('alpha', [1e-1, 1e-3, 2.2e-5])
def test_the_chi_square_quantiles_and_tails_are_scipys(dof, alpha):
    threshold = chi2.isf(alpha, dof)
    assert detection_probability(dof, 0.0, alpha) == pytest.approx(alpha, rel=1e-9)
    for lam in (0.5, 10.0, 80.0):
        expected = ncx2.sf(threshold, dof, lam)
        assert detection_probability(dof, lam, alpha) == pytest.approx(expected, rel=1e-12)
        assert miss_probability(dof, lam, alpha) == pytest.approx(1 - expected, abs=1e-12)
    if dof == 2:                                          # closed form: exp(-t / 2)
        assert threshold == pytest.approx(-2 * math.log(alpha))


def test_the_bound_grows_with_amplitude_and_falls_with_noise():
    kwargs = {'delay_s': 0.02}                            # not saturated at 1
    amplitudes = [0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 3.0]
    for sigma in (0.3, 1.0, 2.0):
        p = [detectability_bound(a, sigma, **kwargs).p_detect for a in amplitudes]
        assert np.all(np.diff(p) >= -1e-12) and p[-1] > p[0]
    for a in (1.0, 3.0):
        p = [detectability_bound(a, s, **kwargs).p_detect for s in (0.3, 0.5, 1.0, 1.5, 2.0)]
        assert np.all(np.diff(p) <= 1e-12) and p[0] > p[-1]
    # more delay, more evidence; more false alarms allowed, more detections
    assert (detectability_bound(1.0, 1.0, delay_s=0.08).p_detect
            >= detectability_bound(1.0, 1.0, delay_s=0.02).p_detect)
    assert (detectability_bound(1.0, 1.0, delay_s=0.02, far_per_minute=1.0).p_detect
            > detectability_bound(1.0, 1.0, delay_s=0.02).p_detect)


def test_the_burst_reaches_its_peak_and_the_quantisation_adds_a_twelfth():
    ringing = burst_ringing(4.0, 25.0, 0.1, 20.0, 0.3, 2000)
    assert np.abs(ringing).max() == pytest.approx(4.0)
    assert effective_noise(1.0) == pytest.approx(math.sqrt(1 + 1 / 12))
    assert effective_noise(1.0, quantised=False) == 1.0


def _detector_runs(signal, sigma, trials, rng, quantised):
    noise = rng.standard_normal((trials, signal.size)) * sigma
    x = signal[None, :] + noise
    if quantised:                     # the ADC rounds offset + signal; the offset is known
        offset = rng.uniform(0.0, 1.0, (trials, 1))
        x = np.rint(x + offset) - offset
    return x


def test_monte_carlo_noise_alone_is_chi_square_with_nu_degrees_of_freedom():
    rng = np.random.default_rng(0)
    n = 160
    nu = band_subspace(n).shape[1]
    y = energy_statistic(rng.standard_normal((20000, n)) * 1.3, 1.3, quantised=False)
    for q in (0.5, 0.9, 0.99):
        assert np.quantile(y, q) == pytest.approx(chi2.ppf(q, nu), rel=0.04)
    alpha = 0.01
    rate = np.mean(y > chi2.isf(alpha, nu))
    assert abs(rate - alpha) < _tolerance(alpha, 20000)


@pytest.mark.parametrize('sigma, quantised', [(1.0, False), (1.0, True), (2.0, True),
                                              (0.5, True)])
def test_monte_carlo_energy_detector_matches_the_bound(sigma, quantised):
    """Within 4 binomial standard deviations (+ 0.005): the chi-square formulas describe
    the energy detector, with the rounding as 1/12 LSB^2 of independent noise from 0.5 LSB
    of white noise on."""
    rng = np.random.default_rng(1)
    n, alpha, trials = 160, 0.01, 20000
    nu = band_subspace(n).shape[1]
    unit = burst_ringing(1.0, 25.0, 0.1, 20.0, 0.3, n)
    sigma_eff = effective_noise(sigma, quantised)
    # the amplitude at which the bound is about one half
    lam_half = next(lam for lam in np.arange(0.5, 200, 0.25)
                    if detection_probability(nu, lam, alpha) >= 0.5)
    amplitude = sigma_eff * math.sqrt(lam_half / band_energy(unit))
    signal = unit * amplitude
    lam = float(band_energy(signal)) / sigma_eff ** 2
    predicted = detection_probability(nu, lam, alpha)
    y = energy_statistic(_detector_runs(signal, sigma, trials, rng, quantised), sigma,
                         quantised)
    measured = np.mean(y > chi2.isf(alpha, nu))
    assert abs(measured - predicted) < _tolerance(predicted, trials)
    y0 = energy_statistic(_detector_runs(np.zeros(n), sigma, trials, rng, quantised), sigma,
                          quantised)
    assert abs(np.mean(y0 > chi2.isf(alpha, nu)) - alpha) < _tolerance(alpha, trials)


def test_a_hann_windowed_band_power_detector_does_no_better_than_the_bound():
    """The paper's kind of statistic (Hann-windowed periodogram summed over 10-50 Hz),
    thresholded at the same false-alarm probability on noise, on bursts of random phase
    (onset anywhere within a release period): its detection rate is below the bound."""
    rng = np.random.default_rng(2)
    n, alpha, trials, sigma = 160, 0.01, 8000, 1.0
    hann = np.hanning(n)
    f = np.fft.rfftfreq(n, 1 / FS)
    inband = (f >= BAND[0]) & (f <= BAND[1])

    def band_power(x):
        return np.sum(np.abs(np.fft.rfft(x * hann, axis=-1))[..., inband] ** 2, axis=-1)

    threshold = np.quantile(band_power(rng.standard_normal((trials, n)) * sigma), 1 - alpha)
    long = burst_ringing(1.5, 25.0, 0.1, 20.0, 0.5, 1000)
    starts = rng.integers(0, 100, trials)
    signals = np.stack([long[s:s + n] for s in starts])
    rate = np.mean(band_power(signals + rng.standard_normal((trials, n)) * sigma) > threshold)
    bounds = [signal_bound(long[s:s + n], sigma, delay_s=n / FS, far_per_minute=alpha * 60
                           / (n / FS), quantised=False, windows=1).p_detect
              for s in range(0, 100, 10)]
    assert rate <= np.mean(bounds) + _tolerance(rate, trials)
    assert rate > 0.05                                   # the comparison has teeth


def test_signal_bound_checks_its_inputs_and_pools_channels():
    x = burst_ringing(2.0, 25.0, 0.1, 20.0, 0.3, 160)
    one = signal_bound(x, 1.0, delay_s=0.02)
    two = signal_bound(np.stack([x, x], axis=1), 1.0, delay_s=0.02, combine='coherent')
    assert two.noncentrality == pytest.approx(2 * one.noncentrality, rel=1e-9)
    assert two.p_detect >= one.p_detect
    with pytest.raises(ValueError, match='delay needs'):
        signal_bound(x[:10], 1.0, delay_s=0.08)
    with pytest.raises(ValueError, match='combine'):
        signal_bound(x, 1.0, combine='sum')
    with pytest.raises(ValueError):
        band_subspace(100, band=(10.0, 2000.0))


def test_scene_event_bounds_on_the_slip_set():
    events = scene_event_bounds(('leading_finger', 'p1', 1), delay_s=0.08)
    assert len(events) == 3
    alpha = window_false_alarm(det.FAR_PER_MINUTE, 0.08)
    for e in events:
        assert alpha - 1e-12 <= e['strongest'] <= e['coherent'] + 1e-12 <= 1 + 1e-12
        assert 1.0 <= e['strength_lsb'] <= 150.0 and 0.3 <= e['noise_lsb'] <= 2.0


def test_the_command_prints_the_table(capsys):
    assert det.main(['--noises', '0.3', '1', '2', '--amplitudes', '3', '5', '10']) == 0
    out = capsys.readouterr().out
    assert '| A [LSB] \\ sigma [LSB] | 0.3 | 1 | 2 |' in out
    rows = [line for line in out.splitlines() if line.startswith(('| 3 ', '| 5 ', '| 10 '))]
    assert len(rows) == 3 and all(row.count('|') == 5 for row in rows)
