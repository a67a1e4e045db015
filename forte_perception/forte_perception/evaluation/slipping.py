"""How well the slipping *state* follows a slide (issue 26), on labelled slip scenes.

The state (:mod:`forte_perception.slip.state`) is raised by a detector's slip event and held
while the finger's band power stays over its quiet level. Per scene it is run on the
scene's filtered frames with the events of a detector mode (a
:class:`~forte_perception.evaluation.benchmark.Detection`); nothing here sees the labels
but the scoring.

Scores, per labelled slip event ``[onset, end]`` (``end`` as labelled: the scene
generators end a stick-slip event 0.1 s after its last release):

- **held fraction**: of the updates from the first detector flag in ``[onset, end]`` to
  ``end``, the share with the state raised (only events flagged before their end count;
  the issue asks for >= 90 % on sustained sliding);
- **clear delay**: from ``end`` to the first update at or after it with the state down
  [ms] (0 when it is already down; the issue asks for <= 100 ms);

and per scene set:

- **raised outside slip**: state raises (a rise from down to up) at an update that lies in
  a holding-still interval or in a scene without slip events (quiet holds, distractors);
  the issue asks for none.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from forte_perception.evaluation.benchmark import Detection, SensorInput
from forte_perception.evaluation.labels import SlipScene
from forte_perception.slip.state import SlippingParams, SlippingState

__all__ = ['SlippingScores', 'score_slipping', 'slipping_trace', 'summarise_slipping']


def slipping_trace(inp: SensorInput, detection: Detection,
                   params: SlippingParams | None = None,
                   band: tuple[float, float] = (10.0, 50.0)) -> np.ndarray:
    """The state (either finger) at each of the detection's updates, (m,) bool."""
    state = SlippingState(inp.fs, band, detection.hop / inp.fs, params)
    power = state.feed(inp.filtered, detection.sample_index)
    return state.decide(power, detection.slip).slipping.any(axis=1)


@dataclass
class SlippingScores:
    """Scores of one scene (or pooled scenes).

    Attributes
    ----------
    held : list of float
        Held fraction of each event flagged before its end.
    clear_ms : list of float
        Clear delay of each event that was raised [ms].
    raised_outside : int
        Raises in holding-still time or in scenes without slip events.
    """

    held: list[float] = field(default_factory=list)
    clear_ms: list[float] = field(default_factory=list)
    raised_outside: int = 0


def score_slipping(scene: SlipScene, sample_index: np.ndarray, flags: np.ndarray,
                   slipping: np.ndarray) -> SlippingScores:
    """Scores of one scene given the updates' last samples, detector flags and state (m,)."""
    ends = np.asarray(sample_index)
    out = SlippingScores()
    for onset, end in np.asarray(scene.events).reshape(-1, 2):
        flagged = ends[(ends >= onset) & (ends <= end) & flags]
        if not flagged.size:
            continue
        window = (ends >= flagged[0]) & (ends < end)
        if window.any():
            out.held.append(float(slipping[window].mean()))
        after = ends[(ends >= end) & ~slipping]
        if slipping[(ends >= flagged[0]) & (ends <= end)].any():
            last = ends[-1] if not after.size else after[0]
            out.clear_ms.append(1000.0 * (last - end) / scene.fs)
    rises = ends[1:][slipping[1:] & ~slipping[:-1]]
    if slipping.size and slipping[0]:
        rises = np.concatenate([ends[:1], rises])
    if not len(scene.events):
        out.raised_outside = int(rises.size)
    else:
        holding = np.asarray(scene.holding).reshape(-1, 2)
        inside = ((rises[:, None] >= holding[:, 0]) & (rises[:, None] < holding[:, 1]))
        out.raised_outside = int(inside.any(axis=1).sum())
    return out


def summarise_slipping(scores: Sequence[SlippingScores]) -> dict[str, float]:
    """Pooled numbers: events, mean held fraction, share held >= 90 %, clear delay p50 / p90
    [ms], share cleared within 100 ms, raises outside slip."""
    held = np.array([h for s in scores for h in s.held])
    clear = np.array([c for s in scores for c in s.clear_ms])
    nan = float('nan')
    return {
        'events': float(held.size),
        'held_mean': float(held.mean()) if held.size else nan,
        'held_90': float((held >= 0.9).mean()) if held.size else nan,
        'clear_p50_ms': float(np.percentile(clear, 50)) if clear.size else nan,
        'clear_p90_ms': float(np.percentile(clear, 90)) if clear.size else nan,
        'clear_100ms': float((clear <= 100.0).mean()) if clear.size else nan,
        'raised_outside': float(sum(s.raised_outside for s in scores)),
    }
