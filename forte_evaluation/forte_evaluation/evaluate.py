"""The paper's evaluation reproduced in simulation: ``python -m forte_evaluation.evaluate``.

1. Grasp benchmark: every object of the simulated catalogue (31 types in the paper's 4
   categories) x ``--trials`` trials (10 as in the paper) x the three controllers
   (On-Off, W/o Slip = NO_SLIP, FORTE), each trial a closed loop of simulator + perception +
   grasp state machine without ROS (:func:`forte_evaluation.closed_loop.run_trial`), spread
   over ``--jobs`` processes; once per slip detector mode of ``--slip-modes``
   (``robust``, the perception node's default, and ``paper``), with every table per mode
   and FORTE's success and slip precision of the modes side by side. Tables: grasp
   success per category and overall; FORTE's trial-wise slip detection accuracy /
   precision / recall / F1 against the simulator's ground truth; the slip detection
   latency distribution (true onset to the first slip flag, p50 / p90 / max); the
   confusion matrix of each controller's own outcome against the simulator's ground-truth
   object state (at the end of the trial, and at the moment of the outcome), with the
   trials in which the controller contradicts the truth on whether the object was
   carried.
2. Force estimation: 10-fold trial-wise cross-validation of the SVR force model on the
   simulated calibration rig (6 indentors), with the history features (24) and without
   them (latest frame only, 6), as in the paper.

Every table prints the paper's numbers next to ours. Results (every trial, the summaries,
timings) go to ``out/evaluation/results.json`` and the tables to
``out/evaluation/results.md``. ``--quick`` runs a subset (one object per category,
2 trials, a small force CV) in under a minute for CI.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from forte_evaluation.metrics import (
    TrialRecord,
    confusion_json,
    confusion_table,
    cue_counts,
    cue_table,
    first_cue,
    force_table,
    latency_table,
    mode_comparison_table,
    result_table,
    summary_json,
)
from forte_perception.evaluation.slip_metrics import (
    CLOSED_LOOP_MAX_LATENCY,
    latency_stats,
    match_onsets,
)
from forte_perception.slip.params import MODES, RECOMMENDED_MODE

CONTROLLERS = ('ON_OFF', 'NO_SLIP', 'FORTE')
#: Slip modes of the benchmark: the node's default first, then the others (the paper's).
SLIP_MODES = (RECOMMENDED_MODE, *(mode for mode in MODES if mode != RECOMMENDED_MODE))


@dataclass(frozen=True)
class Task:
    """One grasp trial to run."""

    object_name: str
    category: str
    controller: str
    trial: int
    seed: int
    slip_mode: str = RECOMMENDED_MODE  # slip detector mode of the perception pipeline


def benchmark_objects(quick: bool) -> list[tuple[str, str]]:
    """(object, category) pairs of the benchmark; ``quick``: the first one per category."""
    from forte_sim import CATEGORIES, objects_in_category

    pairs = []
    for category in CATEGORIES:
        names = objects_in_category(category)
        pairs += [(name, category) for name in (names[:1] if quick else names)]
    return pairs


def make_tasks(objects: Sequence[tuple[str, str]], controllers: Sequence[str], trials: int,
               seed: int) -> list[Task]:
    """Every (object, controller, trial); the seed depends on object and trial only, so the
    three controllers face the same placement, material spread and noise in a trial.

    The scene seed of trial ``t`` of an object is ``seed + 1000 i + t``, with ``i`` the
    object's place in the full benchmark (:func:`benchmark_objects`), not in ``objects``: a
    run of some objects (``--objects``, ``--quick``) repeats the full run's trials of them.
    Two base seeds fewer than ``trials`` apart share trials (seeds 0 and 1 share 9 of 10).
    """
    place = {name: index for index, (name, _) in enumerate(benchmark_objects(quick=False))}
    tasks = []
    for name, category in objects:
        if name not in place:
            raise ValueError(f'{name!r} is not an object of the benchmark: {list(place)}')
        object_index = place[name]
        for trial in range(trials):
            trial_seed = seed + 1000 * object_index + trial
            tasks += [Task(name, category, controller, trial, trial_seed)
                      for controller in controllers]
    return tasks


def run_task(task: Task) -> TrialRecord:
    """Run one closed-loop trial (in a worker process) and condense it to a record."""
    from forte_evaluation.closed_loop import run_trial

    result = run_trial(object_name=task.object_name, controller=task.controller,
                       seed=task.seed, trial=task.trial, slip_mode=task.slip_mode)
    return record_from_result(result, task)


def _get(result: object, name: str, default: object = None) -> object:
    if isinstance(result, dict):
        return result.get(name, default)
    return getattr(result, name, default)


def record_from_result(result: object, task: Task) -> TrialRecord:
    """A :class:`TrialRecord` from a ``run_trial`` result (attribute or dict access).

    Uses the result's ``success``, ``outcome``, ``object_state``, ``slip_true``,
    ``slip_predicted``, ``slip_onset_times`` / ``slip_flag_times`` (for latencies; when
    present), ``max_true_force``, ``duration`` and ``final_height`` fields. Latencies: each
    onset (in time order) against the flags by
    :func:`~forte_perception.evaluation.slip_metrics.match_onsets`, within
    ``CLOSED_LOOP_MAX_LATENCY`` and before the next onset; the gross-slip tightenings
    (``gross_slip_times``) are matched the same way, and each onset gets the cue that found
    it first (:func:`~forte_evaluation.metrics.first_cue`, with its ``slip_onset_types``).
    """
    times = [float(t) for t in _get(result, 'slip_onset_times', []) or []]
    kinds = list(_get(result, 'slip_onset_types', []) or []) or [0] * len(times)
    if len(kinds) != len(times):
        raise ValueError(f'{len(times)} slip onset times but {len(kinds)} onset types')
    onsets, kinds = (list(v) for v in zip(*sorted(zip(times, kinds)))) if times else ([], [])
    flags = list(_get(result, 'slip_flag_times', []) or [])
    latency = match_onsets(onsets, flags, CLOSED_LOOP_MAX_LATENCY, before_next_onset=True)
    latencies = [float(v) for v in latency[~np.isnan(latency)]]
    by_lift_monitor = match_onsets(onsets, list(_get(result, 'gross_slip_times', []) or []),
                                   CLOSED_LOOP_MAX_LATENCY, before_next_onset=True)
    cues = [(int(k), first_cue(float(v), float(g)))
            for k, v, g in zip(kinds, latency, by_lift_monitor)]
    either = np.fmin(latency, by_lift_monitor)  # per onset: the sooner cue (NaN: neither)
    outcome = _get(result, 'outcome', '')
    state = _get(result, 'object_state', '')
    at_outcome = _get(result, 'object_state_at_outcome', '') or ''
    return TrialRecord(
        object_name=task.object_name, category=task.category, controller=task.controller,
        trial=task.trial, success=bool(_get(result, 'success', False)),
        outcome=str(getattr(outcome, 'name', outcome)),
        object_state=str(getattr(state, 'name', state)),
        slip_true=bool(_get(result, 'slip_true', bool(onsets))),
        slip_predicted=bool(_get(result, 'slip_predicted', bool(flags))),
        latencies=latencies, missed_onsets=len(onsets) - len(latencies), onset_cues=cues,
        either_cue_latencies=[float(v) for v in either[~np.isnan(either)]],
        max_true_force=float(_get(result, 'max_true_force', math.nan)),
        duration=float(_get(result, 'duration', math.nan)),
        object_state_at_outcome=str(getattr(at_outcome, 'name', at_outcome)),
        final_height=float(_get(result, 'final_height', math.nan)),
        seed=task.seed,
    )


def run_benchmark(tasks: Sequence[Task], jobs: int,
                  progress: Callable[[int, int, TrialRecord], None] | None = None,
                  runner: Callable[[Task], TrialRecord] = run_task) -> list[TrialRecord]:
    """Run every task, in ``jobs`` worker processes (1: in this process).

    Workers are spawned, not forked: a fork of a process that runs DDS threads (any process
    that used rclpy, e.g. a test session) can deadlock in the child. ``runner`` must
    therefore be importable by reference (a module-level function).
    """
    records: list[TrialRecord] = []
    if jobs <= 1:
        for task in tasks:
            records.append(runner(task))
            if progress:
                progress(len(records), len(tasks), records[-1])
        return records
    with get_context('spawn').Pool(jobs) as pool:
        for record in pool.imap_unordered(runner, tasks, chunksize=1):
            records.append(record)
            if progress:
                progress(len(records), len(tasks), record)
    order = {(t.object_name, t.controller, t.trial): i for i, t in enumerate(tasks)}
    records.sort(key=lambda r: order[(r.object_name, r.controller, r.trial)])
    return records


# --- force estimation ----------------------------------------------------------------------
def calibration_dataset(trials_per_indentor: int, hold_seconds: float, seed: int,
                        indentors: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """The simulated calibration rig in the dataset format of docs/contracts.md.

    Thin wrapper of :func:`forte_sim.dataset.generate_calibration_dataset` (the
    paper's protocol: quiet tare period, close to an angle drawn uniformly between just
    touching and fully closed, hold, release).
    """
    from forte_sim.dataset import CalibrationProtocol, generate_calibration_dataset

    protocol = CalibrationProtocol(trials_per_indentor=trials_per_indentor,
                                   hold_seconds=hold_seconds,
                                   release_seconds=min(2.0, hold_seconds / 4), seed=seed)
    return generate_calibration_dataset(protocol, indentors)


def force_cross_validation(dataset: dict[str, np.ndarray], folds: int = 10, stride: int = 100,
                           seed: int = 0) -> dict[str, dict]:
    """10-fold trial-wise CV of the SVR force model, with and without history features.

    Uses the perception package's trainer (:mod:`forte_perception.force_training`: per-trial
    tare, median 11, 24 features, rows every ``stride`` samples; GroupKFold by trial, so
    whole trials are held out) with its default SVR settings (C 10, epsilon 0.02 N).

    Returns
    -------
    dict
        ``{'with_history': {...}, 'without_history': {...}}``, each with ``rmse``, ``mae``
        [N], ``per_indentor`` RMSE [N], ``points``, ``trials`` and ``force_range`` [N].
    """
    from forte_perception.force_training import cross_validate, make_rows

    del seed  # GroupKFold is deterministic
    rows = make_rows(dataset, stride=stride)
    results = {}
    for key, kind in (('with_history', 'history'), ('without_history', 'latest')):
        result = cross_validate(rows, folds=folds, kind=kind, C=10.0, epsilon=0.02)
        results[key] = {
            'rmse': result['overall']['rmse'], 'mae': result['overall']['mae'],
            'per_indentor': {name: entry['rmse']
                             for name, entry in result['per_indentor'].items()},
            'per_fold_rmse': result['per_fold_rmse'],
            'points': int(rows.force.size), 'trials': int(np.unique(rows.trial).size),
            'force_range': [float(rows.force.min()), float(rows.force.max())],
        }
    return results


# --- command line --------------------------------------------------------------------------
def _progress_printer(started: float) -> Callable[[int, int, TrialRecord], None]:
    def show(done: int, total: int, record: TrialRecord) -> None:
        if done == total or done % max(1, total // 20) == 0:
            elapsed = time.monotonic() - started
            eta = elapsed / done * (total - done)
            print(f'  [{done:4d}/{total}] {elapsed:6.1f} s elapsed, ~{eta:5.1f} s left '
                  f'(last: {record.object_name} {record.controller} '
                  f'{"lifted" if record.success else record.outcome or "failed"})', flush=True)
    return show


def _parser() -> argparse.ArgumentParser:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(prog='forte_evaluate', description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='CI subset, under a minute')
    parser.add_argument('--trials', type=int, default=None, help='trials per object (10)')
    parser.add_argument('--objects', nargs='+', default=None, help='only these objects')
    parser.add_argument('--controllers', nargs='+', default=list(CONTROLLERS),
                        choices=CONTROLLERS)
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    parser.add_argument('--seed', type=int, default=0,
                        help='base seed: trial t of the i-th object of the full benchmark runs '
                             'scene seed SEED + 1000 i + t (seeds fewer than --trials apart '
                             'share trials)')
    parser.add_argument('--slip-modes', nargs='+', default=[RECOMMENDED_MODE, 'paper'],
                        choices=SLIP_MODES,
                        help=f"slip detector modes to run (default {RECOMMENDED_MODE} and "
                             "paper; 'sequential' is issue 26's candidate)")
    parser.add_argument('--skip-grasp', action='store_true')
    parser.add_argument('--skip-force', action='store_true')
    parser.add_argument('--output', type=Path, default=Path('out/evaluation'))
    return parser


def grasp_evaluation(args: argparse.Namespace, trials: int, results: dict) -> list[str]:
    """Run the grasp benchmark of the command line ``args`` in each slip mode, print tables.

    Adds ``by_slip_mode`` (per mode: ``grasp``, ``truth``, ``slip_latency``, ``trials``) and
    the timings to ``results``, and the first mode's entries also at the top level
    (``grasp``, ``truth``, ``slip_latency``, ``trials``); returns the markdown section.
    """
    objects = benchmark_objects(args.quick)
    if args.objects:
        objects = [pair for pair in objects if pair[0] in args.objects] or [
            (name, _category_of(name)) for name in args.objects]
    base = make_tasks(objects, args.controllers, trials, args.seed)
    markdown: list[str] = []
    records_by_mode: dict[str, list[TrialRecord]] = {}
    results['by_slip_mode'] = {}
    for mode in args.slip_modes:
        tasks = [replace(task, slip_mode=mode) for task in base]
        print(f'[evaluate] grasp benchmark, slip mode {mode!r}: {len(objects)} objects x '
              f'{trials} trials x {len(args.controllers)} controllers = {len(tasks)} '
              f'closed-loop trials on {args.jobs} process(es)', flush=True)
        started = time.monotonic()
        records = run_benchmark(tasks, args.jobs, _progress_printer(started))
        elapsed = time.monotonic() - started
        results['timings'][f'grasp_benchmark_{mode}_s'] = elapsed
        records_by_mode[mode] = records
        results['by_slip_mode'][mode] = _mode_results(records, mode)
        markdown += _mode_tables(records, mode, results['by_slip_mode'][mode],
                                 f'{len(tasks)} trials in {elapsed:.1f} s on {args.jobs} '
                                 'process(es).')
    first = results['by_slip_mode'][args.slip_modes[0]]
    results.update({key: first[key] for key in ('grasp', 'truth', 'slip_latency', 'trials')})
    if len(records_by_mode) > 1:
        table = mode_comparison_table(records_by_mode)
        print('\nFORTE in each slip detector mode (success, trial-wise slip precision)\n'
              + table, flush=True)
        markdown += ['## FORTE in each slip detector mode', '', table, '']
    return markdown


def _mode_results(records: Sequence[TrialRecord], mode: str) -> dict:
    """The JSON results of one slip mode's benchmark."""
    forte = [r for r in records if r.controller == 'FORTE']
    stats = latency_stats([v for r in forte for v in r.latencies],
                          sum(r.missed_onsets for r in forte))
    onsets = sum(len(r.onset_cues) for r in forte)
    either = [v for r in forte for v in r.either_cue_latencies]
    return {'grasp': summary_json(records), 'truth': confusion_json(records),
            'slip_latency': stats,
            'slip_latency_either_cue': latency_stats(either, onsets - len(either)),
            'slip_cues': cue_counts(forte),
            'trials': [dict(r.to_dict(), slip_mode=mode) for r in records]}


