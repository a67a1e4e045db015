"""The one page of measured numbers, generated from the evaluation's JSON files.

``docs/results.md`` is written by this tool, never by hand::

    python tools/results_page.py [--evaluation out/evaluation/results.json]
                                 [--slip out/slip_benchmark/sequential.json ...]
                                 [--output docs/results.md]

(``make results`` runs the evaluation, the slip benchmark in the ``sequential`` and ``paper``
modes and then this tool.) The inputs are the files the evaluation tools write:

- ``python -m forte_evaluation.evaluate --output DIR`` -> ``DIR/results.json``: grasp
  success per category next to the paper's, FORTE's trial-wise slip detection, the slip
  latency, the controller's outcome against the ground truth (per slip mode) and the force
  model's cross-validation;
- ``python -m forte_evaluation.slip_benchmark --mode MODE --output DIR`` ->
  ``DIR/MODE.json``: the slip detector modes on the labelled slip set.

The tables are made by the functions that make the evaluation's own tables
(:mod:`forte_evaluation.metrics`, :func:`forte_perception.evaluation.benchmark.markdown`),
from the per-trial records of ``results.json``; the summaries stored beside them must agree
with those records, or the tool stops. Nothing is filled in: a missing file or key is an
error (exit 2) or a sentence saying what was not given. The page depends on the inputs'
bytes and the command line only (no clock, no host), so the same inputs give the same page.

``--slip`` with no file leaves the slip benchmark out (the page says so).
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from forte_evaluation.evaluate import _mode_results
from forte_evaluation.metrics import (
    CATEGORY_LABELS,
    PAPER_RESULTS,
    TrialRecord,
    confusion_table,
    force_table,
    latency_table,
    mode_comparison_table,
    result_table,
)
from forte_perception.evaluation.benchmark import markdown as slip_markdown
from forte_perception.evaluation.slip_metrics import format_value

DEFAULT_EVALUATION = Path('out/evaluation/results.json')
DEFAULT_SLIP = (Path('out/slip_benchmark/sequential.json'),
                Path('out/slip_benchmark/paper.json'))
DEFAULT_OUTPUT = Path('docs/results.md')
#: Keys under which a JSON file may record when and from which commit it was made.
PROVENANCE_KEYS = ('date', 'created', 'timestamp', 'commit', 'git_commit', 'git')
#: Keys of the stored per-mode summaries checked against the per-trial records.
CHECKED_KEYS = ('grasp', 'truth', 'slip_latency')


class InputError(Exception):
    """An input file is missing, unreadable or disagrees with itself (exit code 2)."""


@dataclasses.dataclass
class Source:
    """One input file: its path, parsed document and SHA-256 of its bytes."""

    path: Path
    document: dict
    sha256: str


# --- reading --------------------------------------------------------------------------------
def evaluation_command(path: Path) -> str:
    """The command that writes the evaluation results file ``path``."""
    return f'python -m forte_evaluation.evaluate --output {path.parent}'


def slip_command(path: Path, mode: str | None = None) -> str:
    """The command that writes the slip benchmark file ``path`` (mode: its file name)."""
    return (f'python -m forte_evaluation.slip_benchmark --mode {mode or path.stem} '
            f'--output {path.parent}')


def load(path: Path, command: str) -> Source:
    """Read and parse one JSON input.

    Parameters
    ----------
    path : Path
        The file.
    command : str
        The command that writes it, named in the error.

    Raises
    ------
    InputError
        The file does not exist, cannot be read or is not a JSON object.
    """
    if not path.is_file():
        raise InputError(f'{path} not found; it is written by `{command}`')
    raw = path.read_bytes()
    try:
        document = json.loads(raw)
    except (ValueError, UnicodeDecodeError) as error:
        raise InputError(f'{path} is not valid JSON ({error}); `{command}` rewrites it') \
            from None
    if not isinstance(document, dict):
        raise InputError(f'{path} is not a JSON object; `{command}` rewrites it')
    return Source(path, document, hashlib.sha256(raw).hexdigest())


def trial_records(rows: Sequence[dict], where: str) -> list[TrialRecord]:
    """:class:`TrialRecord` rows from the ``trials`` list of ``results.json``."""
    names = {f.name for f in dataclasses.fields(TrialRecord)}
    try:
        return [TrialRecord(**{k: v for k, v in row.items() if k in names}) for row in rows]
    except TypeError as error:
        raise InputError(f'{where}: a trial record lacks a field ({error})') from None


def _same(a: object, b: object) -> bool:
    """Equal JSON values, floats to 1e-9 relative and NaN equal to NaN (and to null)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, bool) or isinstance(b, bool):
        return a == b
    if isinstance(a, (int, float, type(None))) and isinstance(b, (int, float, type(None))):
        a = math.nan if a is None else a
        b = math.nan if b is None else b
        return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9)
    return a == b


