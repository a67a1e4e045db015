"""tools/results_page.py: docs/results.md is generated from the evaluation's JSON files.

The inputs here are small hand-made documents in the formats that
``python -m forte_evaluation.evaluate`` (``results.json``) and
``python -m forte_evaluation.slip_benchmark`` (``MODE.json``) write, with numbers worked out
by hand; the page must show exactly those, say what was not given, refuse a missing file
(exit 2, naming the file and the command that makes it) and be the same bytes for the same
inputs.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import results_page  # noqa: E402

TOOL = Path(__file__).resolve().parents[1] / 'results_page.py'


def trial(controller: str, number: int, success: bool, slip: tuple[bool, bool] = (False, False),
          outcome: str = 'LIFTED', state: str = 'HELD', at_outcome: str = 'HELD',
          latencies: tuple[float, ...] = (), missed: int = 0) -> dict:
    """One row of ``results.json``'s ``trials`` (the TrialRecord fields + slip_mode)."""
    return {'object_name': 'soap_bar', 'category': 'slippery', 'controller': controller,
            'trial': number, 'success': success, 'outcome': outcome, 'object_state': state,
            'slip_true': slip[0], 'slip_predicted': slip[1], 'latencies': list(latencies),
            'missed_onsets': missed, 'max_true_force': 3.0, 'duration': 9.0,
            'object_state_at_outcome': at_outcome, 'final_height': 0.03,
            'slip_mode': 'robust'}


def trials() -> list[dict]:
    """Five trials per controller on one slippery object, with these known numbers.

    - success: FORTE 4/5 (80.0%), W/o Slip 2/5 (40.0%), On-Off 1/5 (20.0%);
    - FORTE slip (truth, flag): 3 x (T, T), (F, T), (F, F): TP 3, FP 1, TN 1, FN 0, so
      accuracy 0.80, precision 0.75, recall 1.00, F1 0.857 -> 0.86;
    - FORTE latencies 0.05, 0.15, 0.07 s and 1 missed onset: 3 detected, p50 70.0 ms,
      p90 134.0 ms (linear: 0.07 + 0.8 * 0.08), max 150.0 ms, 66.7 % below 100 ms;
    - FORTE trial 4 reports LIFTED on an object RESTING at the end (held at the outcome):
      1/5 contradictions at the end, 0/5 at the outcome.
    """
    forte = [trial('FORTE', 0, True, (True, True), latencies=(0.05, 0.15)),
             trial('FORTE', 1, True, (True, True), latencies=(0.07,), missed=1),
             trial('FORTE', 2, True, (True, True)),
             trial('FORTE', 3, True, (False, True)),
             trial('FORTE', 4, False, (False, False), state='RESTING')]
    no_slip = [trial('NO_SLIP', i, i < 2, outcome='LIFTED' if i < 2 else 'NOT_CARRIED',
                     state='HELD' if i < 2 else 'RESTING',
                     at_outcome='HELD' if i < 2 else 'RESTING') for i in range(5)]
    on_off = [trial('ON_OFF', i, i < 1) for i in range(5)]
    return on_off + no_slip + forte


def evaluation_document(**extra) -> dict:
    """A results.json with one slip mode, a force entry and timings."""
    document = {'config': {'quick': False, 'trials': 5, 'seed': 7, 'jobs': 1,
                           'controllers': ['ON_OFF', 'NO_SLIP', 'FORTE'],
                           'slip_modes': ['robust']},
                'timings': {'grasp_benchmark_robust_s': 12.34, 'force_cv_s': 5.678},
                'by_slip_mode': {'robust': {'trials': trials()}},
                'force': {'with_history': {'rmse': 0.1234, 'mae': 0.0456,
                                           'per_indentor': {'sphere': 0.0987},
                                           'points': 321, 'trials': 24,
                                           'force_range': [0.0, 7.5]},
                          'without_history': {'rmse': 0.2346, 'mae': 0.1567,
                                              'per_indentor': {'sphere': 0.2109},
                                              'points': 321, 'trials': 24,
                                              'force_range': [0.0, 7.5]}}}
    document.update(extra)
    return document


def slip_metrics(scenes: int, events: int, detected: int, precision: float | None) -> dict:
    """One row of the slip benchmark's per-family / pooled metrics."""
    return {'scenes': scenes, 'events': events, 'detected': detected,
            'recall': detected / events, 'latency_p50_ms': 41.0, 'latency_p90_ms': 77.0,
            'runs': 30, 'false_runs': 3, 'precision': precision, 'f1': 0.81,
            'holding_min': 2.5, 'false_per_min_holding': 1.2, 'scenes_with_false': 2,
            'cpu_us_per_update': 0.93}


