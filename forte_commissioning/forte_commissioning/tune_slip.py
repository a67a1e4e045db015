"""``forte_tune_slip``: sweep the slip threshold over labelled recordings, write an overlay.

Example::

    ros2 run forte_commissioning forte_tune_slip out/slip_char/apple.npz \\
        out/slip_char/jam_jar.npz --labels onsets.csv -o slip_overlay.yaml
    ros2 launch forte_bringup hardware.launch.py params_overlay:=$PWD/slip_overlay.yaml

Recordings: the labelled recording format of
:mod:`forte_perception.evaluation.labelled_recordings` (what ``python -m
forte_commissioning.slip_characterization`` writes). Onsets: those in the recordings, or with
``--labels`` those of a CSV label file (format:
:mod:`forte_perception.evaluation.onset_labels`; columns ``recording,onset_s``), e.g. marked
by an operator from video on the robot.

Sweeps T (``--thresholds``; in the sequential mode the CUSUM threshold h,
``--sequential-thresholds``) in each detector mode of ``--modes`` (default: the node's
default mode only; characterisation lifts hold no distractors, so they cannot tell whether
to switch the mode, which the slip set decides: docs/perception.md) and, in the robust
mode, the robust mode's own one-finger threshold and level-shift veto ratio
(``--single-thresholds``, ``--veto-ratios``; ``--thresholds-only`` keeps their defaults);
prints precision / recall / F1 / latency per
setting (:mod:`forte_perception.evaluation.threshold_sweep`, scoring rules and the
recommendation rule there) and writes the recommended setting as a parameter YAML overlay
``{perception: {ros__parameters: {slip_mode: ..., slip_threshold: ...}}}``. Only settings
the perception node can load are recommended (every swept field has a node parameter:
``slip_threshold``, ``slip_single_threshold``, ``slip_veto_ratio``, ...).
Exit codes: 0 done, 2 unusable input (message on stderr). Run time: the two
characterisation recordings (10 trials, 115 s of signal) and the default grid (63 valid
settings) take about 12 s (T only, `--thresholds-only`: about 5 s).
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from forte_perception.evaluation.labelled_recordings import LabelledRecording, load_labelled
from forte_perception.evaluation.onset_labels import (
    LabelError,
    apply_onset_labels,
    load_onset_csv,
)
from forte_perception.evaluation.slip_metrics import MAX_LATENCY, format_value
from forte_perception.evaluation.threshold_sweep import (
    DEFAULT_ROBUST_GRID,
    DEFAULT_SEQUENTIAL_THRESHOLDS,
    DEFAULT_THRESHOLDS,
    PRECISION_FLOOR,
    Recommendation,
    SweepRow,
    parameter_grid,
    recommend,
    sweep,
    table,
    write_overlay,
)
from forte_perception.slip.params import MODES, SlipParams

__all__ = ['main', 'overlay_comment', 'settings_for', 'tune']


def settings_for(modes: Sequence[str], thresholds: Sequence[float],
                 robust_grid: dict | None, fs: float,
                 sequential_thresholds: Sequence[float] = DEFAULT_SEQUENTIAL_THRESHOLDS
                 ) -> tuple[list, list]:
    """The grid of a sweep: per detector mode the T values, in the robust mode times the
    robust grid; in the sequential mode the CUSUM thresholds h (T does not act there).

    Parameters
    ----------
    modes : sequence of str
        Detector modes (``'sequential'``, ``'robust'``, ``'paper'``).
    thresholds : sequence of float
        Values of T [dB^2].
    robust_grid : dict, optional
        Robust-mode field -> values (e.g. :data:`DEFAULT_ROBUST_GRID`); None: defaults only.
    fs : float
        Sampling rate [Hz].
    sequential_thresholds : sequence of float
        Values of h [dB s] in the sequential mode.

    Returns
    -------
    settings : list of (SlipParams, dict)
        The swept values include ``mode`` when more than one mode is swept.
    skipped : list of (dict, str)
        Invalid combinations (e.g. one-finger threshold below T) and why.
    """
    settings, skipped = [], []
    for mode in modes:
        axes = {'mode': (mode,)} if len(modes) > 1 else {}
        if mode == 'sequential':
            axes['sequential_threshold'] = tuple(sequential_thresholds)
        else:
            axes['threshold'] = tuple(thresholds)
        if mode == 'robust' and robust_grid:
            axes.update(robust_grid)
        found, refused = parameter_grid(SlipParams(mode=mode), axes, fs)
        settings += found
        skipped += refused
    return settings, skipped


def tune(recordings: Sequence[LabelledRecording], settings: Sequence,
         precision_floor: float = PRECISION_FLOOR, max_latency: float = MAX_LATENCY
         ) -> tuple[list[SweepRow], Recommendation]:
    """Sweep and recommend (:mod:`forte_perception.evaluation.threshold_sweep`)."""
    rows = sweep(recordings, settings, max_latency)
    return rows, recommend(rows, precision_floor)


def overlay_comment(choice: Recommendation, sources: Sequence[str]) -> str:
    """The header of an overlay file: where it comes from and what it scored."""
    row = choice.row
    return '\n'.join([
        'Slip detector setting recommended by forte_tune_slip (threshold sweep).',
        f'Recordings: {", ".join(sources)}',
        f'Rule: {choice.rule}.',
        f'Scores there: precision {format_value(row.precision, 3)}, recall '
        f'{format_value(row.recall, 3)}, F1 {format_value(row.f1, 3)}, latency p50 '
        f'{format_value(1e3 * row.latency(50), 0)} ms ({row.detected}/{row.onsets} onsets, '
        f'{row.false_runs} false of {row.runs} flag runs).',
        'Load it with: ros2 launch forte_bringup <graph>.launch.py params_overlay:=<this file>',
    ])


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='forte_tune_slip', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('recordings', nargs='+', help='labelled recording .npz files')
    parser.add_argument('--labels', default=None,
                        help='CSV of onsets (recording,onset_s) replacing the recordings\' own')
    parser.add_argument('--modes', choices=MODES, nargs='+', default=[SlipParams().mode],
                        help='detector modes to sweep (default: the node\'s, '
                             f'{SlipParams().mode!r})')
    parser.add_argument('--thresholds', type=float, nargs='+', default=DEFAULT_THRESHOLDS,
                        help='values of T [dB^2]')
    parser.add_argument('--sequential-thresholds', type=float, nargs='+',
                        default=DEFAULT_SEQUENTIAL_THRESHOLDS,
                        help='sequential mode: CUSUM thresholds h [dB s]')
    parser.add_argument('--single-thresholds', type=float, nargs='+',
                        default=DEFAULT_ROBUST_GRID['single_threshold'],
                        help='robust mode: one-finger thresholds [dB^2]')
    parser.add_argument('--veto-ratios', type=float, nargs='+',
                        default=DEFAULT_ROBUST_GRID['veto_ratio'],
                        help='robust mode: level-shift veto ratios [1]')
    parser.add_argument('--thresholds-only', action='store_true',
                        help='sweep T only (robust parameters at their defaults)')
    parser.add_argument('--precision-floor', type=float, default=PRECISION_FLOOR)
    parser.add_argument('--max-latency', type=float, default=MAX_LATENCY,
                        help='longest onset-to-flag delay counted as a detection [s]')
    parser.add_argument('-o', '--overlay', default='slip_overlay.yaml',
                        help='parameter overlay YAML to write')
    parser.add_argument('--report', default=None, help='also write every row as JSON')
    return parser


def _load(paths: Sequence[str], labels: str | None) -> list[LabelledRecording]:
    recordings = [load_labelled(p) for p in paths]
    if labels:
        onsets = load_onset_csv(labels)
        recordings = [apply_onset_labels(r, onsets, labels) for r in recordings]
    return recordings


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        recordings = _load(args.recordings, args.labels)
        grid = None if args.thresholds_only else {'single_threshold': args.single_thresholds,
                                                  'veto_ratio': args.veto_ratios}
        settings, skipped = settings_for(args.modes, args.thresholds, grid, recordings[0].fs,
                                         args.sequential_thresholds)
        if not settings:
            raise ValueError('no valid setting in the grid')
        rows, choice = tune(recordings, settings, args.precision_floor, args.max_latency)
    except (OSError, ValueError, LabelError) as exc:
        print(f'forte_tune_slip: {exc}', file=sys.stderr)
        return 2
    print(table(rows, choice.row))
    if skipped:
        print(f'\n{len(skipped)} invalid combinations skipped (e.g. {skipped[0][1]})')
    print(f'\nrecommended: {choice.row.varied} ({choice.rule})')
    write_overlay(args.overlay, choice.row.params,
                  overlay_comment(choice, [r.name for r in recordings]))
    print(f'overlay written: {args.overlay}')
    if args.report:
        Path(args.report).write_text(json.dumps(
            {'rows': [r.to_dict() for r in rows], 'recommended': choice.row.to_dict(),
             'rule': choice.rule, 'floor_met': choice.floor_met}, indent=1))
    return 0


if __name__ == '__main__':
    sys.exit(main())
