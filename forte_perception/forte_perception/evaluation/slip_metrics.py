"""Event-level slip metrics on labelled scenes (:mod:`forte_perception.evaluation.labels`).

Definitions (issue 14; a *flag* is a detector update that reports slip, at the sample index
of its last input sample; flags before the scene's ``evaluate_from`` are ignored):

- **flag run**: consecutive flagged updates (flags at most one update spacing ``hop`` apart).
- **detected event**: a true slip event ``[onset, end)`` is detected when a flag falls in
  ``[onset, onset + max_latency]`` (``max_latency`` = 0.5 s, both ends included); its
  **latency** is the first such flag minus the onset [s].
- **false event**: a flag run (from its first to its last flag) that overlaps no window
  ``[onset, end + max_latency]`` of the scene's events.
- **precision** = flag runs that are not false events / all flag runs (undefined without
  runs); **recall** = detected events / events (undefined without events);
  **F1** = 2 P R / (P + R) (0 when there are events but no flag run; undefined without
  events).
- **false flags per minute holding still**: false events whose first flag lies in a
  holding-still interval, per minute of holding-still time.
- **latency p50 / p90**: percentiles (linear interpolation) of the detected events'
  latencies [ms].

All counts add up over scenes, so a family's or a split's metrics are those of the pooled
counts (not averages of per-scene ratios).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from forte_perception.evaluation.labels import SlipScene

__all__ = ['MAX_LATENCY', 'SceneOutcome', 'flag_runs', 'scene_outcome', 'summarise']

#: Longest onset-to-flag delay of a detection [s].
MAX_LATENCY = 0.5


def flag_runs(flags: np.ndarray, hop: int) -> np.ndarray:
    """Runs of flags at most ``hop`` samples apart: (r, 2) first and last flag sample."""
    flags = np.asarray(flags, np.int64)
    if flags.size == 0:
        return np.zeros((0, 2), np.int64)
    breaks = np.flatnonzero(np.diff(flags) > hop)
    starts = np.concatenate([[0], breaks + 1])
    stops = np.concatenate([breaks, [flags.size - 1]])
    return np.stack([flags[starts], flags[stops]], axis=1)


@dataclass
class SceneOutcome:
    """What one detector run did on one scene.

    Attributes
    ----------
    name, family, split, source : str
        The scene's identity.
    event_kinds : tuple of str
    event_fingers, event_strength : ndarray (k,)
    detected : ndarray (k,) bool
    latency_s : ndarray (k,)
        Onset to first flag within the window [s]; NaN when missed.
    runs : ndarray (r, 2)
        Flag runs (first, last flag sample).
    false_run : ndarray (r,) bool
        The run is a false event.
    false_in_holding : ndarray (r,) bool
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
    """Score one detector run on ``scene``.

    Parameters
    ----------
    scene : SlipScene
    flag_samples : ndarray (f,)
        Sample index of every flagged update, ascending.
    hop : int
        Samples between consecutive detector updates (runs join flags this close).
    updates : int
        Detector updates in the scene (for the per-update cost).
    max_latency : float
        [s]
    """
    flags = np.asarray(flag_samples, np.int64)
    flags = flags[flags >= scene.evaluate_from]
    window = int(round(max_latency * scene.fs))
    k = scene.events.shape[0]
    detected = np.zeros(k, bool)
    latency = np.full(k, np.nan)
    for i, (onset, _) in enumerate(scene.events):
        hit = flags[(flags >= onset) & (flags <= onset + window)]
        if hit.size:
            detected[i] = True
            latency[i] = (hit[0] - onset) / scene.fs
    runs = flag_runs(flags, hop)
    false_run = np.ones(runs.shape[0], bool)
    for onset, end in scene.events:
        false_run &= ~((runs[:, 1] >= onset) & (runs[:, 0] <= end + window))
    in_holding = _inside(runs[:, 0], scene.holding) & false_run
    holding = float(np.sum(scene.holding[:, 1] - scene.holding[:, 0])) / scene.fs
    return SceneOutcome(scene.name, scene.family, scene.split, scene.source,
                        scene.event_kinds, scene.event_fingers, scene.event_strength,
                        detected, latency, runs, false_run, in_holding, holding,
                        max(scene.n_samples - scene.evaluate_from, 0) / scene.fs, updates)


def _ratio(num: float, den: float) -> float:
    return num / den if den else math.nan


def summarise(outcomes: list[SceneOutcome], event_filter=None) -> dict:
    """Pooled metrics of some scene outcomes (definitions in the module docstring).

    Parameters
    ----------
    outcomes : list of SceneOutcome
    event_filter : callable, optional
        ``f(outcome) -> (k,) bool``: count only these events (e.g. one kind); runs and
        holding time are then not reported (they are not per event).

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
    lat = np.concatenate([o.latency_s[m & o.detected] for o, m in zip(outcomes, keep)]
                         or [np.zeros(0)]) * 1e3
    out = {'scenes': len(outcomes), 'events': events, 'detected': detected,
           'recall': _ratio(detected, events),
           'latency_p50_ms': float(np.percentile(lat, 50)) if lat.size else math.nan,
           'latency_p90_ms': float(np.percentile(lat, 90)) if lat.size else math.nan}
    if event_filter is not None:
        return out
    runs = sum(o.runs.shape[0] for o in outcomes)
    false = sum(int(o.false_run.sum()) for o in outcomes)
    false_holding = sum(int(o.false_in_holding.sum()) for o in outcomes)
    holding_min = sum(o.holding_s for o in outcomes) / 60.0
    precision = _ratio(runs - false, runs)
    recall = out['recall']
    if not events:
        f1 = math.nan
    elif not runs or precision + recall == 0:
        f1 = 0.0
    else:
        f1 = 2 * precision * recall / (precision + recall)
    out.update(runs=runs, false_runs=false, precision=precision, f1=f1,
               holding_min=holding_min, false_holding=false_holding,
               false_per_min_holding=_ratio(false_holding, holding_min),
               scenes_with_false=sum(bool(o.false_run.any()) for o in outcomes),
               updates=sum(o.updates for o in outcomes))
    return out