def slip_document(mode: str) -> dict:
    """A slip benchmark MODE.json with one held-out family and one event kind."""
    return {'config': {'mode': mode, 'splits': ['held_out'], 'repeats': 3,
                       'dataset': {'hash': 'feedbeef12345678'}, 'scenes': 12},
            'results': {'held_out': {
                'families': {'ramp': slip_metrics(12, 30, 27, 0.9)},
                'groups': {'all': slip_metrics(12, 30, 27, 0.9)},
                'kinds': {'signal stick_slip': {'events': 30, 'detected': 27, 'recall': 0.9,
                                                'latency_p50_ms': 41.0,
                                                'latency_p90_ms': 77.0}}}},
            'timings': {'detector_wall_s': 3.21}, 'scenes': []}


def write(path: Path, document: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=1))
    return path


def page(tmp_path: Path, evaluation: dict, slips: dict[str, dict] | None = None) -> str:
    """Run the tool in-process on these documents; return the page."""
    source = write(tmp_path / 'eval' / 'results.json', evaluation)
    slip_paths = [write(tmp_path / 'slip' / f'{mode}.json', doc)
                  for mode, doc in (slips or {}).items()]
    output = tmp_path / 'docs' / 'results.md'
    argv = ['--evaluation', str(source), '--slip', *map(str, slip_paths),
            '--output', str(output)]
    assert results_page.main(argv) == 0
    return output.read_text()


def rows(text: str) -> list[list[str]]:
    """Every markdown table row of ``text`` as its stripped cells."""
    return [[cell.strip() for cell in line.strip().strip('|').split('|')]
            for line in text.splitlines() if line.startswith('|')]


def test_grasp_success_and_slip_scores_are_the_inputs_next_to_the_papers(tmp_path):
    text = page(tmp_path, evaluation_document())
    table = rows(text)
    # On-Off, W/o Slip, FORTE, then accuracy / precision / recall / F1
    assert ['Slippery', '1', '20.0% (1/5)', '40.0% (2/5)', '80.0% (4/5)',
            '0.80', '0.75', '1.00', '0.86'] in table
    assert ['Overall', '1', '20.0% (1/5)', '40.0% (2/5)', '80.0% (4/5)',
            '0.80', '0.75', '1.00', '0.86'] in table
    # the paper's slippery row and its overall row as published
    assert ['paper', '9', '88.8% (80/90)', '31.1% (28/90)', '88.8% (80/90)',
            '0.91', '1.00', '0.82', '0.90'] in table
    assert ['paper', '31', '60.0% (180/300)', '52.6% (163/310)', '91.9% (285/310)',
            '0.93', '1.00', '0.84', '0.91'] in table
    # the trial-wise confusion counts behind the scores
    assert ['`robust`', 'Slippery', '3', '1', '1', '0', '0.80', '0.75', '1.00', '0.86',
            '0.91 / 1.00 / 0.82 / 0.90'] in table


def test_latency_contradictions_force_and_timings_are_the_inputs(tmp_path):
    table = rows(page(tmp_path, evaluation_document()))
    assert ['3', '1', '70.0', '134.0', '150.0', '66.7', '< 100 (typical)'] in table
    assert ['`robust`', 'FORTE', '1/5', '0/5'] in table
    assert ['`robust`', 'NO_SLIP', '0/5', '0/5'] in table
    assert ['latest frame + 2.5/5/10 s means (24 features)', '0.123', '0.046',
            '0.187'] in table
    assert ['latest frame only (6 features)', '0.235', '0.157', '0.211'] in table
    assert ['sphere', '0.099', '0.211'] in table
    timings = {row[1]: row[2] for row in table if len(row) == 3 and row[0].startswith('`')}
    assert timings['grasp_benchmark_robust_s'] == '12.3'
    assert timings['force_cv_s'] == '5.7'


def test_slip_benchmark_tables_per_mode(tmp_path):
    text = page(tmp_path, evaluation_document(),
                {'robust': slip_document('robust'), 'paper': slip_document('paper')})
    table = rows(text)
    for mode in ('robust', 'paper'):
        assert f'{mode} mode, held-out part' in text
        assert [f'`{mode}`', 'held-out', '12', '30', '0.90', '0.90', '0.81', '41', '77',
                '1.2', '0.93'] in table
    # the benchmark's own family table: scenes, events, detected, recall, ...
    assert any(row[:5] == ['ramp', '12', '30', '27', '0.90'] for row in table)
    assert ['signal stick_slip', '30', '27', '0.90', '41', '77'] in table
    assert 'feedbeef12345678' in text
    assert 'detector_wall_s' in text and '3.2' in text


