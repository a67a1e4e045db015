"""Slip detection reported as change detection: detection delay against false alarms (issue 26).

A slip detector is a sequential change detector: it watches a stream whose statistics change
at an unknown time (the slip onset) and must say so as soon as possible without saying so
when nothing changed. The field reports such a detector by two numbers per operating point
(a value of the parameter that trades one for the other, e.g. the threshold): the
**detection delay** (onset to first alarm) and the **false-alarm rate** (equivalently the
mean time between false alarms). One detector is better than another when its curve of
delay against false-alarm rate lies below the other's; a single precision / recall pair is
one point of that curve.

This module computes the curve on labelled slip scenes
(:class:`~forte_perception.evaluation.labels.SlipScene`), one point per setting of a
detector mode, with the definitions of :mod:`forte_perception.evaluation.slip_metrics`
(nothing is re-defined here):

- **delay** of a slip event = onset to the first flag in ``[onset, onset + MAX_LATENCY]``
  (:func:`~forte_perception.evaluation.slip_metrics.scene_outcome`); reported as median and
  p90 over the *detected* events [ms] together with the recall (the delay is conditional on
  detection within 0.5 s, so a point is only read with its recall);
- **false alarm** = a flag run that overlaps no ``[onset, end + MAX_LATENCY]`` window (a
  false event of ``slip_metrics``);
- **false alarms per hour of quiet holding** = false events whose first flag lies in a
  holding-still interval, per hour of holding-still time, over every scene (the
  ``false_holding`` and ``holding_min`` of ``summarise``, in hours: at 0 false alarms a
  one-sided 95 % upper bound is 3 / hours held, so the hours are reported too);
- **false alarms per minute of distractor scenes** = every false event (holding or busy) in
  the *distractor scenes*, per minute of their evaluated time. A distractor scene has no
  slip event and some busy time (closing steps, ramps, sway, ...: the labelled scenes whose
  holding time is shorter than their evaluated time); a scene without events that is
  holding still throughout is a *quiet* scene and counts only in the rate per hour above.

:func:`delay_false_alarm_curve` runs any detector (a
:class:`~forte_perception.evaluation.benchmark.Detection` per
:class:`~forte_perception.evaluation.benchmark.SensorInput`) per setting with
:func:`~forte_perception.evaluation.benchmark.run_mode`; :func:`slip_params_settings` makes
the settings of a :class:`~forte_perception.slip.params.SlipParams` mode along one parameter
with :func:`~forte_perception.evaluation.threshold_sweep.parameter_grid`;
:func:`best_at_zero_false_alarms` picks the point that issue 26 compares modes at;
:func:`markdown_curve` prints the table.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

from forte_perception.evaluation.benchmark import (
    Detection,
    SensorInput,
    prepare,
    robust_mode,
    run_mode,
)
from forte_perception.evaluation.labels import SlipScene
from forte_perception.evaluation.slip_metrics import (
    MAX_LATENCY,
    SceneOutcome,
    format_value,
    ratio,
    summarise,
)
from forte_perception.evaluation.threshold_sweep import parameter_grid
from forte_perception.slip.params import SlipParams
from forte_ros.contract import SAMPLE_RATE

__all__ = ['OperatingPoint', 'best_at_zero_false_alarms', 'delay_false_alarm_curve',
           'is_distractor', 'markdown_curve', 'operating_point', 'slip_params_settings']

#: A setting: the swept values (for the record) and the detector that runs with them.
Setting = tuple[dict, Callable[[SensorInput], Detection]]


@dataclass(frozen=True)
class OperatingPoint:
    """One point of the delay / false-alarm curve (module docstring for the definitions).

    Attributes
    ----------
    setting : dict
        The swept parameter values.
    events, detected : int
        Labelled slip events, detected events [count].
    recall : float
        detected / events; NaN without events.
    delay_p50_ms, delay_p90_ms : float
        Median and p90 delay of the detected events [ms]; NaN when none was detected.
    holding_h : float
        Holding-still time of all scenes [h].
    false_holding : int
        False events starting while holding still [count].
    distractor_min : float
        Evaluated time of the distractor scenes [min].
    false_distractor : int
        False events in the distractor scenes [count].
    runs, false_runs : int
        Flag runs and false events over all scenes [count].
    """

    setting: dict
    events: int
    detected: int
    recall: float
    delay_p50_ms: float
    delay_p90_ms: float
    holding_h: float
    false_holding: int
    distractor_min: float
    false_distractor: int
    runs: int
    false_runs: int

    @property
    def false_per_hour_holding(self) -> float:
        """False alarms per hour of quiet holding [1/h]; NaN without holding time."""
        return ratio(self.false_holding, self.holding_h)

    @property
    def false_per_min_distractor(self) -> float:
        """False alarms per minute of distractor scenes [1/min]; NaN without them."""
        return ratio(self.false_distractor, self.distractor_min)

    @property
    def precision(self) -> float:
        """Flag runs that are not false / flag runs; NaN without flags."""
        return ratio(self.runs - self.false_runs, self.runs)

    @property
    def zero_false_alarms(self) -> bool:
        """No false alarm while holding still nor in a distractor scene."""
        return self.false_holding == 0 and self.false_distractor == 0


def is_distractor(outcome: SceneOutcome) -> bool:
    """A scene without slip events that has busy (not holding-still) evaluated time."""
    return outcome.detected.size == 0 and outcome.holding_s < outcome.evaluated_s


def operating_point(outcomes: Sequence[SceneOutcome], setting: dict | None = None
                    ) -> OperatingPoint:
    """The curve point of one detector run over scenes (pooled counts).

    Parameters
    ----------
    outcomes : sequence of SceneOutcome
        One per scene, from :func:`~forte_perception.evaluation.slip_metrics.scene_outcome`.
    setting : dict, optional
        The swept values, for the record.
    """
    pooled = summarise(list(outcomes))
    distractors = [o for o in outcomes if is_distractor(o)]
    return OperatingPoint(
        setting=dict(setting or {}), events=pooled['events'], detected=pooled['detected'],
        recall=pooled['recall'], delay_p50_ms=pooled['latency_p50_ms'],
        delay_p90_ms=pooled['latency_p90_ms'], holding_h=pooled['holding_min'] / 60.0,
        false_holding=pooled['false_holding'],
        distractor_min=sum(o.evaluated_s for o in distractors) / 60.0,
        false_distractor=sum(int(o.false_run.sum()) for o in distractors),
        runs=pooled['runs'], false_runs=pooled['false_runs'])


def delay_false_alarm_curve(scenes: list[SlipScene], settings: Sequence[Setting],
                            inputs: list[SensorInput] | None = None,
                            max_latency: float = MAX_LATENCY) -> list[OperatingPoint]:
    """One :class:`OperatingPoint` per setting, every setting on the same scenes.

    Parameters
    ----------
    scenes : list of SlipScene
    settings : sequence of (dict, callable)
        The swept values and the detector ``SensorInput -> Detection`` that uses them.
    inputs : list of SensorInput, optional
        :func:`~forte_perception.evaluation.benchmark.prepare` of ``scenes`` (the median
        filter), computed here when not given.
    max_latency : float
        Longest onset-to-flag delay of a detection [s].
    """
    inputs = inputs if inputs is not None else prepare(scenes)
    points = []
    for varied, detector in settings:
        outcomes, _ = run_mode(scenes, detector, repeats=1, inputs=inputs,
                               max_latency=max_latency)
        points.append(operating_point(outcomes, varied))
    return points


def slip_params_settings(base: SlipParams, axis: str, values: Sequence,
                         fs: float = SAMPLE_RATE) -> list[Setting]:
    """Settings of a :class:`SlipParams` mode along one parameter.

    Parameters
    ----------
    base : SlipParams
        Every other field, and the mode (``base.mode``).
    axis : str
        The swept field, e.g. ``'threshold'``.
    values : sequence
        Its values; those :meth:`SlipParams.validate` refuses are left out.
    fs : float
        Sampling rate the settings are checked at [Hz].
    """
    grid, _ = parameter_grid(base, {axis: tuple(values)}, fs)
    # robust_mode runs slip_features with the given params, whatever their mode
    return [(varied, partial(robust_mode, params=params)) for params, varied in grid]


def best_at_zero_false_alarms(points: Sequence[OperatingPoint]) -> OperatingPoint | None:
    """The point issue 26 compares modes at: no false alarm while holding still nor in a
    distractor scene; of these the highest recall, then the lowest median delay. None when
    every point has a false alarm."""
    clean = [p for p in points if p.zero_false_alarms]
    if not clean:
        return None

    def rank(p: OperatingPoint) -> tuple[float, float]:
        recall = p.recall if not math.isnan(p.recall) else -1.0
        p50 = p.delay_p50_ms if not math.isnan(p.delay_p50_ms) else math.inf
        return (-recall, p50)

    return min(clean, key=rank)


_HEADER = ('| {mode} setting | events | recall | delay p50 [ms] | p90 [ms] | holding [h] '
           '| false holding | false / h holding | distractors [min] | false distractor '
           '| false / min distractors | precision |')


def markdown_curve(points: Sequence[OperatingPoint], mode: str) -> str:
    """The curve as a markdown table, one row per point (``n/a`` = undefined); the point of
    :func:`best_at_zero_false_alarms` is marked ``**<-**``."""
    best = best_at_zero_false_alarms(points)
    lines = [_HEADER.format(mode=mode), '|' + '---|' * 12]
    for p in points:
        name = ', '.join(f'{k}={v:g}' if isinstance(v, (int, float)) else f'{k}={v}'
                         for k, v in p.setting.items()) or 'default'
        if p is best:
            name += ' **<-**'
        cells = (name, str(p.events), format_value(p.recall),
                 format_value(p.delay_p50_ms, 0), format_value(p.delay_p90_ms, 0),
                 format_value(p.holding_h, 3), str(p.false_holding),
                 format_value(p.false_per_hour_holding, 1), format_value(p.distractor_min, 1),
                 str(p.false_distractor), format_value(p.false_per_min_distractor, 2),
                 format_value(p.precision))
        lines.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)
