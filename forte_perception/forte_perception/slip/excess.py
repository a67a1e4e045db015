"""A finger's CUSUM input from the excesses of its channels (issue 38).

:mod:`forte_perception.slip.cusum` tests one input per finger. These functions form it from
the six channels' band powers over their quiet levels: the mean and the largest channel
(:func:`pooled_excess`), the coherent sum of the finger's channels (:func:`coherent_excess`)
and, for the weak-change test, the excess of what varies within the window
(:func:`demeaned_excess`). The derivations are the CUSUM module's ("Two drifts", "Coherent
sum").
"""
from __future__ import annotations

import math

import numpy as np

from forte_perception.slip.state import FINGER_INDEX, PAIR_FIRST, PAIR_SECOND, finger_means

__all__ = ['coherent_excess', 'demeaned_excess', 'pooled_excess']


def pooled_excess(z: np.ndarray, single_offset: float, coherent: np.ndarray | None = None,
                  coherent_offset: float = math.inf) -> np.ndarray:
    """Per finger, the largest of the mean excess of its usable channels, the largest
    channel's excess less ``single_offset`` and, when given, its coherent excess less
    ``coherent_offset``.

    The mean is the test for a slip that all three channels of a finger hear. When one
    channel alone carries it (a contact over one leg of the fin ray, a tube crossed to the
    other finger's input, a sensor with fewer elements wired to one input) the mean is a
    third of that channel's excess and a slip of less than three times the drift is never
    found; the largest channel alone is the test for a slip in one unknown channel. Its
    quiet value is the largest of three draws and each has the spread of one channel, not of
    a mean of three: ``single_offset`` puts it back below the drift.

    Parameters
    ----------
    z : ndarray, shape (m, 6)
        Excess of each channel over its quiet level [dB]; NaN: unusable or no level yet.
    single_offset : float
        [dB]; inf gives the mean alone.
    coherent : ndarray, shape (m, 2), optional
        Each finger's coherent excess (:func:`coherent_excess`) [dB]; NaN: unknown.
    coherent_offset : float
        [dB]; the finger's input is at least ``coherent`` less it (inf: not).

    Returns
    -------
    ndarray, shape (m, 2)
        [dB]; NaN where a finger has no usable channel.
    """
    pooled = finger_means(z)
    if math.isfinite(single_offset):
        grouped = z[:, FINGER_INDEX]  # (m, 2, 3)
        usable = np.isfinite(grouped)
        # fmax skips NaN (NaN only where all are): the largest usable channel per finger
        largest = np.fmax.reduce(grouped if usable.all() else
                                 np.where(usable, grouped, np.nan), axis=2)
        pooled = np.fmax(pooled, largest - single_offset)
    if coherent is not None and math.isfinite(coherent_offset):
        pooled = np.fmax(pooled, coherent - coherent_offset)
    return pooled


#: The products ``s_a s_b`` of the channel signs (+++, ++-, +-+, -++) for the pairs
#: (01, 02, 12) of a finger, (4, 3).
_SIGN_PATTERNS = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0],
                           [-1.0, -1.0, 1.0]])


def coherent_excess(power_db: np.ndarray, level: np.ndarray, means: np.ndarray,
                    products: np.ndarray) -> np.ndarray:
    """Per finger, the power of the sum of its channels' band-passed signals, each divided
    by its quiet band amplitude and the window's mean removed, over its quiet value 3.

    A release rings one bending mode that the three channels of a finger see in phase while
    their noises are independent: for three equal in-phase channels the sum's excess is a
    channel's signal-to-noise ratio plus 4.8 dB, where the mean of their dB excesses gains
    nothing. A lab may plumb a transducer reversed, so the largest of the four sign patterns
    (+++, ++-, +-+, -++) is taken. The window's mean is removed: a ramp through the
    band-pass is a constant on every channel, as coherent as a ring, while a 10-50 Hz ring
    has little mean over the window.

    Parameters
    ----------
    power_db : ndarray, shape (m, 6)
        Each channel's band power over the window, floor included [dB]; NaN: unusable.
    level : ndarray, shape (6,)
        Quiet levels of ``power_db`` [dB]; NaN: none yet.
    means, products : ndarray, shape (m, 6)
        The window means of each channel's band-passed signal and of the products of the
        finger pairs (:data:`~forte_perception.slip.state.PAIR_FIRST`, ``PAIR_SECOND``)
        [normalised unit, unit^2].

    Returns
    -------
    ndarray, shape (m, 2)
        [dB]; NaN where a channel of the finger is unusable or has no level.
    """
    weight = 10.0 ** (-0.05 * level)  # 1 / quiet band amplitude, (6,)
    variance = (10.0 ** (0.1 * power_db) - means * means) * (weight * weight)
    covariance = ((products - means[:, PAIR_FIRST] * means[:, PAIR_SECOND])
                  * (weight[PAIR_FIRST] * weight[PAIR_SECOND]))
    best = (covariance.reshape(-1, 2, 1, 3) * _SIGN_PATTERNS).sum(axis=3).max(axis=2)
    with np.errstate(invalid='ignore'):
        return 10.0 * np.log10((variance[:, FINGER_INDEX].sum(axis=2) + 2.0 * best) / 3.0)


def demeaned_excess(power_db: np.ndarray, level: np.ndarray, means: np.ndarray) -> np.ndarray:
    """Each channel's excess over its quiet level with the window mean's power removed: of
    what varies within the window (:mod:`~forte_perception.slip.cusum`, "Two drifts").

    Parameters
    ----------
    power_db : ndarray, shape (m, 6)
        Each channel's band power over the window, floor included [dB]; NaN: unusable.
    level : ndarray, shape (6,)
        Quiet levels of ``power_db`` [dB]; NaN: none yet.
    means : ndarray, shape (m, 6)
        The window means of the band-passed signals [unit].

    Returns
    -------
    ndarray, shape (m, 6)
        [dB]; NaN where ``power_db`` or ``level`` is. The floor keeps the variance positive
        (a window mean's square never exceeds the mean square); the smallest normal number
        guards the logarithm against rounding.
    """
    variance = np.maximum(10.0 ** (0.1 * power_db) - means * means, np.finfo(float).tiny)
    return 10.0 * np.log10(variance) - level
