"""Slip decisions from the PSD history: moving variance, finger average, alpha gate,
threshold (steps 3-5 of :mod:`forte_perception.slip.detector`), and the guard bands that send a
borderline decision back to the reference PSD.

All arithmetic is elementwise in a fixed order, so a decision does not depend on how many
updates are decided together (the detector's chunking).
"""
from __future__ import annotations

import numpy as np

from forte_perception.slip.params import SlipParams
from forte_ros.contract import N_CHANNELS

__all__ = ['decide_slip', 'decide_updates']


def _decide_terms(h: list[np.ndarray], params: SlipParams
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decision arithmetic on V arrays of equal shape (6, ...), oldest first.

    Elementwise in a fixed order, so a result does not depend on how many updates are
    decided together or on the memory layout.
    Returns channel_variance (6, ...), finger (2, ...), slip (...), min_diff (6, ...),
    finger_raw (2, ...).
    """
    v = len(h)
    min_diff = h[1] - h[0]
    for i in range(2, v):
        min_diff = np.minimum(min_diff, h[i] - h[i - 1])
    return _decide_rest(h, min_diff, params)


def _decide_rest(h: list[np.ndarray], min_diff: np.ndarray, params: SlipParams
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Variance, group average, gate and threshold given the smallest differences.

    ``h``: V arrays (6, m) (or (6, ...)), ``min_diff`` (6, ...). The variance matters only
    where some channel rises monotonically (rare in practice), so it is computed for those
    updates only (same arithmetic per element, so the same bits). In the robust mode a
    finger may also pass alone: its group average above ``single_threshold`` with at least
    ``single_min_rising`` of its channels rising with a variance of at least alpha
    (:mod:`forte_perception.slip.robust`).
    """
    shape = min_diff.shape
    md = min_diff.reshape(shape[0], -1)
    m = md.shape[1]
    rising = md > params.delta
    both, candidate = _candidates(rising, params)
    cols = np.nonzero(candidate)[0]
    channel_variance = np.zeros((N_CHANNELS, m))
    finger = np.zeros((2, m))
    finger_raw = np.zeros((2, m))
    slip = np.zeros(m, bool)
    if cols.size:
        if cols.size * 4 > m:  # many: contiguous slices beat gathering
            cols = np.arange(m)
        cv = _rising_variance(h, rising & candidate, cols, m)  # 0 off the candidates
        left = (cv[0] + cv[1] + cv[2]) / 3.0
        right = (cv[3] + cv[4] + cv[5]) / 3.0
        gate = both[cols] & (left >= params.alpha) & (right >= params.alpha)
        keep_left, keep_right = gate, gate
        if params.robust:  # alone: enough channels of the finger rise by >= alpha each
            strong = cv >= params.alpha
            k = int(params.single_min_rising)
            single = params.single_threshold
            keep_left = gate | (((strong[0].astype(np.int8) + strong[1] + strong[2]) >= k)
                                & (left > single))
            keep_right = gate | (((strong[3].astype(np.int8) + strong[4] + strong[5]) >= k)
                                 & (right > single))
        channel_variance[:, cols] = cv
        finger_raw[:, cols] = np.stack([left, right], axis=0)
        finger[0, cols] = np.where(keep_left, left, 0.0)
        finger[1, cols] = np.where(keep_right, right, 0.0)
        slip[cols] = np.maximum(finger[0, cols], finger[1, cols]) > params.threshold
    return (channel_variance.reshape(shape), finger.reshape((2,) + shape[1:]),
            slip.reshape(shape[1:]), min_diff, finger_raw.reshape((2,) + shape[1:]))


def _candidates(rising: np.ndarray, params: SlipParams) -> tuple[np.ndarray, np.ndarray]:
    """Updates where both fingers have a rising channel, and those whose decision needs the
    variances, each (m,), bool.

    The group averages pass the alpha gate only if both groups have a rising channel (a
    channel's variance is 0 unless it rises; alpha > 0); in the robust mode a finger with
    ``single_min_rising`` rising channels is a candidate alone.
    """
    count = [rising[0].astype(np.int8) + rising[1] + rising[2],
             rising[3].astype(np.int8) + rising[4] + rising[5]]
    both = (count[0] > 0) & (count[1] > 0)
    if not params.robust:
        if params.alpha <= 0.0:
            both = np.ones(rising.shape[1], bool)
        return both, both
    k = int(params.single_min_rising)
    return both, both | (count[0] >= k) | (count[1] >= k)


def _rising_variance(h: list[np.ndarray], rising: np.ndarray, cols: np.ndarray, m: int
                     ) -> np.ndarray:
    """Moving variance (0 where the channel does not rise) of the updates ``cols``, (6, c).

    One arithmetic order for both modes, so the same values give the same bits.
    """
    v = len(h)
    flat = [np.asarray(x).reshape(x.shape[0], -1) for x in h]
    hs = flat if cols.size == m else [x[:, cols] for x in flat]
    total = hs[0].copy()
    for i in range(1, v):
        total = total + hs[i]
    mean = total / v
    sq = (hs[0] - mean) ** 2
    for i in range(1, v):
        sq = sq + (hs[i] - mean) ** 2
    return np.where(rising[:, cols], sq / v, 0.0)


def decide_slip(history: np.ndarray, params: SlipParams
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Moving variance, finger average, alpha gate and threshold for full histories.

    Parameters
    ----------
    history : ndarray, shape (m, V, 6)
        The last V ``psd_max_db`` values (oldest first) of m updates [dB].
    params : SlipParams

    Returns
    -------
    channel_variance : ndarray, shape (m, 6) [dB^2]
    finger_variance : ndarray, shape (m, 2) [dB^2]
    slip : ndarray, shape (m,), bool
    min_diff : ndarray, shape (m, 6)
        Smallest consecutive difference per channel [dB].
    """
    hist = np.asarray(history, dtype=np.float64)
    terms = [np.ascontiguousarray(hist[:, i, :].T) for i in range(hist.shape[1])]
    cv, fv, sl, md, _ = _decide_terms(terms, params)
    return cv.T, fv.T, sl, md.T


def _running_min(values: np.ndarray, width: int) -> np.ndarray:
    """Minimum over each run of ``width`` consecutive columns, (r, c) -> (r, c - width + 1).

    Doubling (sparse table): minima of runs of 1, 2, 4, ... columns, then two overlapping
    runs cover ``width``. Exact (min does no arithmetic).
    """
    out_len = values.shape[1] - width + 1
    span, cur = 1, values
    while 2 * span <= width:
        cur = np.minimum(cur[:, :-span], cur[:, span:])
        span *= 2
    return np.minimum(cur[:, :out_len], cur[:, width - span:width - span + out_len])


def _borderline(finger_raw: np.ndarray, min_diff: np.ndarray, params: SlipParams,
                channel_variance: np.ndarray | None = None) -> np.ndarray:
    """Updates whose decision could flip inside the numerical guard bands, shape (m,).

    ``finger_raw`` (2, m) and ``min_diff`` (6, m); in the robust mode also a channel
    variance (6, m) near alpha (the one-finger rule counts the channels reaching it).
    """
    border = np.abs(min_diff - params.delta).min(axis=0) <= params.guard_db
    cols = np.nonzero(finger_raw.any(axis=0))[0]  # group averages are 0 elsewhere
    if cols.size:
        g = params.guard_variance
        f = finger_raw[:, cols]
        near = ((np.abs(f - params.alpha) <= g * max(1.0, abs(params.alpha)))
                | (np.abs(f - params.threshold) <= g * max(1.0, abs(params.threshold))))
        if params.robust:
            single = params.single_threshold
            near |= np.abs(f - single) <= g * max(1.0, abs(single))
        border[cols] |= near.any(axis=0)
        if params.robust and channel_variance is not None:
            cv = channel_variance[:, cols]
            border[cols] |= (np.abs(cv - params.alpha)
                             <= g * max(1.0, abs(params.alpha))).any(axis=0)
    if params.alpha <= 0.0 or params.threshold <= 0.0:  # 0 itself is near a threshold
        border |= _zero_near(finger_raw, params)
    return border


def _zero_near(finger_raw: np.ndarray, params: SlipParams) -> np.ndarray:
    """Guard for unusual thresholds at or below 0, where a zero average is borderline."""
    g = params.guard_variance
    near = ((np.abs(finger_raw - params.alpha) <= g * max(1.0, abs(params.alpha)))
            | (np.abs(finger_raw - params.threshold) <= g * max(1.0, abs(params.threshold))))
    return near.any(axis=0)


def decide_updates(psd: np.ndarray, first_update: int, params: SlipParams, prior: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decisions for consecutive updates ``first_update ..`` given the previous history.

    Channel-major: ``psd`` (6, m); ``prior`` (6, h) holds up to V-1 psd values of the
    updates just before. Returns channel_variance (6, m), finger_variance (2, m), slip (m,),
    active (m,), borderline (m,).
    """
    v = int(params.history)
    m = psd.shape[1]
    channel_variance = np.zeros((N_CHANNELS, m))
    finger = np.zeros((2, m))
    slip = np.zeros(m, bool)
    border = np.zeros(m, bool)
    active = (first_update + np.arange(m)) >= v - 1
    if active[-1]:
        first = int(np.argmax(active))  # active updates are a suffix
        series = np.concatenate([prior, psd], axis=1)  # (6, h + m)
        offset = prior.shape[1]
        ma = m - first
        lo = offset + first - v + 1  # history of the first active update starts here
        terms = [series[:, lo + i:lo + i + ma] for i in range(v)]
        # smallest of the V-1 consecutive differences: a running minimum (exact)
        steps = series[:, lo + 1:lo + v - 1 + ma] - series[:, lo:lo + v - 2 + ma]
        min_diff = _running_min(steps, v - 1)
        cv, fv, sl, md, fraw = _decide_rest(terms, min_diff, params)
        channel_variance[:, first:] = cv
        finger[:, first:] = fv
        slip[first:] = sl
        border[first:] = _borderline(fraw, md, params, cv)
    return channel_variance, finger, slip, active, border

