"""Slip detection delay against false alarms: ``python -m forte_evaluation.slip_delay_report``.

The "speed against error" report of issue 26. For each detector mode of
:mod:`forte_perception.evaluation.benchmark`, one operating point per value of its operating
parameter (:mod:`forte_perception.evaluation.change_detection`): recall, detection delay
p50 / p90 of the detected events, false alarms per hour of holding still and per minute of
distractor scenes, precision; then the slipping state's scores on the same scenes at each
mode's default (:mod:`forte_perception.evaluation.slipping`). The scenes are those of the
slip set (:mod:`forte_evaluation.slip_dataset`, cached in ``--cache-dir``), by default its
held-out part. Writes ``<output>/delay_false_alarms.md`` (the tables),
``<output>/delay_false_alarms.json`` and ``<output>/delay_false_alarms.png`` (delay
against false alarms, one curve per mode).

Example::

    python -m forte_evaluation.slip_delay_report                       # held-out, every mode
    python -m forte_evaluation.slip_delay_report --split tune --signal-only --modes robust

Operating parameters: the threshold T of the paper and robust modes (the robust mode's
``single_threshold`` is kept at 1.5 T), the CUSUM threshold h of the ``cusum`` and
``sequential`` modes.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, replace
from functools import partial
from pathlib import Path

from forte_evaluation.slip_dataset import build_set
from forte_perception.evaluation.benchmark import (
    cusum_mode,
    prepare,
    robust_mode,
    sequential_mode,
)
from forte_perception.evaluation.change_detection import (
    delay_false_alarm_curve,
    markdown_curve,
    slip_params_settings,
)
from forte_perception.evaluation.labels import SPLITS
from forte_perception.evaluation.slipping import (
    score_slipping,
    slipping_trace,
    summarise_slipping,
)
from forte_perception.slip.cusum import CusumParams
from forte_perception.slip.params import SlipParams
from forte_perception.slip.sequential import SequentialParams

#: mode -> the values of its operating parameter
SWEEPS = {
    'paper': (1.0, 2.0, 4.0, 10.0),
    'robust': (1.0, 2.0, 3.0, 4.0),
    'cusum': (0.05, 0.1, 0.4),
    'sequential': (0.02, 0.05, 0.1, 0.2),
}
#: the mode's default setting, whose slipping state is scored
DEFAULTS = {'paper': 2.0, 'robust': 2.0, 'cusum': 0.1, 'sequential': 0.05}


def settings(mode: str) -> list:
    """(setting, detector) pairs along the mode's operating parameter."""
    values = SWEEPS[mode]
    if mode in ('paper', 'robust'):
        base = SlipParams(mode=mode)
        if mode == 'paper':
            return slip_params_settings(base, 'threshold', values)
        return [({'T': t}, partial(robust_mode, params=replace(base, threshold=t,
                                                                 single_threshold=1.5 * t)))
                for t in values]
    if mode == 'cusum':
        return [({'h': h}, partial(cusum_mode, cusum=CusumParams(drift=9.0, threshold=h)))
                for h in values]
    base = SequentialParams()
    return [({'h': h}, partial(sequential_mode,
                               params=replace(base, cusum=replace(base.cusum, threshold=h))))
            for h in values]


def slipping_summary(scenes, inputs, detector) -> dict:
    """The slipping state's pooled scores with ``detector``'s events."""
    scores = []
    for scene, inp in zip(scenes, inputs, strict=True):
        detection = detector(inp)
        state = slipping_trace(inp, detection)
        scores.append(score_slipping(scene, detection.sample_index, detection.slip, state))
    return summarise_slipping(scores)