def _without_paper(grasp: dict) -> dict:
    return {category: {k: v for k, v in entry.items() if k != 'paper'}
            for category, entry in grasp.items()}


def grasp_modes(source: Source) -> dict[str, dict]:
    """Per slip mode: the records and the summaries made from them (as the evaluation does).

    Returns
    -------
    dict
        ``{mode: {'records': [TrialRecord], 'grasp': ..., 'truth': ..., 'slip_latency':
        ...}}`` in the file's order; empty when the file has no grasp benchmark.

    Raises
    ------
    InputError
        A stored summary disagrees with the trials it summarises.
    """
    document = source.document
    stored = document.get('by_slip_mode')
    if stored is None and 'trials' in document:
        rows = document['trials']
        mode = rows[0].get('slip_mode', 'unrecorded') if rows else 'unrecorded'
        stored = {mode: document}
    modes = {}
    for mode, entry in (stored or {}).items():
        where = f'{source.path}: by_slip_mode.{mode}'
        if not entry.get('trials'):
            raise InputError(f'{where} has no trials; `{evaluation_command(source.path)}` '
                             'rewrites it')
        records = trial_records(entry['trials'], where)
        made = _mode_results(records, mode)
        for key in CHECKED_KEYS:
            ours, theirs = made[key], entry.get(key)
            if key == 'grasp' and theirs is not None:
                ours, theirs = _without_paper(ours), _without_paper(theirs)
            if theirs is not None and not _same(ours, theirs):
                raise InputError(f'{where}.{key} disagrees with its own trials; the file was '
                                 f'edited or is damaged: `{evaluation_command(source.path)}`')
        modes[mode] = {'records': records, **{key: made[key] for key in CHECKED_KEYS}}
    return modes


# --- formatting helpers --------------------------------------------------------------------
def _cell(value: object) -> str:
    """A config value as table text (lists comma-separated, floats to 4 digits)."""
    if isinstance(value, (list, tuple)):
        return ', '.join(_cell(v) for v in value)
    if isinstance(value, float):
        return f'{value:.4g}'
    return str(value)


def _flat(config: dict, prefix: str = '') -> list[str]:
    """``key=value`` items of a (nested) config dictionary, in its order."""
    items = []
    for key, value in config.items():
        if isinstance(value, dict):
            items += _flat(value, f'{prefix}{key}.')
        else:
            items.append(f'{prefix}{key}={_cell(value)}')
    return items


def provenance(document: dict) -> str:
    """The date and commit the file records about itself, or a sentence saying it has none."""
    places = [document, document.get('config') or {}]
    found = [f'{key} {_cell(place[key])}' for place in places for key in PROVENANCE_KEYS
             if key in place]
    return '; '.join(found) if found else 'no date or commit recorded in the file'


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    return lines + ['| ' + ' | '.join(row) + ' |' for row in rows]


def _label(category: str) -> str:
    return CATEGORY_LABELS.get(category, 'Overall' if category == 'overall' else category)


def _absent(what: str, reason: str) -> list[str]:
    return [f'_Not on this page: {what} ({reason})._', '']


