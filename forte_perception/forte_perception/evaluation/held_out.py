"""Compare two slip detector settings on labelled slip scenes (the held-out check).

A tuned setting (:mod:`forte_perception.evaluation.threshold_sweep`) is accepted when, on
scenes it was not tuned on (the ``held_out`` part of the issue-14 slip evaluation set,
:mod:`forte_perception.evaluation.labels`, without the objects the tuning recordings show),
it is no worse than the default setting. Scores are the slip set's event-level metrics
(:func:`forte_perception.evaluation.slip_metrics.summarise`: pooled flag-run precision,
event recall, F1, latency p50 / p90, false flags per minute holding still); the decision
metric is the pooled **F1** (ties count as no worse).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

from forte_perception.evaluation.benchmark import (
    Detection,
    SensorInput,
    prepare,
    run_mode,
    sequential_mode,
)
from forte_perception.evaluation.labels import SlipScene
from forte_perception.evaluation.slip_metrics import format_value, summarise
from forte_perception.slip.detector import SlipParams, slip_features
from forte_perception.slip.sequential import SequentialParams

__all__ = ['Comparison', 'compare_settings', 'held_out_scenes']


def held_out_scenes(scenes: Sequence[SlipScene], exclude_objects: Sequence[str] = ()
                    ) -> list[SlipScene]:
    """The ``held_out`` scenes whose object is not in ``exclude_objects`` (e.g. the objects
    of the tuning recordings: the jam jar is a held-out object of the slip set)."""
    return [s for s in scenes if s.split == 'held_out' and s.object_name not in exclude_objects]


def _mode(params: SlipParams):
    if params.mode == 'sequential':  # streaming, with the scene's servo gate
        return partial(sequential_mode, params=SequentialParams.from_slip(params))

    def detect(inp: SensorInput) -> Detection:
        res = slip_features(inp.filtered, fs=inp.fs, params=params)
        return Detection(res.sample_index, res.slip, int(params.hop))
    return detect


@dataclass
class Comparison:
    """Pooled metrics of the default and the candidate setting on the same scenes.

    Attributes
    ----------
    default, candidate : dict
        :func:`~forte_perception.evaluation.slip_metrics.summarise` of each.
    scenes : int
        Scenes scored [count].
    """

    default: dict
    candidate: dict
    scenes: int

    @property
    def no_worse(self) -> bool:
        """The candidate's F1 is at least the default's (NaN F1 counts as 0)."""
        def f1(m: dict) -> float:
            return 0.0 if math.isnan(m['f1']) else m['f1']
        return f1(self.candidate) >= f1(self.default) - 1e-12

    def lines(self) -> list[str]:
        """A small markdown table of both settings."""
        out = ['| setting | events | detected | recall | flag runs | false | precision | F1 '
               '| p50 [ms] | p90 [ms] | false / min holding |', '|' + '---|' * 11]
        for name, m in (('default', self.default), ('recommended', self.candidate)):
            out.append(f'| {name} | {m["events"]} | {m["detected"]} | '
                       f'{format_value(m["recall"], 3)} | {m["runs"]} | {m["false_runs"]} | '
                       f'{format_value(m["precision"], 3)} | {format_value(m["f1"], 3)} | '
                       f'{format_value(m["latency_p50_ms"], 0)} | '
                       f'{format_value(m["latency_p90_ms"], 0)} | '
                       f'{format_value(m["false_per_min_holding"], 2)} |')
        return out


def compare_settings(scenes: Sequence[SlipScene], candidate: SlipParams,
                     default: SlipParams | None = None) -> Comparison:
    """Score ``default`` (default: ``SlipParams()``, the node's) and ``candidate`` on
    ``scenes`` (the median filter is computed once)."""
    default = default or SlipParams()
    scenes = list(scenes)
    inputs = prepare(scenes)
    results = []
    for params in (default, candidate):
        outcomes, _ = run_mode(scenes, _mode(params), repeats=1, inputs=inputs)
        results.append(summarise(outcomes))
    return Comparison(results[0], results[1], len(scenes))
