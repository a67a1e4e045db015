"""The FORTE perception pipeline as a pure, streaming library (no ROS).

Per chunk of raw frames (n, 6)::

    raw --median(11)--> filtered --(- baseline)--> tared  --> output.filtered
                          |  \\--> contact per finger (range over w samples > tau)
                          |  \\--> slip detector (PSD band max, moving variance)
                          \\--> force features (24, running means) - baseline --> SVR

Design choices (see docs/perception.md):

- Tare: the baseline is the mean of the *raw* samples over a quiet period of
  ``tare_duration`` seconds (as the calibration trainer does); filtered output is
  ``median(raw) - baseline``. A tare request collects the *next* quiet period; it is refused
  when a finger is in contact at the request and aborted if contact occurs during the
  collection. With ``auto_tare`` the pipeline tares itself from its first quiet period
  (the paper's warm-up) and retries after contact.
- Contact (paper): finger f is in contact at sample t when, for any of its 3 channels, the
  max minus min of the filtered signal over the last ``contact_window`` samples exceeds
  ``contact_threshold`` (0.5 % of the 2.0 full-scale span = 0.01). It flags a change, not a
  static load.
- Slip runs on the filtered signal before the tare subtraction (the PSD band of a
  constant offset is zero, so the tare does not change it, and a re-tare cannot cause a
  step). Force features are computed on the filtered signal and the baseline is subtracted
  from all 24 values (the mean of ``x - b`` is ``mean(x) - b``), so a re-tare applies at once.
- Force is estimated at absolute samples t with ``(t + 1) % (fs / force_rate) == 0``.
- Gaps (:meth:`mark_gap`, or rows with NaN/inf which are dropped and counted): no sample is
  invented. The median filter, the contact window and the slip detector restart after the
  gap (slip becomes inactive for N + (V - 1) * hop samples); the force means continue over
  the samples that exist; the baseline is kept. ``data_valid`` is false for the output of
  that chunk.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from .force import ForceFeatures, ForceModel
from .median import RunningMedian
from .slip import SlipDetector, SlipParams

__all__ = ['PerceptionOutput', 'PerceptionPipeline', 'PipelineConfig', 'TareResult',
           'contact_flags']

N_CHANNELS = 6
FINGERS = ((0, 1, 2), (3, 4, 5))


@dataclass(frozen=True)
class PipelineConfig:
    """Pipeline parameters.

    Attributes
    ----------
    fs : float
        Sampling rate [Hz].
    median_window : int
        Median filter length M [samples].
    contact_window : int
        Contact window w [samples].
    contact_threshold : float
        Contact threshold tau [normalised units] (0.01 = 0.5 % of the 2.0 span).
    tare_duration : float
        Quiet period averaged for a tare [s].
    auto_tare : bool
        Tare automatically from the first quiet period after (re)start.
    force_rate : float
        Force estimates per second [Hz]; fs / force_rate must be an integer.
    slip : SlipParams
    """

    fs: float = 2000.0
    median_window: int = 11
    contact_window: int = 200
    contact_threshold: float = 0.01
    tare_duration: float = 2.0
    auto_tare: bool = True
    force_rate: float = 100.0
    slip: SlipParams = field(default_factory=SlipParams)

    @property
    def force_step(self) -> int:
        """Samples between force estimates."""
        return int(round(self.fs / self.force_rate))

    @property
    def tare_samples(self) -> int:
        """Samples averaged for a tare."""
        return max(1, int(round(self.tare_duration * self.fs)))

    def validate(self) -> None:
        """Raise ValueError with a reason if a value is unusable."""
        if not (np.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f'fs must be positive, got {self.fs}')
        if int(self.median_window) != self.median_window or self.median_window < 1:
            raise ValueError(f'median_window must be an integer >= 1, got {self.median_window}')
        if int(self.contact_window) != self.contact_window or self.contact_window < 2:
            raise ValueError(f'contact_window must be an integer >= 2, got {self.contact_window}')
        if not (self.contact_threshold > 0 and np.isfinite(self.contact_threshold)):
            raise ValueError(f'contact_threshold must be > 0, got {self.contact_threshold}')
        if not (self.tare_duration > 0 and np.isfinite(self.tare_duration)):
            raise ValueError(f'tare_duration must be > 0 s, got {self.tare_duration}')
        if not (0 < self.force_rate <= self.fs):
            raise ValueError(f'force_rate must be in (0, fs], got {self.force_rate}')
        ratio = self.fs / self.force_rate
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f'fs / force_rate must be an integer, got {ratio}')
        self.slip.validate(self.fs)


@dataclass
class TareResult:
    """Outcome of a tare: success flag, reason, baseline (6,) [normalised]."""

    success: bool
    message: str
    baseline: np.ndarray


@dataclass
class PerceptionOutput:
    """State after a chunk; fields mirror forte_msgs/TactileState (plus bookkeeping).

    Attributes
    ----------
    sample_index : int
        Index of the latest input row since (re)start (-1 before any input).
    force : float
        Latest force estimate [N], NaN when none is possible.
    force_valid : bool
    contact : ndarray, shape (2,), bool
    slip : bool
        True if any detector update inside the chunk flagged slip.
    slip_active : bool
    psd_max_db : ndarray, shape (6,) [dB]
    finger_variance : ndarray, shape (2,) [dB^2]
    slip_updates : int
    filtered : ndarray, shape (6,)
        Latest median-filtered, tared sample (untared before the first tare).
    tared : bool
    data_valid : bool
        False if this chunk contained rejected rows or followed a gap.
    input_gaps : int
        Cumulative gaps (marked gaps and runs of rejected rows).
    rejected_samples : int
        Cumulative rows dropped because of NaN/inf.
    baseline : ndarray, shape (6,)
    force_sample_index : int
        Sample index of the latest force estimate (-1: none yet).
    slip_sample_index : int
        Sample index of the latest detector update (-1: none yet).
    """

    sample_index: int = -1
    force: float = float('nan')
    force_valid: bool = False
    contact: np.ndarray = field(default_factory=lambda: np.zeros(2, bool))
    slip: bool = False
    slip_active: bool = False
    psd_max_db: np.ndarray = field(default_factory=lambda: np.full(N_CHANNELS, np.nan))
    finger_variance: np.ndarray = field(default_factory=lambda: np.zeros(2))
    slip_updates: int = 0
    filtered: np.ndarray = field(default_factory=lambda: np.full(N_CHANNELS, np.nan))
    tared: bool = False
    data_valid: bool = True
    input_gaps: int = 0
    rejected_samples: int = 0
    baseline: np.ndarray = field(default_factory=lambda: np.zeros(N_CHANNELS))
    force_sample_index: int = -1
    slip_sample_index: int = -1


def contact_flags(filtered: np.ndarray, history: np.ndarray, window: int,
                  threshold: float) -> np.ndarray:
    """Per-sample contact flags of a chunk.

    Parameters
    ----------
    filtered : ndarray, shape (n, 6)
        New filtered samples.
    history : ndarray, shape (h, 6)
        Up to ``window - 1`` filtered samples just before them (since the last restart).
    window : int
        w [samples].
    threshold : float
        tau [normalised units].

    Returns
    -------
    ndarray, shape (n, 2), bool
        Finger f at row i: any channel of f has max - min over the last w samples (fewer
        at start-up) greater than tau.
    """
    n = filtered.shape[0]
    if n == 0:
        return np.zeros((0, 2), bool)
    ext = np.concatenate([history, filtered], axis=0)
    h = history.shape[0]
    # causal window [t - w + 1, t]: pad the front with the first sample (does not change
    # max - min of the start-up windows, which only contain real samples and this copy)
    pad = window - 1
    padded = np.concatenate([np.repeat(ext[:1], pad, axis=0), ext], axis=0)
    origin = (window - 1) // 2  # shift a centred filter so that it ends at t
    hi = maximum_filter1d(padded, window, axis=0, origin=origin)
    lo = minimum_filter1d(padded, window, axis=0, origin=origin)
    span = (hi - lo)[pad + h:]
    exceed = span > threshold
    return np.stack([exceed[:, list(f)].any(axis=1) for f in FINGERS], axis=1)


class PerceptionPipeline:
    """Streaming median -> tare -> contact, force, slip.

    Parameters
    ----------
    config : PipelineConfig, optional
    model : ForceModel, optional
        Without a model ``force`` is NaN and ``force_valid`` false.
    """

    def __init__(self, config: PipelineConfig | None = None,
                 model: ForceModel | None = None) -> None:
        self.config = config or PipelineConfig()
        self.config.validate()
        self.model = model
        self.reset()

    # -- control
    def reset(self) -> None:
        """Restart everything: filters, detector, means, baseline, counters."""
        c = self.config
        self._median = RunningMedian(c.median_window, N_CHANNELS)
        self._slip = SlipDetector(c.fs, c.slip)
        self._force_features = ForceFeatures(c.fs)
        self._contact_history = np.zeros((0, N_CHANNELS))
        self._baseline: np.ndarray | None = None
        self._baseline_tiled = np.zeros(4 * N_CHANNELS)
        self._samples = 0
        self._gaps = 0
        self._rejected = 0
        self._gap_pending = False
        self._tare_buffer: list[np.ndarray] | None = [] if c.auto_tare else None
        self._tare_target = c.tare_samples
        self._tare_auto = c.auto_tare
        self.tare_result: TareResult | None = None
        self._out = PerceptionOutput()

    def set_model(self, model: ForceModel | None) -> None:
        """Replace the force model (takes effect at the next force instant)."""
        self.model = model

    def reconfigure(self, **changes) -> None:
        """Change configuration values and restart (e.g. ``force_rate=200``)."""
        config = replace(self.config, **changes)
        config.validate()
        self.config = config
        self.reset()

    def mark_gap(self) -> None:
        """Declare that samples were lost before the next chunk (see module notes)."""
        self._gaps += 1
        self._restart_streams()
        self._gap_pending = True

    def _restart_streams(self) -> None:
        self._median.reset()
        self._slip.reset()
        self._contact_history = np.zeros((0, N_CHANNELS))
        self._out.slip_active = False

    @property
    def samples_seen(self) -> int:
        """Input rows consumed since (re)start, including rejected ones [count]."""
        return self._samples

    @property
    def gaps(self) -> int:
        """Gaps since (re)start: marked gaps and runs of rejected rows [count]."""
        return self._gaps

    @property
    def tare_pending(self) -> bool:
        """True while a tare is collecting its quiet period."""
        return self._tare_buffer is not None

    @property
    def baseline(self) -> np.ndarray | None:
        """Current baseline (6,) or None before the first tare."""
        return None if self._baseline is None else self._baseline.copy()

    def request_tare(self, duration: float | None = None) -> tuple[bool, str]:
        """Start a tare from the next quiet period of ``duration`` s (default: config).

        Returns (accepted, reason). Refused while any finger is in contact. The outcome is
        published in :attr:`tare_result` when the period is complete.
        """
        if duration is not None and not (np.isfinite(duration) and duration > 0):
            return False, f'tare duration must be > 0 s, got {duration}'
        if self._out.contact.any():
            return False, 'refused: a finger is in contact'
        self._tare_target = (self.config.tare_samples if not duration
                             else max(1, int(round(duration * self.config.fs))))
        self._tare_buffer = []
        self._tare_auto = False
        self.tare_result = None
        return True, f'collecting {self._tare_target} quiet samples'

    def set_baseline(self, baseline: np.ndarray) -> None:
        """Set the baseline (6,) directly (e.g. restored from a previous run)."""
        b = np.asarray(baseline, dtype=np.float64)
        if b.shape != (N_CHANNELS,) or not np.isfinite(b).all():
            raise ValueError(f'baseline must be 6 finite values, got {b}')
        self._set_baseline(b.copy())

    def _set_baseline(self, baseline: np.ndarray) -> None:
        self._baseline = baseline
        self._baseline_tiled = np.tile(baseline, 4)

    # -- processing
    def process(self, frames: np.ndarray) -> PerceptionOutput:
        """Consume raw frames (n, 6) and return the state after the last row.

        Rows containing NaN/inf are dropped and counted (``rejected_samples``); each run of
        such rows counts as a gap. Never raises on bad values; raises ValueError on a bad
        shape.
        """
        x = np.asarray(frames, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != N_CHANNELS:
            raise ValueError(f'frames must have shape (n, {N_CHANNELS}), got {x.shape}')
        out = self._out
        data_valid = not self._gap_pending
        self._gap_pending = False
        slip_any = False
        good = np.isfinite(x).all(axis=1)
        if good.all():
            slip_any = self._process_run(x)
        else:
            data_valid = False
            # split into runs of finite rows; each bad run is a gap
            edges = np.flatnonzero(np.diff(np.concatenate([[0], good.astype(np.int8), [0]])))
            starts, stops = edges[::2], edges[1::2]
            bad_rows = int((~good).sum())
            self._rejected += bad_rows
            pos = 0
            for a, b in zip(starts, stops, strict=True):
                if a > pos:  # bad rows before this run
                    self._samples += a - pos
                    self._gaps += 1
                    self._restart_streams()
                slip_any |= self._process_run(x[a:b])
                pos = b
            if pos < x.shape[0]:
                self._samples += x.shape[0] - pos
                self._gaps += 1
                self._restart_streams()
        out.slip = bool(slip_any)
        out.sample_index = self._samples - 1
        out.data_valid = data_valid
        out.input_gaps = self._gaps
        out.rejected_samples = self._rejected
        out.tared = self._baseline is not None
        out.baseline = (self._baseline.copy() if self._baseline is not None
                        else np.zeros(N_CHANNELS))
        return replace(out, contact=out.contact.copy(), psd_max_db=out.psd_max_db.copy(),
                       finger_variance=out.finger_variance.copy(),
                       filtered=out.filtered.copy())

    def _process_run(self, raw: np.ndarray) -> bool:
        """Process consecutive finite rows; returns True if a slip update fired."""
        c = self.config
        out = self._out
        n = raw.shape[0]
        if n == 0:
            return False
        first_index = self._samples
        self._samples += n
        filtered = self._median.update(raw)
        # contact: per sample while a tare collects, else at the last sample only
        keep = c.contact_window - 1
        ext = np.concatenate([self._contact_history, filtered])
        if self._tare_buffer is not None:
            flags = contact_flags(filtered, self._contact_history, c.contact_window,
                                  c.contact_threshold)
            out.contact = flags[-1].copy()
            self._collect_tare(raw, flags)
        else:
            window = ext[-c.contact_window:]
            exceed = (window.max(axis=0) - window.min(axis=0)) > c.contact_threshold
            out.contact = np.array([exceed[:3].any(), exceed[3:].any()])
        self._contact_history = ext[-keep:]
        # slip on the filtered, untared signal
        res = self._slip.update(filtered)
        slip_any = bool(res.slip.any())
        if len(res):
            out.psd_max_db = res.psd_max_db[-1].copy()
            out.finger_variance = res.finger_variance[-1].copy()
            out.slip_active = bool(res.active[-1])
            out.slip_sample_index = first_index + int(res.sample_index[-1]) - \
                (self._slip.samples_seen - n)
        elif self._slip.updates == 0:
            out.slip_active = False
        out.slip_updates += len(res)
        # force features at the force instants (absolute pipeline sample index)
        step = c.force_step
        offset = first_index - self._force_features.samples_seen
        idx, feats = self._force_features.update(filtered, every=step, offset=offset)
        if idx.size:
            out.force_sample_index = int(idx[-1] + offset)
            out.force, out.force_valid = self._estimate(feats[-1])
        base = self._baseline if self._baseline is not None else 0.0
        out.filtered = filtered[-1] - base
        return slip_any

    def _estimate(self, features: np.ndarray) -> tuple[float, bool]:
        if self.model is None or self._baseline is None:
            return float('nan'), False
        v = features - self._baseline_tiled
        return self.model.predict_one(v[None])

    def _collect_tare(self, raw: np.ndarray, flags: np.ndarray) -> None:
        if self._tare_buffer is None:
            return
        contact_rows = np.flatnonzero(flags.any(axis=1))
        if contact_rows.size:
            if self._tare_auto:  # warm-up: start again after the contact
                self._tare_buffer = [raw[contact_rows[-1] + 1:]]
                self._finish_tare_if_complete()
                return
            self.tare_result = TareResult(False, 'aborted: contact during the quiet period',
                                          np.full(N_CHANNELS, np.nan))
            self._tare_buffer = None
            return
        self._tare_buffer.append(raw)
        self._finish_tare_if_complete()

    def _finish_tare_if_complete(self) -> None:
        have = sum(b.shape[0] for b in self._tare_buffer)
        if have < self._tare_target:
            return
        samples = np.concatenate(self._tare_buffer)[:self._tare_target]
        self._set_baseline(samples.mean(axis=0))
        self.tare_result = TareResult(True, f'baseline from {samples.shape[0]} samples',
                                      self._baseline.copy())
        self._tare_buffer = None
        self._tare_auto = False
