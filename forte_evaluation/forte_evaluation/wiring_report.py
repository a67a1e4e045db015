"""Slip modes under the wirings a lab could build: ``python -m forte_evaluation.wiring_report``.

Runs signal scenes of the slip set (:mod:`forte_perception.evaluation.scenes`, one split)
through the perception pipeline under every wiring of
:data:`forte_perception.evaluation.wiring.WIRINGS` and with each input lost
(:func:`~forte_perception.evaluation.wiring.masked`) and with each input the only one of its
finger's to read that finger (:func:`~forte_perception.evaluation.wiring.alone`), and prints
per mode and wiring the pooled recall, precision, false flag runs (and the families they fell
in) and the leading-finger recall, with the recall as a fraction of the as-built wiring's.

Example::

    python -m forte_evaluation.wiring_report --modes robust sequential \\
        --families leading_finger stick_slip_3_10lsb quiet_sub_lsb closing_step --lost 0 3
"""
from __future__ import annotations

import argparse
import sys
import time
from multiprocessing import Pool

from forte_perception.evaluation.scenes import signal_scenes
from forte_perception.evaluation.slip_metrics import format_value, summarise
from forte_perception.evaluation.wiring import WIRINGS, alone, masked, run_scene
from forte_perception.slip.params import MODES


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='wiring_report', description=__doc__.split('\n')[0])
    parser.add_argument('--modes', nargs='+', default=['robust', 'sequential'], choices=MODES)
    parser.add_argument('--split', default='held_out', choices=('tune', 'held_out'))
    parser.add_argument('--families', nargs='+', default=None, help='default: all')
    parser.add_argument('--lost', nargs='*', type=int, default=list(range(6)),
                        help='inputs lost one at a time (default: each)')
    parser.add_argument('--alone', nargs='*', type=int, default=list(range(6)),
                        help='inputs left alone to read their finger, one at a time '
                        '(default: each)')
    parser.add_argument('--chunk', type=int, default=100, help='samples per pipeline call')
    parser.add_argument('--jobs', type=int, default=2)
    return parser


def _run(job: tuple) -> tuple:
    scene, mode, wiring, chunk = job
    return mode, wiring.name, run_scene(scene, mode, wiring, chunk)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    scenes = signal_scenes(args.split, args.families)
    wirings = list(WIRINGS) + [alone(k) for k in args.alone] + [masked(k) for k in args.lost]
    jobs = [(s, m, w, args.chunk) for m in args.modes for w in wirings for s in scenes]
    started = time.time()
    with Pool(max(1, args.jobs)) as pool:
        rows = pool.map(_run, jobs, chunksize=8)
    print(f'{len(scenes)} {args.split} scenes x {len(wirings)} wirings x {len(args.modes)} '
          f'modes in {time.time() - started:.0f} s\n')
    print('| mode | wiring | recall | of as built | precision | false runs (families) '
          '| leading finger |\n|---|---|---|---|---|---|---|')
    for mode in args.modes:
        built = None
        for wiring in wirings:
            outs = [o for m, name, o in rows if m == mode and name == wiring.name]
            total = summarise(outs)
            lead = summarise([o for o in outs if o.family == 'leading_finger'])
            built = total['recall'] if built is None else built
            ratio = total['recall'] / built if built else float('nan')
            families = ', '.join(sorted({o.family for o in outs if o.false_run.any()}))
            print(f'| {mode} | {wiring.name} | {format_value(total["recall"])} | '
                  f'{format_value(ratio)} | {format_value(total["precision"])} | '
                  f'{total["false_runs"]} ({families}) | {lead["detected"]}/{lead["events"]} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
