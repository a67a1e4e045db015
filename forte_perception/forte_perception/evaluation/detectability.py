"""How detectable a weak stick-slip burst is for any detector that knows only the 10-50 Hz
band (issue 38): an upper bound on the detection probability within a delay, at a
false-alarm rate.

The question: a stick-slip burst rings the finger with a peak of ``A`` LSB in white noise of
``sigma`` LSB (plus the 11-bit quantisation); the detector must flag it within ``D`` s of
the first release and may raise at most ``F`` false alarms per minute. What detection
probability can a detector that looks at the 10-50 Hz band reach at best?

**The bound computed.** The detector sees the window ``[onset, onset + d]`` (``d <= D``;
the onset is given to it: an oracle) projected onto the band: the ``nu`` discrete prolate
spheroidal (Slepian) sequences of that window and band, whose spectral concentration in
the band is at least 1/2; ``nu`` = 2 B d to within one (Landau-Pollak: the degrees of freedom
of a signal of bandwidth B and length d; B = 40 Hz). Its statistic is the energy there,
``Y = |V^T x|^2 / sigma_eff^2`` with ``sigma_eff^2 = sigma^2 + 1/12`` (quantisation as
independent uniform noise of one LSB). Without a burst ``Y`` is chi-square with ``nu``
degrees of freedom; with one, non-central chi-square with non-centrality ``lambda =
|V^T s|^2 / sigma_eff^2`` (the burst's in-band energy in the window over the noise).
Threshold: ``P(Y > t) = alpha = F D / 60`` under noise alone; bound =
``P(chi2'(nu, lambda) > t)``, the best over ``d`` in ``D / windows, ..., D``.

**Why it bounds band-power detectors from above.**

1. *Size.* A detector raising on average ``F`` false alarms per minute raises at least one
   in a given interval of ``D`` s with probability at most ``F D / 60`` (Markov's
   inequality on the count). So "a flag in ``[onset, onset + D]``" is a test of size at
   most ``alpha`` between noise alone and the burst, whatever the detector does before
   the onset (its history is independent noise: randomisation, which cannot beat the
   best test of that size).
2. *Power.* A detector that knows only the band treats every band-limited burst of the
   same in-band energy alike: it is invariant to rotations of the band subspace. Among
   such tests the energy detector is uniformly most powerful (the non-central chi-square
   has a monotone likelihood ratio in ``Y``: the matched-subspace detector of Scharf and
   Friedlander, 1994). A band-power detector that is not invariant (Hann-windowed PSD,
   its maximum bin, a moving variance, a CUSUM on band power) does no better on average
   over the bursts' waveforms of that energy (phase, shape within the band), by the
   Hunt-Stein argument for the compact rotation group.
3. *Optimism kept on purpose.* The onset is known (a real detector slides its window over
   noise before the onset); sigma is known exactly; the band is exactly 10-50 Hz with no
   taper loss; one channel is watched (a detector watching six channels and every hop
   pays for that multiplicity with a higher threshold); no hum, drift or distractor. Each
   makes the number larger.

It is not a bound on detectors that use more than the band (the burst's waveform, its
static step below 10 Hz, the channel pattern): the ``'coherent'`` option of
:func:`signal_bound` pools the in-band energy of several channels into the same ``nu``
degrees of freedom, the ceiling for a band-only detector that also knows how the channels
share one waveform.

Units: amplitudes and noise in LSB (1 LSB = 2/2048 of the normalised reading), times in s,
frequencies in Hz, false alarms per minute.

Command line (the table of issue 38)::

    python -m forte_perception.evaluation.detectability
    python -m forte_perception.evaluation.detectability --delay 0.5 --damping 0.3 --rate 3
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2, ncx2

from forte_perception.evaluation.scenes import FS, LSB
from forte_perception.evaluation.stick_slip import _ring, shear_sawtooth

__all__ = ['BAND', 'DELAY', 'FAR_PER_MINUTE', 'Bound', 'band_dof', 'band_energy',
           'band_subspace', 'bound_table', 'burst_ringing', 'detectability_bound',
           'detection_probability', 'effective_noise', 'energy_statistic', 'main',
           'miss_probability',
           'scene_event_bounds', 'signal_bound', 'window_false_alarm']

#: The paper detector's band [Hz].
BAND = (10.0, 50.0)
#: Default delay: flag within 80 ms of the first release [s].
DELAY = 0.08
#: Default false-alarm rate: one per hour [1/min].
FAR_PER_MINUTE = 1.0 / 60.0


@lru_cache(maxsize=64)
def _subspace(samples: int, fs: float, low: float, high: float) -> np.ndarray:
    m = np.arange(samples)
    lag = (m[:, None] - m[None, :]).astype(float)
    with np.errstate(divide='ignore', invalid='ignore'):
        kernel = (np.sin(2 * np.pi * high / fs * lag) - np.sin(2 * np.pi * low / fs * lag)) / (
            np.pi * lag)
    kernel[lag == 0] = 2.0 * (high - low) / fs
    values, vectors = np.linalg.eigh(kernel)
    keep = values >= 0.5
    out = vectors[:, keep][:, ::-1].copy()
    out.flags.writeable = False
    return out


def band_subspace(samples: int, fs: float = FS, band: tuple[float, float] = BAND) -> np.ndarray:
    """Orthonormal basis (samples, nu) of the band-limited signals of a window.

    The eigenvectors of the time-and-band limiting operator (discrete prolate spheroidal
    sequences of a band-pass band, kernel ``(sin(2 pi f2 k / fs) - sin(2 pi f1 k / fs)) /
    (pi k)``) whose concentration in ``band`` is at least 1/2; ``nu`` = 2 B T to within one.

    Parameters
    ----------
    samples : int
        Window length [samples].
    fs : float
        Sampling rate [Hz].
    band : (float, float)
        [Hz].
    """
    if samples < 1:
        raise ValueError(f'samples must be >= 1, got {samples}')
    low, high = band
    if not 0.0 <= low < high <= fs / 2:
        raise ValueError(f'band must satisfy 0 <= low < high <= fs / 2, got {band}')
    return _subspace(int(samples), float(fs), float(low), float(high))


def band_dof(window_s: float, band: tuple[float, float] = BAND) -> float:
    """Degrees of freedom 2 B T of a band of width B [Hz] over T [s] (Landau-Pollak)."""
    return 2.0 * (band[1] - band[0]) * window_s


def window_false_alarm(far_per_minute: float, delay_s: float) -> float:
    """Probability of a false alarm in one window of ``delay_s`` [s] allowed by a rate of
    ``far_per_minute`` [1/min]: ``min(F D / 60, 1)`` (Markov's inequality on the count)."""
    if far_per_minute < 0 or delay_s <= 0:
        raise ValueError('far_per_minute must be >= 0 and delay_s > 0')
    return min(far_per_minute * delay_s / 60.0, 1.0)


def effective_noise(noise_lsb: float, quantised: bool = True) -> float:
    """White noise [LSB] plus the 11-bit grid's rounding (1/12 LSB^2 if ``quantised``)."""
    return math.sqrt(noise_lsb ** 2 + (1.0 / 12.0 if quantised else 0.0))


def detection_probability(dof: float, noncentrality: float, alpha: float) -> float:
    """``P(chi2'(dof, noncentrality) > chi2.isf(alpha, dof))``: the energy detector's
    detection probability at false-alarm probability ``alpha`` (``alpha`` at zero
    non-centrality)."""
    threshold = chi2.isf(alpha, dof)
    if noncentrality <= 0.0:
        return float(chi2.sf(threshold, dof))
    return float(ncx2.sf(threshold, dof, noncentrality))


def miss_probability(dof: float, noncentrality: float, alpha: float) -> float:
    """``1 - detection_probability``, computed without cancellation (for bounds near 1)."""
    threshold = chi2.isf(alpha, dof)
    if noncentrality <= 0.0:
        return float(chi2.cdf(threshold, dof))
    return float(ncx2.cdf(threshold, dof, noncentrality))


def band_energy(x: np.ndarray, fs: float = FS, band: tuple[float, float] = BAND) -> np.ndarray:
    """In-band energy ``|V^T x|^2`` of a window ``x`` (n,) or of each column of (n, c)
    [units of x squared]. A constant cut to the window has in-band edges (4 % of its energy
    at 0.2 s): pass signals relative to the level before the window."""
    v = band_subspace(x.shape[0], fs, band)
    return np.sum((v.T @ x) ** 2, axis=0)


def energy_statistic(x: np.ndarray, noise_lsb: float, quantised: bool = True,
                     fs: float = FS, band: tuple[float, float] = BAND) -> np.ndarray:
    """The energy detector's statistic ``Y = |V^T x|^2 / sigma_eff^2`` of windows ``x``
    (n,) or (trials, n) [LSB]; chi-square with ``nu`` degrees of freedom in noise alone."""
    x = np.asarray(x, float)
    v = band_subspace(x.shape[-1], fs, band)
    return np.sum((x @ v) ** 2, axis=-1) / effective_noise(noise_lsb, quantised) ** 2


def burst_ringing(amplitude_lsb: float, resonance_hz: float, damping: float, rate_hz: float,
                  duration_s: float, samples: int, release_s: float = 0.001,
                  fs: float = FS) -> np.ndarray:
    """The ringing (samples,) [LSB] of a regular stick-slip burst from its first release
    (sample 0) on: the slip set's model (:func:`~forte_perception.evaluation.scenes.
    stick_slip_train`) with equal drops at exactly ``rate_hz``, peak ``|ringing|`` over the
    whole burst = ``amplitude_lsb``. No static sawtooth (below the band, mostly)."""
    if fs != FS:
        raise ValueError(f'the slip set is sampled at {FS} Hz')
    lead = int(0.5 * FS)
    last = lead + duration_s * fs
    times = np.arange(lead, last, fs / rate_hz).round().astype(np.int64)
    n = lead + max(samples, int(math.ceil(duration_s * fs)) + int(2 * fs))
    shear = shear_sawtooth(n, times, np.ones(times.size), rate_hz, release_s)
    ringing = _ring(shear, resonance_hz, damping)
    ringing *= amplitude_lsb / np.abs(ringing).max() if amplitude_lsb else 0.0
    return ringing[lead:lead + samples]


@dataclass(frozen=True)
class Bound:
    """An upper bound on the detection probability (module docstring).

    Attributes
    ----------
    p_detect : float
        Detection probability of the best window-aligned energy detector [-].
    p_false_alarm : float
        Its false-alarm probability per window, ``F D / 60`` [-].
    dof : int
        Degrees of freedom of the best window [-].
    noncentrality : float
        Its non-centrality (in-band signal energy / sigma_eff^2) [-].
    window_s : float
        Its length [s].
    p_miss : float
        ``1 - p_detect`` without cancellation [-].
    """

    p_detect: float
    p_false_alarm: float
    dof: int
    noncentrality: float
    window_s: float
    p_miss: float


def signal_bound(signal_lsb: np.ndarray, noise_lsb: float, *, delay_s: float = DELAY,
                 far_per_minute: float = FAR_PER_MINUTE, combine: str = 'strongest',
                 quantised: bool = True, windows: int = 8, fs: float = FS,
                 band: tuple[float, float] = BAND) -> Bound:
    """Bound for a given noise-free signal from the onset on.

    Parameters
    ----------
    signal_lsb : ndarray (n,) or (n, c)
        The burst on one or ``c`` channels from its onset (sample 0), relative to the level
        before it, at least ``delay_s * fs`` samples [LSB].
    noise_lsb : float
        White noise on every channel [LSB].
    delay_s : float
        The flag must come within this [s].
    far_per_minute : float
        Allowed false alarms [1/min].
    combine : {'strongest', 'coherent'}
        ``'strongest'``: the best single channel (the detector watches it alone);
        ``'coherent'``: the channels' in-band energies pooled into one window's degrees of
        freedom (a band-only detector that also knows how the channels share the waveform:
        exact if they do, a ceiling otherwise).
    quantised : bool
        Add the 11-bit rounding (1/12 LSB^2).
    windows : int
        Window lengths tried: ``delay_s * k / windows``, k = 1 .. windows.
    fs : float
        [Hz]
    band : (float, float)
        [Hz]
    """
    x = np.asarray(signal_lsb, float)
    x = x[:, None] if x.ndim == 1 else x
    total = int(round(delay_s * fs))
    if x.shape[0] < total:
        raise ValueError(f'the signal has {x.shape[0]} samples, the delay needs {total}')
    if combine not in ('strongest', 'coherent'):
        raise ValueError(f"combine must be 'strongest' or 'coherent', got {combine!r}")
    alpha = window_false_alarm(far_per_minute, delay_s)
    sigma2 = effective_noise(noise_lsb, quantised) ** 2
    best = None
    for k in range(1, windows + 1):
        n = max(int(round(total * k / windows)), 2)
        energy = band_energy(x[:n], fs, band)
        lam = float(energy.sum() if combine == 'coherent' else energy.max()) / sigma2
        dof = band_subspace(n, fs, band).shape[1]
        if dof == 0:
            continue
        miss = miss_probability(dof, lam, alpha)
        # the lowest miss; among windows whose miss underflows, the most signal
        if best is None or (miss, -lam) < (best.p_miss, -best.noncentrality):
            best = Bound(detection_probability(dof, lam, alpha), alpha, dof, lam, n / fs,
                         miss)
    if best is None:
        raise ValueError('no window of the delay holds a degree of freedom of the band')
    return best


def detectability_bound(amplitude_lsb: float, noise_lsb: float, *, delay_s: float = DELAY,
                        far_per_minute: float = FAR_PER_MINUTE, resonance_hz: float = 25.0,
                        damping: float = 0.1, rate_hz: float = 20.0, duration_s: float = 0.3,
                        release_s: float = 0.001, channel_gains=(1.0,),
                        quantised: bool = True, windows: int = 8) -> Bound:
    """Upper bound on the detection probability of a regular stick-slip burst.

    Parameters
    ----------
    amplitude_lsb : float
        Peak ringing ``A`` on the strongest channel [LSB].
    noise_lsb : float
        White noise ``sigma`` [LSB] (0.3-2 on the sensor).
    delay_s : float
        Detection within this delay of the first release [s] (default 80 ms).
    far_per_minute : float
        False alarms allowed per minute [1/min] (default one per hour).
    resonance_hz, damping : float
        The finger's bending mode [Hz] and damping ratio [-].
    rate_hz : float
        Release rate [Hz].
    duration_s : float
        Burst duration [s] (the peak ``A`` is over the whole burst).
    release_s : float
        Duration of each release [s].
    channel_gains : sequence of float
        Channels carrying the ringing (strongest 1): one channel by default; several are
        pooled coherently (:func:`signal_bound`, ``'coherent'``).
    quantised : bool
        Add the 11-bit rounding.
    windows : int
        Window lengths tried within the delay.

    Returns
    -------
    Bound
    """
    if amplitude_lsb < 0 or noise_lsb < 0:
        raise ValueError('amplitude_lsb and noise_lsb must be >= 0')
    samples = int(round(delay_s * FS))
    ringing = burst_ringing(amplitude_lsb, resonance_hz, damping, rate_hz, duration_s,
                            samples, release_s)
    gains = np.asarray(channel_gains, float)
    return signal_bound(ringing[:, None] * gains[None, :], noise_lsb, delay_s=delay_s,
                        far_per_minute=far_per_minute,
                        combine='coherent' if gains.size > 1 else 'strongest',
                        quantised=quantised, windows=windows)


def scene_event_bounds(scene_or_key, *, delay_s: float = DELAY,
                       far_per_minute: float = FAR_PER_MINUTE) -> list[dict]:
    """Bounds for every slip event of a signal-level scene of the slip set.

    The scene's own noise-free signal (:func:`~forte_perception.evaluation.scenes.
    make_scene` with ``noise_free=True``, analog) from each onset on, relative to the level
    just before it, at the scene's ``noise_lsb``.

    Parameters
    ----------
    scene_or_key : SlipScene or (family, profile, seed)

    Returns
    -------
    list of dict
        Per event: ``onset``, ``strength_lsb``, ``noise_lsb``, ``strongest`` (bound, one
        channel), ``coherent`` (bound, all six channels pooled), ``dof``.
    """
    from forte_perception.evaluation.scenes import make_scene

    key = scene_or_key if isinstance(scene_or_key, tuple) else (
        scene_or_key.family, scene_or_key.object_name, scene_or_key.seed)
    clean = make_scene(*key, quantised=False, noise_free=True)
    x = clean.frames / LSB
    sigma = float(clean.params['noise_lsb'])
    samples = int(round(delay_s * FS))
    out = []
    for (onset, _), strength in zip(clean.events, clean.event_strength, strict=True):
        window = x[onset:onset + samples] - x[onset - 1]
        if window.shape[0] < samples:
            window = np.vstack([window, np.repeat(window[-1:], samples - window.shape[0], 0)])
        one = signal_bound(window, sigma, delay_s=delay_s, far_per_minute=far_per_minute)
        pooled = signal_bound(window, sigma, delay_s=delay_s, far_per_minute=far_per_minute,
                              combine='coherent')
        out.append({'onset': int(onset), 'strength_lsb': float(strength), 'noise_lsb': sigma,
                    'strongest': one.p_detect, 'coherent': pooled.p_detect, 'dof': one.dof})
    return out


def _cell(bound: Bound) -> str:
    if bound.p_miss < 5e-4:
        return f'1 - {bound.p_miss:.0e}' if bound.p_miss >= 1e-99 else '1 - <1e-99'
    return f'{bound.p_detect:.3f}'


def bound_table(amplitudes=(3.0, 5.0, 10.0), noises=(0.3, 1.0, 2.0), **kwargs) -> str:
    """Markdown table amplitude [LSB] x noise [LSB] -> bound (kwargs of
    :func:`detectability_bound`); bounds above 0.9995 as ``1 - miss``, with the
    non-centrality and degrees of freedom of the best window."""
    head = '| A [LSB] \\ sigma [LSB] | ' + ' | '.join(f'{s:g}' for s in noises) + ' |'
    lines = [head, '|---' * (len(noises) + 1) + '|']
    for a in amplitudes:
        cells = []
        for s in noises:
            b = detectability_bound(a, s, **kwargs)
            cells.append(f'{_cell(b)} (lambda {b.noncentrality:.0f}, nu {b.dof})')
        lines.append(f'| {a:g} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='python -m forte_perception.evaluation.detectability',
        description=__doc__.split('\n')[0])
    parser.add_argument('--amplitudes', type=float, nargs='+', default=[3.0, 5.0, 10.0],
                        help='peak ringing A [LSB]')
    parser.add_argument('--noises', type=float, nargs='+', default=[0.3, 1.0, 2.0],
                        help='white noise sigma [LSB]')
    parser.add_argument('--delay', type=float, default=DELAY, help='delay D [s]')
    parser.add_argument('--far', type=float, default=FAR_PER_MINUTE,
                        help='false alarms per minute F')
    parser.add_argument('--resonance', type=float, default=25.0, help='mode [Hz]')
    parser.add_argument('--damping', type=float, default=0.1, help='damping ratio')
    parser.add_argument('--rate', type=float, default=20.0, help='release rate [Hz]')
    parser.add_argument('--duration', type=float, default=0.3, help='burst duration [s]')
    parser.add_argument('--release', type=float, default=0.001, help='release duration [s]')
    parser.add_argument('--channels', type=float, nargs='+', default=[1.0],
                        help='channel gains pooled coherently (default: one channel)')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Print the bound table; returns the exit code."""
    args = _parser().parse_args(argv)
    kwargs = {'delay_s': args.delay, 'far_per_minute': args.far,
              'resonance_hz': args.resonance, 'damping': args.damping, 'rate_hz': args.rate,
              'duration_s': args.duration, 'release_s': args.release,
              'channel_gains': tuple(args.channels)}
    alpha = window_false_alarm(args.far, args.delay)
    print(f'Upper bound on P(detect within {args.delay * 1e3:g} ms) at {args.far:g} false '
          f'alarms / min (alpha = {alpha:.3g} per window), band {BAND[0]:g}-{BAND[1]:g} Hz '
          f'(2BT = {band_dof(args.delay):.1f}); burst: mode {args.resonance:g} Hz, damping '
          f'{args.damping:g}, releases {args.rate:g} Hz for {args.duration:g} s; channels '
          f'{args.channels}\n')
    print(bound_table(tuple(args.amplitudes), tuple(args.noises), **kwargs))
    return 0


if __name__ == '__main__':
    sys.exit(main())
