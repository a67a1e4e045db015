"""The evaluation harness: task generation, aggregation, force CV, the command line."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from forte_evaluation import evaluate
from forte_evaluation.evaluate import (
    Task,
    benchmark_objects,
    calibration_dataset,
    force_cross_validation,
    make_tasks,
    record_from_result,
    run_benchmark,
)
from forte_evaluation.metrics import (
    TrialRecord,
    cue_counts,
    cue_table,
    mode_comparison_table,
    summarize,
)


def test_benchmark_objects_cover_the_paper_categories():
    full = benchmark_objects(quick=False)
    counts = {}
    for _, category in full:
        counts[category] = counts.get(category, 0) + 1
    assert counts == {'fragile_rigid': 7, 'fragile_deformable': 7, 'slippery': 9,
                      'everyday': 8}
    assert len({name for name, _ in full}) == 31
    quick = benchmark_objects(quick=True)
    assert len(quick) == 4 and set(quick) <= set(full)


def test_tasks_share_seeds_across_controllers():
    tasks = make_tasks([('raspberry', 'fragile_deformable'), ('soda_can', 'slippery')],
                       ['ON_OFF', 'NO_SLIP', 'FORTE'], trials=3, seed=5)
    assert len(tasks) == 2 * 3 * 3
    by_trial = {}
    for task in tasks:
        by_trial.setdefault((task.object_name, task.trial), set()).add(task.seed)
    assert all(len(seeds) == 1 for seeds in by_trial.values())  # same scene per controller
    assert len({next(iter(s)) for s in by_trial.values()}) == 6  # different across trials


def test_a_run_of_some_objects_repeats_the_full_runs_trials_of_them():
    full = make_tasks(benchmark_objects(quick=False), ['FORTE'], trials=10, seed=900)
    some = make_tasks([('pocky_box', 'slippery'), ('raw_egg', 'fragile_rigid')], ['FORTE'],
                      trials=10, seed=900)
    seeds = {(task.object_name, task.trial): task.seed for task in full}
    assert all(task.seed == seeds[task.object_name, task.trial] for task in some)
    quick = make_tasks(benchmark_objects(quick=True), ['FORTE'], trials=2, seed=0)
    assert all(task.seed == seeds[task.object_name, task.trial] - 900 for task in quick)
    assert len({task.seed for task in full}) == 310  # no two trials share a scene
    with pytest.raises(ValueError, match='not an object of the benchmark'):
        make_tasks([('teapot', 'everyday')], ['FORTE'], trials=1, seed=0)
    record = record_from_result({'success': True}, some[3])
    assert record.to_dict()['seed'] == some[3].seed == 900 + 1000 * 20 + 3  # rerun it alone


def fake_runner(task: Task) -> TrialRecord:
    """Deterministic stand-in: FORTE lifts everything, NO_SLIP only trial 0, ON_OFF never."""
    success = {'FORTE': True, 'NO_SLIP': task.trial == 0, 'ON_OFF': False}[task.controller]
    return record_from_result({'success': success, 'outcome': 'LIFTED' if success else
                               'DROPPED', 'slip_onset_times': [1.0],
                               'slip_flag_times': [1.05] if task.trial % 2 else []}, task)


def test_run_benchmark_aggregates_in_task_order():
    tasks = make_tasks([('raspberry', 'fragile_deformable')], ['ON_OFF', 'NO_SLIP', 'FORTE'],
                       trials=4, seed=0)
    seen = []
    records = run_benchmark(tasks, 1, lambda done, total, record: seen.append(done),
                            runner=fake_runner)
    assert seen == [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]
    assert [(r.controller, r.trial) for r in records] == [
        (t.controller, t.trial) for t in tasks]
    summary = summarize(records)['fragile_deformable']
    assert summary['success']['FORTE'].successes == 4
    assert summary['success']['NO_SLIP'].successes == 1
    assert summary['success']['ON_OFF'].successes == 0
    slip = summary['slip']  # trials 1 and 3 flagged the slip 50 ms after onset
    assert (slip.true_positive, slip.false_negative, slip.false_positive) == (2, 2, 0)
    forte = [r for r in records if r.controller == 'FORTE']
    assert [r.latencies for r in forte] == [[], pytest.approx([0.05]), [],
                                            pytest.approx([0.05])]
    assert [r.missed_onsets for r in forte] == [1, 0, 1, 0]


def test_parallel_workers_give_the_serial_results_in_task_order():
    tasks = make_tasks([('raspberry', 'fragile_deformable'), ('soda_can', 'slippery')],
                       ['NO_SLIP', 'FORTE'], trials=1, seed=3)
    serial = run_benchmark(tasks, 1)
    parallel = run_benchmark(tasks, 2)  # spawned workers, same seeds: same trials
    assert [(r.object_name, r.controller) for r in parallel] == [
        (t.object_name, t.controller) for t in tasks]
    assert [r.to_dict() for r in parallel] == [r.to_dict() for r in serial]


def test_record_from_result_reads_attributes_and_dicts():
    class Result:
        success = True
        outcome = 'LIFTED'
        object_state = 'HELD'
        slip_true = True
        slip_predicted = False
        max_true_force = 1.5
        duration = 7.0

    record = record_from_result(Result(), Task('soda_can', 'slippery', 'FORTE', 3, 0))
    assert record.success and record.slip_true and not record.slip_predicted
    assert record.outcome == 'LIFTED' and record.object_state == 'HELD'
    assert record.object_state_at_outcome == ''
    Result.object_state_at_outcome = 'HELD'
    assert record_from_result(Result(), Task('soda_can', 'slippery', 'FORTE', 3, 0)
                              ).object_state_at_outcome == 'HELD'
    assert record.max_true_force == 1.5 and record.trial == 3
    empty = record_from_result({}, Task('soda_can', 'slippery', 'FORTE', 0, 0))
    assert not empty.success and not empty.slip_true and np.isnan(empty.duration)


def test_record_latencies_follow_the_closed_loop_rule():
    """Onsets matched within 1 s and before the next onset (slip_metrics' closed-loop rule)."""
    task = Task('soda_can', 'slippery', 'FORTE', 0, 0)

    def latencies(onsets, flags):
        record = record_from_result({'slip_onset_times': onsets, 'slip_flag_times': flags},
                                    task)
        return record.latencies, record.missed_onsets

    caught, missed = latencies([1.0, 2.0], [1.05, 1.5, 2.2])
    assert caught == pytest.approx([0.05, 0.2]) and missed == 0
    # the flag after 1.0 comes after the next onset: it answers 2.0 only
    caught, missed = latencies([2.0, 1.0], [2.2])           # any order: matched in time order
    assert caught == pytest.approx([0.2]) and missed == 1
    assert latencies([1.0], [2.0]) == ([1.0], 0)            # exactly 1 s later: caught
    assert latencies([1.0], [2.0005]) == ([], 1)            # one sample (0.5 ms) later: missed
    assert latencies([], [1.0]) == ([], 0)


def test_each_onset_gets_the_cue_that_found_it_first():
    """Flags and gross-slip tightenings matched to the onsets by the same rule; the earlier
    cue wins, a tie goes to the vibration cue, neither within 1 s counts as neither; the
    onset types follow their onsets into time order."""
    result = {'slip_onset_times': [5.0, 1.0, 3.0, 7.0], 'slip_onset_types': [3, 2, 2, 1],
              'slip_flag_times': [1.30, 3.10, 5.05], 'gross_slip_times': [1.20, 3.10, 6.5]}
    record = record_from_result(result, Task('pocky_box', 'slippery', 'FORTE', 0, 0))
    assert record.onset_cues == [(2, 'lift monitor'), (2, 'vibration'), (3, 'vibration'),
                                 (1, 'neither')]
    counts = cue_counts([record])
    assert counts['gross'] == {'vibration': 1, 'lift monitor': 1, 'neither': 0}
    assert counts['all'] == {'vibration': 2, 'lift monitor': 1, 'neither': 1}
    table = cue_table([record, replace(record, controller='NO_SLIP')])  # FORTE only
    rows = {cells[0]: cells[1:] for line in table.splitlines()[2:]
            for cells in [[c.strip() for c in line.strip('|').split('|')]]}
    assert rows['all'] == ['4', '2', '1', '1'] and rows['stick-slip'] == ['1', '1', '0', '0']
    assert list(rows) == ['incipient', 'gross', 'stick-slip', 'all']
    # onset to the first of either cue, in time order: 1.0 by the tightening at 1.20, 3.0 at
    # 3.10 (both), 5.0 by the flag at 5.05; 7.0 by neither
    assert record.either_cue_latencies == pytest.approx([0.20, 0.10, 0.05])
    assert record.latencies == pytest.approx([0.30, 0.10, 0.05])
    nothing = record_from_result({}, Task('pocky_box', 'slippery', 'FORTE', 0, 0))
    assert nothing.onset_cues == [] and nothing.either_cue_latencies == []
    with pytest.raises(ValueError, match='2 slip onset times but 1 onset types'):
        record_from_result({'slip_onset_times': [1.0, 2.0], 'slip_onset_types': [3]},
                           Task('pocky_box', 'slippery', 'FORTE', 0, 0))


def test_force_cross_validation_on_the_calibration_rig():
    dataset = calibration_dataset(trials_per_indentor=5, hold_seconds=2.0, seed=1,
                                  indentors=['flat_wide', 'sphere'])
    trials = np.unique(dataset['trial'])
    assert trials.size == 10
    assert dataset['frames'].shape[1] == 6 and dataset['frames'].dtype == np.float32
    assert dataset['force'].shape == (dataset['frames'].shape[0],)
    # the quiet tare period has no load on the load cell, the hold has some
    first = dataset['trial'] == trials[0]
    assert np.nanmax(np.abs(dataset['force'][first][:int(dataset['tare_samples'])])) < 0.05
    assert np.nanmax(dataset['force']) > 0.5
    results = force_cross_validation(dataset, folds=10, stride=50)
    for key in ('with_history', 'without_history'):
        entry = results[key]
        assert entry['trials'] == 10 and entry['points'] > 100
        assert 0.0 < entry['rmse'] < 0.5 * (entry['force_range'][1] - entry['force_range'][0])
        assert entry['mae'] <= entry['rmse']
        assert set(entry['per_indentor']) == {'flat_wide', 'sphere'}


def test_command_line_force_only_writes_results(tmp_path, capsys):
    assert evaluate.main(['--quick', '--skip-grasp', '--output', str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert 'paper RMSE' in printed and '0.187' in printed
    data = json.loads((tmp_path / 'results.json').read_text())
    assert data['config']['quick'] is True
    assert data['force']['with_history']['rmse'] > 0
    assert (tmp_path / 'results.md').read_text().startswith('# FORTE evaluation')


@pytest.mark.slow
def test_quick_evaluation_end_to_end(tmp_path, capsys):
    assert evaluate.main(['--quick', '--skip-force', '--jobs', '2',
                          '--output', str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert 'Fragile / Rigid' in printed and 'p90' in printed
    data = json.loads((tmp_path / 'results.json').read_text())
    assert len(data['trials']) == 4 * 2 * 3
    overall = data['grasp']['overall']['success']
    assert sum(entry['trials'] for entry in overall.values()) == 24
    # the controller's outcome against the simulator's truth, per controller
    assert 'contradicts truth' in printed and 'outcome \\ truth' in printed
    for controller in ('FORTE', 'NO_SLIP', 'ON_OFF'):
        entry = data['truth'][controller]
        assert entry['final']['trials'] == entry['at_outcome']['trials'] == 8
        assert sum(sum(row.values()) for row in entry['final']['matrix'].values()) == 8
    assert all(trial['object_state_at_outcome'] for trial in data['trials'])
    # both slip detector modes, each a whole benchmark, compared side by side
    assert data['config']['slip_modes'] == ['sequential', 'paper']
    assert set(data['by_slip_mode']) == {'sequential', 'paper'}
    for mode, entry in data['by_slip_mode'].items():
        assert len(entry['trials']) == 24
        assert {trial['slip_mode'] for trial in entry['trials']} == {mode}
        # either cue finds at least the onsets the flags find, out of the same onsets
        vibration, either = entry['slip_latency'], entry['slip_latency_either_cue']
        assert either['count'] >= vibration['count']
        assert either['count'] + either['missed'] == vibration['count'] + vibration['missed']
    assert data['trials'] == data['by_slip_mode']['sequential']['trials']
    assert 'first slip flag or gross-slip tightening' in printed
    assert 'FORTE in each slip detector mode' in printed
    assert 'FORTE (sequential)' in printed and 'Prec. (paper)' in printed


def test_mode_comparison_table_counts_each_mode_separately():
    """Known answer: robust lifts 2/2 with one correct flag, paper 1/2 with one false flag."""
    def record(mode_success: bool, slip_true: bool, slip_predicted: bool) -> TrialRecord:
        return TrialRecord(object_name='soda_can', category='slippery', controller='FORTE',
                           trial=0, success=mode_success, outcome='LIFTED',
                           object_state='HELD', slip_true=slip_true,
                           slip_predicted=slip_predicted)

    table = mode_comparison_table({
        'robust': [record(True, True, True), record(True, False, False)],
        'paper': [record(True, False, True), record(False, False, False)],
    })
    slippery = next(line for line in table.splitlines() if line.startswith('| Slippery'))
    cells = [cell.strip() for cell in slippery.strip('|').split('|')]
    assert cells == ['Slippery', '100.0% (2/2)', '1.00', '50.0% (1/2)', '0.00']
