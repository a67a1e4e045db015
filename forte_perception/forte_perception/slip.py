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
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

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

N_CHANNELS = 6
FINGER_CHANNELS = ((0, 1, 2), (3, 4, 5))


class NonFiniteInputError(ValueError):
    """Raised when input frames contain NaN or inf; the detector state is left unchanged."""


@dataclass(frozen=True)
class SlipParams:
    """Parameters of the slip detector (paper, Table "Slip Detection Parameters").

    Attributes
    ----------
    window : int
        FFT window length N [samples] (400).
    hop : int
        Samples between detector updates (4 = overlap 0.99 at N = 400; 1 = every sample).
    f_min, f_max : float
        Frequency band [Hz], inclusive (10, 50).
    history : int
        PSD history length V [updates] (15).
    delta : float
        Minimal increment for monotonicity [dB] (0.1).
    alpha : float
        Minimum group average variance [dB^2] (0.6).
    threshold : float
        Slip detection threshold T [dB^2] (2.0).
    eps : float
        Constant added to the PSD before the logarithm [PSD units] (1e-12).
    resync_interval : int
        Updates between exact recomputations of the sliding DFT (numerics only).
    guard_db : float
        Half-width of the band around ``delta`` [dB] inside which a decision is re-made
        with the reference PSD (numerics only).
    guard_variance : float
        Half-width of the band around ``alpha`` and ``T`` [dB^2], same purpose.
    """

    window: int = 400
    hop: int = 4
    f_min: float = 10.0
    f_max: float = 50.0
    history: int = 15
    delta: float = 0.1
    alpha: float = 0.6
    threshold: float = 2.0
    eps: float = 1e-12
    resync_interval: int = 1000
    guard_db: float = 1e-7
    guard_variance: float = 1e-6

    def validate(self, fs: float = 2000.0) -> None:
        """Raise ValueError with a reason if the parameters are unusable at rate ``fs`` [Hz]."""
        if not np.isfinite(fs) or fs <= 0:
            raise ValueError(f'fs must be a positive finite rate, got {fs}')
        if int(self.window) != self.window or self.window < 8:
            raise ValueError(f'window must be an integer >= 8, got {self.window}')
        if int(self.hop) != self.hop or not 1 <= self.hop <= self.window:
            raise ValueError(f'hop must be an integer in [1, window], got {self.hop}')
        if int(self.history) != self.history or self.history < 2:
            raise ValueError(f'history must be an integer >= 2, got {self.history}')
        if not (0 <= self.f_min <= self.f_max <= fs / 2):
            raise ValueError(
                f'need 0 <= f_min <= f_max <= fs/2, got f_min={self.f_min} f_max={self.f_max}')
        if not bins_in_band(self, fs).size:
            raise ValueError(
                f'no FFT bin (spacing {fs / self.window} Hz) inside '
                f'[{self.f_min}, {self.f_max}] Hz')
        for name in ('delta', 'alpha', 'threshold'):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f'{name} must be finite')
        if not (self.eps > 0 and np.isfinite(self.eps)):
            raise ValueError(f'eps must be positive, got {self.eps}')
        if int(self.resync_interval) != self.resync_interval or self.resync_interval < 1:
            raise ValueError(f'resync_interval must be an integer >= 1, got {self.resync_interval}')
        if not (self.guard_db >= 0 and self.guard_variance >= 0):
            raise ValueError('guards must be >= 0')


