"""The threshold sweep, its recommendation rule and the overlay.

Known answer: a recording whose labelled slips are strong PSD rises and whose unlabelled
distractors are weak ones. A low T flags the distractors too (precision drops), a very high
T flags nothing (recall 0), the T between the two peaks is right.
"""
import math

import numpy as np
import pytest

from forte_perception.evaluation.labelled_recordings import (
    LabelledRecording,
)
from forte_perception.evaluation.slip_metrics import TrialScores
from forte_perception.evaluation.threshold_sweep import (
    NODE_PARAMETERS,
    SweepRow,
    node_settable,
    overlay,
    overlay_yaml,
    parameter_grid,
    params_from_overlay,
    prefilter,
    recommend,
    sweep,
    table,
)
from forte_perception.median import running_median
from forte_perception.slip.detector import SlipParams, slip_features
from forte_perception.testing import (
    FS,
    SWEEP_DISTRACTORS,
    SWEEP_SAMPLES,
    SWEEP_SLIPS,
    known_answer_recording,
)

N, SLIPS, DISTRACTORS = SWEEP_SAMPLES, SWEEP_SLIPS, SWEEP_DISTRACTORS
PAPER = SlipParams(mode='paper')


def peak_variance(frames: np.ndarray, lo: int, hi: int) -> float:
    res = slip_features(running_median(frames, 11), fs=FS, params=replace_threshold(PAPER, 1e9))
    inside = (res.sample_index >= lo) & (res.sample_index < hi)
    return float(res.finger_variance[inside].max())


def replace_threshold(params: SlipParams, value: float) -> SlipParams:
    from dataclasses import replace
    return replace(params, threshold=value)


def test_sweep_finds_the_obvious_threshold(capsys):
    rec = known_answer_recording()
    weak = peak_variance(rec.frames[:N], 6000, 7000)
    strong = min(peak_variance(rec.frames[:N], s, s + 1000) for s in SLIPS)
    assert 2.0 < weak < 25.0 < strong < 200.0, (weak, strong)  # the premise of the answer
    settings, skipped = parameter_grid(PAPER, {'threshold': (2.0, 25.0, 200.0)}, FS)
    assert not skipped and len(settings) == 3
    rows = sweep([rec], settings)
    low, middle, high = rows
    print('\n' + table(rows, middle))
    assert low.false_runs >= 2 and low.precision < 0.9 and low.recall == 1.0
    assert (middle.detected, middle.onsets, middle.false_runs) == (2, 2, 0)
    assert middle.precision == 1.0 and middle.f1 == 1.0
    assert 0.0 < middle.latency(50) < 0.1
    assert middle.trials.true_positive == 1 and middle.trials.true_negative == 1
    assert high.runs == 0 and high.recall == 0.0 and math.isnan(high.precision)
    choice = recommend(rows)
    assert choice.row is middle and choice.floor_met
    assert overlay(choice.row.params) == {'perception': {'ros__parameters': {
        'slip_mode': 'paper', 'slip_threshold': 25.0}}}


def test_mask_and_prefilter():
    rec = known_answer_recording()
    mask = np.zeros(2 * N, bool)
    mask[:5000] = True                  # only the first slip's part is evaluated
    masked = LabelledRecording(rec.frames, FS, rec.onsets, rec.trial, name='m', mask=mask)
    (row,) = sweep([masked], [(replace_threshold(PAPER, 25.0), {})])
    assert row.detected == 1 and row.onsets == 2 and row.false_runs == 0
    filtered = prefilter([rec])
    assert filtered[0].filtered and prefilter(filtered)[0] is filtered[0]


def test_parameter_grid_skips_invalid_combinations():
    settings, skipped = parameter_grid(SlipParams(mode='robust'),
                                       {'threshold': (2.0, 4.0),
                                        'single_threshold': (3.0, 5.0)}, FS)
    assert [v for _, v in settings] == [{'threshold': 2.0, 'single_threshold': 3.0},
                                        {'threshold': 2.0, 'single_threshold': 5.0},
                                        {'threshold': 4.0, 'single_threshold': 5.0}]
    assert len(skipped) == 1 and 'single_threshold' in skipped[0][1]
    with pytest.raises(ValueError, match='not slip parameters'):
        parameter_grid(PAPER, {'thresh': (1.0,)}, FS)


