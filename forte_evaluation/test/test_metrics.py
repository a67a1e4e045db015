"""Known-answer tests of the evaluation metrics and tables."""
from __future__ import annotations

import math

import numpy as np
import pytest

from forte_evaluation.metrics import (
    PAPER_RESULTS,
    Rate,
    TrialRecord,
    confusion,
    confusion_json,
    confusion_table,
    contradiction_count,
    contradicts_carried,
    force_table,
    latency_table,
    result_table,
    slip_scores,
    summarize,
    summary_json,
)
from forte_perception.evaluation.slip_metrics import TrialScores, latency_stats


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


def test_slip_scores_count_the_records_trial_wise():
    # 6 TP, 1 FP, 2 TN, 3 FN (the scores of these counts: test_slip_metrics.py)
    records = ([record(slip_true=True, slip_predicted=True)] * 6
               + [record(slip_true=False, slip_predicted=True)]
               + [record()] * 2
               + [record(slip_true=True)] * 3)
    assert slip_scores(records) == TrialScores(true_positive=6, false_positive=1,
                                               true_negative=2, false_negative=3)


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
    # no slip and nothing flagged: precision, recall, F1 undefined (n/a); the paper's row
    # keeps its own 1.00 / 1.00 / 0.00 / 0.00
    cells = [[cell.strip() for cell in line.strip('|').split('|')] for line in lines]
    deformable = cells.index(next(c for c in cells if c[0] == 'Fragile / Deformable'))
    assert cells[deformable][-4:] == ['1.00', 'n/a', 'n/a', 'n/a']
    assert cells[deformable + 1][0] == 'paper'
    assert cells[deformable + 1][-4:] == ['1.00', '1.00', '0.00', '0.00']
    data = summary_json(records)
    assert data['overall']['slip']['accuracy'] == 1.0
    assert math.isnan(data['overall']['slip']['precision'])
    assert data['overall']['success']['FORTE'] == {'successes': 19, 'trials': 20,
                                                   'rate': 0.95}
    assert data['slippery']['paper'] == PAPER_RESULTS['slippery']


def test_latency_table_in_milliseconds():
    table = latency_table(latency_stats(np.arange(1, 11) / 100.0, missed=2))  # 10..100 ms
    row = [cell.strip() for cell in table.splitlines()[2].strip('|').split('|')]
    assert row == ['10', '2', '55.0', '91.0', '100.0', '90.0', '< 100 (typical)']
    empty = [cell.strip() for cell in
             latency_table(latency_stats([], missed=4)).splitlines()[2].strip('|').split('|')]
    assert empty == ['0', '4', 'n/a', 'n/a', 'n/a', 'n/a', '< 100 (typical)']


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