def figure(curves: dict, path: Path) -> None:
    """Delay p50 (p90 as a bar) against false alarms per hour of holding, one line a mode."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for mode, points in curves.items():
        rate = [p.false_per_hour_holding + p.false_per_min_distractor * 60 for p in points]
        p50 = [p.delay_p50_ms for p in points]
        p90 = [p.delay_p90_ms for p in points]
        line, = axes[0].plot(rate, p50, 'o-', label=mode)
        axes[0].vlines(rate, p50, p90, color=line.get_color(), alpha=0.4)
        axes[1].plot(rate, [p.recall for p in points], 'o-', color=line.get_color(),
                     label=mode)
    for axis in axes:
        axis.set_xscale('symlog', linthresh=1.0)
        axis.set_xlabel('false alarms per hour (holding still + distractor scenes)')
        axis.grid(alpha=0.3)
    axes[0].set_ylabel('detection delay p50, bar to p90 [ms]')
    axes[1].set_ylabel('event recall')
    axes[1].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='slip_delay_report',
                                     description=__doc__.split('\n')[0])
    parser.add_argument('--modes', nargs='+', default=list(SWEEPS), choices=list(SWEEPS))
    parser.add_argument('--split', default='held_out', choices=SPLITS)
    parser.add_argument('--signal-only', action='store_true',
                        help='skip the simulator scenes')
    parser.add_argument('--cache-dir', type=Path, default=Path('out/slip_dataset'))
    parser.add_argument('--output', type=Path, default=Path('out/slip_delay'))
    return parser


def delay_report(scenes, modes) -> tuple[str, dict, dict]:
    """The curves of ``modes`` on ``scenes`` and the slipping state at each default.

    Returns the markdown text, ``mode -> list of OperatingPoint`` and ``mode -> slipping
    scores`` (:func:`forte_perception.evaluation.slipping.summarise_slipping`).
    """
    inputs = prepare(scenes)
    curves, tables, states = {}, [], {}
    for mode in modes:
        chosen = settings(mode)
        curves[mode] = delay_false_alarm_curve(scenes, chosen, inputs)
        tables.append(markdown_curve(curves[mode], mode))
        default = next(d for s, d in chosen if DEFAULTS[mode] in s.values())
        states[mode] = slipping_summary(scenes, inputs, default)
    state_table = ['| mode (default setting) | events | held mean | held >= 90 % | clear p50 '
                   '/ p90 [ms] | cleared <= 100 ms | raised outside slip |',
                   '|---|---|---|---|---|---|---|']
    for mode, s in states.items():
        state_table.append(
            f'| {mode} | {s["events"]:.0f} | {s["held_mean"]:.2f} | {s["held_90"]:.2f} | '
            f'{s["clear_p50_ms"]:.0f} / {s["clear_p90_ms"]:.0f} | {s["clear_100ms"]:.2f} | '
            f'{s["raised_outside"]:.0f} |')
    return '\n\n'.join(tables + ['\n'.join(state_table)]) + '\n', curves, states


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code."""
    args = _parser().parse_args(argv)
    started = time.perf_counter()
    scenes, info = build_set(args.cache_dir)
    scenes = [s for s in scenes if s.split == args.split
              and not (args.signal_only and s.source == 'sim')]
    print(f'[slip_delay_report] set {info["hash"]}, {args.split}: {len(scenes)} scenes, '
          f'{sum(s.seconds for s in scenes) / 60:.1f} min', flush=True)
    text, curves, states = delay_report(scenes, args.modes)
    print(text, flush=True)
    args.output.mkdir(parents=True, exist_ok=True)
    (args.output / 'delay_false_alarms.md').write_text(text)
    (args.output / 'delay_false_alarms.json').write_text(json.dumps(
        {'dataset': info, 'split': args.split, 'signal_only': args.signal_only,
         'curves': {m: [asdict(p) for p in c] for m, c in curves.items()},
         'slipping': states}, indent=1, default=str))
    figure(curves, args.output / 'delay_false_alarms.png')
    print(f'[slip_delay_report] wrote {args.output}/delay_false_alarms.md, .json, .png in '
          f'{time.perf_counter() - started:.0f} s', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
