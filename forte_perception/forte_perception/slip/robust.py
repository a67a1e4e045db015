"""The robust slip detector mode: what it changes in the paper's detector, and why.

``SlipParams(mode='robust')`` builds this mode (the default until issue 38, which made the
sequential mode :data:`~forte_perception.slip.params.RECOMMENDED_MODE`; the sequential mode
reports this mode's PSD features); ``mode='paper'`` is the paper's algorithm bit for bit.
Each change below answers a way the paper's rule fails on the slip evaluation set; which
parameter values were tried, on which part of the set, and what each change gains and costs
is in docs/perception.md, "Robust mode".

1. **A PSD floor from quantisation instead of eps.** The sensor is an 11-bit ADC, q = 2/2048
   in normalised units (:data:`forte_ros.contract.QUANTUM`). Below about 1 LSB of noise the
   median-filtered signal is a staircase: most windows are constant (PSD 0, feature
   ``10 log10(eps)`` = -120 dB) and a single 1-LSB step lifts the band maximum to about
   -79 dB, a monotone rise of 40 dB in a few updates, i.e. a moving variance far above T.
   Uniform quantisation noise has variance q^2/12, spread one-sided over fs/2: density
   ``q^2 / (6 fs)`` = 7.9e-11 / Hz at 2 kHz, the smallest PSD a real signal change of the
   order of 1 LSB can be told from. A floor of ``floor_factor`` times that density replaces
   eps (``P + floor`` before the logarithm): a lone 1-LSB step now moves the feature by a few
   dB instead of 40. It does not mask stick-slip: a sinusoid of amplitude A at a bin has the
   Hann PSD peak ``P = A^2 N / (3 fs)``, for A = 3 q 5.7e-7 / Hz, 1800 times the floor at the
   default ``floor_factor`` = 4 (3.2e-10 / Hz).

2. **A veto on low-frequency level shifts.** Closing steps, ramps and 0.5-5 Hz sway leak into
   the 10-50 Hz bins through the Hann window's main lobe and sidelobes; the leakage grows
   monotonically while the shift enters the window, which is exactly the paper's rising-power
   signature. Stick-slip, in contrast, moves the level little compared with its vibration. At
   a flagged update the detector compares, per channel, the level shift
   ``|mean(x[t-L+1..t]) - mean(x[t-S-L+1..t-S])|`` (running mean of L = ``veto_level`` = 200
   samples, 100 ms, whose zeros at 10, 20, ... Hz keep the band's vibration from moving it;
   span S = ``veto_span`` = 400 samples, the window length) with the peak-to-peak amplitude
   ``2 A`` of a sinusoid whose Hann PSD peak equals the band maximum P, inverting the formula
   above: ``A = sqrt(3 fs P / N)``. The flag is vetoed when on every finger the largest shift
   exceeds ``veto_ratio`` times the largest ``2 A``. Its price: strong stick-slip that also
   shifts the level is vetoed at first. Computed only at flagged updates (flags are rare),
   from the samples kept for them.

3. **One finger may flag alone.** The paper's alpha gate needs both finger groups above
   alpha, so stick-slip under the leading finger only is missed. A finger's group average may
   now flag by itself when it exceeds ``single_threshold`` (3 dB^2 = 1.5 T) with at least
   ``single_min_rising`` (2) of its three channels rising monotonically with a moving variance
   of at least alpha each: one strongly rising channel plus a noise channel drifting up (the
   PSD of 99 %-overlapping windows rises monotonically for 15 updates by chance) cannot make
   it.

Not in the detector: ignoring flags for a while after a commanded servo change needs the servo
command, which the detector does not see; it belongs to the controller (which knows when it
moves the servo) or to a pipeline input carrying the command. The benchmark runner offers it
as the separate mode ``robust_servo_gate`` (:mod:`forte_perception.evaluation.benchmark`).
Updates with masked channels (:mod:`forte_perception.slip.mask`) are re-decided from their
usable channels with this mode's rule (a finger may flag alone), and their flags get the
level-shift veto from the usable channels (``level_shift_veto(..., usable=...)``; before issue 38
they got none, so with one transducer lost every closing step flagged).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from forte_perception.slip.params import SlipParams
from forte_ros.contract import FINGER_CHANNELS

__all__ = ['level_shift_veto', 'veto_reach']


def veto_reach(params: SlipParams) -> int:
    """Samples before an update's last sample that its veto reads (0 in the paper mode)."""
    if not params.robust:
        return 0
    return int(params.veto_span) + int(params.veto_level) - 1


