"""Metrics and tables of the paper's evaluation (pure: no rclpy, no simulation).

Inputs are :class:`TrialRecord` rows (one per grasp trial, whatever produced them: the
closed-loop simulation, a replayed bag, a lab log). The tables follow the layout of the
paper's Table "Category-level summary of grasp success rates and slip-detection
performance" (tables/result_table.tex) and its conventions:

- grasp success per category and overall for On-Off, W/o Slip and FORTE, as
  ``xx.x% (successes/trials)``;
- slip detection judged trial-wise on the FORTE trials: a trial is positive when the
  ground truth has a slip onset during the lift, predicted positive when the detector
  flagged slip during the lift. Precision is defined as 1.0 when there are no predicted
  positives (the paper: "correct abstention from false positives"); recall (and hence F1)
  is 0.0 when there are no true positives to find, which is how the paper's
  fragile / deformable row reads (1.00 / 1.00 / 0.00 / 0.00).

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

import numpy as np

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
    max_true_force : float
        Largest true per-finger normal force during the trial [N] (NaN if unknown).
    duration : float
        Trial length [s].
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
    max_true_force: float = float('nan')
    duration: float = float('nan')
    object_state_at_outcome: str = ''
    final_height: float = float('nan')

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
        return self.successes / self.trials if self.trials else float('nan')

    def __str__(self) -> str:
        if not self.trials:
            return 'n/a'
        return f'{100.0 * self.value:.1f}% ({self.successes}/{self.trials})'


@dataclass(frozen=True)
class SlipScores:
    """Trial-wise confusion counts and scores of the slip detector."""

    true_positive: int
    false_positive: int
    true_negative: int
    false_negative: int

    @property
    def trials(self) -> int:
        return self.true_positive + self.false_positive + self.true_negative + self.false_negative

    @property
    def accuracy(self) -> float:
        """(TP + TN) / trials; NaN without trials."""
        if not self.trials:
            return float('nan')
        return (self.true_positive + self.true_negative) / self.trials

    @property
    def precision(self) -> float:
        """TP / (TP + FP); 1.0 when nothing was flagged (the paper's convention)."""
        flagged = self.true_positive + self.false_positive
        return self.true_positive / flagged if flagged else 1.0

    @property
    def recall(self) -> float:
        """TP / (TP + FN); 0.0 when there was no slip to find (as the paper's table)."""
        positives = self.true_positive + self.false_negative
        return self.true_positive / positives if positives else 0.0

    @property
    def f1(self) -> float:
        """Harmonic mean of precision and recall; 0.0 when both are 0."""
        total = self.precision + self.recall
        return 2.0 * self.precision * self.recall / total if total else 0.0

    def as_tuple(self) -> tuple[float, float, float, float]:
        """(accuracy, precision, recall, F1)."""
        return (self.accuracy, self.precision, self.recall, self.f1)


def slip_scores(records: Iterable[TrialRecord]) -> SlipScores:
    """Trial-wise slip confusion counts of ``records``."""
    tp = fp = tn = fn = 0
    for record in records:
        if record.slip_true and record.slip_predicted:
            tp += 1
        elif record.slip_predicted:
            fp += 1
        elif record.slip_true:
            fn += 1
        else:
            tn += 1
    return SlipScores(tp, fp, tn, fn)


def success_rate(records: Iterable[TrialRecord]) -> Rate:
    """Successes over trials of ``records``."""
    records = list(records)
    return Rate(sum(1 for r in records if r.success), len(records))


def latency_stats(latencies: Sequence[float], missed: int = 0) -> dict[str, float]:
    """Distribution of slip detection latencies (onset to first flag).

    Parameters
    ----------
    latencies : sequence of float
        One value per detected onset [s].
    missed : int
        Onsets never flagged within the horizon [count].

    Returns
    -------
    dict
        ``count``, ``missed``, ``p50``, ``p90``, ``max``, ``mean`` [s] (NaN when empty)
        and ``fraction_below_100ms`` of the detected onsets. Percentiles use linear
        interpolation between order statistics (numpy's default).
    """
    values = np.asarray(list(latencies), dtype=float)
    if values.size and not np.all(np.isfinite(values)):
        raise ValueError('latencies must be finite')
    nan = float('nan')
    return {
        'count': int(values.size),
        'missed': int(missed),
        'p50': float(np.percentile(values, 50)) if values.size else nan,
        'p90': float(np.percentile(values, 90)) if values.size else nan,
        'max': float(values.max()) if values.size else nan,
        'mean': float(values.mean()) if values.size else nan,
        'fraction_below_100ms': float(np.mean(values < 0.100)) if values.size else nan,
    }


def detection_latencies(
    onset_times: Sequence[float],
    flag_times: Sequence[float],
    horizon: float = 1.0,
) -> tuple[list[float], int]:
    """Match each true slip onset to the first slip flag at or after it.

    Parameters
    ----------
    onset_times : sequence of float
        Ground-truth slip onset times [s], any order.
    flag_times : sequence of float
        Times at which the detector flagged slip [s], any order.
    horizon : float
        A flag later than ``horizon`` after the onset, or at/after the next onset, does
        not count for it [s].

    Returns
    -------
    latencies : list of float
        Onset-to-flag times of the caught onsets [s].
    missed : int
        Onsets without a flag inside their window.
    """
    onsets = sorted(float(t) for t in onset_times)
    flags = np.sort(np.asarray(list(flag_times), dtype=float))
    latencies: list[float] = []
    missed = 0
    for index, onset in enumerate(onsets):
        next_onset = onsets[index + 1] if index + 1 < len(onsets) else math.inf
        position = int(np.searchsorted(flags, onset, side='left'))
        if position < flags.size and flags[position] <= onset + horizon and (
            flags[position] < next_onset
        ):
            latencies.append(float(flags[position] - onset))
        else:
            missed += 1
    return latencies, missed


# --- tables --------------------------------------------------------------------------------
def _fmt(value: float, digits: int = 2) -> str:
    return 'n/a' if value is None or (isinstance(value, float) and math.isnan(value)) else (
        f'{value:.{digits}f}')


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
        'slip': SlipScores}}``, categories in the paper's order (only those present).
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
                     *(_fmt(v) for v in entry['slip'].as_tuple())])
        paper = PAPER_RESULTS.get(category)
        if with_paper and paper is not None:
            rows.append(['  paper', str(paper['objects']),
                         *(f'{paper[c][2]} ({paper[c][0]}/{paper[c][1]})'
                           for c in CONTROLLER_LABELS),
                         *(_fmt(v) for v in paper['slip'])])
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
            row += ([str(entry['success']['FORTE']), _fmt(entry['slip'].precision)]
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
        rows.append([label, _fmt(entry.get('rmse', float('nan')), 3),
                     _fmt(entry.get('mae', float('nan')), 3), _fmt(PAPER_FORCE_RMSE[key], 3)])
    return _table(['Force features', 'RMSE [N]', 'MAE [N]', 'paper RMSE [N]'], rows)


def latency_table(stats: dict[str, float]) -> str:
    """Slip latency distribution (onset to flag) as a one-row table, in milliseconds."""
    def ms(value: float) -> str:
        return _fmt(1000.0 * value, 1)
    row = [str(stats['count']), str(stats['missed']), ms(stats['p50']), ms(stats['p90']),
           ms(stats['max']), _fmt(100.0 * stats['fraction_below_100ms'], 1),
           f'< {1000 * PAPER_SLIP_LATENCY_BOUND:.0f} (typical)']
    return _table(['detected onsets', 'missed', 'p50 [ms]', 'p90 [ms]', 'max [ms]',
                   '% < 100 ms', 'paper [ms]'], [row])


def summary_json(records: Sequence[TrialRecord]) -> dict:
    """The result table as plain numbers (for the results JSON)."""
    out = {}
    for category, entry in summarize(records).items():
        scores = entry['slip']
        out[category] = {
            'objects': entry['objects'],
            'success': {c: {'successes': r.successes, 'trials': r.trials, 'rate': r.value}
                        for c, r in entry['success'].items()},
            'slip': {'true_positive': scores.true_positive,
                     'false_positive': scores.false_positive,
                     'true_negative': scores.true_negative,
                     'false_negative': scores.false_negative,
                     'accuracy': scores.accuracy, 'precision': scores.precision,
                     'recall': scores.recall, 'f1': scores.f1},
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
