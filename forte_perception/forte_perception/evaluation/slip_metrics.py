"""The slip metrics: one implementation for every evaluation of the slip detector.

Three evaluations use it: the closed-loop grasp benchmark (:mod:`forte_evaluation.evaluate`,
:mod:`forte_evaluation.metrics`: trial-wise scores and latencies of the FORTE trials), labelled
recordings (:func:`forte_perception.evaluation.labelled_recordings.evaluate_slip`,
``forte_evaluate_slip``) and the labelled slip set of issue 14
(:mod:`forte_perception.evaluation.benchmark`, ``python -m forte_evaluation.slip_benchmark``:
event-level scores per scene, :func:`scene_outcome` and :func:`summarise`).

**Empty cases.** A ratio whose denominator is zero is undefined and is NaN, never an
invented 0.0 or 1.0: precision with nothing flagged, recall with nothing to find, F1 when
precision or recall is undefined, accuracy without trials, a false-flag rate without
holding time, a latency percentile without latencies. F1 (:func:`f1_score`) is undefined
exactly when the recall is (nothing to find); with something to find and nothing found it
is 0.0. Tables print NaN as ``n/a`` (:func:`format_value`);
JSON keeps it (``NaN`` in ``forte_evaluation.evaluate``'s and ``forte_evaluate_slip``'s
files, ``null`` in ``forte_evaluation.slip_benchmark``'s).

**Onset matching** (:func:`match_onsets`). A true slip onset is caught by the first flag at
or after it when that flag comes no later than ``onset + max_latency`` (end included) and,
with ``before_next_onset``, strictly before the next onset; its latency is that flag minus
the onset. Each caller keeps the rule its published numbers were made with:

- closed loop (``forte_evaluation.evaluate.record_from_result``): onset and flag times [s],
  ``max_latency`` = :data:`CLOSED_LOOP_MAX_LATENCY` (1.0 s), ``before_next_onset=True``.
  The simulator reports onsets, not slip episodes with an end, so a flag after the next
  onset is taken to answer that onset; the horizon only bounds a match (what is reported is
  the latency distribution, against the paper's "typically below 100 ms") and is the 1 s of
  the published tables.
- labelled recordings (:func:`forte_perception.evaluation.labelled_recordings.evaluate_slip`):
  sample indices, ``max_latency`` from ``--max-latency`` (default :data:`MAX_LATENCY`,
  0.5 s) rounded to samples, ``before_next_onset=True``: recordings are labelled with
  onsets only, as in the closed loop.
- slip set (:func:`scene_outcome`): sample indices, :data:`MAX_LATENCY` rounded to samples,
  ``before_next_onset=False``: events are labelled intervals ``[onset, end)`` and issue 14
  defines a detection as a flag in ``[onset, onset + 0.5 s]`` whatever the next event
  (false events are judged against ``[onset, end + 0.5 s]``).

On samples the end is inclusive: at 2 kHz a flag 1000 samples after the onset counts, one
1001 samples after it does not.

**Trial-wise scores** (:class:`TrialScores`, closed loop and recordings, as the paper): a
trial is positive when it has a true slip onset, predicted positive when the detector
flagged slip in it (both during the evaluated part).

**Event-level scores on the slip set** (issue 14; a *flag* is a detector update that
reports slip, at the sample index of its last input sample; flags before the scene's
``evaluate_from`` are ignored):

- **flag run**: consecutive flagged updates (flags at most one update spacing ``hop`` apart).
- **detected event**: a true slip event ``[onset, end)`` is detected when a flag falls in
  ``[onset, onset + MAX_LATENCY]``; its **latency** is the first such flag minus the onset.
- **false event**: a flag run (from its first to its last flag) that overlaps no window
  ``[onset, end + MAX_LATENCY]`` of the scene's events.
- **precision** = flag runs that are not false events / all flag runs; **recall** =
  detected events / events; **F1** from the two.
- **false flags per minute holding still**: false events whose first flag lies in a
  holding-still interval, per minute of holding-still time.
- **latency p50 / p90**: percentiles (linear interpolation) of the detected events'
  latencies [ms].

All counts add up over scenes, so a family's or a split's metrics are those of the pooled
counts (not averages of per-scene ratios).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from forte_perception.evaluation.labels import SlipScene

__all__ = ['CLOSED_LOOP_MAX_LATENCY', 'MAX_LATENCY', 'SceneOutcome', 'TrialScores',
           'f1_score', 'flag_runs', 'format_value', 'latency_stats', 'match_onsets',
           'outside_windows', 'ratio', 'scene_outcome', 'summarise']

#: Longest onset-to-flag delay of a detection on the slip set and the recordings [s].
MAX_LATENCY = 0.5
#: Longest onset-to-flag delay of a detection in the closed-loop grasp benchmark [s].
CLOSED_LOOP_MAX_LATENCY = 1.0


# --- ratios and their empty cases -----------------------------------------------------------
def ratio(numerator: float, denominator: float) -> float:
    """``numerator / denominator``; NaN (undefined) when the denominator is 0."""
    return numerator / denominator if denominator else math.nan


def f1_score(precision: float, recall: float) -> float:
    """Harmonic mean ``2 P R / (P + R)``, undefined exactly when the recall is.

    With nothing to find (recall NaN) F1 is NaN. With something to find and nothing found
    (recall 0) it is 0.0 whatever the precision (NaN when nothing was flagged): the harmonic
    mean with a zero is zero. A recall above 0 means some flag found an onset, so the
    precision is then defined.
    """
    if math.isnan(recall):
        return math.nan
    if recall == 0.0:
        return 0.0
    return 2.0 * precision * recall / (precision + recall)


def format_value(value: float | None, digits: int = 2) -> str:
    """A table cell: ``n/a`` for None or NaN (undefined or unknown), else ``digits`` decimals."""
    if value is None or math.isnan(value):
        return 'n/a'
    return f'{value:.{digits}f}'


@dataclass(frozen=True)
class TrialScores:
    """Trial-wise confusion counts of the slip detector and their scores [count].

    Attributes
    ----------
    true_positive, false_positive, true_negative, false_negative : int
        Trials with slip and flagged; without slip but flagged; without slip nor flag; with
        slip but no flag.
    """

    true_positive: int
    false_positive: int
    true_negative: int
    false_negative: int

    @classmethod
    def count(cls, trials: Iterable[tuple[bool, bool]]) -> TrialScores:
        """Counts of ``(slip_true, slip_predicted)`` pairs, one per trial."""
        counts = dict.fromkeys(('true_positive', 'false_positive', 'true_negative',
                                'false_negative'), 0)
        for truth, predicted in trials:
            agree = 'true_' if bool(truth) == bool(predicted) else 'false_'
            counts[agree + ('positive' if predicted else 'negative')] += 1
        return cls(**counts)

    @property
    def trials(self) -> int:
        """All trials [count]."""
        return self.true_positive + self.false_positive + self.true_negative + self.false_negative

    @property
    def accuracy(self) -> float:
        """(TP + TN) / trials; NaN without trials."""
        return ratio(self.true_positive + self.true_negative, self.trials)

    @property
    def precision(self) -> float:
        """TP / (TP + FP); NaN when nothing was flagged."""
        return ratio(self.true_positive, self.true_positive + self.false_positive)

    @property
    def recall(self) -> float:
        """TP / (TP + FN); NaN when no trial had slip."""
        return ratio(self.true_positive, self.true_positive + self.false_negative)

    @property
    def f1(self) -> float:
        """:func:`f1_score` of precision and recall."""
        return f1_score(self.precision, self.recall)

    def as_tuple(self) -> tuple[float, float, float, float]:
        """(accuracy, precision, recall, F1)."""
        return (self.accuracy, self.precision, self.recall, self.f1)

    def to_dict(self) -> dict[str, float]:
        """The four counts and the four scores, JSON-ready."""
        return {'true_positive': self.true_positive, 'false_positive': self.false_positive,
                'true_negative': self.true_negative, 'false_negative': self.false_negative,
                'accuracy': self.accuracy, 'precision': self.precision,
                'recall': self.recall, 'f1': self.f1}


# --- onsets, flags and latencies --------------------------------------------------------------
def match_onsets(onsets: Sequence[float] | np.ndarray, flags: Sequence[float] | np.ndarray,
                 max_latency: float, before_next_onset: bool) -> np.ndarray:
    """Latency of each true slip onset to the first flag at or after it (module docstring).

    Parameters
    ----------
    onsets : array-like, shape (k,)
        True slip onsets [s, or samples], any order.
    flags : array-like, shape (f,)
        Positions of the detector's slip flags, in the unit of ``onsets``, any order.
    max_latency : float
        A flag later than ``onset + max_latency`` does not count (one exactly there does),
        in the unit of ``onsets``.
    before_next_onset : bool
        A flag at or after the next onset (in time order) does not count either.

    Returns
    -------
    ndarray, shape (k,), float
        Flag minus onset per onset, in the order of ``onsets`` and their unit; NaN where
        the onset was missed.
    """
    onsets = np.asarray(onsets)
    flags = np.sort(np.asarray(flags))
    latency = np.full(onsets.shape, math.nan)
    if not onsets.size or not flags.size:
        return latency
    first = np.searchsorted(flags, onsets, side='left')
    candidate = flags[np.minimum(first, flags.size - 1)]
    caught = (first < flags.size) & (candidate <= onsets + max_latency)
    if before_next_onset:
        order = np.argsort(onsets, kind='stable')
        next_onset = np.full(onsets.shape, math.inf)
        next_onset[order[:-1]] = onsets[order[1:]]
        caught &= candidate < next_onset
    latency[caught] = candidate[caught] - onsets[caught]
    return latency


def _percentile(values: np.ndarray, q: float) -> float:
    """Percentile ``q`` (linear interpolation) of ``values``; NaN when there are none."""
    return float(np.percentile(values, q)) if values.size else math.nan


def latency_stats(latencies: Sequence[float], missed: int = 0) -> dict[str, float]:
    """Distribution of slip detection latencies (onset to first flag).

    Parameters
    ----------
    latencies : sequence of float, length d
        One value per caught onset [s].
    missed : int
        Onsets never flagged within their window [count].

    Returns
    -------
    dict
        ``count``, ``missed``, ``p50``, ``p90``, ``max``, ``mean`` [s] and
        ``fraction_below_100ms`` of the caught onsets (NaN when none was caught).
        Percentiles use linear interpolation between order statistics (numpy's default).
    """
    values = np.asarray(list(latencies), dtype=float)
    if values.size and not np.all(np.isfinite(values)):
        raise ValueError('latencies must be finite')
    return {
        'count': int(values.size),
        'missed': int(missed),
        'p50': _percentile(values, 50),
        'p90': _percentile(values, 90),
        'max': float(values.max()) if values.size else math.nan,
        'mean': float(values.mean()) if values.size else math.nan,
        'fraction_below_100ms': float(np.mean(values < 0.100)) if values.size else math.nan,
    }


def flag_runs(flags: np.ndarray, hop: int) -> np.ndarray:
    """Runs of flags at most ``hop`` samples apart.

    Parameters
    ----------
    flags : ndarray, shape (f,), int
        Flag sample indices, ascending.
    hop : int
        Samples between consecutive detector updates.

    Returns
    -------
    ndarray, shape (r, 2), int64
        First and last flag sample of each run.
    """
    flags = np.asarray(flags, np.int64)
    if flags.size == 0:
        return np.zeros((0, 2), np.int64)
    breaks = np.flatnonzero(np.diff(flags) > hop)
    starts = np.concatenate([[0], breaks + 1])
    stops = np.concatenate([breaks, [flags.size - 1]])
    return np.stack([flags[starts], flags[stops]], axis=1)


def outside_windows(first: np.ndarray, last: np.ndarray, windows: np.ndarray) -> np.ndarray:
    """Which intervals ``[first, last]`` overlap none of the ``windows``.

    Parameters
    ----------
    first, last : ndarray, shape (r,)
        Interval ends [samples], both included.
    windows : ndarray, shape (k, 2)
        ``[start, stop]`` [samples], both included.

    Returns
    -------
    ndarray, shape (r,), bool
    """
    outside = np.ones(np.shape(first), bool)
    for start, stop in np.asarray(windows).reshape(-1, 2):
        outside &= (last < start) | (first > stop)
    return outside


# --- the labelled slip set ------------------------------------------------------------------
@dataclass
class SceneOutcome:
    """What one detector run did on one scene.

    Attributes
    ----------
    name, family, split, source : str
        The scene's identity.
    event_kinds : tuple of str, length k
    event_fingers, event_strength : ndarray, shape (k,)
    detected : ndarray, shape (k,), bool
    latency_s : ndarray, shape (k,)
        Onset to first flag within the window [s]; NaN when missed.
    runs : ndarray, shape (r, 2)
        Flag runs (first, last flag sample).
    false_run : ndarray, shape (r,), bool
        The run is a false event.
    false_in_holding : ndarray, shape (r,), bool
        A false event whose first flag is in a holding-still interval.
    holding_s : float
        Holding-still time [s].
    evaluated_s : float
        Evaluated time (from ``evaluate_from`` to the end) [s].
    updates : int
        Detector updates in the scene.
    """

    name: str
    family: str
    split: str
    source: str
    event_kinds: tuple[str, ...]
    event_fingers: np.ndarray
    event_strength: np.ndarray
    detected: np.ndarray
    latency_s: np.ndarray
    runs: np.ndarray
    false_run: np.ndarray
    false_in_holding: np.ndarray
    holding_s: float
    evaluated_s: float
    updates: int = 0


def _inside(samples: np.ndarray, intervals: np.ndarray) -> np.ndarray:
    """Which ``samples`` lie in one of the sorted disjoint ``[start, stop)`` intervals."""
    if intervals.size == 0 or samples.size == 0:
        return np.zeros(samples.shape, bool)
    i = np.searchsorted(intervals[:, 0], samples, side='right') - 1
    ok = i >= 0
    out = np.zeros(samples.shape, bool)
    out[ok] = samples[ok] < intervals[i[ok], 1]
    return out


def scene_outcome(scene: SlipScene, flag_samples: np.ndarray, hop: int, updates: int = 0,
                  max_latency: float = MAX_LATENCY) -> SceneOutcome:
    """Score one detector run on ``scene`` (definitions in the module docstring).

    Parameters
    ----------
    scene : SlipScene
    flag_samples : ndarray, shape (f,), int
        Sample index of every flagged update, ascending.
    hop : int
        Samples between consecutive detector updates (runs join flags this close).
    updates : int
        Detector updates in the scene (for the per-update cost).
    max_latency : float
        Longest onset-to-flag delay of a detection [s]; rounded to samples.
    """
    flags = np.asarray(flag_samples, np.int64)
    flags = flags[flags >= scene.evaluate_from]
    window = int(round(max_latency * scene.fs))
    latency = match_onsets(scene.events[:, 0], flags, window, before_next_onset=False)
    runs = flag_runs(flags, hop)
    windows = np.stack([scene.events[:, 0], scene.events[:, 1] + window], axis=1)
    false_run = outside_windows(runs[:, 0], runs[:, 1], windows)
    in_holding = _inside(runs[:, 0], scene.holding) & false_run
    holding = float(np.sum(scene.holding[:, 1] - scene.holding[:, 0])) / scene.fs
    return SceneOutcome(scene.name, scene.family, scene.split, scene.source,
                        scene.event_kinds, scene.event_fingers, scene.event_strength,
                        ~np.isnan(latency), latency / scene.fs, runs, false_run, in_holding,
                        holding, max(scene.n_samples - scene.evaluate_from, 0) / scene.fs,
                        updates)


def summarise(outcomes: list[SceneOutcome],
              event_filter: Callable[[SceneOutcome], np.ndarray] | None = None) -> dict:
    """Pooled metrics of some scene outcomes (definitions in the module docstring).

    Parameters
    ----------
    outcomes : list of SceneOutcome
    event_filter : callable, optional
        ``f(outcome) -> ndarray (k,) bool``: count only these events (e.g. one kind); runs
        and holding time are then not reported (they are not per event).

    Returns
    -------
    dict
        ``scenes``, ``events``, ``detected``, ``recall``, ``latency_p50_ms``,
        ``latency_p90_ms`` and, without a filter, ``runs``, ``false_runs``, ``precision``,
        ``f1``, ``holding_min``, ``false_holding``, ``false_per_min_holding``,
        ``scenes_with_false``, ``updates``.
    """
    keep = [event_filter(o) if event_filter else np.ones(o.detected.size, bool)
            for o in outcomes]
    events = int(sum(int(m.sum()) for m in keep))
    detected = int(sum(int(o.detected[m].sum()) for o, m in zip(outcomes, keep)))
    latency_ms = np.concatenate([o.latency_s[m & o.detected] for o, m in zip(outcomes, keep)]
                                or [np.zeros(0)]) * 1e3
    out = {'scenes': len(outcomes), 'events': events, 'detected': detected,
           'recall': ratio(detected, events),
           'latency_p50_ms': _percentile(latency_ms, 50),
           'latency_p90_ms': _percentile(latency_ms, 90)}
    if event_filter is not None:
        return out
    runs = sum(o.runs.shape[0] for o in outcomes)
    false = sum(int(o.false_run.sum()) for o in outcomes)
    false_holding = sum(int(o.false_in_holding.sum()) for o in outcomes)
    holding_min = sum(o.holding_s for o in outcomes) / 60.0
    precision = ratio(runs - false, runs)
    out.update(runs=runs, false_runs=false, precision=precision,
               f1=f1_score(precision, out['recall']),
               holding_min=holding_min, false_holding=false_holding,
               false_per_min_holding=ratio(false_holding, holding_min),
               scenes_with_false=sum(bool(o.false_run.any()) for o in outcomes),
               updates=sum(o.updates for o in outcomes))
    return out
