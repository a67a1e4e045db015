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
- Gaps (:meth:`mark_gap`): no sample is invented. The median filter, the contact window and
  the slip detector restart after the gap (slip becomes inactive for N + (V - 1) * hop
  samples); the force means continue over the samples that exist; the baseline is kept.
  ``data_valid`` is false for the output of that chunk.
- Invalid values (NaN, inf, ``|x| > input_limit``) affect only their channel: the value is
  replaced internally by the channel's last valid value and every output of that channel
  whose window holds it is masked (:mod:`forte_perception.channel_health`,
  :mod:`forte_perception.slip.mask`): ``filtered`` and ``psd_max_db`` NaN, excluded from
  contact and from its finger's slip average, force invalid (NaN) while a force window holds
  it. Nothing restarts; ``data_valid`` is false for the chunk that contained it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from forte_perception.channel_health import HEALTH_MASKED, ChannelHealth
from forte_perception.force import ForceFeatures, ForceModel, window_lengths
from forte_perception.median import MEDIAN_WINDOW, RunningMedian
from forte_perception.slip.detector import SlipDetector, SlipParams
from forte_perception.slip.mask import SlipMask
from forte_perception.slip.sequential import SequentialDetector, SequentialParams
from forte_perception.slip.servo_gate import ServoGate
from forte_perception.slip.state import SlippingParams, SlippingState
from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS, SAMPLE_RATE

