"""``forte_evaluate_slip``: slip detection metrics on labelled recordings.

Example::

    forte_evaluate_slip trial1.npz trial2.npz --max-latency 0.5 --report slip.json

Recording format: see :mod:`forte_perception.evaluation.labelled_recordings` (``frames``, ``fs``,
``onsets``, optional ``trial``, ``filtered`` and ``mask`` of the rows where flags count).
Prints the trial-wise TP/FP/FN/TN, accuracy, precision, recall and F1 (as in the paper;
``n/a`` where undefined, :mod:`forte_perception.evaluation.slip_metrics`), the
onset-to-flag latency distribution, missed onsets and false alarms. The detector mode
(``--mode``, default the perception node's) and every slip detector parameter can be
overridden.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from forte_perception.evaluation.labelled_recordings import evaluate_slip, load_labelled
from forte_perception.evaluation.slip_metrics import MAX_LATENCY, format_value, latency_stats
from forte_perception.median import MEDIAN_WINDOW
from forte_perception.slip.detector import SlipParams
from forte_perception.slip.params import MODES


def main(argv: list[str] | None = None) -> int:
    d = SlipParams()
    parser = argparse.ArgumentParser(prog='forte_evaluate_slip', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('recordings', nargs='+', help='labelled recording .npz files')
    parser.add_argument('--max-latency', type=float, default=MAX_LATENCY,
                        help='longest onset-to-flag delay counted as a detection [s]')
    parser.add_argument('--skip', type=float, default=0.0,
                        help='ignore flags in the first SKIP seconds of every trial [s]')
    parser.add_argument('--median-window', type=int, default=MEDIAN_WINDOW)
    parser.add_argument('--window', type=int, default=d.window, help='FFT window N')
    parser.add_argument('--hop', type=int, default=d.hop)
    parser.add_argument('--f-min', type=float, default=d.f_min)
    parser.add_argument('--f-max', type=float, default=d.f_max)
    parser.add_argument('--history', type=int, default=d.history, help='V')
    parser.add_argument('--delta', type=float, default=d.delta)
    parser.add_argument('--alpha', type=float, default=d.alpha)
    parser.add_argument('--threshold', type=float, default=d.threshold, help='T')
    parser.add_argument('--mode', choices=MODES, default=d.mode,
                        help=f'slip detector mode (default {d.mode!r}, as the perception node)')
    parser.add_argument('--report', default=None, help='write the results as JSON')
    args = parser.parse_args(argv)
    params = SlipParams(window=args.window, hop=args.hop, f_min=args.f_min, f_max=args.f_max,
                        history=args.history, delta=args.delta, alpha=args.alpha,
                        threshold=args.threshold, mode=args.mode)
    try:
        recordings = [load_labelled(p) for p in args.recordings]
        for rec in recordings:
            params.validate(rec.fs)
    except (OSError, ValueError) as exc:
        print(f'forte_evaluate_slip: {exc}', file=sys.stderr)
        return 2
    result = evaluate_slip(recordings, params, args.median_window, args.max_latency, args.skip)
    scores = result['trials']
    print(f'trials: {scores.trials}  TP {scores.true_positive}  FP {scores.false_positive}  '
          f'FN {scores.false_negative}  TN {scores.true_negative}')
    print(f'accuracy {format_value(scores.accuracy, 3)}  '
          f'precision {format_value(scores.precision, 3)}  '
          f'recall {format_value(scores.recall, 3)}  F1 {format_value(scores.f1, 3)}')
    stats = latency_stats(result['latencies_s'], result['missed_onsets'])
    if stats['count']:
        print(f'onset-to-flag latency [ms]: median {1e3 * stats["p50"]:.1f}, p90 '
              f'{1e3 * stats["p90"]:.1f}, max {1e3 * stats["max"]:.1f} '
              f'({stats["count"]} onsets detected)')
    print(f'missed onsets {result["missed_onsets"]}, false alarms {result["false_alarms"]}')
    if args.report:
        Path(args.report).write_text(json.dumps(dict(result, trials=scores.to_dict()),
                                                indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