# --- sections ------------------------------------------------------------------------------
def header(command: str, evaluation: Source, slips: Sequence[Source]) -> list[str]:
    """Title, how the page is made, and one row per input (file, hash, config, provenance)."""
    lines = ['# FORTE: measured results', '',
             '<!-- Generated by tools/results_page.py; edit that tool, not this page. -->', '',
             'This page is generated; do not edit it by hand. `make results` reruns the '
             'evaluation and the slip benchmark (`sequential` and `paper` modes) and regenerates '
             'it. This copy was made by', '', f'    {command}', '',
             'from the files below. Every table is made by the functions that print the '
             "evaluation's own tables, from the per-trial records of the files; the paper's "
             'numbers are those of `forte_evaluation.metrics` (its Table of results, force '
             'RMSE and latency statement). Simulation numbers depend on a simulator whose '
             'parameters are partly estimates: they show that the software reproduces the '
             "paper's pattern, not that the real gripper would score the same.", '',
             '## Inputs', '']
    rows = [['grasp and force evaluation', f'`{evaluation.path}`',
             f'`{evaluation.sha256[:16]}`', f'`{evaluation_command(evaluation.path)}`',
             '; '.join(_flat(evaluation.document.get('config') or {})) or 'no config',
             provenance(evaluation.document)]]
    for source in slips:
        config = source.document.get('config') or {}
        rows.append([f'slip benchmark, `{config.get("mode", "?")}` mode', f'`{source.path}`',
                     f'`{source.sha256[:16]}`',
                     f'`{slip_command(source.path, config.get("mode"))}`',
                     '; '.join(_flat(config)) or 'no config', provenance(source.document)])
    if not slips:
        rows.append(['slip benchmark', 'not given', '', f'`{slip_command(DEFAULT_SLIP[0])}`',
                     '', 'its section is left out'])
    lines += _table(['input', 'file', 'sha256 (first 16)', 'written by', 'run', 'recorded'],
                    rows)
    if (evaluation.document.get('config') or {}).get('quick'):
        lines += ['', '**The evaluation is a `--quick` subset (one object per category, few '
                  'trials, small force CV), not the full benchmark.**']
    return lines + ['']


def grasp_section(modes: dict[str, dict]) -> list[str]:
    """Grasp success per category and FORTE's slip scores next to the paper's, per mode."""
    lines = ['## Grasp success per category (ours next to the paper\'s)', '',
             'Success: object lifted to the goal height and held intact, as '
             '`xx.x% (successes/trials)`; Acc. / Prec. / Recall / F1: FORTE\'s trial-wise '
             'slip detection (next section). Rows `paper`: the paper\'s Table as published.',
             '']
    if not modes:
        return lines + _absent('the grasp benchmark', 'the evaluation file has none; it '
                               'ran with --skip-grasp')
    for mode, entry in modes.items():
        lines += [f'### Slip mode `{mode}`', '', result_table(entry['records']), '']
    if len(modes) > 1:
        lines += ['### FORTE in each slip mode', '',
                  mode_comparison_table({m: e['records'] for m, e in modes.items()}), '']
    return lines


def slip_detection_section(modes: dict[str, dict]) -> list[str]:
    """FORTE's trial-wise slip confusion counts and scores per category, per mode."""
    lines = ['## Slip detection, trial-wise (FORTE trials)', '',
             'A trial is positive when the simulator has a slip onset during the lift, '
             'flagged when the detector flagged slip during the lift. `n/a`: undefined '
             '(nothing flagged, or no slip to find); the paper fills these cases in.', '']
    if not modes:
        return lines + _absent('slip detection', 'no grasp benchmark in the evaluation file')
    rows = []
    for mode, entry in modes.items():
        for category, summary in entry['grasp'].items():
            slip = summary['slip']
            paper = PAPER_RESULTS.get(category, {}).get('slip')
            rows.append([f'`{mode}`', _label(category),
                         *(str(slip[k]) for k in ('true_positive', 'false_positive',
                                                  'true_negative', 'false_negative')),
                         *(format_value(slip[k]) for k in ('accuracy', 'precision',
                                                           'recall', 'f1')),
                         ' / '.join(format_value(v) for v in paper) if paper else '-'])
    return lines + _table(['slip mode', 'category', 'TP', 'FP', 'TN', 'FN', 'Acc.', 'Prec.',
                           'Recall', 'F1', 'paper Acc. / Prec. / Recall / F1'], rows) + ['']