def bins_in_band(params: SlipParams, fs: float) -> np.ndarray:
    """FFT bin indices k with ``f_min <= k * fs / N <= f_max`` and ``k <= N // 2``, shape (b,)."""
    n = int(params.window)
    k = np.arange(n // 2 + 1)
    f = k * (fs / n)
    return k[(f >= params.f_min) & (f <= params.f_max)]


@dataclass
class SlipFeatures:
    """Per-update slip detector output.

    Attributes
    ----------
    sample_index : ndarray, shape (m,), int64
        Index of the last sample of each update's window (first update: N - 1).
    psd_max_db : ndarray, shape (m, 6)
        Band maximum of ``10*log10(P + eps)`` per channel [dB re 1/Hz].
    channel_variance : ndarray, shape (m, 6)
        Per-channel moving variance (0 unless the channel rises monotonically) where both
        finger groups have a rising channel; 0 elsewhere, where the alpha gate zeroes the
        group averages anyway [dB^2].
    finger_variance : ndarray, shape (m, 2)
        Finger-group average moving variance after the alpha gate (left, right) [dB^2].
    slip : ndarray, shape (m,), bool
        Slip indicator eta.
    active : ndarray, shape (m,), bool
        True once the history holds V values.
    """

    sample_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    psd_max_db: np.ndarray = field(default_factory=lambda: np.zeros((0, N_CHANNELS)))
    channel_variance: np.ndarray = field(default_factory=lambda: np.zeros((0, N_CHANNELS)))
    finger_variance: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    slip: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    active: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    def __len__(self) -> int:
        return int(self.sample_index.shape[0])

    @staticmethod
    def concatenate(parts: list[SlipFeatures]) -> SlipFeatures:
        """Join consecutive per-chunk results into one."""
        if not parts:
            return SlipFeatures()
        return SlipFeatures(
            sample_index=np.concatenate([p.sample_index for p in parts]),
            psd_max_db=np.concatenate([p.psd_max_db for p in parts]),
            channel_variance=np.concatenate([p.channel_variance for p in parts]),
            finger_variance=np.concatenate([p.finger_variance for p in parts]),
            slip=np.concatenate([p.slip for p in parts]),
            active=np.concatenate([p.active for p in parts]),
        )


def _check_frames(frames: np.ndarray) -> np.ndarray:
    x = np.asarray(frames, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != N_CHANNELS:
        raise ValueError(f'frames must have shape (n, {N_CHANNELS}), got {x.shape}')
    # fast test: the sum is finite unless an element is NaN/inf (or the sum overflows)
    if not np.isfinite(np.add.reduce(x, axis=None)) and not np.isfinite(x).all():
        bad = np.argwhere(~np.isfinite(x))[0]
        raise NonFiniteInputError(
            f'non-finite input (NaN or inf) at row {bad[0]}, channel {bad[1]}; '
            'chunk rejected, detector state unchanged')
    return x


# ----------------------------------------------------------------------------- decisions
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
    updates only (same arithmetic per element, so the same bits).
    """
    v = len(h)
    shape = min_diff.shape
    md = min_diff.reshape(shape[0], -1)
    m = md.shape[1]
    rising = md > params.delta
    # the group averages pass the alpha gate only if both groups have a rising channel
    # (a channel's variance is 0 unless it rises; alpha > 0): compute variances there only
    if params.alpha > 0.0:
        both = rising[0] | rising[1] | rising[2]
        both &= rising[3] | rising[4] | rising[5]
    else:
        both = np.ones(m, bool)
    cols = np.nonzero(both)[0]
    channel_variance = np.zeros((N_CHANNELS, m))
    finger = np.zeros((2, m))
    finger_raw = np.zeros((2, m))
    slip = np.zeros(m, bool)
    if cols.size:
        flat = [np.asarray(x).reshape(x.shape[0], -1) for x in h]
        if cols.size * 4 > m:  # many: contiguous slices beat gathering
            cols = np.arange(m)
            hs = flat
        else:
            hs = [x[:, cols] for x in flat]
        total = hs[0].copy()
        for i in range(1, v):
            total = total + hs[i]
        mean = total / v
        sq = (hs[0] - mean) ** 2
        for i in range(1, v):
            sq = sq + (hs[i] - mean) ** 2
        cv = np.where(rising[:, cols] & both[cols], sq / v, 0.0)
        left = (cv[0] + cv[1] + cv[2]) / 3.0
        right = (cv[3] + cv[4] + cv[5]) / 3.0
        gate = (left >= params.alpha) & (right >= params.alpha)
        channel_variance[:, cols] = cv
        finger_raw[:, cols] = np.stack([left, right], axis=0)
        finger[:, cols] = np.where(gate, finger_raw[:, cols], 0.0)
        slip[cols] = np.maximum(finger[0, cols], finger[1, cols]) > params.threshold
    return (channel_variance.reshape(shape), finger.reshape((2,) + shape[1:]),
            slip.reshape(shape[1:]), min_diff, finger_raw.reshape((2,) + shape[1:]))


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


def _borderline(finger_raw: np.ndarray, min_diff: np.ndarray, params: SlipParams) -> np.ndarray:
    """Updates whose decision could flip inside the numerical guard bands, shape (m,).

    ``finger_raw`` (2, m) and ``min_diff`` (6, m).
    """
    border = np.abs(min_diff - params.delta).min(axis=0) <= params.guard_db
    cols = np.nonzero(finger_raw.any(axis=0))[0]  # group averages are 0 elsewhere
    if cols.size:
        g = params.guard_variance
        f = finger_raw[:, cols]
        near = ((np.abs(f - params.alpha) <= g * max(1.0, abs(params.alpha)))
                | (np.abs(f - params.threshold) <= g * max(1.0, abs(params.threshold))))
        border[cols] |= near.any(axis=0)
    if params.alpha <= 0.0 or params.threshold <= 0.0:  # 0 itself is near a threshold
        border |= _zero_near(finger_raw, params)
    return border


def _zero_near(finger_raw: np.ndarray, params: SlipParams) -> np.ndarray:
    """Guard for unusual thresholds at or below 0, where a zero average is borderline."""
    g = params.guard_variance
    near = ((np.abs(finger_raw - params.alpha) <= g * max(1.0, abs(params.alpha)))
            | (np.abs(finger_raw - params.threshold) <= g * max(1.0, abs(params.threshold))))
    return near.any(axis=0)


def _finish(psd: np.ndarray, first_update: int, params: SlipParams, prior: np.ndarray
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
        border[first:] = _borderline(fraw, md, params)
    return channel_variance, finger, slip, active, border


# ----------------------------------------------------------------------------- reference
def reference_psd_max_db(window: np.ndarray, fs: float, params: SlipParams) -> np.ndarray:
    """Straightforward PSD feature of one window with ``scipy.signal.welch``.

    Parameters
    ----------
    window : ndarray, shape (N, 6)
    fs : float
        Sampling rate [Hz].
    params : SlipParams

    Returns
    -------
    ndarray, shape (6,)
        ``max over f_min <= f <= f_max of 10*log10(P + eps)`` [dB re 1/Hz].
    """
    n = int(params.window)
    f, p = signal.welch(window, fs=fs, window='hann', nperseg=n, noverlap=0,
                        detrend='constant', return_onesided=True, scaling='density', axis=0)
    band = (f >= params.f_min) & (f <= params.f_max)
    return np.max(10.0 * np.log10(p[band] + params.eps), axis=0)


def slip_features_reference(frames: np.ndarray, fs: float = 2000.0,
                            params: SlipParams | None = None,
                            vectorized: bool = False) -> SlipFeatures:
    """The straightforward baseline: a Welch PSD of every window at every update.

    Same signature and output as :func:`slip_features`; used by the tests and benchmarks.

    Parameters
    ----------
    vectorized : bool
        False: one ``scipy.signal.welch`` call per window (the definition, and what guarded
        decisions use). True: welch over blocks of stacked windows (much faster; FFT
        batching may change the last bits, ~1e-14 dB).
    """
    params = params or SlipParams()
    params.validate(fs)
    x = _check_frames(frames)
    n, hop = int(params.window), int(params.hop)
    if x.shape[0] < n:
        return SlipFeatures()
    ends = np.arange(n - 1, x.shape[0], hop)
    psd = np.empty((ends.size, N_CHANNELS))
    if vectorized:
        windows = np.lib.stride_tricks.sliding_window_view(x, n, axis=0)[::hop]  # (m, 6, N)
        for b in range(0, ends.size, 2000):
            f, p = signal.welch(windows[b:b + 2000], fs=fs, window='hann', nperseg=n,
                                noverlap=0, detrend='constant', scaling='density', axis=-1)
            band = (f >= params.f_min) & (f <= params.f_max)
            psd[b:b + 2000] = np.max(10.0 * np.log10(p[..., band] + params.eps), axis=-1)
    else:
        for i, t in enumerate(ends):
            psd[i] = reference_psd_max_db(x[t - n + 1:t + 1], fs, params)
    cv, fv, sl, act, _ = _finish(np.ascontiguousarray(psd.T), 0, params,
                                 np.zeros((N_CHANNELS, 0)))
    return SlipFeatures(ends.astype(np.int64), psd, cv.T, fv.T, sl, act)


# ----------------------------------------------------------------------------- fast
class SlipDetector:
    """Streaming slip detector: feed frames in chunks of any size.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    params : SlipParams, optional
        Defaults to the paper's values.

    Notes
    -----
    Updates happen at absolute sample indices ``N - 1 + u * hop`` (u = 0, 1, ...) counted
    from the last :meth:`reset`. Results are bit-for-bit independent of the chunking.
    """

    def __init__(self, fs: float = 2000.0, params: SlipParams | None = None) -> None:
        self.params = params or SlipParams()
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
        x = _check_frames(frames)
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
        cv, fv, sl, act, border = _finish(psd, u0, self.params, prior)
        v = int(self.params.history)
        self._psd_history = np.concatenate([prior, psd[:, -(v - 1):]], axis=1)[:, -(v - 1):]
        psd, cv, fv = psd.T, cv.T, fv.T
        if border.any():
            self._redecide(border, buf, start, ends, cv, fv, sl)
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
        return 10.0 * np.log10(top + self.params.eps)

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

    def _store(self, buf: np.ndarray, start: int) -> None:
        """Keep the samples the next updates (and a guarded re-decision) may need."""
        n, hop, v = self._n, self._hop, int(self.params.history)
        next_t = n - 1 + self._updates * hop
        first_needed = max(0, next_t - hop - (v - 1) * hop - n + 1)
        drop = max(0, first_needed - start)
        self._buffer = buf[drop:].copy()
        self._buffer_start = start + drop


def slip_features(frames: np.ndarray, fs: float = 2000.0,
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
    x = _check_frames(frames)
    parts = []
    block = 65536  # bounds temporary memory; chunking does not change the result
    for i in range(0, x.shape[0], block):
        parts.append(detector.update(x[i:i + block]))
    return SlipFeatures.concatenate(parts)
