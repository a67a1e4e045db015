"""Grip force estimation (FORTE paper, section "Force Estimation Algorithm").

Feature vector
--------------
``v(t) = S(t) ⊕ mean_2.5s(t) ⊕ mean_5s(t) ⊕ mean_10s(t)`` (24 values), in this order::

    v[0:6]   = S(t)                latest (filtered, tared) frame, channels 0..5
    v[6:12]  = mean of the last 2.5 s (5000 samples at 2 kHz), channels 0..5
    v[12:18] = mean of the last 5 s   (10000 samples)
    v[18:24] = mean of the last 10 s  (20000 samples)

Window lengths are ``round(seconds * fs)`` samples and include sample t. Until a window is
full (the first 2.5 / 5 / 10 s after a reset) its mean is the mean of the samples available
so far (since the reset, including t).

The means are running sums, O(1) per sample: ``S += x[t] - x[t - L]``. Every L samples (at
fixed absolute indices) the sum is recomputed directly from the window, which bounds the
rounding error; results equal ``numpy.mean`` of the window to ~1e-15 relative and are
bit-for-bit independent of the chunking.

Model
-----
:class:`ForceModel`: StandardScaler + RBF-kernel epsilon-SVR (scikit-learn) for training;
prediction with a numpy implementation of the same function
``f(v) = sum_i dual_i exp(-gamma |z - sv_i|^2) + intercept``, ``z = (v - mean) / scale``.
Saved as ``.npz`` without pickle (arrays + a JSON header with format version, feature
definition, units, training metadata and the training input range). Inputs outside the
training range (by ``range_margin`` of the range) or non-finite are flagged invalid; outputs
are clipped to ``force_range`` [N].
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forte_ros.contract import CHANNEL_NAMES, N_CHANNELS, SAMPLE_RATE

__all__ = [
    'FEATURE_NAMES',
    'FORMAT_NAME',
    'FORMAT_VERSION',
    'ForceFeatures',
    'ForceModel',
    'force_features',
    'force_features_reference',
    'window_lengths',
]

WINDOW_SECONDS = (2.5, 5.0, 10.0)
FEATURE_NAMES = tuple(
    [f'{c}_latest' for c in CHANNEL_NAMES]
    + [f'{c}_mean_{s}s' for s in WINDOW_SECONDS for c in CHANNEL_NAMES])
FORMAT_NAME = 'forte_force_model'
FORMAT_VERSION = 1


def window_lengths(fs: float = SAMPLE_RATE) -> tuple[int, int, int]:
    """History window lengths [samples] for 2.5, 5 and 10 s at rate ``fs`` [Hz]."""
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f'fs must be positive, got {fs}')
    lengths = tuple(max(1, int(round(s * fs))) for s in WINDOW_SECONDS)
    return lengths  # type: ignore[return-value]


class ForceFeatures:
    """Streaming 24-value force features, O(1) per sample.

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    """

    def __init__(self, fs: float = SAMPLE_RATE) -> None:
        self.fs = float(fs)
        self.lengths = window_lengths(fs)
        self._keep = max(self.lengths)
        self.reset()

    def reset(self) -> None:
        """Forget every sample (the means restart from the next sample)."""
        self._ring = np.zeros((self._keep, N_CHANNELS))  # sample t at row t % keep
        self._last = np.full(N_CHANNELS, np.nan)
        self._samples = 0
        self._sums = [np.zeros(N_CHANNELS) for _ in self.lengths]

    @property
    def samples_seen(self) -> int:
        """Samples consumed since the last reset [count]."""
        return self._samples

    def latest(self) -> np.ndarray:
        """Feature vector (24,) at the latest sample; NaN if no sample yet."""
        if self._samples == 0:
            return np.full(4 * N_CHANNELS, np.nan)
        out = [self._last]
        for length, total in zip(self.lengths, self._sums, strict=True):
            out.append(total / min(length, self._samples))
        return np.concatenate(out)

    def _past(self, a: int, b: int) -> np.ndarray:
        """Stored samples with absolute indices a .. b-1 (all < samples_seen), (b - a, 6)."""
        if b <= a:
            return np.zeros((0, N_CHANNELS))
        i, j = a % self._keep, (b - 1) % self._keep + 1
        if i < j:
            return self._ring[i:j]
        return np.concatenate([self._ring[i:], self._ring[:j]], axis=0)

    def update(self, frames: np.ndarray, every: int = 1, offset: int = 0
               ) -> tuple[np.ndarray, np.ndarray]:
        """Consume frames (n, 6); return the features of the rows selected by ``every``.

        Parameters
        ----------
        frames : ndarray, shape (n, 6)
        every : int
            Return features only at sample indices ``t`` (counted since reset) with
            ``(t + offset + 1) % every == 0`` (1: every sample). The state advances over all
            samples regardless.
        offset : int
            Added to the sample index for the selection above.

        Returns
        -------
        index : ndarray, shape (r,), int64
            Absolute sample indices of the returned rows.
        features : ndarray, shape (r, 24)

        Notes
        -----
        Work per call is O(n) plus one window sum per window length crossed (O(1) per
        sample amortised); past samples live in a ring buffer of 10 s.
        """
        x = np.asarray(frames, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != N_CHANNELS:
            raise ValueError(f'frames must have shape (n, {N_CHANNELS}), got {x.shape}')
        if not np.isfinite(np.add.reduce(x, axis=None)) and not np.isfinite(x).all():
            raise ValueError('non-finite input (NaN or inf); chunk rejected, state unchanged')
        n = x.shape[0]
        t0 = self._samples
        abs_idx = t0 + np.arange(n)
        sel = np.nonzero((abs_idx + offset + 1) % int(every) == 0)[0]
        feats = np.empty((sel.size, 4 * N_CHANNELS))
        feats[:, :N_CHANNELS] = x[sel]
        for w, length in enumerate(self.lengths):
            total = self._running(x, t0, length, w)  # (n, 6) window sums
            count = np.minimum(abs_idx[sel] + 1, length)[:, None]
            feats[:, N_CHANNELS * (w + 1):N_CHANNELS * (w + 2)] = total[sel] / count
        # store the new samples in the ring
        if n:
            keep = self._keep
            tail = x[-keep:]
            start = t0 + n - tail.shape[0]
            i = start % keep
            first = min(tail.shape[0], keep - i)
            self._ring[i:i + first] = tail[:first]
            self._ring[:tail.shape[0] - first] = tail[first:]
            self._last = x[-1].copy()
        self._samples += n
        return abs_idx[sel].astype(np.int64), feats

    def _running(self, x: np.ndarray, t0: int, length: int, which: int) -> np.ndarray:
        """Window sums at every new sample; resynchronised at absolute multiples of length."""
        n = x.shape[0]
        abs_idx = t0 + np.arange(n)
        # increment at sample t: x[t] - x[t - length] (samples before the reset are absent)
        inc = x.copy()
        old_lo = max(0, t0 - length)  # absolute range of the old samples, before the chunk
        old_hi = min(t0, t0 + n - length)
        if old_hi > old_lo:
            first = old_lo + length - t0  # chunk row whose old sample is old_lo
            inc[first:first + old_hi - old_lo] -= self._past(old_lo, old_hi)
        if n > length:  # old samples inside the chunk itself
            inc[length:] -= x[:n - length]
        out = np.empty((n, N_CHANNELS))
        cur = self._sums[which]
        resync = np.nonzero(abs_idx % length == length - 1)[0]
        pos = 0
        for nxt in [*resync.tolist(), n]:
            if nxt > pos:
                seg = np.concatenate([cur[None], inc[pos:nxt]], axis=0)
                out[pos:nxt] = np.cumsum(seg, axis=0)[1:]
                cur = out[nxt - 1]
            if nxt < n:
                t = t0 + nxt  # window t - length + 1 .. t, fully present
                lo = t - length + 1
                window = np.concatenate([self._past(lo, min(t0, t + 1)),
                                         x[max(0, lo - t0):nxt + 1]], axis=0)
                out[nxt] = _window_sum(window)
                cur = out[nxt]
                pos = nxt + 1
        self._sums[which] = cur.copy()
        return out


def _window_sum(window: np.ndarray) -> np.ndarray:
    """Column sums of a window (L, 6) with a fixed reduction (pairwise, contiguous copy)."""
    return np.ascontiguousarray(window.T).sum(axis=1)


def force_features(frames: np.ndarray, fs: float = SAMPLE_RATE) -> np.ndarray:
    """Force features at every sample of a recording.

    Parameters
    ----------
    frames : ndarray, shape (n, 6)
        Filtered, tared samples.
    fs : float
        Sampling rate [Hz].

    Returns
    -------
    ndarray, shape (n, 24)
        Rows as described in the module docstring; equal to :class:`ForceFeatures` fed in
        any chunks.
    """
    x = np.asarray(frames, dtype=np.float64)
    feat = ForceFeatures(fs)
    parts = [feat.update(x[i:i + 65536])[1] for i in range(0, x.shape[0], 65536)]
    return np.concatenate(parts, axis=0) if parts else np.zeros((0, 4 * N_CHANNELS))


def force_features_reference(frames: np.ndarray, fs: float = SAMPLE_RATE,
                             index: np.ndarray | None = None) -> np.ndarray:
    """Naive features with ``numpy.mean`` over each window (for tests and benchmarks).

    Parameters
    ----------
    frames : ndarray, shape (n, 6)
    fs : float
    index : ndarray of int, optional
        Sample indices to evaluate (default: all).

    Returns
    -------
    ndarray, shape (len(index), 24)
    """
    x = np.asarray(frames, dtype=np.float64)
    idx = np.arange(x.shape[0]) if index is None else np.asarray(index)
    out = np.empty((idx.size, 4 * N_CHANNELS))
    for r, t in enumerate(idx):
        out[r, :N_CHANNELS] = x[t]
        for w, length in enumerate(window_lengths(fs)):
            out[r, N_CHANNELS * (w + 1):N_CHANNELS * (w + 2)] = \
                x[max(0, t - length + 1):t + 1].mean(axis=0)
    return out


# ----------------------------------------------------------------------------- model
@dataclass
class ForceModel:
    """RBF-kernel SVR force model with its scaler, validity range and metadata.

    Attributes
    ----------
    scaler_mean, scaler_scale : ndarray, shape (d,)
        StandardScaler parameters.
    support_vectors : ndarray, shape (s, d)
        Support vectors in scaled units.
    dual_coef : ndarray, shape (s,)
    intercept : float
    gamma : float
        RBF parameter [1 / scaled unit^2].
    feature_min, feature_max : ndarray, shape (d,)
        Training input range (unscaled feature units).
    force_range : (float, float)
        Output clip range [N].
    range_margin : float
        Inputs may exceed the training range by this fraction of its width.
    features : str
        'history' (24 values) or 'latest' (the 6 latest values only, the paper's baseline).
    metadata : dict
        Free-form training metadata (JSON-serialisable).
    """

    scaler_mean: np.ndarray
    scaler_scale: np.ndarray
    support_vectors: np.ndarray
    dual_coef: np.ndarray
    intercept: float
    gamma: float
    feature_min: np.ndarray
    feature_max: np.ndarray
    force_range: tuple[float, float] = (0.0, 10.0)
    range_margin: float = 0.05
    features: str = 'history'
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._cache()

    def _cache(self) -> None:
        """Derived arrays used by every prediction."""
        self.support_vectors = np.ascontiguousarray(self.support_vectors, np.float64)
        self._sv_sq = np.einsum('ij,ij->i', self.support_vectors, self.support_vectors)
        width = self.feature_max - self.feature_min
        self._valid_lo = self.feature_min - self.range_margin * width
        self._valid_hi = self.feature_max + self.range_margin * width

    @property
    def n_features(self) -> int:
        """Input dimension d (24 for 'history', 6 for 'latest')."""
        return int(self.scaler_mean.shape[0])

    # -- training
    @classmethod
    def fit(cls, features: np.ndarray, force: np.ndarray, *, C: float = 10.0,
            epsilon: float = 0.05, gamma: float | str = 'scale',
            force_range: tuple[float, float] | None = None, range_margin: float = 0.05,
            kind: str = 'history', metadata: dict | None = None) -> ForceModel:
        """Train StandardScaler + SVR(kernel='rbf') with scikit-learn.

        Parameters
        ----------
        features : ndarray, shape (n, 24) or (n, 6)
        force : ndarray, shape (n,)
            Target force [N].
        C, epsilon, gamma
            SVR hyper-parameters (epsilon in N).
        force_range : (float, float), optional
            Output clip range [N]; default: 0 (a grip force is never negative) to the largest
            training force.
        range_margin : float
            Allowed excursion beyond the training input range, fraction of its width.
        kind : {'history', 'latest'}
        metadata : dict, optional
        """
        from sklearn.preprocessing import StandardScaler
        from sklearn.svm import SVR

        x = np.asarray(features, dtype=np.float64)
        y = np.asarray(force, dtype=np.float64)
        if x.ndim != 2 or x.shape[0] != y.shape[0]:
            raise ValueError(f'features (n, d) and force (n,) mismatch: {x.shape}, {y.shape}')
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            raise ValueError('training data contains NaN or inf')
        if kind not in ('history', 'latest'):
            raise ValueError(f"kind must be 'history' or 'latest', got {kind!r}")
        expected = 4 * N_CHANNELS if kind == 'history' else N_CHANNELS
        if x.shape[1] != expected:
            raise ValueError(f'{kind} model needs {expected} features, got {x.shape[1]}')
        scaler = StandardScaler().fit(x)
        z = scaler.transform(x)
        t = time.perf_counter()
        svr = SVR(kernel='rbf', C=C, epsilon=epsilon, gamma=gamma).fit(z, y)
        fit_seconds = time.perf_counter() - t
        meta = dict(metadata or {})
        meta.update({
            'n_train': int(x.shape[0]), 'C': float(C), 'epsilon': float(epsilon),
            'gamma_setting': str(gamma), 'fit_seconds': round(fit_seconds, 3),
            'train_force_min': float(y.min()), 'train_force_max': float(y.max()),
            'sklearn_version': _sklearn_version(),
        })
        frange = force_range if force_range is not None else (0.0, float(y.max()))
        return cls(
            scaler_mean=scaler.mean_.copy(), scaler_scale=scaler.scale_.copy(),
            support_vectors=np.ascontiguousarray(svr.support_vectors_),
            dual_coef=svr.dual_coef_[0].copy(), intercept=float(svr.intercept_[0]),
            gamma=float(svr._gamma), feature_min=x.min(axis=0), feature_max=x.max(axis=0),
            force_range=(float(frange[0]), float(frange[1])), range_margin=float(range_margin),
            features=kind, metadata=meta)

    # -- prediction
    def select(self, features: np.ndarray) -> np.ndarray:
        """Columns of a (n, 24) feature array this model uses ((n, 24) or (n, 6))."""
        x = np.atleast_2d(np.asarray(features, dtype=np.float64))
        if x.shape[1] == self.n_features:
            return x
        if x.shape[1] == 4 * N_CHANNELS and self.features == 'latest':
            return x[:, :N_CHANNELS]
        raise ValueError(f'model needs {self.n_features} features, got {x.shape[1]}')

    def decision(self, features: np.ndarray) -> np.ndarray:
        """Raw SVR output (unclipped) for finite inputs, shape (n,) [N]."""
        x = self.select(features)
        z = (x - self.scaler_mean) / self.scaler_scale
        sv = self.support_vectors
        out = np.empty(z.shape[0])
        sv_sq = self._sv_sq
        block = 4096
        for i in range(0, z.shape[0], block):
            zb = z[i:i + block]
            d2 = np.einsum('ij,ij->i', zb, zb)[:, None] + sv_sq[None, :] - 2.0 * (zb @ sv.T)
            np.maximum(d2, 0.0, out=d2)
            out[i:i + block] = np.exp(-self.gamma * d2) @ self.dual_coef + self.intercept
        return out

    def valid(self, features: np.ndarray) -> np.ndarray:
        """True where every feature is finite and inside the (widened) training range, (n,)."""
        x = self.select(features)
        with np.errstate(invalid='ignore'):
            inside = (x >= self._valid_lo) & (x <= self._valid_hi)
        return np.isfinite(x).all(axis=1) & inside.all(axis=1)

    def predict(self, features: np.ndarray, return_valid: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Force [N] clipped to ``force_range``; NaN where the input is not finite.

        Parameters
        ----------
        features : ndarray, shape (n, d) or (d,)
        return_valid : bool
            Also return the validity flags (n,) (see :meth:`valid`).
        """
        x = self.select(features)
        finite = np.isfinite(x).all(axis=1)
        force = np.full(x.shape[0], np.nan)
        if finite.any():
            force[finite] = np.clip(self.decision(x[finite]), *self.force_range)
        if return_valid:
            return force, self.valid(x)
        return force

    def predict_one(self, features: np.ndarray) -> tuple[float, bool]:
        """Force [N] and validity of one feature vector (24,) (or (6,)); fast path.

        The formula of :meth:`decision` evaluated for one row (a matrix-vector product
        instead of the blocked matrix product): it agrees with :meth:`predict` within about
        1e-13 N, not bit for bit.
        """
        x = self.select(features)[0]
        if not math.isfinite(float(np.add.reduce(x))) and not np.isfinite(x).all():
            return float('nan'), False
        # decision() on one row, element for element: ||z||^2 + ||sv||^2 - 2 sv.z
        z = (x - self.scaler_mean) / self.scaler_scale
        d2 = np.dot(z, z) + self._sv_sq
        d2 -= 2.0 * (self.support_vectors @ z)
        np.maximum(d2, 0.0, out=d2)
        d2 *= -self.gamma
        np.exp(d2, out=d2)
        value = float(d2 @ self.dual_coef) + self.intercept
        low, high = self.force_range
        valid = bool(((x >= self._valid_lo) & (x <= self._valid_hi)).all())
        return min(max(value, low), high), valid

    # -- persistence
    def save(self, path: str | Path) -> None:
        """Write a versioned ``.npz`` (no pickle): arrays plus a JSON header."""
        header = {
            'format': FORMAT_NAME, 'version': FORMAT_VERSION,
            'features': self.features,
            'feature_names': list(FEATURE_NAMES if self.features == 'history'
                                  else FEATURE_NAMES[:N_CHANNELS]),
            'feature_definition': (
                'v = S(t) + mean_2.5s + mean_5s + mean_10s per channel (channel order '
                'left_distal..right_root); S = median(11)-filtered, tared sensor value; '
                'means over the samples available since reset until the window is full'
                if self.features == 'history' else 'v = S(t), latest filtered tared frame'),
            'feature_units': 'normalised transducer reading (-1..1 span, +1 = +1 inH2O)',
            'output_units': 'N',
            'kernel': 'rbf', 'gamma': self.gamma, 'intercept': self.intercept,
            'force_range': list(self.force_range), 'range_margin': self.range_margin,
            'metadata': self.metadata,
        }
        with open(path, 'wb') as f:
            np.savez(f, header=np.array(json.dumps(header)),
                     scaler_mean=self.scaler_mean, scaler_scale=self.scaler_scale,
                     support_vectors=self.support_vectors, dual_coef=self.dual_coef,
                     feature_min=self.feature_min, feature_max=self.feature_max)

    @classmethod
    def load(cls, path: str | Path) -> ForceModel:
        """Read a model written by :meth:`save`; refuses unknown formats and versions."""
        with np.load(path, allow_pickle=False) as data:
            try:
                header = json.loads(str(data['header']))
            except (KeyError, ValueError) as exc:
                raise ValueError(f'{path}: not a FORTE force model ({exc})') from exc
            if header.get('format') != FORMAT_NAME:
                raise ValueError(f'{path}: format {header.get("format")!r} is not {FORMAT_NAME}')
            if header.get('version') != FORMAT_VERSION:
                raise ValueError(f'{path}: version {header.get("version")} unsupported '
                                 f'(this code reads {FORMAT_VERSION})')
            model = cls(
                scaler_mean=data['scaler_mean'].astype(np.float64),
                scaler_scale=data['scaler_scale'].astype(np.float64),
                support_vectors=np.ascontiguousarray(data['support_vectors'], np.float64),
                dual_coef=data['dual_coef'].astype(np.float64),
                intercept=float(header['intercept']), gamma=float(header['gamma']),
                feature_min=data['feature_min'].astype(np.float64),
                feature_max=data['feature_max'].astype(np.float64),
                force_range=(float(header['force_range'][0]), float(header['force_range'][1])),
                range_margin=float(header['range_margin']), features=header['features'],
                metadata=header.get('metadata', {}))
        d = model.n_features
        if (model.scaler_scale.shape != (d,) or model.support_vectors.shape[1:] != (d,)
                or model.dual_coef.shape != (model.support_vectors.shape[0],)):
            raise ValueError(f'{path}: inconsistent array shapes')
        return model

    def reduced(self, n_support: int) -> ForceModel:
        """Approximation keeping the ``n_support`` support vectors of largest |dual_coef|.

        The dual coefficients of the kept vectors are refitted by least squares on the
        kernel matrix of all support vectors, so the approximation follows the full model.
        """
        n_support = int(n_support)
        if n_support >= self.support_vectors.shape[0]:
            return self
        order = np.argsort(-np.abs(self.dual_coef))[:n_support]
        keep = self.support_vectors[order]
        full = self._kernel(self.support_vectors, self.support_vectors) @ self.dual_coef
        k_sub = self._kernel(self.support_vectors, keep)
        coef, *_ = np.linalg.lstsq(k_sub, full, rcond=None)
        meta = dict(self.metadata, reduced_from=int(self.support_vectors.shape[0]))
        return ForceModel(self.scaler_mean, self.scaler_scale, keep, coef, self.intercept,
                          self.gamma, self.feature_min, self.feature_max, self.force_range,
                          self.range_margin, self.features, meta)

    def _kernel(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d2 = (np.einsum('ij,ij->i', a, a)[:, None] + np.einsum('ij,ij->i', b, b)[None, :]
              - 2.0 * (a @ b.T))
        return np.exp(-self.gamma * np.maximum(d2, 0.0))


def _sklearn_version() -> str:
    import sklearn
    return str(sklearn.__version__)
