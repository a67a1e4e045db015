"""forte_sim_dataset: write the simulated force calibration dataset (.npz of docs/contracts.md).

Examples::

    forte_sim_dataset --output calibration.npz            # 6 indentors x 40 trials
    forte_sim_dataset --quick --output quick.npz

Training and cross-validation on the file: ``forte_train_force`` (forte_perception).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace

from forte_sim.dataset import (
    QUICK_PROTOCOL,
    CalibrationProtocol,
    generate_calibration_dataset,
    save_dataset,
)


def build_parser() -> argparse.ArgumentParser:
    """Command line of forte_sim_dataset."""
    parser = argparse.ArgumentParser(
        prog='forte_sim_dataset',
        description='Simulate the FORTE force calibration rig (6 indentors, random closure, '
                    'load cell) and write the calibration dataset .npz.')
    parser.add_argument('--output', '-o', required=True, help='output .npz file')
    parser.add_argument('--quick', action='store_true',
                        help='8 trials per indentor with 6 s holds (default: 40 with 12 s)')
    parser.add_argument('--trials-per-indentor', type=int, default=None,
                        help='override the number of trials per indentor')
    parser.add_argument('--hold-seconds', type=float, default=None,
                        help='override the hold time after closing [s]')
    parser.add_argument('--seed', type=int, default=0, help='seed of the campaign')
    parser.add_argument('--uncompressed', action='store_true', help='write without deflate')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the process exit code."""
    args = build_parser().parse_args(argv)
    protocol = QUICK_PROTOCOL if args.quick else CalibrationProtocol()
    if args.trials_per_indentor is not None:
        if args.trials_per_indentor < 1:
            print('forte_sim_dataset: --trials-per-indentor must be >= 1', file=sys.stderr)
            return 2
        protocol = replace(protocol, trials_per_indentor=args.trials_per_indentor)
    if args.hold_seconds is not None:
        if not args.hold_seconds > 0:
            print('forte_sim_dataset: --hold-seconds must be > 0', file=sys.stderr)
            return 2
        protocol = replace(protocol, hold_seconds=args.hold_seconds)
    protocol = replace(protocol, seed=args.seed)
    started = time.perf_counter()

    def progress(done: int, total: int) -> None:
        if done == total or done % 12 == 0:
            print(f'  trial {done}/{total}', file=sys.stderr)

    dataset = generate_calibration_dataset(protocol, progress=progress)
    simulated = time.perf_counter() - started
    path = save_dataset(args.output, dataset, compressed=not args.uncompressed)
    samples = len(dataset['frames'])
    report = {
        'output': str(path),
        'trials': int(dataset['trial'].max()) + 1,
        'samples': samples,
        'recorded_seconds': samples / float(dataset['fs']),
        'force_max': float(dataset['force'].max()),
        'simulation_seconds': round(simulated, 2),
    }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
