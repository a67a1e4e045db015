"""Event-level slip metrics (forte_perception.evaluation.slip_metrics): known answers on hand-built
flags and labels, from the definitions of issue 14."""
import math

import numpy as np
import pytest

from forte_perception.evaluation.labels import FINGER_BOTH, SlipScene
from forte_perception.evaluation.slip_metrics import flag_runs, scene_outcome, summarise

FS = 2000.0


def scene(events=((2000, 2400),), holding=((1000, 1900), (3400, 6000)), n=6000,
          family='f', split='tune'):
    """A labelled scene with zero frames: only the labels matter here."""
    events = np.array(events, np.int64).reshape(-1, 2)
    k = events.shape[0]
    return SlipScene(f'{family}/x/0', family, split, 'signal', 'x', 0, np.zeros((n, 6)),
                     events, [FINGER_BOTH] * k, ('stick_slip',) * k, np.full(k, 5.0),
                     np.array(holding, np.int64).reshape(-1, 2), FS, 1000)


def test_flag_runs_join_flags_one_update_apart():
    runs = flag_runs(np.array([10, 14, 18, 30, 34, 100]), hop=4)
    np.testing.assert_array_equal(runs, [[10, 18], [30, 34], [100, 100]])
    assert flag_runs(np.array([], np.int64), 4).shape == (0, 2)


def test_a_scene_scored_by_hand():
    flags = np.array([500, 1950, 2100, 2104, 2108, 5000])
    out = scene_outcome(scene(), flags, hop=4, updates=1000)
    # 500 is before evaluate_from; 2100 is the first flag 100 samples after the onset
    np.testing.assert_array_equal(out.detected, [True])
    assert out.latency_s[0] == pytest.approx(0.05)
    np.testing.assert_array_equal(out.runs, [[1950, 1950], [2100, 2108], [5000, 5000]])
    # 1950 overlaps no [onset, end + 0.5 s] window: a false event, but in busy time
    np.testing.assert_array_equal(out.false_run, [True, False, True])
    np.testing.assert_array_equal(out.false_in_holding, [False, False, True])
    assert out.holding_s == pytest.approx((900 + 2600) / FS)
    assert out.evaluated_s == pytest.approx(2.5)
    assert out.updates == 1000


def test_detection_window_is_onset_to_onset_plus_half_a_second_inclusive():
    late = scene_outcome(scene(), np.array([2000 + 1001]), hop=4)
    assert not late.detected[0] and math.isnan(late.latency_s[0])
    # ... yet the flag overlaps [onset, end + 0.5 s], so it is not a false event
    assert not late.false_run.any()
    edge = scene_outcome(scene(), np.array([2000 + 1000]), hop=4)
    assert edge.detected[0] and edge.latency_s[0] == pytest.approx(0.5)
    early = scene_outcome(scene(), np.array([1999]), hop=4)
    assert not early.detected[0]
    after_window = scene_outcome(scene(), np.array([2400 + 1001]), hop=4)
    assert after_window.false_run.all() and after_window.false_in_holding.all()


def test_a_run_that_starts_before_the_onset_is_true_and_detects_from_the_onset():
    flags = np.arange(1990, 2011, 4)                     # 1990 ... 2010
    out = scene_outcome(scene(), flags, hop=4)
    assert out.runs.shape == (1, 2) and not out.false_run.any()
    assert out.latency_s[0] == pytest.approx(2 / FS)     # first flag >= onset: 2002


def test_pooled_metrics_by_hand():
    a = scene_outcome(scene(), np.array([2100, 2104, 5000, 5400]), hop=4)
    b = scene_outcome(scene(events=((2000, 2400), (4000, 4200)), holding=((1000, 1900),)),
                      np.array([4040]), hop=4)
    m = summarise([a, b])
    # events: a detected, b's first missed, b's second detected (latency 20 ms)
    assert (m['events'], m['detected']) == (3, 2)
    assert m['recall'] == pytest.approx(2 / 3)
    # runs: a: [2100-2104] true, 5000 false, 5400 false; b: 4040 true
    assert (m['runs'], m['false_runs']) == (4, 2)
    assert m['precision'] == pytest.approx(0.5)
    assert m['f1'] == pytest.approx(2 * 0.5 * (2 / 3) / (0.5 + 2 / 3))
    holding_min = ((900 + 2600) + 900) / FS / 60
    assert m['holding_min'] == pytest.approx(holding_min)
    assert m['false_holding'] == 2
    assert m['false_per_min_holding'] == pytest.approx(2 / holding_min)
    assert m['scenes_with_false'] == 1
    assert m['latency_p50_ms'] == pytest.approx(35.0)    # 50 and 20 ms
    assert m['latency_p90_ms'] == pytest.approx(20 + 0.9 * 30)


def test_latency_percentiles_interpolate_linearly():
    onsets = [2000 + 3000 * i for i in range(5)]
    s = scene(events=[(o, o + 100) for o in onsets], holding=(), n=20000)
    flags = np.array([o + 20 * (i + 1) for i, o in enumerate(onsets)])  # 10 ... 50 ms
    m = summarise([scene_outcome(s, flags, hop=4)])
    assert m['latency_p50_ms'] == pytest.approx(30.0)
    assert m['latency_p90_ms'] == pytest.approx(46.0)


def test_conventions_without_runs_or_without_events():
    silent = summarise([scene_outcome(scene(), np.array([], np.int64), hop=4)])
    assert math.isnan(silent['precision']) and silent['recall'] == 0.0
    assert silent['f1'] == 0.0 and math.isnan(silent['latency_p50_ms'])
    quiet = scene(events=(), holding=((1000, 6000),))
    flagged = summarise([scene_outcome(quiet, np.array([3000, 3004, 4000]), hop=4)])
    assert math.isnan(flagged['recall']) and math.isnan(flagged['f1'])
    assert flagged['precision'] == 0.0 and flagged['false_holding'] == 2
    assert flagged['false_per_min_holding'] == pytest.approx(2 / (5000 / FS / 60))


def test_event_filter_counts_only_the_chosen_events():
    s = scene(events=((2000, 2400), (4000, 4200)), holding=())
    s.event_kinds = ('stick_slip', 'gross')
    out = scene_outcome(s, np.array([2010, 4300]), hop=4)
    m = summarise([out], lambda o: np.array([k == 'gross' for k in o.event_kinds]))
    assert (m['events'], m['detected']) == (1, 1)
    assert m['latency_p50_ms'] == pytest.approx(150.0)
    assert 'precision' not in m
