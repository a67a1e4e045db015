"""Slip decisions with masked channels (pure, no ROS).

The :class:`~forte_perception.slip.detector.SlipDetector` runs on every channel (invalid raw values
are replaced by a substitute before the median filter, see
:mod:`forte_perception.channel_health`); this module re-makes the decisions of the updates
whose windows hold a substituted sample, from the channels that are *usable* there.

Rule (documented in docs/perception.md):

- channel c is usable at an update ending at sample e when no substituted sample lies in
  the raw reach of its decision, ``e - (N + (V - 1) hop + M - 1) + 1 .. e`` (window N, its
  history of V updates, the median of M);
- a finger is *available* when at least one of its channels is usable; its group average
  is the mean moving variance of its usable channels (the paper's average of three when all
  are usable);
- the alpha gate applies to the available fingers only (all of them must reach alpha);
  slip when an available finger's average exceeds T; an unavailable finger's
  ``finger_variance`` is NaN;
- the update is *decidable* (``slip_active``) when the detector is active (full history
  since its restart) and at least one finger is available;
- ``psd_max_db`` of channel c is NaN when its own PSD window (reach ``N + M - 1``) holds a
  substituted sample.

In the robust mode (:mod:`forte_perception.slip.robust`) a finger may also flag alone, as
unmasked: its group average (usable channels) above ``single_threshold`` with at least
``single_min_rising`` usable channels rising with a variance of at least alpha. The
quantisation floor is in the PSD features already; the level-shift veto is applied to a
masked update's flag from its usable channels
(:func:`forte_perception.slip.robust.level_shift_veto` with ``usable``).

Decisions are guarded as the detector's own: a masked update whose smallest usable
difference is within ``guard_db`` of delta, or an available group average within
``guard_variance`` of alpha or T, is re-decided from ``scipy.signal.welch`` PSDs of its whole
history. Updates with every channel usable keep the detector's results untouched (bit for
bit the unmasked algorithm).
"""
from __future__ import annotations

import numpy as np

from forte_perception.slip.params import SlipFeatures, SlipParams
from forte_perception.slip.reference import reference_psd_max_db
from forte_perception.slip.robust import level_shift_veto, veto_reach
from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS

__all__ = ['SlipMask', 'decide_slip_masked']