def test_an_undefined_value_prints_as_n_a_not_a_number(tmp_path):
    slip = slip_document('paper')
    slip['results']['held_out']['groups']['all']['precision'] = None
    table = rows(page(tmp_path, evaluation_document(), {'paper': slip}))
    assert ['`paper`', 'held-out', '12', '30', 'n/a', '0.90', '0.81', '41', '77', '1.2',
            '0.93'] in table


def test_what_was_not_given_is_said_not_filled_in(tmp_path):
    document = evaluation_document()
    del document['force']
    text = page(tmp_path, document)
    assert 'slip benchmark | not given' in text
    assert 'Not on this page: the slip benchmark' in text
    assert 'Not on this page: force estimation' in text
    assert 'RMSE [N]' not in text
    assert 'mode, held-out part' not in text


def test_header_names_the_command_the_files_and_their_config(tmp_path):
    document = evaluation_document()
    document['config']['commit'] = 'abc1234'
    text = page(tmp_path, document, {'robust': slip_document('robust')})
    head = text.split('## Grasp success')[0]
    assert 'generated' in head.lower()
    assert 'python tools/results_page.py --evaluation' in head
    assert str(tmp_path / 'eval' / 'results.json') in head
    assert str(tmp_path / 'slip' / 'robust.json') in head
    assert 'python -m forte_evaluation.evaluate' in head
    assert 'python -m forte_evaluation.slip_benchmark --mode robust' in head
    assert 'seed=7' in head and 'trials=5' in head and 'commit abc1234' in head
    assert 'make results' in head
    assert 'issue' not in text.lower()


def test_a_quick_run_is_marked_as_such(tmp_path):
    document = evaluation_document()
    document['config']['quick'] = True
    assert '`--quick` subset' in page(tmp_path, document)


def test_summaries_written_by_the_evaluation_are_accepted(tmp_path):
    from forte_evaluation.metrics import confusion_json, summary_json
    from forte_perception.evaluation.slip_metrics import latency_stats

    document = evaluation_document()
    records = results_page.trial_records(trials(), 'test')
    forte = [r for r in records if r.controller == 'FORTE']
    document['by_slip_mode']['robust'].update(
        grasp=json.loads(json.dumps(summary_json(records))), truth=confusion_json(records),
        slip_latency=latency_stats([v for r in forte for v in r.latencies],
                                   sum(r.missed_onsets for r in forte)))
    assert '80.0% (4/5)' in page(tmp_path, document)


def test_a_summary_that_contradicts_its_trials_is_refused(tmp_path, capsys):
    document = evaluation_document()
    document['by_slip_mode']['robust']['slip_latency'] = {
        'count': 99, 'missed': 0, 'p50': 0.01, 'p90': 0.02, 'max': 0.03, 'mean': 0.02,
        'fraction_below_100ms': 1.0}
    source = write(tmp_path / 'results.json', document)
    output = tmp_path / 'results.md'
    code = results_page.main(['--evaluation', str(source), '--slip', '--output', str(output)])
    assert code == 2
    assert 'slip_latency' in capsys.readouterr().err
    assert not output.exists()


def test_same_inputs_give_the_same_bytes(tmp_path):
    evaluation = write(tmp_path / 'results.json', evaluation_document())
    slip = write(tmp_path / 'robust.json', slip_document('robust'))
    output = tmp_path / 'results.md'
    argv = ['--evaluation', str(evaluation), '--slip', str(slip), '--output', str(output)]
    assert results_page.main(argv) == 0
    first = output.read_bytes()
    output.unlink()
    assert results_page.main(argv) == 0
    assert output.read_bytes() == first
    assert first.endswith(b'\n') and not first.endswith(b'\n\n')


def run_tool(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(TOOL), *args], capture_output=True, text=True,
                          timeout=60, env=os.environ.copy())


def test_a_missing_evaluation_file_exits_2_naming_it_and_its_command(tmp_path):
    missing = tmp_path / 'nowhere' / 'results.json'
    output = tmp_path / 'results.md'
    result = run_tool('--evaluation', str(missing), '--slip', '--output', str(output))
    assert result.returncode == 2
    assert str(missing) in result.stderr
    assert 'python -m forte_evaluation.evaluate' in result.stderr
    assert not output.exists()


def test_a_missing_slip_file_exits_2_naming_it_and_its_command(tmp_path):
    evaluation = write(tmp_path / 'results.json', evaluation_document())
    missing = tmp_path / 'bench' / 'paper.json'
    output = tmp_path / 'results.md'
    code = results_page.main(['--evaluation', str(evaluation), '--slip', str(missing),
                              '--output', str(output)])
    assert code == 2
    assert not output.exists()
    result = run_tool('--evaluation', str(evaluation), '--slip', str(missing),
                      '--output', str(output))
    assert result.returncode == 2
    assert str(missing) in result.stderr
    assert 'python -m forte_evaluation.slip_benchmark --mode paper' in result.stderr
