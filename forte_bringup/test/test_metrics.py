"""Known-answer tests of the evaluation metrics and tables."""
from __future__ import annotations

import math

import numpy as np
import pytest

from forte_bringup.metrics import (
    PAPER_RESULTS,
    Rate,
    SlipScores,
    TrialRecord,
    confusion,
    confusion_json,
    confusion_table,
    contradiction_count,
    contradicts_carried,
    detection_latencies,
    force_table,
    latency_stats,
    latency_table,
    result_table,
    slip_scores,
    summarize,
    summary_json,
)


def record(category='slippery', controller='FORTE', success=True, slip_true=False,
           slip_predicted=False, name='soda_can', trial=0) -> TrialRecord:
    return TrialRecord(object_name=name, category=category, controller=controller,
                       trial=trial, success=success, slip_true=slip_true,
                       slip_predicted=slip_predicted)


def test_paper_row_reproduces_from_counts():
    # Overall row of the paper: 285/310 -> 91.9 %, 163/310 -> 52.6 %, 180/300 -> 60.0 %
    assert str(Rate(285, 310)) == '91.9% (285/310)'
    assert str(Rate(163, 310)) == '52.6% (163/310)'
    assert str(Rate(180, 300)) == '60.0% (180/300)'
    assert str(Rate(0, 0)) == 'n/a' and math.isnan(Rate(0, 0).value)


def test_slip_scores_known_answer():
    # 6 TP, 1 FP, 2 TN, 3 FN
    records = ([record(slip_true=True, slip_predicted=True)] * 6
               + [record(slip_true=False, slip_predicted=True)]
               + [record()] * 2
               + [record(slip_true=True)] * 3)
    scores = slip_scores(records)
    assert (scores.true_positive, scores.false_positive, scores.true_negative,
            scores.false_negative) == (6, 1, 2, 3)
    assert scores.accuracy == pytest.approx(8 / 12)
    assert scores.precision == pytest.approx(6 / 7)
    assert scores.recall == pytest.approx(6 / 9)
    p, r = 6 / 7, 6 / 9
    assert scores.f1 == pytest.approx(2 * p * r / (p + r))


def test_slip_conventions_of_the_paper():
    # no predicted positives: precision 1.0 (correct abstention); no positives: recall 0
    nothing = SlipScores(0, 0, 10, 0)
    assert nothing.as_tuple() == (1.0, 1.0, 0.0, 0.0)  # the paper's fragile/deformable row
    all_missed = SlipScores(0, 0, 5, 5)
    assert all_missed.precision == 1.0 and all_missed.recall == 0.0 and all_missed.f1 == 0.0
    assert math.isnan(SlipScores(0, 0, 0, 0).accuracy)
    # paper's slippery row: recall 0.82 with precision 1.00 -> F1 0.90
    assert SlipScores(41, 0, 0, 9).f1 == pytest.approx(0.90, abs=0.005)


def test_summarize_groups_by_category_and_controller():
    records = []
    for controller, wins in (('FORTE', 9), ('NO_SLIP', 3), ('ON_OFF', 8)):
        for trial in range(10):
            records.append(record(controller=controller, success=trial < wins, trial=trial))
    for controller in ('FORTE', 'NO_SLIP', 'ON_OFF'):
        for trial in range(10):
            records.append(record(category='fragile_deformable', controller=controller,
                                  success=controller != 'ON_OFF', name='raspberry',
                                  trial=trial))
    summary = summarize(records)
    assert list(summary) == ['fragile_deformable', 'slippery', 'overall']  # paper order
    assert summary['slippery']['success']['FORTE'] == Rate(9, 10)
    assert summary['slippery']['success']['NO_SLIP'] == Rate(3, 10)
    assert summary['fragile_deformable']['success']['ON_OFF'] == Rate(0, 10)
    assert summary['overall']['success']['FORTE'] == Rate(19, 20)
    assert summary['overall']['objects'] == 2
    table = result_table(records)
    lines = table.splitlines()
    assert lines[0].startswith('| Category') and 'On-Off' in lines[0] and 'F1' in lines[0]
    assert any('90.0% (9/10)' in line and 'Slippery' in line for line in lines)
    assert any('paper' in line and '88.8% (80/90)' in line for line in lines)  # slippery
    assert 'Overall' in table and '95.0% (19/20)' in table
    assert 'paper' not in result_table(records, with_paper=False)
    data = summary_json(records)
    assert data['overall']['success']['FORTE'] == {'successes': 19, 'trials': 20,
                                                   'rate': 0.95}
    assert data['slippery']['paper'] == PAPER_RESULTS['slippery']