def _mode_tables(records: Sequence[TrialRecord], mode: str, mode_results: dict,
                 timing: str) -> list[str]:
    """Print one slip mode's tables (``mode_results``: its :func:`_mode_results`); return
    them as markdown, ending with the ``timing`` line."""
    table = result_table(records)
    latency = latency_table(mode_results['slip_latency'])
    either = latency_table(mode_results['slip_latency_either_cue'])
    truth = confusion_table(records)
    truth_at_outcome = confusion_table(records, at_outcome=True)
    print(f'\nGrasp success and slip detection, slip mode {mode!r} (rows "paper": the '
          "paper's Table)\n" + table, flush=True)
    print('\nSlip detection latency, true onset to first flag (FORTE trials)\n' + latency,
          flush=True)
    print('\nSame, true onset to the first slip flag or gross-slip tightening (either cue: '
          'the controller acts on both)\n' + either, flush=True)
    cues = cue_table(records)
    print('\nWhich cue found each true onset first within '
          f'{CLOSED_LOOP_MAX_LATENCY:g} s (FORTE trials)\n' + cues, flush=True)
    print('\nController outcome against the ground-truth object state at the end of the '
          'trial (! = contradicts the truth on whether the object was carried)\n' + truth,
          flush=True)
    print('\nSame, ground truth at the moment of the outcome\n' + truth_at_outcome,
          flush=True)
    return [f'## Grasp success and slip detection (slip mode `{mode}`)', '', table, '',
            f'## Slip detection latency, onset to flag (slip mode `{mode}`)', '', latency, '',
            'Onset to the first slip flag or gross-slip tightening (either cue):', '', either,
            '',
            f'## Which cue found each onset first (slip mode `{mode}`)', '',
            'Within the latency horizon: the slip flag (vibration) or the tightening on the '
            "lift monitor's gross-slip evidence (quasi-static).", '', cues, '',
            f'## Controller outcome against the ground truth (slip mode `{mode}`)', '',
            'Ground truth at the end of the trial (1 s after the outcome); `!` marks '
            'a contradiction on whether the object was carried (LIFTED vs RESTING '
            'or DROPPED, DROPPED or NOT_CARRIED vs HELD).', '', truth, '',
            'Ground truth at the moment of the outcome:', '', truth_at_outcome, '',
            timing, '']


