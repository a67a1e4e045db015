"""Slip detection by the rise of spectral power (FORTE paper, section "Slip Detection").

For every detector update (every ``hop`` samples, counted in samples), per channel:

1. ``P`` = one-segment Welch power spectral density of the last ``N`` samples: constant
   detrend, periodic Hann window (``scipy.signal.get_window('hann', N)``), one-sided
   (bins other than DC and Nyquist doubled), density scaling ``1 / (fs * sum(w**2))``.
2. ``psd_max_db`` = max over bins with ``f_min <= f <= f_max`` of ``10 * log10(P + eps)``.
3. The last ``V`` values form a history ``H``. Moving variance ``var(H)`` (population
   variance) if every consecutive difference ``H[k+1] - H[k] > delta``, else 0.
4. Finger-group average of the moving variances (channels 0-2 left, 3-5 right); both
   groups are set to 0 when either group average is below ``alpha``.
5. Slip when either group average exceeds ``T``.

Until the history holds ``V`` values, the moving variances are 0 and no slip is reported
(``active`` is False).

Fast and exact
--------------
The straightforward computation (:func:`slip_features_reference`) runs a Welch PSD on each
window. :class:`SlipDetector` instead keeps, per channel, a sliding DFT of only the bins
``k_min - 1 .. k_max + 1`` in an absolute phase frame,
``A_k(t) = sum_{j=t-N+1..t} x[j] exp(-2i pi k j / N)``, updated by running sums of
``(x[j] - x[j-N]) exp(-2i pi k j / N)``. The Hann window is the combination
``0.5 D_k - 0.25 D_{k-1} - 0.25 D_{k+1}`` of unwindowed bins ``D_k`` (the periodic Hann
window is three complex exponentials); the constant detrend changes only ``D_0`` (set to
0), so bins ``k >= 1`` need no detrending. The increments are offset-free (``x[j] - x[j-N]``)
so a DC offset such as raw ADC counts around 2048 adds no rounding error. Every
``resync_interval`` updates (at fixed absolute update indices) the bins are recomputed
directly from the window with its mean removed, which bounds the accumulated rounding error.

Decisions are guarded: when a moving-variance comparison (``diff > delta``,
``mean >= alpha``, ``mean > T``) of an update lies within a guard band around its threshold,
that update's history is recomputed with the reference Welch PSD and decided from it, so
slip decisions equal the reference's exactly.

All arithmetic is elementwise numpy (no BLAS reductions of varying shape, fixed update
boundaries, sequential cumulative sums), so feeding the detector in chunks of any size gives
bit-for-bit the batch result.

Where the parts live
--------------------
This module holds the streaming :class:`SlipDetector` and :func:`slip_features`; the
parameters, the per-update results and the input check are in
:mod:`forte_perception.slip.params`, the decisions (steps 3-5 and the guard bands) in
:mod:`forte_perception.slip.decision`, the Welch reference in
:mod:`forte_perception.slip.reference`. Everything public is importable from here.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from forte_perception.slip.decision import decide_slip, decide_updates
from forte_perception.slip.params import (
    NonFiniteInputError,
    SlipFeatures,
    SlipParams,
    bins_in_band,
    check_frames,
)
from forte_perception.slip.reference import reference_psd_max_db, slip_features_reference
from forte_perception.slip.robust import level_shift_veto, veto_reach
from forte_ros.contract import N_CHANNELS, SAMPLE_RATE

__all__ = [
    'NonFiniteInputError',
    'SlipDetector',
    'SlipFeatures',
    'SlipParams',
    'decide_slip',
    'reference_psd_max_db',
    'slip_features',
    'slip_features_reference',
]


class SlipDetector:
    """Streaming slip detector: feed frames in chunks of any size.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    params : SlipParams, optional
        Default ``SlipParams()``. In the ``'sequential'`` mode this detector computes that
        mode's PSD features and flags, the robust mode's (:attr:`SlipParams.features`); the
        sequential mode's slip events come from :mod:`forte_perception.slip.sequential`.

    Notes
    -----
    Updates happen at absolute sample indices ``N - 1 + u * hop`` (u = 0, 1, ...) counted
    from the last :meth:`reset`. Results are bit-for-bit independent of the chunking.
    """

    def __init__(self, fs: float = SAMPLE_RATE, params: SlipParams | None = None) -> None:
        self.params = (params or SlipParams()).features
        self.params.validate(fs)
        self.fs = float(fs)
        n = int(self.params.window)
        self._n = n
        self._hop = int(self.params.hop)
        band = bins_in_band(self.params, self.fs)
        self._band = band
        # unwindowed bins needed: k_min - 1 .. k_max + 1 (k = -1 and k > N/2 are fine)
        self._bins = np.arange(band[0] - 1, band[-1] + 2)
        angle = 2.0 * np.pi * np.outer(np.arange(n), self._bins) / n  # (N, K)
        # exp(-i 2 pi k j / N) = cos - i sin, tabulated over j mod N
        self._cos_t = np.ascontiguousarray(np.cos(angle).T)  # (K, N)
        self._sin_t = np.ascontiguousarray(np.sin(angle).T)
        unit = 2.0 * np.pi * np.arange(n) / n
        self._unit_conj = np.cos(unit) + 1j * np.sin(unit)  # exp(+2i pi p / N)
        # exp(+2i pi k s / N) for every needed bin k and window start s mod N, (K, N)
        self._rotation = self._unit_conj[np.outer(self._bins, np.arange(n)) % n]
        self._rotation_conj = np.ascontiguousarray(self._rotation.conj())
        # updates per vectorised block: small enough to stay in cache and to keep the
        # (6 block, hop) @ (hop, 2K) product below OpenBLAS' multithreading threshold
        # (threads cost more than they bring at this size); no effect on the results
        self._block = int(np.clip(250000 // (6 * 2 * self._bins.size * self._hop), 16, 512))
        i = np.arange(self._hop)
        # z_k G_k = sum_i d_i exp(-2i pi k (i - hop) / N): columns (re, im) per bin, (hop, 2K)
        ang = 2.0 * np.pi * (np.outer(i - self._hop, self._bins) % n) / n  # (hop, K)
        table = np.empty((self._hop, 2 * self._bins.size))
        table[:, 0::2] = np.cos(ang)
        table[:, 1::2] = -np.sin(ang)
        self._hop_dft_interleaved = table
        # rotation to the window frame: D_k = exp(+i 2 pi k s / N) A_k, s = window start
        self._zero_dc = self._bins == 0
        s2 = float(np.sum(signal.get_window('hann', n) ** 2))
        doubling = np.where((band == 0) | ((n % 2 == 0) & (band == n // 2)), 1.0, 2.0)
        self._scale = (doubling / (16.0 * self.fs * s2))[:, None, None]  # (B, 1, 1)
        self._uniform_scale = bool(np.all(doubling == doubling[0]))
        self._keep = n + (int(self.params.history) - 1) * self._hop + self._hop
        self._floor = self.params.psd_floor(self.fs)  # eps in the paper mode
        self._reach = veto_reach(self.params)  # 0 in the paper mode
        self.reset()

    # -- state
    def reset(self) -> None:
        """Forget every sample: the next sample is index 0 again."""
        self._buffer = np.zeros((0, N_CHANNELS))
        self._buffer_start = 0  # absolute index of _buffer[0]
        self._samples = 0
        self._updates = 0
        self._a = np.zeros((self._bins.size, N_CHANNELS), np.complex128)
        self._psd_history = np.zeros((N_CHANNELS, 0))
        self._scratch: dict[str, np.ndarray] = {}
        self.reference_recomputations = 0

    @property
    def samples_seen(self) -> int:
        """Samples consumed since the last reset [count]."""
        return self._samples

    @property
    def updates(self) -> int:
        """Detector updates since the last reset [count]."""
        return self._updates

    # -- core
    def _exact(self, buf_t: np.ndarray, lo: int, start: int) -> np.ndarray:
        """A_k (K, 6) complex of the window ``buf_t[:, lo:lo + N]`` (absolute start ``start``).

        The window mean is removed first (it changes only k = 0, which is zeroed anyway)
        to keep the magnitudes, and so the rounding, small. Fixed shapes, so the result does
        not depend on the caller.
        """
        w = np.ascontiguousarray(buf_t[:, lo:lo + self._n].T)  # (N, 6)
        w = w - w.mean(axis=0)
        phase = (start + np.arange(self._n)) % self._n
        c = np.ascontiguousarray(self._cos_t[:, phase])  # (K, N)
        s = np.ascontiguousarray(self._sin_t[:, phase])
        return (c @ w) - 1j * (s @ w)

    def update(self, frames: np.ndarray) -> SlipFeatures:
        """Consume frames (n, 6) and return the updates completed inside them.

        Raises
        ------
        NonFiniteInputError
            If the chunk contains NaN or inf (nothing is consumed).
        """
        x = check_frames(frames)
        n, hop = self._n, self._hop
        buf = np.concatenate([self._buffer, x], axis=0) if self._buffer.size else x
        start = self._buffer_start
        last = self._samples + x.shape[0] - 1
        u0 = self._updates
        first_t = n - 1 + u0 * hop
        m = 0 if last < first_t else (last - first_t) // hop + 1
        self._samples += x.shape[0]
        if m == 0:
            self._store(buf, start)
            return SlipFeatures()
        ends = first_t + hop * np.arange(m)
        buf_t = np.ascontiguousarray(buf.T)  # (6, L): updates on the fast axis below
        psd = np.empty((N_CHANNELS, m))
        for b in range(0, m, self._block):
            e = ends[b:b + self._block]
            psd[:, b:b + e.size] = self._psd_block(buf_t, start, e, u0 + b)
        prior = self._psd_history  # (6, <= V-1), channel-major
        cv, fv, sl, act, border = decide_updates(psd, u0, self.params, prior)
        v = int(self.params.history)
        self._psd_history = np.concatenate([prior, psd[:, -(v - 1):]], axis=1)[:, -(v - 1):]
        psd, cv, fv = psd.T, cv.T, fv.T
        if border.any():
            self._redecide(border, buf, start, ends, cv, fv, sl)
        if self._reach and sl.any():
            self._veto(buf, start, ends, psd, fv, sl)
        self._updates += m
        self._store(buf, start)
        return SlipFeatures(ends.astype(np.int64), psd, cv, fv, sl, act)

    def _work(self, name: str, shape: tuple[int, ...], dtype=np.float64) -> np.ndarray:
        """Contiguous scratch array: a prefix of a buffer kept between calls (stays in cache,
        no allocation per block)."""
        size = math.prod(shape)
        buf = self._scratch.get(name)
        if buf is None or buf.size < size or buf.dtype != dtype:
            buf = np.empty(max(size, 1), dtype)
            self._scratch[name] = buf
        return buf[:size].reshape(shape)

    def _psd_block(self, buf_t: np.ndarray, start: int, ends: np.ndarray,
                   first_update: int) -> np.ndarray:
        """psd_max_db (mb, 6) of consecutive updates ending at ``ends`` (mb,).

        Layout (bins, channels, updates): the update axis is the contiguous one.
        """
        n, hop = self._n, self._hop
        mb = ends.size
        k = self._bins.size
        c = N_CHANNELS
        upd = first_update + np.arange(mb)
        resync = np.nonzero(upd % int(self.params.resync_interval) == 0)[0]
        # increments: inc_k(u) = sum over the update's hop samples j of
        # (x[j] - x[j-N]) exp(-2i pi k j/N) = exp(-2i pi k q/N) * G_k(u), q = first sample,
        # G_k(u) = sum_i (x[q+i] - x[q+i-N]) exp(-2i pi k i/N): one matrix product
        lo = int(ends[0]) - hop + 1 - start  # first increment sample, relative to buffer
        hi = int(ends[-1]) + 1 - start
        pad = max(0, n - lo)  # only update 0 (a resync) lacks x[j - N]; its increment is unused
        diff = self._work('diff', (c, hi - lo))
        diff[:, :pad] = 0.0
        np.subtract(buf_t[:, lo + pad:hi], buf_t[:, lo + pad - n:hi - n], out=diff[:, pad:])
        # (6 mb, hop) @ (hop, 2K) with interleaved (re, im) columns = complex (6, mb, K);
        # the table includes exp(+2i pi k hop / N) so that the remaining rotation is the
        # conjugate of the window rotation R below: inc = conj(R) * (z G)
        prod = self._work('prod', (c * mb, 2 * k))
        np.matmul(diff.reshape(c * mb, hop), self._hop_dft_interleaved, out=prod)
        g = prod.view(np.complex128).reshape(c, mb, k).transpose(2, 0, 1)  # (K, 6, mb)
        s_mod = (ends - n + 1) % n  # window start s mod N
        rot = self._rotation[:, s_mod]  # R = exp(+2i pi k s / N), (K, mb)
        inc = self._work('inc', (k, c, mb), np.complex128)
        np.multiply(g, self._rotation_conj[:, s_mod][:, None, :], out=inc)
        # running sums between resync points, continuing from the stored state:
        # inc[pos] += cur, then a sequential cumulative sum into a
        a = prod.view(np.complex128).reshape(k, c, mb)  # reuse: g is consumed
        cur = self._a
        pos = 0
        for nxt in [*resync.tolist(), mb]:
            if nxt > pos:
                inc[:, :, pos] += cur
                np.add.accumulate(inc[:, :, pos:nxt], axis=2, out=a[:, :, pos:nxt])
                cur = a[:, :, nxt - 1]
            if nxt < mb:
                t = int(ends[nxt])
                a[:, :, nxt] = self._exact(buf_t, t - n + 1 - start, t - n + 1)
                cur = a[:, :, nxt]
                pos = nxt + 1
        self._a = cur.copy()
        # rotate to the window frame: D_k = exp(+2i pi k s / N) A_k, s = window start
        d = inc  # reuse
        np.multiply(a, rot[:, None, :], out=d)
        if self._zero_dc.any():  # constant detrend: D_0 = 0
            d[self._zero_dc] = 0.0
        # Hann: X_k = (2 D_k - D_{k-1} - D_{k+1}) / 4; -4 X_k = (D_{k-1} + D_{k+1}) - 2 D_k,
        # the factor 1/16 of |X|^2 is folded into the scale
        x = a[:k - 2]  # reuse: a is no longer needed
        np.add(d[:-2], d[2:], out=x)
        np.subtract(x, d[1:-1], out=x)
        np.subtract(x, d[1:-1], out=x)
        sq = d[:k - 2].view(np.float64)  # reuse: (K-2, 6, 2 mb) real
        np.square(x.view(np.float64), out=sq)
        p = self._work('p', (k - 2, c, mb))
        np.add(sq[:, :, 0::2], sq[:, :, 1::2], out=p)
        if self._uniform_scale:
            top = p.max(axis=0) * self._scale[0, 0, 0]
        else:
            top = (p * self._scale).max(axis=0)
        return 10.0 * np.log10(top + self._floor)

    def _redecide(self, border: np.ndarray, buf: np.ndarray, start: int, ends: np.ndarray,
                  cv: np.ndarray, fv: np.ndarray, sl: np.ndarray) -> None:
        """Re-make borderline decisions from the reference PSD of their whole history."""
        n, hop, v = self._n, self._hop, int(self.params.history)
        cache: dict[int, np.ndarray] = {}
        for i in np.nonzero(border)[0]:
            hist = np.empty((v, N_CHANNELS))
            for h in range(v):
                t = int(ends[i] - (v - 1 - h) * hop)
                if t not in cache:
                    cache[t] = reference_psd_max_db(buf[t - n + 1 - start:t + 1 - start],
                                                    self.fs, self.params)
                hist[h] = cache[t]
            c, f, s, _ = decide_slip(hist[None], self.params)
            cv[i], fv[i], sl[i] = c[0], f[0], s[0]
            self.reference_recomputations += 1

    def _veto(self, buf: np.ndarray, start: int, ends: np.ndarray, psd: np.ndarray,
              fv: np.ndarray, sl: np.ndarray) -> None:
        """Robust mode: clear the flags the level-shift rule vetoes (and their finger
        averages, as if they had not passed), :mod:`forte_perception.slip.robust`."""
        n = self._n

        def exact(i: int) -> np.ndarray:
            t = int(ends[i])
            return reference_psd_max_db(buf[t - n + 1 - start:t + 1 - start], self.fs,
                                        self.params)

        veto = level_shift_veto(buf, start, ends, psd, sl, self.params, self.fs, exact)
        sl[veto] = False
        fv[veto] = 0.0

    def _store(self, buf: np.ndarray, start: int) -> None:
        """Keep the samples the next updates (and a guarded re-decision) may need."""
        n, hop, v = self._n, self._hop, int(self.params.history)
        next_t = n - 1 + self._updates * hop
        first_needed = max(0, min(next_t - hop - (v - 1) * hop - n + 1,
                                  next_t - self._reach))
        drop = max(0, first_needed - start)
        self._buffer = buf[drop:].copy()
        self._buffer_start = start + drop


def slip_features(frames: np.ndarray, fs: float = SAMPLE_RATE,
                  params: SlipParams | None = None) -> SlipFeatures:
    """Slip features of a whole recording (fast path; equal to feeding :class:`SlipDetector`).

    Parameters
    ----------
    frames : ndarray, shape (n, 6)
        Already preprocessed samples (this applies only the slip computation).
    fs : float
        Sampling rate [Hz].
    params : SlipParams, optional

    Returns
    -------
    SlipFeatures
        m = 0 if n < N, else ``(n - N) // hop + 1`` updates.
    """
    detector = SlipDetector(fs, params)
    x = check_frames(frames)
    parts = []
    block = 65536  # bounds temporary memory; chunking does not change the result
    for i in range(0, x.shape[0], block):
        parts.append(detector.update(x[i:i + block]))
    return SlipFeatures.concatenate(parts)