def _levels(buf: np.ndarray, start: int, ends: np.ndarray, length: int) -> np.ndarray:
    """Mean of the ``length`` samples up to each of ``ends`` (absolute), (f, 6).

    Every update's mean is a contiguous reduction of its own (6, length) block, so it does
    not depend on which other updates are computed with it.
    """
    rows = (ends - start)[:, None] + np.arange(1 - length, 1)  # (f, L)
    block = np.ascontiguousarray(buf[rows].transpose(0, 2, 1))  # (f, 6, L)
    return block.sum(axis=2) / length


def _terms(buf: np.ndarray, start: int, ends: np.ndarray, psd: np.ndarray,
           params: SlipParams, fs: float, usable: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray]:
    """Per finger (f, 2): largest level shift, veto_ratio x largest peak-to-peak amplitude
    (over the ``usable`` (f, 6) channels; -inf for both where a finger has none)."""
    length, span = int(params.veto_level), int(params.veto_span)
    shift = np.abs(_levels(buf, start, ends, length) - _levels(buf, start, ends - span, length))
    amp = 2.0 * np.sqrt(3.0 * fs / int(params.window) * 10.0 ** (psd / 10.0))
    if usable is not None:
        usable = usable & np.isfinite(amp)
        shift = np.where(usable, shift, -np.inf)
        amp = np.where(usable, amp, -np.inf)
    fingers = [list(c) for c in FINGER_CHANNELS]
    s = np.stack([shift[:, c].max(axis=1) for c in fingers], axis=1)
    a = np.stack([amp[:, c].max(axis=1) for c in fingers], axis=1) * params.veto_ratio
    return s, a


def level_shift_veto(buf: np.ndarray, start: int, ends: np.ndarray, psd: np.ndarray,
                     slip: np.ndarray, params: SlipParams, fs: float,
                     exact_psd: Callable[[int], np.ndarray] | None = None,
                     usable: np.ndarray | None = None) -> np.ndarray:
    """Updates whose flag the level-shift rule vetoes, shape (m,), bool.

    Parameters
    ----------
    buf : ndarray (L, 6)
        Samples; ``buf[0]`` is absolute sample ``start``; must reach back
        :func:`veto_reach` samples before every flagged update that is old enough.
    ends : ndarray (m,)
        Last sample of each update (absolute).
    psd : ndarray (m, 6)
        ``psd_max_db`` of the updates [dB].
    slip : ndarray (m,), bool
        The flags; only these are examined. Updates younger than the reach are not vetoed.
    exact_psd : callable, optional
        ``i -> psd (6,)`` from the reference Welch PSD; when given, a comparison within
        ``guard_variance`` (relative) of equality is re-made from it, so that the fast
        detector's vetoes equal the reference's.
    usable : ndarray (m, 6), bool, optional
        Channels usable at each update (default: all). The veto is judged from the usable
        ones (a NaN ``psd`` counts as unusable): a finger without one has no say, an update
        without any is not vetoed. Masked updates (:mod:`forte_perception.slip.mask`) use it.
    """
    veto = np.zeros(slip.shape[0], bool)
    if not params.robust:
        return veto
    idx = np.nonzero(slip & (ends >= veto_reach(params)))[0]  # absolute: chunking-free
    if not idx.size:
        return veto
    s, a = _terms(buf, start, ends[idx], psd[idx], params, fs,
                  None if usable is None else usable[idx])
    known = np.isfinite(s)  # a finger with a usable channel
    veto[idx] = known.any(axis=1) & ((s > a) | ~known).all(axis=1)
    if exact_psd is not None:
        near = (np.abs(s - a) <= params.guard_variance * np.maximum(s, a)).any(axis=1)
        for j in np.nonzero(near)[0]:
            i = idx[j]
            s1, a1 = _terms(buf, start, ends[i:i + 1], exact_psd(int(i))[None], params, fs)
            veto[i] = bool((s1 > a1).all())
    return veto
