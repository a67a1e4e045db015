"""The slip metrics (forte_perception.evaluation.slip_metrics): known answers on hand-built
onsets, flags and labels, from the definitions (the module docstring, issue 14, the paper)."""
import math

import numpy as np
import pytest

from forte_perception.evaluation.labels import FINGER_BOTH, SlipScene
from forte_perception.evaluation.slip_metrics import (
    CLOSED_LOOP_MAX_LATENCY,
    MAX_LATENCY,
    TrialScores,
    f1_score,
    flag_runs,
    format_value,
    latency_stats,
    match_onsets,
    outside_windows,
    ratio,
    scene_outcome,
    summarise,
)

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
    # no flag run: precision undefined; recall 0 of 1 event is defined, so F1 is 0
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


# --- the empty cases ---------------------------------------------------------------------------
def test_undefined_ratios_are_nan_and_print_as_n_a():
    assert ratio(3, 4) == 0.75 and math.isnan(ratio(0, 0)) and math.isnan(ratio(2, 0))
    assert f1_score(0.5, 1.0) == pytest.approx(2 / 3)
    assert f1_score(0.0, 0.0) == 0.0                      # both defined, both 0
    # nothing to find: undefined, whatever was flagged
    assert math.isnan(f1_score(1.0, math.nan)) and math.isnan(f1_score(0.0, math.nan))
    # something to find, nothing found (nothing flagged: precision undefined): F1 is 0
    assert f1_score(math.nan, 0.0) == 0.0
    assert format_value(math.nan) == 'n/a' and format_value(None) == 'n/a'
    assert format_value(float('nan'), 1) == 'n/a'
    assert format_value(0.8) == '0.80' and format_value(12.34, 1) == '12.3'
    assert format_value(3, 0) == '3' and format_value(0.0) == '0.00'


# --- trial-wise scores ---------------------------------------------------------------------------
def test_trial_scores_known_answer():
    # 6 TP, 1 FP, 2 TN, 3 FN
    pairs = [(True, True)] * 6 + [(False, True)] + [(False, False)] * 2 + [(True, False)] * 3
    scores = TrialScores.count(pairs)
    assert scores == TrialScores(true_positive=6, false_positive=1, true_negative=2,
                                 false_negative=3)
    assert scores.trials == 12
    assert scores.accuracy == pytest.approx(8 / 12)
    assert scores.precision == pytest.approx(6 / 7)
    assert scores.recall == pytest.approx(6 / 9)
    p, r = 6 / 7, 6 / 9
    assert scores.f1 == pytest.approx(2 * p * r / (p + r))
    assert scores.as_tuple() == (scores.accuracy, scores.precision, scores.recall, scores.f1)
    assert scores.to_dict() == {'true_positive': 6, 'false_positive': 1, 'true_negative': 2,
                                'false_negative': 3, 'accuracy': scores.accuracy,
                                'precision': scores.precision, 'recall': scores.recall,
                                'f1': scores.f1}
    # 8 TP, 2 FN, 5 TN: nothing false flagged
    scores = TrialScores(8, 0, 5, 2)
    assert scores.accuracy == 13 / 15 and scores.precision == 1.0 and scores.recall == 0.8
    assert scores.f1 == pytest.approx(2 * 0.8 / 1.8)
    # the paper's slippery row: recall 0.82 with precision 1.00 -> F1 0.90
    assert TrialScores(41, 0, 0, 9).f1 == pytest.approx(0.90, abs=0.005)


def test_trial_scores_empty_cases_are_nan():
    # no slip and nothing flagged (the paper prints 1.00 / 1.00 / 0.00 / 0.00 here)
    nothing = TrialScores(0, 0, 10, 0)
    assert nothing.accuracy == 1.0
    assert all(math.isnan(v) for v in nothing.as_tuple()[1:])
    # every slip missed, nothing flagged: precision undefined, recall 0, F1 0
    all_missed = TrialScores(0, 0, 5, 5)
    assert math.isnan(all_missed.precision) and all_missed.recall == 0.0
    assert all_missed.f1 == 0.0 and all_missed.accuracy == 0.5
    # only false flags, no slip: precision 0, recall undefined
    false_only = TrialScores(0, 3, 1, 0)
    assert false_only.precision == 0.0 and math.isnan(false_only.recall)
    assert math.isnan(false_only.f1)
    # flags and slips, none matching: both 0 and defined, F1 0
    assert TrialScores(0, 3, 0, 2).f1 == 0.0
    assert math.isnan(TrialScores(0, 0, 0, 0).accuracy)
    assert [format_value(v) for v in nothing.as_tuple()] == ['1.00', 'n/a', 'n/a', 'n/a']