def test_detection_latencies_match_each_onset_to_its_first_flag():
    onsets = [1.0, 3.0, 5.0, 5.2]
    flags = [0.5, 1.04, 1.06, 3.09, 5.25, 9.0]
    latencies, missed = detection_latencies(onsets, flags, horizon=0.5)
    # 1.0 -> 1.04; 3.0 -> 3.09; 5.0: next flag 5.25 is after the next onset (5.2) -> missed;
    # 5.2 -> 5.25
    assert latencies == pytest.approx([0.04, 0.09, 0.05])
    assert missed == 1
    assert detection_latencies([2.0], [2.6], horizon=0.5) == ([], 1)
    assert detection_latencies([2.0], [2.0], horizon=0.5) == ([0.0], 0)
    assert detection_latencies([], [1.0]) == ([], 0)


def test_latency_stats_known_answer():
    values = np.arange(1, 11) / 100.0  # 10..100 ms
    stats = latency_stats(values, missed=2)
    assert stats['count'] == 10 and stats['missed'] == 2
    assert stats['p50'] == pytest.approx(0.055)
    assert stats['p90'] == pytest.approx(0.091)
    assert stats['max'] == pytest.approx(0.10)
    assert stats['fraction_below_100ms'] == pytest.approx(0.9)
    empty = latency_stats([])
    assert empty['count'] == 0 and math.isnan(empty['p50'])
    with pytest.raises(ValueError):
        latency_stats([0.1, float('nan')])
    table = latency_table(stats)
    assert '55.0' in table and '91.0' in table and '100.0' in table and '< 100' in table


def test_force_table_shows_ours_and_paper():
    table = force_table({'with_history': {'rmse': 0.1234, 'mae': 0.0987}})
    assert '0.123' in table and '0.099' in table and '0.187' in table and '0.211' in table
    assert 'n/a' in table  # the missing without-history entry


def outcome_record(outcome, truth, controller='FORTE', at_outcome=''):
    return TrialRecord(object_name='soda_can', category='slippery', controller=controller,
                       trial=0, success=outcome == 'LIFTED' and truth == 'HELD',
                       outcome=outcome, object_state=truth,
                       object_state_at_outcome=at_outcome)


@pytest.mark.parametrize('outcome, truth, wrong', [
    ('LIFTED', 'HELD', False), ('LIFTED', 'RESTING', True), ('LIFTED', 'DROPPED', True),
    ('LIFTED', 'CRUSHED', False),        # crushed in the grasp: carrying not judged
    ('NOT_CARRIED', 'RESTING', False), ('NOT_CARRIED', 'HELD', True),
    ('DROPPED', 'DROPPED', False), ('DROPPED', 'RESTING', False), ('DROPPED', 'HELD', True),
    ('NO_CONTACT', 'RESTING', False), ('FAULT', 'HELD', False),
])
def test_contradiction_on_carrying(outcome, truth, wrong):
    assert contradicts_carried(outcome, truth) is wrong


def test_confusion_matrix_known_answer():
    records = ([outcome_record('LIFTED', 'HELD')] * 5
               + [outcome_record('LIFTED', 'RESTING', at_outcome='HELD')]
               + [outcome_record('NOT_CARRIED', 'RESTING')] * 3
               + [outcome_record('DROPPED', 'HELD')]
               + [outcome_record('LIFTED', 'HELD', controller='ON_OFF')] * 2)
    matrix = confusion(records, 'FORTE')
    assert matrix == {'LIFTED': {'HELD': 5, 'RESTING': 1}, 'NOT_CARRIED': {'RESTING': 3},
                      'DROPPED': {'HELD': 1}}
    assert contradiction_count(matrix) == (2, 10)
    # at the moment of the outcome the one that fell later was still held
    assert confusion(records, 'FORTE', at_outcome=True)['LIFTED'] == {'HELD': 6}
    assert contradiction_count(confusion(records, 'FORTE', at_outcome=True)) == (1, 10)
    data = confusion_json(records)
    assert set(data) == {'FORTE', 'ON_OFF'}
    assert data['FORTE']['final']['contradictions'] == 2
    assert data['FORTE']['at_outcome']['contradictions'] == 1
    assert data['ON_OFF']['final'] == {'matrix': {'LIFTED': {'HELD': 2}},
                                       'contradictions': 0, 'trials': 2}
    table = confusion_table(records)
    lines = table.splitlines()
    assert [c.strip() for c in lines[0].split('|')[3:-1]] == [
        'HELD', 'RESTING', 'DROPPED', 'BROKEN', 'CRUSHED', 'total']
    lifted = next(line for line in lines if 'FORTE' in line and 'LIFTED' in line)
    assert [c.strip() for c in lifted.split('|')[3:8]] == ['5', '1!', '.', '.', '.']
    assert '**2/10 (20.0%)**' in table and '**0/2 (0.0%)**' in table