def latency_section(modes: dict[str, dict]) -> list[str]:
    """Slip latency (true onset to the first flag) of the FORTE trials, per mode."""
    lines = ['## Slip latency, true onset to first flag (FORTE trials)', '']
    if not modes:
        return lines + _absent('slip latency', 'no grasp benchmark in the evaluation file')
    for mode, entry in modes.items():
        lines += [f'### Slip mode `{mode}`', '', latency_table(entry['slip_latency']), '']
    return lines


def truth_section(modes: dict[str, dict]) -> list[str]:
    """Trials in which a controller's outcome contradicts the simulator's ground truth."""
    lines = ['## Controller outcome against the ground truth', '',
             'Trials in which the controller\'s outcome contradicts the simulator\'s '
             'ground-truth object state on whether the object was carried (LIFTED vs RESTING '
             'or DROPPED; DROPPED or NOT_CARRIED vs HELD), with the truth at the end of the '
             'trial (1 s after the outcome) and at the moment of the outcome. The paper has '
             'no such table.', '']
    if not modes:
        return lines + _absent('the contradictions', 'no grasp benchmark in the evaluation '
                               'file')
    rows = []
    for mode, entry in modes.items():
        for controller, counts in entry['truth'].items():
            rows.append([f'`{mode}`', controller,
                         *(f'{counts[k]["contradictions"]}/{counts[k]["trials"]}'
                           for k in ('final', 'at_outcome'))])
    lines += _table(['slip mode', 'controller', 'at the end', 'at the outcome'], rows) + ['']
    for mode, entry in modes.items():
        lines += [f'### Slip mode `{mode}`: outcome \\ truth at the end of the trial', '',
                  '`!` marks a contradiction.', '', confusion_table(entry['records']), '']
    return lines


def force_section(evaluation: Source) -> list[str]:
    """Force model RMSE / MAE (10-fold trial-wise CV) next to the paper's, per indentor."""
    lines = ['## Force estimation (10-fold trial-wise CV on the simulated rig)', '']
    force = evaluation.document.get('force')
    if not force:
        return lines + _absent('force estimation', 'the evaluation file has no `force`; it '
                               'ran with --skip-force')
    lines += [force_table(force), '']
    entries = [(k, force[k]) for k in ('with_history', 'without_history') if k in force]
    indentors = list(dict.fromkeys(name for _, e in entries for name in e.get('per_indentor',
                                                                                {})))
    if indentors:
        rows = [[name, *(format_value(e.get('per_indentor', {}).get(name), 3)
                         for _, e in entries)] for name in indentors]
        lines += ['RMSE per indentor [N]:', '',
                  *_table(['indentor', *(k.replace('_', ' ') for k, _ in entries)], rows), '']
    for key, entry in entries:
        low, high = (entry.get('force_range') or [math.nan, math.nan])[:2]
        lines.append(f'- {key.replace("_", " ")}: {entry.get("points", "?")} points from '
                     f'{entry.get("trials", "?")} trials, force {format_value(low, 2)} to '
                     f'{format_value(high, 2)} N')
    return lines + ['']


