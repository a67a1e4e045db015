"""Metrics and tables of the paper's evaluation (pure: no rclpy, no simulation).

Inputs are :class:`TrialRecord` rows (one per grasp trial, whatever produced them: the
closed-loop simulation, a replayed bag, a lab log). The tables follow the layout of the
paper's Table "Category-level summary of grasp success rates and slip-detection
performance" (tables/result_table.tex) and its conventions:

- grasp success per category and overall for On-Off, W/o Slip and FORTE, as
  ``xx.x% (successes/trials)``;
- slip detection judged trial-wise on the FORTE trials: a trial is positive when the
  ground truth has a slip onset during the lift, predicted positive when the detector
  flagged slip during the lift; accuracy / precision / recall / F1 of these trials and the
  onset-to-flag latencies come from :mod:`forte_perception.evaluation.slip_metrics`, whose
  convention holds here: an undefined ratio (precision with nothing flagged, recall with no
  slip to find, F1 when either is undefined) is NaN and prints as ``n/a``. The paper fills
  these cases in (its fragile / deformable row reads 1.00 / 1.00 / 0.00 / 0.00: precision
  1 for "correct abstention from false positives", recall 0 without slip); the ``paper``
  rows print its numbers as published.

And one table the paper does not have: the confusion matrix of the controller's own outcome
against the simulator's ground-truth object state, per controller, with the number of trials
in which the controller contradicts the truth on whether the object was carried
(:func:`contradicts_carried`). "Carried" is the ground-truth state HELD: the object hangs
from the fingers, however far it slid down them (an object held 2.4 mm above the table after
sliding 28 mm down the fingers is carried, though not a success, which needs 5 mm).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field

from forte_perception.evaluation.slip_metrics import TrialScores, format_value, ratio

#: Category keys (forte_sim.catalogue.CATEGORIES) and the paper's row labels.
CATEGORY_LABELS = {
    'fragile_rigid': 'Fragile / Rigid',
    'fragile_deformable': 'Fragile / Deformable',
    'slippery': 'Slippery',
    'everyday': 'Everyday',
}
#: Controller keys (Grasp goal constant names) and the paper's column labels, in its order.
CONTROLLER_LABELS = {'ON_OFF': 'On-Off', 'NO_SLIP': 'W/o Slip', 'FORTE': 'FORTE'}

#: The paper's Table (tables/result_table.tex): per category the object count, per
#: controller (successes, trials, the percentage as printed in the paper: it truncates
#: 80/90 to 88.8 % but rounds 1/80 to 1.3 %), and FORTE's slip accuracy / precision /
#: recall / F1.
PAPER_RESULTS: dict[str, dict] = {
    'fragile_rigid': {'objects': 7, 'ON_OFF': (20, 60, '33.3%'), 'NO_SLIP': (64, 70, '91.4%'),
                      'FORTE': (68, 70, '97.1%'), 'slip': (0.97, 1.00, 0.60, 0.75)},
    'fragile_deformable': {'objects': 7, 'ON_OFF': (0, 70, '0%'), 'NO_SLIP': (70, 70, '100%'),
                           'FORTE': (70, 70, '100%'), 'slip': (1.00, 1.00, 0.00, 0.00)},
    'slippery': {'objects': 9, 'ON_OFF': (80, 90, '88.8%'), 'NO_SLIP': (28, 90, '31.1%'),
                 'FORTE': (80, 90, '88.8%'), 'slip': (0.91, 1.00, 0.82, 0.90)},
    'everyday': {'objects': 8, 'ON_OFF': (80, 80, '100%'), 'NO_SLIP': (1, 80, '1.3%'),
                 'FORTE': (68, 80, '85.0%'), 'slip': (0.88, 1.00, 0.86, 0.93)},
    'overall': {'objects': 31, 'ON_OFF': (180, 300, '60.0%'), 'NO_SLIP': (163, 310, '52.6%'),
                'FORTE': (285, 310, '91.9%'), 'slip': (0.93, 1.00, 0.84, 0.91)},
}
#: The paper's force RMSE (10-fold trial-wise CV, 6 indentors x 40 trials) [N].
PAPER_FORCE_RMSE = {'with_history': 0.187, 'without_history': 0.211}
#: The paper's slip latency statement: "typically below 100 ms" [s].
PAPER_SLIP_LATENCY_BOUND = 0.100


@dataclass
class TrialRecord:
    """Outcome of one grasp trial, as the tables need it.

    Attributes
    ----------
    object_name, category, controller : str
        Object type, its category key, controller key (``FORTE``/``NO_SLIP``/``ON_OFF``).
    trial : int
        Trial index for this object and controller.
    success : bool
        Object lifted to the goal height and held intact.
    outcome : str
        Grasp result outcome name (``LIFTED``, ``DROPPED``, ...).
    object_state : str
        Ground-truth object state at the end (``HELD``, ``DROPPED``, ``BROKEN``, ...).
    object_state_at_outcome : str
        Ground-truth object state when the controller reached its outcome ('' if unknown).
    final_height : float
        Ground-truth object height above the table at the end [m] (NaN if unknown).
    slip_true : bool
        Ground truth: at least one slip onset during the lift.
    slip_predicted : bool
        The detector flagged slip at least once during the lift.
    latencies : list of float
        Per true slip onset that the detector caught: time from onset to the first flag
        after it [s].
    missed_onsets : int
        True slip onsets with no flag within the latency horizon [count].
    onset_cues : list of (int, str)
        Per true slip onset: its ``SimGroundTruth`` ``SLIP_*`` type and the cue that found it
        first within the latency horizon (:data:`CUES`).
    either_cue_latencies : list of float
        Per true slip onset that either cue found within the latency horizon: time from
        onset to the first slip flag or gross-slip tightening, whichever came first [s]
        (the controller acts on both).
    max_true_force : float
        Largest true per-finger normal force during the trial [N] (NaN if unknown).
    duration : float
        Trial length [s].
    seed : int or None
        Scene seed of the trial (``forte_evaluation.closed_loop.run_trial``'s ``seed``, with
        ``trial``, reruns it); None if unknown.
    """

    object_name: str
    category: str
    controller: str
    trial: int
    success: bool
    outcome: str = ''
    object_state: str = ''
    slip_true: bool = False
    slip_predicted: bool = False
    latencies: list[float] = field(default_factory=list)
    missed_onsets: int = 0
    onset_cues: list[tuple[int, str]] = field(default_factory=list)
    either_cue_latencies: list[float] = field(default_factory=list)
    max_true_force: float = float('nan')
    duration: float = float('nan')
    object_state_at_outcome: str = ''
    final_height: float = float('nan')
    seed: int | None = None

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return asdict(self)


@dataclass(frozen=True)
class Rate:
    """A success rate ``successes / trials``."""

    successes: int
    trials: int

    @property
    def value(self) -> float:
        """Fraction in [0, 1]; NaN when there were no trials."""
        return ratio(self.successes, self.trials)

    def __str__(self) -> str:
        if not self.trials:
            return 'n/a'
        return f'{100.0 * self.value:.1f}% ({self.successes}/{self.trials})'


def slip_scores(records: Iterable[TrialRecord]) -> TrialScores:
    """Trial-wise slip confusion counts and scores of ``records``."""
    return TrialScores.count((r.slip_true, r.slip_predicted) for r in records)


def success_rate(records: Iterable[TrialRecord]) -> Rate:
    """Successes over trials of ``records``."""
    records = list(records)
    return Rate(sum(1 for r in records if r.success), len(records))


# --- tables --------------------------------------------------------------------------------
def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]
    def line(cells: Sequence[str]) -> str:
        return '| ' + ' | '.join(str(c).ljust(w) for c, w in zip(cells, widths)) + ' |'
    rule = '|' + '|'.join('-' * (w + 2) for w in widths) + '|'
    return '\n'.join([line(header), rule, *(line(row) for row in rows)])


def summarize(records: Sequence[TrialRecord]) -> dict:
    """Per-category and overall success rates and FORTE slip scores.

    Returns
    -------
    dict
        ``{category or 'overall': {'objects': n, 'success': {controller: Rate},
        'slip': TrialScores}}``, categories in the paper's order (only those present).
    """
    summary: dict[str, dict] = {}
    groups = [c for c in CATEGORY_LABELS if any(r.category == c for r in records)]
    extra = sorted({r.category for r in records} - set(CATEGORY_LABELS))
    for category in [*groups, *extra, 'overall']:
        rows = [r for r in records if category == 'overall' or r.category == category]
        summary[category] = {
            'objects': len({r.object_name for r in rows}),
            'success': {c: success_rate(r for r in rows if r.controller == c)
                        for c in CONTROLLER_LABELS},
            'slip': slip_scores(r for r in rows if r.controller == 'FORTE'),
        }
    return summary


def result_table(records: Sequence[TrialRecord], with_paper: bool = True) -> str:
    """The paper's result table (grasp success and slip detection) as Markdown.

    With ``with_paper``, each row is followed by the paper's row (``paper``) so that the
    numbers read side by side.
    """
    summary = summarize(records)
    header = ['Category', '# Obj', *CONTROLLER_LABELS.values(), 'Acc.', 'Prec.', 'Recall',
              'F1']
    rows = []
    for category, entry in summary.items():
        label = CATEGORY_LABELS.get(category, 'Overall' if category == 'overall' else category)
        rows.append([label, str(entry['objects']),
                     *(str(entry['success'][c]) for c in CONTROLLER_LABELS),
                     *(format_value(v) for v in entry['slip'].as_tuple())])
        paper = PAPER_RESULTS.get(category)
        if with_paper and paper is not None:
            rows.append(['  paper', str(paper['objects']),
                         *(f'{paper[c][2]} ({paper[c][0]}/{paper[c][1]})'
                           for c in CONTROLLER_LABELS),
                         *(format_value(v) for v in paper['slip'])])
    return _table(header, rows)


def mode_comparison_table(records_by_mode: dict[str, Sequence[TrialRecord]]) -> str:
    """FORTE's success and slip precision per category, one column pair per slip mode.

    Parameters
    ----------
    records_by_mode : dict
        Slip detector mode (``'robust'``, ``'paper'``) -> the benchmark's records in it.
    """
    summaries = {mode: summarize(records) for mode, records in records_by_mode.items()}
    header = ['Category']
    for mode in summaries:
        header += [f'FORTE ({mode})', f'Prec. ({mode})']
    categories = list(next(iter(summaries.values()))) if summaries else []
    rows = []
    for category in categories:
        label = CATEGORY_LABELS.get(category, 'Overall' if category == 'overall' else category)
        row = [label]
        for summary in summaries.values():
            entry = summary.get(category)
            row += ([str(entry['success']['FORTE']), format_value(entry['slip'].precision)]
                    if entry else ['-', '-'])
        rows.append(row)
    return _table(header, rows)


def force_table(results: dict[str, dict]) -> str:
    """Force RMSE table: rows = feature sets, columns = ours / paper.

    Parameters
    ----------
    results : dict
        ``{'with_history': {'rmse': float, 'mae': float, 'per_indentor': {...}},
        'without_history': {...}}`` (missing entries are shown as n/a).
    """
    rows = []
    for key, label in (('with_history', 'latest frame + 2.5/5/10 s means (24 features)'),
                       ('without_history', 'latest frame only (6 features)')):
        entry = results.get(key, {})
        rows.append([label, format_value(entry.get('rmse'), 3),
                     format_value(entry.get('mae'), 3), format_value(PAPER_FORCE_RMSE[key], 3)])
    return _table(['Force features', 'RMSE [N]', 'MAE [N]', 'paper RMSE [N]'], rows)


def latency_table(stats: dict[str, float]) -> str:
    """Slip latency distribution (onset to flag) as a one-row table, in milliseconds."""
    def ms(value: float) -> str:
        return format_value(1000.0 * value, 1)
    row = [str(stats['count']), str(stats['missed']), ms(stats['p50']), ms(stats['p90']),
           ms(stats['max']), format_value(100.0 * stats['fraction_below_100ms'], 1),
           f'< {1000 * PAPER_SLIP_LATENCY_BOUND:.0f} (typical)']
    return _table(['detected onsets', 'missed', 'p50 [ms]', 'p90 [ms]', 'max [ms]',
                   '% < 100 ms', 'paper [ms]'], [row])


#: Which cue found a closed-loop slip onset first: the slip detector's flag (vibration), the
#: controller's tightening on the lift monitor's gross-slip evidence (quasi-static: unequal
#: finger levels or a decaying deformation while the arm lifts), or neither in the horizon.
CUES = ('vibration', 'lift monitor', 'neither')
#: SimGroundTruth SLIP_* types by value.
ONSET_TYPES = {1: 'incipient', 2: 'gross', 3: 'stick-slip', 4: 'rotational'}


def first_cue(vibration_latency: float, lift_monitor_latency: float) -> str:
    """The cue (:data:`CUES`) that found an onset first, from each cue's latency [s] (NaN:
    not within the horizon); a tie goes to the vibration cue."""
    if math.isnan(lift_monitor_latency):
        return CUES[2] if math.isnan(vibration_latency) else CUES[0]
    if math.isnan(vibration_latency) or lift_monitor_latency < vibration_latency:
        return CUES[1]
    return CUES[0]


def cue_counts(records: Iterable[TrialRecord]) -> dict[str, dict[str, int]]:
    """Onsets per onset type (and ``all``): how many each cue found first."""
    counts: dict[str, dict[str, int]] = {}
    for record in records:
        for kind, cue in record.onset_cues:
            for row in (ONSET_TYPES.get(kind, str(kind)), 'all'):
                counts.setdefault(row, dict.fromkeys(CUES, 0))[cue] += 1
    return counts


def cue_table(records: Sequence[TrialRecord]) -> str:
    """Which cue found each true onset first (FORTE trials), per onset type."""
    counts = cue_counts(r for r in records if r.controller == 'FORTE')
    order = [*ONSET_TYPES.values(), 'all']
    rows = [[row, str(sum(c.values())), *(str(c[cue]) for cue in CUES)]
            for row in sorted(counts, key=lambda k: order.index(k) if k in order else -1)
            for c in [counts[row]]]
    return _table(['onset type', 'onsets', 'vibration first', 'lift monitor first',
                   'found by neither'], rows)


def summary_json(records: Sequence[TrialRecord]) -> dict:
    """The result table as plain numbers (for the results JSON)."""
    out = {}
    for category, entry in summarize(records).items():
        out[category] = {
            'objects': entry['objects'],
            'success': {c: {'successes': r.successes, 'trials': r.trials, 'rate': r.value}
                        for c, r in entry['success'].items()},
            'slip': entry['slip'].to_dict(),
            'paper': PAPER_RESULTS.get(category),
        }
    return out


# --- controller outcome against the ground truth ------------------------------------------
#: Grasp outcomes in table order (forte_msgs/action/Grasp result constants).
OUTCOME_ORDER = ('LIFTED', 'NOT_CARRIED', 'DROPPED', 'NO_CONTACT', 'CLOSED_ON_OBJECT',
                 'FORCE_LIMIT', 'TIMEOUT', 'CANCELED', 'FAULT')
#: Ground-truth object states in table order (forte_msgs/msg/SimGroundTruth OBJECT_*).
TRUTH_ORDER = ('HELD', 'RESTING', 'DROPPED', 'BROKEN', 'CRUSHED')


def carrying_agreement(outcome: str, truth: str) -> bool | None:
    """Do the outcome and the truth agree on whether the object was carried?

    LIFTED claims the object is carried, DROPPED and NOT_CARRIED that it is not; the truth
    says it is (HELD) or is not (RESTING, DROPPED). A BROKEN or CRUSHED object may or may not
    hang in the grasp (the truth does not say), and other outcomes make no claim.

    Returns
    -------
    bool or None
        True or False when both sides say something about carrying; None otherwise.
    """
    claims = {'LIFTED': True, 'DROPPED': False, 'NOT_CARRIED': False}.get(outcome)
    carried = {'HELD': True, 'RESTING': False, 'DROPPED': False}.get(truth)
    if claims is None or carried is None:
        return None
    return claims == carried


def contradicts_carried(outcome: str, truth: str) -> bool:
    """True when the outcome and the truth disagree on whether the object was carried
    (LIFTED against RESTING or DROPPED; DROPPED or NOT_CARRIED against HELD)."""
    return carrying_agreement(outcome, truth) is False


def confusion(records: Iterable[TrialRecord], controller: str,
              at_outcome: bool = False) -> dict[str, dict[str, int]]:
    """Counts of (controller outcome, ground-truth object state) of one controller.

    Parameters
    ----------
    records : iterable of TrialRecord
    controller : str
        Controller key; other records are ignored.
    at_outcome : bool
        Use the truth at the controller's outcome instead of the truth at the end of the
        trial (records without it fall back to the final truth).

    Returns
    -------
    dict
        ``{outcome: {truth: count}}`` with only the pairs that occurred.
    """
    table: dict[str, dict[str, int]] = {}
    for record in records:
        if record.controller != controller:
            continue
        truth = (record.object_state_at_outcome or record.object_state) if at_outcome \
            else record.object_state
        row = table.setdefault(record.outcome, {})
        row[truth] = row.get(truth, 0) + 1
    return table


def contradiction_count(matrix: dict[str, dict[str, int]]) -> tuple[int, int]:
    """(trials contradicting the truth on carrying, trials) of a :func:`confusion` matrix."""
    bad = sum(n for outcome, row in matrix.items() for truth, n in row.items()
              if contradicts_carried(outcome, truth))
    total = sum(n for row in matrix.values() for n in row.values())
    return bad, total


def confusion_table(records: Sequence[TrialRecord], at_outcome: bool = False) -> str:
    """Markdown confusion matrices, one block of rows per controller, and the contradictions.

    Rows: controller outcome (only those that occurred); columns: ground-truth object state.
    Each controller ends with a row ``contradicts truth`` counting the trials in which the
    outcome and the truth disagree on whether the object was carried.
    """
    matrices = {controller: confusion(records, controller, at_outcome)
                for controller in CONTROLLER_LABELS}
    seen = {truth for matrix in matrices.values() for row in matrix.values() for truth in row}
    truths = list(TRUTH_ORDER) + sorted(seen - set(TRUTH_ORDER))
    header = ['controller', 'outcome \\ truth', *truths, 'total']
    rows = []
    for controller, label in CONTROLLER_LABELS.items():
        matrix = matrices[controller]
        if not matrix:
            continue
        outcomes = [o for o in OUTCOME_ORDER if o in matrix] + sorted(
            set(matrix) - set(OUTCOME_ORDER))
        for outcome in outcomes:
            row = matrix[outcome]
            cells = []
            for truth in truths:
                n = row.get(truth, 0)
                mark = '!' if n and contradicts_carried(outcome, truth) else ''
                cells.append(f'{n}{mark}' if n else '.')
            rows.append([label, outcome, *cells, str(sum(row.values()))])
        bad, total = contradiction_count(matrix)
        rows.append([label, '**contradicts truth**', *([''] * len(truths)),
                     f'**{bad}/{total} ({100.0 * bad / total:.1f}%)**'])
    return _table(header, rows)


def confusion_json(records: Sequence[TrialRecord]) -> dict:
    """Confusion matrices (final truth and truth at the outcome) and contradiction counts."""
    out = {}
    for controller in CONTROLLER_LABELS:
        entry = {}
        for key, at_outcome in (('final', False), ('at_outcome', True)):
            matrix = confusion(records, controller, at_outcome)
            bad, total = contradiction_count(matrix)
            entry[key] = {'matrix': matrix, 'contradictions': bad, 'trials': total}
        if entry['final']['trials']:
            out[controller] = entry
    return out