def force_evaluation(args: argparse.Namespace, results: dict) -> list[str]:
    """Cross-validate the force model on the simulated rig, print its table.

    Adds ``force`` and the timing to ``results``; returns the markdown section.
    """
    per_indentor = 3 if args.quick else 40
    hold = 4.0 if args.quick else 12.0
    indentors = None
    if args.quick:
        from forte_sim import INDENTORS
        indentors = list(INDENTORS)[:4]
    print(f'\n[evaluate] force model: calibration rig, {per_indentor} trials per indentor, '
          '10-fold trial-wise CV with and without history features', flush=True)
    started = time.monotonic()
    dataset = calibration_dataset(per_indentor, hold, args.seed, indentors)
    force = force_cross_validation(dataset, folds=10, stride=200 if args.quick else 600,
                                   seed=args.seed)
    results['timings']['force_cv_s'] = time.monotonic() - started
    results['force'] = force
    table = force_table(force)
    print(table, flush=True)
    return ['## Force estimation (10-fold trial-wise CV)', '', table, '']


def main(argv: list[str] | None = None) -> int:
    """Entry point (``python -m forte_evaluation.evaluate``, ``forte_evaluate``)."""
    args = _parser().parse_args(argv)
    trials = args.trials or (2 if args.quick else 10)
    args.output.mkdir(parents=True, exist_ok=True)
    results: dict = {'config': {'quick': args.quick, 'trials': trials, 'seed': args.seed,
                                'jobs': args.jobs, 'controllers': args.controllers,
                                'slip_modes': args.slip_modes},
                     'timings': {}}
    markdown = ['# FORTE evaluation in simulation', '']
    if not args.skip_grasp:
        markdown += grasp_evaluation(args, trials, results)
    if not args.skip_force:
        markdown += force_evaluation(args, results)
    (args.output / 'results.json').write_text(json.dumps(results, indent=1, default=float))
    (args.output / 'results.md').write_text('\n'.join(markdown) + '\n')
    print(f'\n[evaluate] results: {args.output / "results.json"}, '
          f'{args.output / "results.md"}', flush=True)
    return 0


def _category_of(name: str) -> str:
    from forte_sim import OBJECTS

    return OBJECTS[name].category


if __name__ == '__main__':
    sys.exit(main())