def row(threshold: float, precision_runs: tuple[int, int], detected: int,
        latency: float, **changes) -> SweepRow:
    from dataclasses import replace
    runs, false = precision_runs
    params = replace(SlipParams(mode='robust'), threshold=threshold, **changes)
    return SweepRow(params, {'threshold': threshold}, 10, detected, runs, false,
                    np.full(detected, latency), TrialScores(1, 0, 0, 0))


def test_recommendation_rule():
    # highest F1 among those above the precision floor
    best = row(1.5, (10, 0), 9, 0.05)
    assert recommend([row(1.0, (20, 5), 10, 0.04), best, row(3.0, (8, 0), 8, 0.05)]).row is best
    # equal F1: lower latency; then T closer to the default (2.0)
    fast = row(3.0, (10, 0), 9, 0.03)
    assert recommend([best, fast]).row is fast
    near = row(2.5, (10, 0), 9, 0.05)
    assert recommend([best, near]).row is best           # |1.5 - 2| = |2.5 - 2|: grid order
    assert recommend([row(1.0, (10, 0), 9, 0.05), near]).row is near
    # a p50 less than one detector update (2 ms) lower is the median's quantisation: a tie
    assert recommend([row(1.0, (10, 0), 9, 0.049), near]).row is near
    assert recommend([row(1.0, (10, 0), 9, 0.047), near]).row.params.threshold == 1.0
    # settings the node cannot load are never recommended
    hidden = row(2.0, (10, 0), 10, 0.01, veto_span=800)
    assert not node_settable(hidden.params)
    assert recommend([best, hidden]).row is best
    with pytest.raises(ValueError, match='loaded by the perception node'):
        recommend([hidden])
    # no setting reaches the floor: best F1, said so
    choice = recommend([row(1.0, (10, 5), 10, 0.05), row(2.0, (10, 6), 6, 0.05)])
    assert not choice.floor_met and choice.row.params.threshold == 1.0
    assert 'no setting reached the floor' in choice.rule


def test_in_the_sequential_mode_ties_go_to_the_cusum_threshold_nearest_its_default():
    from dataclasses import replace

    def sequential(h: float) -> SweepRow:
        base = row(2.0, (10, 0), 9, 0.05)
        return replace(base, params=SlipParams(mode='sequential', sequential_threshold=h),
                       varied={'sequential_threshold': h})

    far, near = sequential(0.2), sequential(0.1)   # default h = 0.05
    assert recommend([far, near]).row is near
    assert overlay(near.params)['perception']['ros__parameters'] == {
        'slip_mode': 'sequential', 'slip_threshold': 2.0, 'slip_sequential_threshold': 0.1}


def test_node_parameters_are_the_perception_nodes():
    from forte_perception.ros.perception_node import PARAMETERS

    for field, parameter in NODE_PARAMETERS.items():
        assert PARAMETERS[parameter].field == f'slip.{field}', parameter
    slip_fields = {spec.field[5:] for spec in PARAMETERS.values()
                   if spec.field and spec.field.startswith('slip.')}
    assert slip_fields == set(NODE_PARAMETERS)


def test_overlay_text_and_round_trip():
    params = SlipParams(mode='robust', threshold=1.5, alpha=0.5)
    document = overlay(params)
    assert document == {'perception': {'ros__parameters': {
        'slip_mode': 'robust', 'slip_threshold': 1.5, 'slip_alpha': 0.5}}}
    text = overlay_yaml(document, 'made by a test\nsecond line')
    assert text.splitlines() == ['# made by a test', '# second line', 'perception:',
                                 '  ros__parameters:', "    slip_mode: 'robust'",
                                 '    slip_threshold: 1.5', '    slip_alpha: 0.5']
    assert params_from_overlay(document) == params
    assert 'slip_threshold: 1.0e-05' in overlay_yaml(overlay(SlipParams(threshold=1e-5,
                                                                        mode='paper')))
    with pytest.raises(ValueError, match='does not declare'):
        overlay(SlipParams(veto_span=800))
    with pytest.raises(ValueError, match='ros__parameters'):
        params_from_overlay({'grasp_controller': {'ros__parameters': {}}})