__all__ = ['PerceptionOutput', 'PerceptionPipeline', 'PipelineConfig', 'TareResult',
           'contact_exceed', 'contact_flags']



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
    slipping : SlippingParams
        The slipping state beside the slip event (:mod:`forte_perception.slip.state`).
    input_limit : float
        Largest valid ``|raw|`` [normalised units]; beyond it (or NaN/inf) a value is invalid.
    stuck_duration : float
        A channel exactly constant this long is reported stuck [s].
    """

    fs: float = SAMPLE_RATE
    median_window: int = MEDIAN_WINDOW
    contact_window: int = 200
    contact_threshold: float = 0.01
    tare_duration: float = 2.0
    auto_tare: bool = True
    force_rate: float = 100.0
    slip: SlipParams = field(default_factory=SlipParams)
    slipping: SlippingParams = field(default_factory=SlippingParams)
    input_limit: float = 1.0
    stuck_duration: float = 5.0

    @property
    def stuck_samples(self) -> int:
        """Samples of an exactly constant value reported as stuck."""
        return max(1, int(round(self.stuck_duration * self.fs)))

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
        if not (np.isfinite(self.input_limit) and self.input_limit > 0):
            raise ValueError(f'input_limit must be > 0, got {self.input_limit}')
        if not (np.isfinite(self.stuck_duration) and self.stuck_duration > 0):
            raise ValueError(f'stuck_duration must be > 0 s, got {self.stuck_duration}')
        self.slip.validate(self.fs)
        self.slipping.validate(self.fs, (self.slip.f_min, self.slip.f_max))


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
    slipping : bool
        Either finger is slipping after the chunk's last detector update.
    finger_slipping : ndarray, shape (2,), bool
        The slipping state per finger (left, right).
    slip_excess : ndarray, shape (2,) [dB]
        Per finger, mean short-window band power over the channels' quiet levels (NaN:
        no usable channel with a level).
    filtered : ndarray, shape (6,)
        Latest median-filtered, tared sample (untared before the first tare).
    tared : bool
    data_valid : bool
        False if this chunk contained an invalid value or followed a gap.
    input_gaps : int
        Cumulative marked gaps.
    rejected_samples : int
        Cumulative rows that contained at least one invalid value.
    channel_health : ndarray, shape (6,), uint8
        ``HEALTH_*`` bits (:mod:`forte_perception.channel_health`) of this chunk.
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
    slipping: bool = False
    finger_slipping: np.ndarray = field(default_factory=lambda: np.zeros(2, bool))
    slip_excess: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))
    filtered: np.ndarray = field(default_factory=lambda: np.full(N_CHANNELS, np.nan))
    tared: bool = False
    data_valid: bool = True
    input_gaps: int = 0
    rejected_samples: int = 0
    channel_health: np.ndarray = field(default_factory=lambda: np.zeros(N_CHANNELS, np.uint8))
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
    exceed = contact_exceed(filtered, history, window, threshold)
    return np.stack([exceed[:, list(f)].any(axis=1) for f in FINGER_CHANNELS], axis=1)


def contact_exceed(filtered: np.ndarray, history: np.ndarray, window: int,
                   threshold: float) -> np.ndarray:
    """Per-channel part of :func:`contact_flags`: (n, 6) bool, max - min over w > tau."""
    n = filtered.shape[0]
    if n == 0:
        return np.zeros((0, N_CHANNELS), bool)
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
    return span > threshold


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
        self._slip = SlipDetector(c.fs, c.slip.features)
        self._force_features = ForceFeatures(c.fs)
        self.health = ChannelHealth(c.input_limit, c.stuck_samples)
        self._slip_mask = SlipMask(c.fs, c.slip.features, c.median_window)
        # the slipping state: the sequential detector's own, or one beside the PSD rule
        self._sequential = (SequentialDetector(c.fs, c.slip.hop, (c.slip.f_min, c.slip.f_max),
                                               SequentialParams.from_slip(c.slip), c.slipping)
                            if c.slip.mode == 'sequential' else None)
        self._slipping = (SlippingState(c.fs, (c.slip.f_min, c.slip.f_max), c.slip.hop / c.fs,
                                        c.slipping) if self._sequential is None else None)
        self._servo_gate = ServoGate(int(round(self._sequential.params.servo_hold * c.fs))
                                     if self._sequential is not None else 0)
        self._median_reach = c.median_window
        self._contact_reach = c.contact_window + c.median_window - 1
        self._force_reach = max(window_lengths(c.fs)) + c.median_window - 1
        self._masked_reach = max(self._contact_reach, self._slip_mask.decision_reach)
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

    def servo_moved(self, sample: int | None = None, motion: float | None = None) -> None:
        """The servo command changed, taking effect at pipeline sample ``sample`` (default:
        the next one); the servo needs ``motion`` seconds to get there (the step over the
        profile velocity; None: unknown). The sequential mode vetoes its alarms for the
        motion plus ``servo_hold`` after it (:mod:`forte_perception.slip.servo_gate`); the
        other modes ignore it."""
        samples = None if motion is None else int(math.ceil(motion * self.config.fs))
        self._servo_gate.moved(self._samples if sample is None else sample, samples)

    def mark_gap(self) -> None:
        """Declare that samples were lost before the next chunk (see module notes)."""
        self._gaps += 1
        self._restart_streams()
        self._gap_pending = True

    def _restart_streams(self) -> None:
        self._median.reset()
        self._slip.reset()
        self._slip_mask.reset()
        if self._sequential is not None:
            self._sequential.reset()
        else:
            self._slipping.reset()
        self._contact_history = np.zeros((0, N_CHANNELS))
        self._out.slip_active = False

    @property
    def samples_seen(self) -> int:
        """Input rows consumed since (re)start, including rejected ones [count]."""
        return self._samples

    @property
    def gaps(self) -> int:
        """Marked gaps since (re)start [count]."""
        return self._gaps

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

    def _set_baseline(self, baseline: np.ndarray) -> None:
        self._baseline = baseline
        self._baseline_tiled = np.tile(baseline, 4)

    # -- processing
    def process(self, frames: np.ndarray) -> PerceptionOutput:
        """Consume raw frames (n, 6) and return the state after the last row.

        Invalid values (NaN, inf, ``|x| > input_limit``) are replaced internally and mask
        their channel's outputs (module notes); they are counted per channel in
        :attr:`health`. Never raises on bad values; raises ValueError on a bad shape.
        """
        x = np.asarray(frames, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != N_CHANNELS:
            raise ValueError(f'frames must have shape (n, {N_CHANNELS}), got {x.shape}')
        out = self._out
        data_valid = not self._gap_pending
        self._gap_pending = False
        slip_any = False
        flags = np.zeros(N_CHANNELS, np.uint8)
        if x.shape[0]:
            flags, substituted = self.health.check(x, self._samples)
            tare_raw = x
            if substituted is not None:
                data_valid = False
                invalid = self.health.chunk_invalid
                self._rejected += int(invalid.any(axis=1).sum())
                tare_raw = np.where(invalid, np.nan, x)
                x = substituted
            slip_any = self._process_run(x, tare_raw)
            if self.health.any_masked_since(self._samples - 1, self._masked_reach):
                masked = self.health.masked(self._samples - 1, self._masked_reach)
                flags[masked] |= HEALTH_MASKED
        out.slip = bool(slip_any)
        out.sample_index = self._samples - 1
        out.data_valid = data_valid
        out.input_gaps = self._gaps
        out.rejected_samples = self._rejected
        out.tared = self._baseline is not None
        out.baseline = (self._baseline.copy() if self._baseline is not None
                        else np.zeros(N_CHANNELS))
        # a snapshot with its own arrays (the constructor directly: cheaper than replace())
        return PerceptionOutput(**{
            **vars(out), 'contact': out.contact.copy(), 'psd_max_db': out.psd_max_db.copy(),
            'finger_variance': out.finger_variance.copy(), 'filtered': out.filtered.copy(),
            'finger_slipping': out.finger_slipping.copy(), 'slip_excess': out.slip_excess.copy(),
            'channel_health': flags})

    def _process_run(self, raw: np.ndarray, tare_raw: np.ndarray) -> bool:
        """Process consecutive rows (invalid values already substituted; ``tare_raw`` has
        them as NaN); returns True if a slip update fired."""
        c = self.config
        out = self._out
        health = self.health
        n = raw.shape[0]
        first_index = self._samples
        self._samples += n
        last = first_index + n - 1
        filtered = self._median.update(raw)
        # contact: per sample while a tare collects, else at the last sample only
        keep = c.contact_window - 1
        ext = np.concatenate([self._contact_history, filtered])
        contact_masks = health.any_masked_since(first_index, self._contact_reach)
        if self._tare_buffer is not None:
            exceed = contact_exceed(filtered, self._contact_history, c.contact_window,
                                    c.contact_threshold)
            if contact_masks:
                exceed &= ~health.masked(first_index + np.arange(n), self._contact_reach)
            flags = np.stack([exceed[:, list(f)].any(axis=1) for f in FINGER_CHANNELS], axis=1)
            out.contact = flags[-1].copy()
            self._collect_tare(tare_raw, flags)
        else:
            window = ext[-c.contact_window:]
            exceed = (window.max(axis=0) - window.min(axis=0)) > c.contact_threshold
            if contact_masks:
                exceed &= ~health.masked(last, self._contact_reach)
            out.contact = np.array([exceed[:3].any(), exceed[3:].any()])
        self._contact_history = ext[-keep:]
        slip_any = self._update_slip(filtered, first_index)  # on the untared signal
        # force features at the force instants (absolute pipeline sample index)
        step = c.force_step
        offset = first_index - self._force_features.samples_seen
        idx, feats = self._force_features.update(filtered, every=step, offset=offset)
        if idx.size:
            instant = int(idx[-1] + offset)
            out.force_sample_index = instant
            if health.any_masked_since(instant, self._force_reach) and \
                    health.masked(instant, self._force_reach).any():
                out.force, out.force_valid = float('nan'), False
            else:
                out.force, out.force_valid = self._estimate(feats[-1])
        base = self._baseline if self._baseline is not None else 0.0
        out.filtered = filtered[-1] - base
        if health.any_masked_since(last, self._median_reach):
            out.filtered[health.masked(last, self._median_reach)] = np.nan
        return slip_any

    def _update_slip(self, filtered: np.ndarray, first_index: int) -> bool:
        """Slip detector, masks and slipping state on a chunk of filtered samples starting at
        pipeline sample ``first_index``; updates the output's slip fields. True if an update
        of the chunk flagged slip."""
        out, health, n = self._out, self.health, filtered.shape[0]
        res = self._slip.update(filtered)
        self._slip_mask.record(filtered, res)
        shift = first_index - (self._slip.samples_seen - n)
        samples = res.sample_index + shift  # the updates' last samples, pipeline indices
        psd_ok = None
        if len(res) and health.any_masked_since(first_index, self._slip_mask.decision_reach):
            psd_ok = ~health.masked(samples, self._slip_mask.psd_reach)
        if self._sequential is not None:  # its events replace the PSD rule's flags
            stop, known = self._servo_gate.latest(samples)
            stop = np.where(stop >= 0, stop - shift, -1)  # in the detector's samples
            _, events, state = self._sequential.update(
                filtered, psd_ok, res.sample_index, self._servo_gate.gated(samples),
                (stop, known))
        else:
            power = self._slipping.feed(filtered, res.sample_index)
        if len(res):
            active = bool(res.active[-1])
            if psd_ok is not None:
                usable = ~health.masked(samples, self._slip_mask.decision_reach)
                self._slip_mask.apply(res, usable, psd_ok)
                active &= bool(usable[-1, :3].any() or usable[-1, 3:].any())
            if self._sequential is not None:
                res.slip[:] = events
            else:
                state = self._slipping.decide(power, res.slip, psd_ok)
            out.finger_slipping = state.slipping[-1].copy()
            out.slipping = bool(out.finger_slipping.any())
            out.slip_excess = state.excess[-1].copy()
            out.psd_max_db = res.psd_max_db[-1].copy()
            out.finger_variance = res.finger_variance[-1].copy()
            out.slip_active = active
            out.slip_sample_index = int(samples[-1])
        elif self._slip.updates == 0:  # restarted, no update yet: nothing is known to slip
            out.slip_active = out.slipping = False
            out.finger_slipping = np.zeros(2, bool)
            out.slip_excess = np.full(2, np.nan)
        out.slip_updates += len(res)
        return bool(res.slip.any())

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
        valid = ~np.isnan(samples)  # invalid raw values arrive here as NaN
        if valid.all():
            self._set_baseline(samples.mean(axis=0))
        else:
            counts = valid.sum(axis=0)
            if (2 * counts < samples.shape[0]).any():  # a channel valid less than half the time
                bad = [int(ch) for ch in np.flatnonzero(2 * counts < samples.shape[0])]
                if self._tare_auto:
                    self._tare_buffer = []
                    return
                self.tare_result = TareResult(
                    False, f'aborted: channels {bad} invalid in more than half of the quiet '
                    'period', np.full(N_CHANNELS, np.nan))
                self._tare_buffer = None
                return
            self._set_baseline(np.where(valid, samples, 0.0).sum(axis=0) / counts)
        self.tare_result = TareResult(True, f'baseline from {samples.shape[0]} samples',
                                      self._baseline.copy())
        self._tare_buffer = None
        self._tare_auto = False