def decide_slip_masked(history: np.ndarray, usable: np.ndarray, params: SlipParams
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The decision (paper, or robust with one finger alone) on the usable channels of m
    updates.

    Parameters
    ----------
    history : ndarray, shape (m, V, 6)
        The last V ``psd_max_db`` values of each update, oldest first [dB].
    usable : ndarray, shape (m, 6), bool
    params : SlipParams

    Returns
    -------
    channel_variance : ndarray, shape (m, 6)
        Moving variance (0 unless rising), NaN where unusable [dB^2].
    finger_variance : ndarray, shape (m, 2)
        Gated group averages, NaN for an unavailable finger [dB^2].
    slip : ndarray, shape (m,), bool
    borderline : ndarray, shape (m,), bool
        Decision within the numerical guard bands.
    """
    h = np.asarray(history, dtype=np.float64)
    v = h.shape[1]
    usable = np.asarray(usable, bool)
    min_diff = np.min(h[:, 1:, :] - h[:, :-1, :], axis=1)  # (m, 6)
    rising = min_diff > params.delta
    mean = h.sum(axis=1) / v
    variance = ((h - mean[:, None, :]) ** 2).sum(axis=1) / v
    cv = np.where(rising & usable, variance, 0.0)
    groups = np.empty((h.shape[0], 2))
    available = np.empty((h.shape[0], 2), bool)
    for f, channels in enumerate(FINGER_CHANNELS):
        count = usable[:, channels].sum(axis=1)
        available[:, f] = count > 0
        groups[:, f] = np.where(count > 0, cv[:, channels].sum(axis=1) / np.maximum(count, 1),
                                np.nan)
    passes = np.where(available, groups >= params.alpha, True).all(axis=1)
    keep = np.repeat(passes[:, None], 2, axis=1)
    if params.robust:  # one finger alone: enough usable channels rising by >= alpha each
        strong = cv >= params.alpha
        for f, channels in enumerate(FINGER_CHANNELS):
            alone = strong[:, channels].sum(axis=1) >= int(params.single_min_rising)
            keep[:, f] |= alone & (groups[:, f] > params.single_threshold)
    gated = np.where(keep, groups, np.where(available, 0.0, np.nan))
    slip = (np.where(available, gated, -np.inf) > params.threshold).any(axis=1)
    g = params.guard_variance
    near = ((np.abs(groups - params.alpha) <= g * max(1.0, abs(params.alpha)))
            | (np.abs(groups - params.threshold) <= g * max(1.0, abs(params.threshold))))
    if params.robust:
        single = params.single_threshold
        near |= np.abs(groups - single) <= g * max(1.0, abs(single))
    border = (near & available).any(axis=1)
    border |= ((np.abs(min_diff - params.delta) <= params.guard_db) & usable).any(axis=1)
    return np.where(usable, cv, np.nan), gated, slip, border


class SlipMask:
    """Masked decisions for a :class:`~forte_perception.slip.detector.SlipDetector`'s updates.

    Keeps the last V - 1 ``psd_max_db`` rows and the last ``N + (V - 1) hop`` input samples
    of the detector (for guarded re-decisions); :meth:`reset` together with the detector.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    params : SlipParams
    median_window : int
        M [samples]: a raw sample reaches M filtered samples.
    """

    def __init__(self, fs: float, params: SlipParams, median_window: int) -> None:
        self.fs = float(fs)
        self.params = params
        n, hop, v = int(params.window), int(params.hop), int(params.history)
        self.psd_reach = n + int(median_window) - 1
        self.decision_reach = n + (v - 1) * hop + int(median_window) - 1
        # detector samples kept before the newest chunk (the PSD history; the veto's reach)
        self._keep = max(n + (v - 1) * hop, veto_reach(params))
        self._history_keep = v - 1  # psd rows kept before the newest chunk
        self.reference_recomputations = 0
        self.reset()

    def reset(self) -> None:
        """Forget the detector's past (call when the detector restarts)."""
        # recent chunks by reference (no copies on the healthy path), oldest first
        self._psd_parts: list[np.ndarray] = []
        self._psd_rows = 0
        self._sample_parts: list[np.ndarray] = []
        self._sample_rows = 0
        self._samples_end = 0  # detector samples seen

    def record(self, samples: np.ndarray, result: SlipFeatures) -> None:
        """Remember a chunk given to the detector (not modified later) and its result."""
        m = result.sample_index.shape[0]
        if m:
            self._psd_parts.append(result.psd_max_db)  # apply() NaNs a copy, not this
            self._psd_rows += m
            if self._psd_rows - self._psd_parts[0].shape[0] - m >= self._history_keep:
                self._psd_rows = _trim(self._psd_parts, self._psd_rows, self._history_keep)
        n = samples.shape[0]
        self._sample_parts.append(samples)
        self._sample_rows += n
        self._samples_end += n
        if self._sample_rows - self._sample_parts[0].shape[0] - n >= self._keep:
            self._sample_rows = _trim(self._sample_parts, self._sample_rows, self._keep)

    def apply(self, result: SlipFeatures, usable: np.ndarray, psd_ok: np.ndarray) -> None:
        """Re-decide the updates of ``result`` (the last :meth:`record`) with an unusable
        channel, in place.

        Parameters
        ----------
        result : SlipFeatures
            The detector's result for one chunk (m updates).
        usable : ndarray, shape (m, 6), bool
            Channel usable for each update's decision.
        psd_ok : ndarray, shape (m, 6), bool
            Channel's own PSD window clean.
        """
        series = np.concatenate(self._psd_parts)  # (h + m, 6)
        result.psd_max_db = np.where(psd_ok, result.psd_max_db, np.nan)
        rows = np.flatnonzero(~usable.all(axis=1) & result.active)
        inactive = np.flatnonzero(~usable.all(axis=1) & ~result.active)
        result.finger_variance[inactive] = 0.0
        result.channel_variance[inactive] = 0.0
        if not rows.size:
            return
        v = int(self.params.history)
        h = series.shape[0] - len(result)
        idx = h + rows[:, None] - (v - 1) + np.arange(v)[None, :]  # (r, V), all >= 0: active
        hist = series[idx]  # (r, V, 6)
        cv, fv, sl, border = decide_slip_masked(hist, usable[rows], self.params)
        if border.any():
            buffer = np.concatenate(self._sample_parts)
            buffer_start = self._samples_end - buffer.shape[0]
        for k in np.flatnonzero(border):
            hist_ref = self._reference_history(int(result.sample_index[rows[k]]), buffer,
                                               buffer_start)
            c, f, s, _ = decide_slip_masked(hist_ref[None], usable[rows[k]][None], self.params)
            cv[k], fv[k], sl[k] = c[0], f[0], s[0]
            self.reference_recomputations += 1
        result.channel_variance[rows] = cv
        result.finger_variance[rows] = fv
        flagged = rows[sl]
        if flagged.size and self.params.robust:
            buffer = np.concatenate(self._sample_parts)
            veto = level_shift_veto(
                buffer, self._samples_end - buffer.shape[0], result.sample_index[flagged],
                result.psd_max_db[flagged], np.ones(flagged.size, bool), self.params, self.fs,
                usable=usable[flagged])
            sl[np.flatnonzero(sl)[veto]] = False
        result.slip[rows] = sl

    def _reference_history(self, end: int, buffer: np.ndarray, start: int) -> np.ndarray:
        """Welch psd_max_db (V, 6) of the V windows of the update ending at ``end``."""
        n, hop, v = int(self.params.window), int(self.params.hop), int(self.params.history)
        out = np.empty((v, N_CHANNELS))
        for i in range(v):
            t = end - (v - 1 - i) * hop
            out[i] = reference_psd_max_db(buffer[t - n + 1 - start:t + 1 - start], self.fs,
                                          self.params)
        return out


def _trim(parts: list[np.ndarray], rows: int, keep: int) -> int:
    """Drop the oldest parts while the others still hold ``keep`` rows before the newest."""
    while len(parts) > 1 and rows - parts[0].shape[0] - parts[-1].shape[0] >= keep:
        rows -= parts.pop(0).shape[0]
    return rows
