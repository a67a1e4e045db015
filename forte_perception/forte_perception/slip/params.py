"""Parameters, per-update results and input check of the slip detector.

The algorithm and its fast implementation are described in :mod:`forte_perception.slip.detector`;
this module holds what every part of it shares: :class:`SlipParams` (the paper's table and
the numerical knobs), :class:`SlipFeatures` (the output of every update), the FFT bins of
the band and the check of the input frames.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from forte_ros.contract import N_CHANNELS, QUANTUM, SAMPLE_RATE

__all__ = ['MODES', 'RECOMMENDED_MODE', 'NonFiniteInputError',
           'SlipFeatures', 'SlipParams', 'bins_in_band', 'check_frames']

#: Detector modes (:attr:`SlipParams.mode`).
MODES = ('paper', 'robust', 'sequential')
#: The mode that wins on held-out evidence (issue 38, docs/perception.md: the held-out part
#: of the slip set, the wirings, a held-out closed-loop seed): the default of
#: :attr:`SlipParams.mode`, hence of the perception node, the closed loop and every tool;
#: ``mode='paper'`` selects the paper's algorithm bit for bit.
RECOMMENDED_MODE = 'sequential'


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
    mode : str
        ``'sequential'`` (default, :data:`RECOMMENDED_MODE`): slip events from a CUSUM on the
        fast band power per finger (:mod:`forte_perception.slip.sequential`); the PSD
        features it reports are the robust mode's. ``'robust'``: the issue-14 mode
        (:mod:`forte_perception.slip.robust`), which replaces ``eps`` by a quantisation
        floor, adds a per-finger rule and vetoes level shifts. ``'paper'``: the paper's
        algorithm bit for bit; the fields below are then ignored.
    quantum : float
        Robust mode: the ADC step q [normalised units] (``forte_ros.contract.QUANTUM``).
    floor_factor : float
        Robust mode: PSD floor = ``floor_factor * q**2 / (6 fs)`` [1] (4).
    single_threshold : float
        Robust mode: a finger may flag alone when its group average exceeds this [dB^2] (3).
    single_min_rising : int
        Robust mode: ... and at least this many of its channels rise monotonically with a
        moving variance of at least ``alpha`` each (2).
    veto_level : int
        Robust mode: length of the running mean that gives a channel's level [samples] (200).
    veto_span : int
        Robust mode: the level shift is taken over this many samples [samples] (400).
    veto_ratio : float
        Robust mode: a flag is vetoed when, on every finger, the largest level shift exceeds
        ``veto_ratio`` times the largest peak-to-peak 10-50 Hz amplitude implied by the
        band's PSD maximum [1] (0.33).
    sequential_drift : float
        Sequential mode: the CUSUM's drift k, half the rise of the fast band power it is
        tuned to [dB] (8; :mod:`forte_perception.slip.sequential`).
    sequential_threshold : float
        Sequential mode: the CUSUM's alarm threshold h [dB s] (0.05): higher, fewer false
        alarms and later detections.
    sequential_single_offset : float
        Sequential mode: a finger's input is the larger of its channels' mean excess and its
        largest channel's excess less this [dB] (4; inf: the mean alone;
        :func:`forte_perception.slip.excess.pooled_excess`).
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
    mode: str = RECOMMENDED_MODE
    quantum: float = QUANTUM
    floor_factor: float = 4.0
    single_threshold: float = 3.0
    single_min_rising: int = 2
    veto_level: int = 200
    veto_span: int = 400
    veto_ratio: float = 0.33
    sequential_drift: float = 8.0
    sequential_threshold: float = 0.05
    sequential_single_offset: float = 4.0

    @property
    def robust(self) -> bool:
        """True in the robust mode."""
        return self.mode == 'robust'

    @property
    def features(self) -> SlipParams:
        """The parameters of the PSD features and flags the detector computes: these, or
        the robust mode's for the ``'sequential'`` mode, whose slip events come from
        :mod:`forte_perception.slip.sequential` instead."""
        return replace(self, mode='robust') if self.mode == 'sequential' else self

    def psd_floor(self, fs: float) -> float:
        """What is added to the PSD before the logarithm [PSD units]: ``eps`` in the paper
        mode, ``floor_factor * quantum**2 / (6 fs)`` in the robust mode."""
        if not self.robust:
            return self.eps
        return float(self.floor_factor * self.quantum ** 2 / (6.0 * fs))

    def validate(self, fs: float = SAMPLE_RATE) -> None:
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
        if self.mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, got {self.mode!r}')
        if self.mode != 'paper':  # the sequential mode computes the robust mode's features
            self._validate_robust()
        if self.mode == 'sequential':
            for name in ('sequential_drift', 'sequential_threshold'):
                value = getattr(self, name)
                if not (np.isfinite(value) and value > 0):
                    raise ValueError(f'{name} must be positive and finite, got {value}')
            if not self.sequential_single_offset >= 0:  # inf allowed (off), NaN refused
                raise ValueError('sequential_single_offset must be >= 0 dB, got '
                                 f'{self.sequential_single_offset}')

    def _validate_robust(self) -> None:
        for name in ('quantum', 'floor_factor', 'veto_ratio'):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f'{name} must be positive and finite, got {value}')
        if not (np.isfinite(self.single_threshold) and self.single_threshold >= self.threshold):
            raise ValueError(f'single_threshold must be >= threshold, got {self.single_threshold}')
        if int(self.single_min_rising) != self.single_min_rising or not (
                1 <= self.single_min_rising <= 3):
            raise ValueError(f'single_min_rising must be 1, 2 or 3, got {self.single_min_rising}')
        for name in ('veto_level', 'veto_span'):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f'{name} must be an integer >= 1, got {value}')


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


def check_frames(frames: np.ndarray) -> np.ndarray:
    """``frames`` as a float64 array (n, 6); ValueError on another shape,
    :class:`NonFiniteInputError` if it holds NaN or inf."""
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