# --- onset matching ------------------------------------------------------------------------------
def test_match_onsets_under_each_callers_rule():
    onsets, flags = [1.0, 2.0], [1.05, 1.5, 2.2]
    # closed loop: 1 s, before the next onset: 1.0 -> 1.05, 2.0 -> 2.2
    closed = match_onsets(onsets, flags, CLOSED_LOOP_MAX_LATENCY, before_next_onset=True)
    np.testing.assert_allclose(closed, [0.05, 0.2])
    # slip set's rule (0.5 s, no next-onset cut): the same here
    np.testing.assert_allclose(match_onsets(onsets, flags, MAX_LATENCY, False), [0.05, 0.2])
    # 0.1 s: 2.2 is 0.2 s after the second onset, too late
    short = match_onsets(onsets, flags, 0.1, before_next_onset=False)
    assert short[0] == pytest.approx(0.05) and math.isnan(short[1])


def test_the_next_onset_closes_an_onsets_window_only_when_asked():
    onsets, flags = [1.0, 2.0], [2.2]  # the first flag after 1.0 comes after the next onset
    cut = match_onsets(onsets, flags, 1.5, before_next_onset=True)
    assert math.isnan(cut[0]) and cut[1] == pytest.approx(0.2)
    np.testing.assert_allclose(match_onsets(onsets, flags, 1.5, False), [1.2, 0.2])
    # a flag exactly at the next onset belongs to that onset
    at_next = match_onsets(onsets, [2.0], 1.5, before_next_onset=True)
    assert math.isnan(at_next[0]) and at_next[1] == 0.0


def test_match_onsets_known_answers_in_seconds():
    onsets = [1.0, 3.0, 5.0, 5.2]
    flags = [0.5, 1.04, 1.06, 3.09, 5.25, 9.0]
    latency = match_onsets(onsets, flags, 0.5, before_next_onset=True)
    # 1.0 -> 1.04; 3.0 -> 3.09; 5.0: its first flag 5.25 is after the next onset (5.2) ->
    # missed; 5.2 -> 5.25
    np.testing.assert_allclose(latency, [0.04, 0.09, math.nan, 0.05])
    assert math.isnan(match_onsets([2.0], [2.6], 0.5, True)[0])     # later than 0.5 s
    assert match_onsets([2.0], [2.0], 0.5, True)[0] == 0.0          # a flag at the onset
    assert match_onsets([], [1.0], 0.5, True).shape == (0,)
    assert np.isnan(match_onsets([1.0, 2.0], [], 0.5, True)).all()  # no flag: all missed
    # any order in, the onsets' order out
    np.testing.assert_allclose(match_onsets([5.2, 1.0], flags, 0.5, True), [0.05, 0.04])
    # the same onset twice: the first one's window closes at once (at the second)
    twice = match_onsets([1.0, 1.0], [1.04], 0.5, True)
    assert np.isnan(twice).sum() == 1 and np.nanmax(twice) == pytest.approx(0.04)


def test_max_latency_is_inclusive_to_the_sample():
    window = 1000                                          # 0.5 s at 2 kHz
    for before_next_onset in (True, False):
        edge = match_onsets(np.array([2000]), np.array([3000]), window, before_next_onset)
        late = match_onsets(np.array([2000]), np.array([3001]), window, before_next_onset)
        assert edge[0] == 1000 and math.isnan(late[0])
    # in seconds (closed loop, 0.5 ms samples): a flag at onset + 1 s counts, one sample on not
    assert match_onsets([1.0], [2.0], CLOSED_LOOP_MAX_LATENCY, True)[0] == 1.0
    assert math.isnan(match_onsets([1.0], [2.0005], CLOSED_LOOP_MAX_LATENCY, True)[0])


def test_outside_windows_known_answer():
    first = np.array([0, 10, 25, 40])
    last = np.array([5, 12, 30, 41])
    windows = np.array([[8, 10], [28, 35]])
    # [0, 5] misses both; [10, 12] touches 10; [25, 30] overlaps 28; [40, 41] misses both
    np.testing.assert_array_equal(outside_windows(first, last, windows),
                                  [True, False, False, True])
    assert outside_windows(first, last, np.zeros((0, 2), np.int64)).all()


def test_latency_stats_known_answer():
    values = np.arange(1, 11) / 100.0  # 10..100 ms
    stats = latency_stats(values, missed=2)
    assert stats['count'] == 10 and stats['missed'] == 2
    assert stats['p50'] == pytest.approx(0.055)
    assert stats['p90'] == pytest.approx(0.091)
    assert stats['max'] == pytest.approx(0.10)
    assert stats['mean'] == pytest.approx(0.055)
    assert stats['fraction_below_100ms'] == pytest.approx(0.9)
    empty = latency_stats([], missed=3)
    assert empty['count'] == 0 and empty['missed'] == 3
    assert all(math.isnan(empty[key])
               for key in ('p50', 'p90', 'max', 'mean', 'fraction_below_100ms'))
    with pytest.raises(ValueError):
        latency_stats([0.1, float('nan')])
