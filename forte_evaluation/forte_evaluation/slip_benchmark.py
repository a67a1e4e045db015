"""Slip detector modes on the labelled slip set: ``python -m forte_evaluation.slip_benchmark``.

Builds (or loads from ``out/slip_dataset/``) the issue-14 slip evaluation set
(:mod:`forte_evaluation.slip_dataset`: signal-level scenes of
:mod:`forte_perception.evaluation.scenes` and scripted simulator lifts), runs a detector mode of
:mod:`forte_perception.evaluation.benchmark` on it (``--repeats`` times for the CPU time, best
repetition), and prints one markdown table per split (tune, held-out): per family and
pooled, event recall / precision / F1, latency p50 / p90, false flags per minute while
holding still, scenes with a false event and CPU time per detector update; then recall and
latency per event kind. Writes ``<output>/<mode>.json`` (config, dataset hash, tables,
every scene's outcome, timings) and ``<output>/<mode>.md``.

Example::

    python -m forte_evaluation.slip_benchmark --mode paper
    python -m forte_evaluation.slip_benchmark --split held_out --families quiet_sub_lsb ramp

The CPU time is ``time.process_time`` (all threads of the process); the paper detector's
matrix products stay below OpenBLAS' threading threshold (see ``forte_perception.slip.detector``),
and ``OPENBLAS_NUM_THREADS=1`` makes sure of it for any mode.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from forte_evaluation.slip_dataset import build_set
from forte_perception.evaluation.benchmark import MODES, markdown, prepare, report, run_mode
from forte_perception.evaluation.labels import SPLITS
from forte_perception.evaluation.slip_metrics import MAX_LATENCY
from forte_perception.slip.params import RECOMMENDED_MODE


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='slip_benchmark',
                                     description=__doc__.split('\n')[0])
    parser.add_argument('--mode', default=RECOMMENDED_MODE, choices=sorted(MODES),
                        help=f'detector mode (default {RECOMMENDED_MODE!r}, the node\'s)')
    parser.add_argument('--split', nargs='+', default=list(SPLITS), choices=SPLITS)
    parser.add_argument('--families', nargs='+', default=None,
                        help='only these families (default: all)')
    parser.add_argument('--signal-only', action='store_true',
                        help='skip the simulator scenes')
    parser.add_argument('--repeats', type=int, default=3,
                        help='runs for the CPU time (best one counts)')
    parser.add_argument('--rebuild', action='store_true', help='ignore the cached set')
    parser.add_argument('--cache-dir', type=Path, default=Path('out/slip_dataset'))
    parser.add_argument('--output', type=Path, default=Path('out/slip_benchmark'))
    return parser


def _json_ready(value):
    """NaN -> None, numpy scalars and arrays -> Python, recursively."""
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_ready(value.tolist())
    if isinstance(value, (np.floating, float)):
        return None if math.isnan(value) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value


def _scene_record(outcome) -> dict:
    return {'name': outcome.name, 'split': outcome.split, 'family': outcome.family,
            'event_kinds': list(outcome.event_kinds), 'event_fingers': outcome.event_fingers,
            'event_strength_lsb': outcome.event_strength, 'detected': outcome.detected,
            'latency_s': outcome.latency_s, 'flag_runs': int(outcome.runs.shape[0]),
            'false_runs': int(outcome.false_run.sum()),
            'false_in_holding': int(outcome.false_in_holding.sum()),
            'holding_s': outcome.holding_s, 'updates': outcome.updates}


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code."""
    args = _parser().parse_args(argv)
    wall_start = time.perf_counter()
    timings = {}
    scenes, info = build_set(args.cache_dir, args.rebuild)
    timings['dataset_s'] = info['seconds']
    print(f'[slip_benchmark] set {info["hash"]}: {len(scenes)} scenes '
          f'({"cached" if info["cached"] else "built"} in {info["seconds"]:.1f} s)',
          flush=True)
    scenes = [s for s in scenes if s.split in args.split
              and (args.families is None or s.family in args.families)
              and not (args.signal_only and s.source == 'sim')]
    if not scenes:
        print('[slip_benchmark] no scene matches the selection', file=sys.stderr)
        return 2
    started = time.process_time()
    inputs = prepare(scenes)
    timings['median_filter_cpu_s'] = time.process_time() - started
    started = time.perf_counter()
    outcomes, cpu = run_mode(scenes, args.mode, args.repeats, inputs)
    timings['detector_wall_s'] = time.perf_counter() - started
    results = report(outcomes, cpu)
    table = markdown(results, args.mode)
    seconds = sum(s.seconds for s in scenes)
    print(f'\n{len(scenes)} scenes, {seconds / 60:.1f} min of signal; event detected '
          f'when a flag falls in [onset, onset + {MAX_LATENCY} s]\n', flush=True)
    print(table, flush=True)
    timings['total_wall_s'] = time.perf_counter() - wall_start
    print(f'[slip_benchmark] set {timings["dataset_s"]:.1f} s, median filter '
          f'{timings["median_filter_cpu_s"]:.1f} s CPU, detector x{args.repeats} '
          f'{timings["detector_wall_s"]:.1f} s; total {timings["total_wall_s"]:.1f} s wall',
          flush=True)
    args.output.mkdir(parents=True, exist_ok=True)
    document = {'config': {'mode': args.mode, 'splits': args.split,
                           'families': args.families, 'signal_only': args.signal_only,
                           'repeats': args.repeats, 'max_latency_s': MAX_LATENCY,
                           'dataset': info, 'scenes': len(scenes),
                           'signal_minutes': seconds / 60},
                'results': results, 'timings': timings,
                'scenes': [_scene_record(o) for o in outcomes]}
    (args.output / f'{args.mode}.json').write_text(json.dumps(_json_ready(document), indent=1))
    (args.output / f'{args.mode}.md').write_text(table + '\n')
    print(f'[slip_benchmark] wrote {args.output / (args.mode + ".json")} and .md', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
