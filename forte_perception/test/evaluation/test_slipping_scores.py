"""Scores of the slipping state (forte_perception.evaluation.slipping): known answers from
hand-built labels and hand-placed flags and states; one end-to-end run on a generated
sustained slide."""
import numpy as np
import pytest

from forte_perception.evaluation.benchmark import prepare, robust_mode
from forte_perception.evaluation.labels import FINGER_BOTH, SlipScene
from forte_perception.evaluation.scenes import make_scene
from forte_perception.evaluation.slipping import (
    score_slipping,
    slipping_trace,
    summarise_slipping,
)

FS = 2000.0
ENDS = np.arange(3, 12000, 4)  # updates every 4 samples


def labelled(events, holding):
    events = np.array(events, np.int64).reshape(-1, 2)
    k = events.shape[0]
    return SlipScene('s/x/0', 's', 'tune', 'signal', 'x', 0, np.zeros((12000, 6)), events,
                     [FINGER_BOTH] * k, ('stick_slip',) * k, np.full(k, 5.0),
                     np.array(holding, np.int64).reshape(-1, 2), FS, 1000)


def between(start, stop):
    """Updates whose last sample lies in [start, stop)."""
    return (ENDS >= start) & (ENDS < stop)


def test_held_fraction_and_clear_delay_of_one_slide():
    scene = labelled([(2000, 4000)], [(1000, 2000), (5000, 12000)])
    flags = between(2100, 2104)  # first flag at 2103
    slipping = between(2100, 3000) | between(3200, 4100)  # a 100-sample dip, cleared at 4103
    scores = score_slipping(scene, ENDS, flags, slipping)
    dip = between(3000, 3200).sum() / between(2103, 4000).sum()
    assert scores.held == pytest.approx([1.0 - dip])
    assert scores.clear_ms == pytest.approx([1000 * (4103 - 4000) / FS])
    assert scores.raised_outside == 0


def test_raises_in_holding_time_or_in_scenes_without_slip_count():
    scene = labelled([(2000, 4000)], [(1000, 2000), (5000, 12000)])
    slipping = between(6000, 6100) | between(8000, 8040)  # two raises while holding still
    assert score_slipping(scene, ENDS, np.zeros(ENDS.size, bool), slipping).raised_outside == 2
    quiet = labelled([], [(1000, 12000)])
    assert score_slipping(quiet, ENDS, np.zeros(ENDS.size, bool),
                          between(500, 600)).raised_outside == 1  # any raise in a no-slip scene
    summary = summarise_slipping([score_slipping(scene, ENDS, between(2100, 2104),
                                                 between(2100, 4000))])
    # down from the first update after the end (sample 4003): 3 samples = 1.5 ms
    assert summary['held_mean'] == 1.0 and summary['clear_p50_ms'] == pytest.approx(1.5)
    assert summary['clear_100ms'] == 1.0 and summary['raised_outside'] == 0


def test_an_unflagged_event_is_not_scored():
    scene = labelled([(2000, 4000)], [(1000, 2000)])
    scores = score_slipping(scene, ENDS, np.zeros(ENDS.size, bool), np.zeros(ENDS.size, bool))
    assert scores.held == [] and scores.clear_ms == []


def test_generated_sustained_slide_is_followed():
    # a tune scene whose two slides the robust mode flags; the state then holds through them
    scene = make_scene('sustained_sliding', 'p0', 2)
    inp = prepare([scene])[0]
    detection = robust_mode(inp)
    slipping = slipping_trace(inp, detection)
    scores = score_slipping(scene, detection.sample_index, detection.slip, slipping)
    assert scores.held and min(scores.held) >= 0.5
    assert scores.raised_outside == 0