def slip_benchmark_section(slips: Sequence[Source]) -> list[str]:
    """The slip benchmark's tables, all modes side by side, then each mode's own tables."""
    lines = ['## Slip detector modes on the labelled slip set', '']
    if not slips:
        return lines + _absent('the slip benchmark', 'no slip benchmark file was given; '
                               f'`{slip_command(DEFAULT_SLIP[0])}` writes one')
    lines += ['An event is detected when a flag falls within the latency horizon after its '
              'onset; CPU time per detector update is the best of the repetitions.', '',
              '### All scenes, each mode', '']
    keys = (('precision', 2), ('recall', 2), ('f1', 2), ('latency_p50_ms', 0),
            ('latency_p90_ms', 0), ('false_per_min_holding', 1), ('cpu_us_per_update', 2))
    rows = []
    for source in slips:
        mode = (source.document.get('config') or {}).get('mode', source.path.stem)
        for split, part in (source.document.get('results') or {}).items():
            total = part.get('groups', {}).get('all', {})
            rows.append([f'`{mode}`', split.replace('_', '-'), _cell(total.get('scenes')),
                         _cell(total.get('events')),
                         *(format_value(total.get(key), digits) for key, digits in keys)])
    lines += _table(['mode', 'part', 'scenes', 'events', 'precision', 'recall', 'F1',
                     'latency p50 [ms]', 'p90 [ms]', 'false / min holding',
                     'CPU / update [us]'], rows) + ['']
    for source in slips:
        mode = (source.document.get('config') or {}).get('mode', source.path.stem)
        if not source.document.get('results'):
            raise InputError(f'{source.path} has no results; `{slip_command(source.path)}` '
                             'rewrites it')
        lines += [slip_markdown(source.document['results'], mode)]
    return lines


def timings_section(evaluation: Source, slips: Sequence[Source]) -> list[str]:
    """The run times the files record (seconds on the machine that made them)."""
    rows = [[f'`{source.path}`', key, f'{float(value):.1f}']
            for source in (evaluation, *slips)
            for key, value in (source.document.get('timings') or {}).items()
            if isinstance(value, (int, float))]
    lines = ['## Timings', '', 'As recorded in the files (seconds on the machine that made '
             'them; `_cpu_` entries are CPU time, the others wall time).', '']
    if not rows:
        return lines + _absent('timings', 'the files record none')
    return lines + _table(['file', 'step', 'seconds'], rows) + ['']


# --- the page ------------------------------------------------------------------------------
def render(evaluation: Source, slips: Sequence[Source], command: str) -> str:
    """The whole page as markdown text (ends with one newline)."""
    modes = grasp_modes(evaluation)
    lines = [*header(command, evaluation, slips), *grasp_section(modes),
             *slip_detection_section(modes), *latency_section(modes), *truth_section(modes),
             *force_section(evaluation), *slip_benchmark_section(slips),
             *timings_section(evaluation, slips)]
    while lines and lines[-1] == '':
        lines.pop()
    return '\n'.join(lines) + '\n'


def command_line(evaluation: Path, slips: Sequence[Path], output: Path) -> str:
    """The command that makes this page from these files."""
    return ' '.join(['python tools/results_page.py', '--evaluation', str(evaluation),
                     '--slip', *(str(p) for p in slips), '--output', str(output)])


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='results_page', description=__doc__.split('\n')[0])
    parser.add_argument('--evaluation', type=Path, default=DEFAULT_EVALUATION,
                        help=f'results.json of forte_evaluation.evaluate '
                             f'(default {DEFAULT_EVALUATION})')
    parser.add_argument('--slip', type=Path, nargs='*', default=list(DEFAULT_SLIP),
                        help='MODE.json files of forte_evaluation.slip_benchmark (default: '
                             'sequential and paper in out/slip_benchmark/; none: leave it out)')
    parser.add_argument('--output', type=Path, default=DEFAULT_OUTPUT,
                        help=f'the page to write (default {DEFAULT_OUTPUT})')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (2: an input is missing or inconsistent)."""
    args = _parser().parse_args(argv)
    try:
        evaluation = load(args.evaluation, evaluation_command(args.evaluation))
        slips = [load(path, slip_command(path)) for path in args.slip]
        page = render(evaluation, slips, command_line(args.evaluation, args.slip, args.output))
    except InputError as error:
        print(f'results_page: error: {error}', file=sys.stderr)
        return 2
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(page)
    print(f'[results_page] wrote {args.output} from {args.evaluation}'
          + ''.join(f', {path}' for path in args.slip), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
