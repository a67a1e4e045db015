"""``forte_train_force``: cross-validate and train the SVR force model on a calibration set.

Example::

    forte_train_force calibration.npz -o force_model.npz --folds 10 --report cv.json

Prints the 10-fold trial-wise cross-validation (RMSE and MAE per indentor shape and
overall) with the history features (24) and without them (the latest frame only, the
paper's baseline), then fits the final model on every row and saves it (versioned .npz,
no pickle) with its metadata (dataset hash, settings, CV results, training input range, and
``sensor``: the sample rate, channel order and recorded sensor identity of the dataset,
which the perception node checks against the sensor it runs on).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from forte_perception.force_training import (
    cross_validate,
    file_sha256,
    load_calibration,
    make_rows,
    train_model,
    training_sensor,
)


def _table(result: dict) -> str:
    lines = [f'  {"indentor":16s}{"RMSE [N]":>10s}{"MAE [N]":>10s}{"rows":>8s}']
    for name, m in result['per_indentor'].items():
        lines.append(f'  {name:16s}{m["rmse"]:10.3f}{m["mae"]:10.3f}{m["rows"]:8d}')
    o = result['overall']
    lines.append(f'  {"overall":16s}{o["rmse"]:10.3f}{o["mae"]:10.3f}{o["rows"]:8d}')
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='forte_train_force', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('dataset', help='calibration dataset .npz (docs/contracts.md)')
    parser.add_argument('-o', '--output', default='force_model.npz', help='model file')
    parser.add_argument('--folds', type=int, default=10, help='CV folds (0: no CV)')
    parser.add_argument('--stride', type=int, default=200,
                        help='training row every STRIDE samples (200 = 10 Hz at 2 kHz)')
    parser.add_argument('--C', type=float, default=10.0, help='SVR C')
    parser.add_argument('--epsilon', type=float, default=0.02, help='SVR epsilon [N]')
    parser.add_argument('--gamma', default='scale', help="RBF gamma or 'scale'")
    parser.add_argument('--force-range', type=float, nargs=2, default=None,
                        metavar=('LOW', 'HIGH'),
                        help='output clip range [N] (default: 0 to the largest training force)')
    parser.add_argument('--range-margin', type=float, default=0.05,
                        help='allowed excursion beyond the training input range (fraction)')
    parser.add_argument('--report', default=None, help='write the CV results as JSON')
    args = parser.parse_args(argv)
    try:
        gamma = float(args.gamma)
    except ValueError:
        gamma = args.gamma
    try:
        dataset = load_calibration(args.dataset)
    except (OSError, ValueError) as exc:
        print(f'forte_train_force: {exc}', file=sys.stderr)
        return 2
    rows = make_rows(dataset, stride=args.stride)
    fit_args = {'C': args.C, 'epsilon': args.epsilon, 'gamma': gamma}
    print(f'{Path(args.dataset).name}: {len(set(rows.trial.tolist()))} trials, '
          f'{rows.force.size} rows (stride {args.stride}), indentors '
          f'{", ".join(rows.indentor_names)}, force {rows.force.min():.2f}.'
          f'.{rows.force.max():.2f} N')
    report: dict = {'dataset': str(args.dataset), 'stride': args.stride, **fit_args}
    if args.folds:
        for kind, label in (('history', 'with history features (24)'),
                            ('latest', 'latest frame only (6), the paper\'s baseline')):
            t0 = time.perf_counter()
            result = cross_validate(rows, folds=args.folds, kind=kind, **fit_args)
            print(f'\n{args.folds}-fold trial-wise CV, {label} '
                  f'({time.perf_counter() - t0:.1f} s):\n{_table(result)}')
            report[f'cv_{kind}'] = result
    metadata = {'dataset_sha256': file_sha256(args.dataset), 'dataset': Path(args.dataset).name,
                'stride': args.stride, 'trials': int(len(set(rows.trial.tolist()))),
                'indentor_names': list(rows.indentor_names),
                'sensor': training_sensor(dataset),
                'trained_utc': time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}
    if 'cv_history' in report:
        metadata['cv_rmse'] = report['cv_history']['overall']['rmse']
        metadata['cv_mae'] = report['cv_history']['overall']['mae']
    model = train_model(rows, force_range=tuple(args.force_range) if args.force_range else None,
                        metadata=metadata, range_margin=args.range_margin, **fit_args)
    model.save(args.output)
    print(f'\nsaved {args.output}: {model.support_vectors.shape[0]} support vectors, '
          f'gamma {model.gamma:.4g}, output clipped to {model.force_range} N')
    if args.report:
        Path(args.report).write_text(json.dumps(report, indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
