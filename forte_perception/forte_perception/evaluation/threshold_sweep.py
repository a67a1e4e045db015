"""Sweep the slip threshold (T; h in the sequential mode) and the robust mode's own parameters
over labelled recordings.

The tuning half of the paper's slip characterisation: recordings of lifts that slip (the
procedure ``forte_commissioning.slip_characterization`` in simulation, or bags made on
the robot and labelled with :mod:`forte_perception.evaluation.onset_labels`) are run through
the slip detector once per parameter setting; every setting is scored against the onsets,
one setting is recommended by a written rule and written as a parameter YAML overlay for
the perception node (``params_overlay:=`` of the launch files).

**Scores per setting** (the rules of ``forte_evaluate_slip`` on labelled recordings,
:mod:`forte_perception.evaluation.labelled_recordings`; every trial through a fresh
detector, flags outside the recording's ``mask`` ignored):

- an onset is *detected* when :func:`~forte_perception.evaluation.slip_metrics.match_onsets`
  (``before_next_onset=True``) finds a flag in ``[onset, onset + max_latency]`` before the
  next onset; its latency is that flag minus the onset;
- a *flag run* (consecutive updates that flag slip) is *false* when it starts outside every
  ``[onset, onset + max_latency]`` window of its trial;
- precision = true flag runs / flag runs, recall = detected onsets / onsets, F1 from both
  (NaN where undefined); latency p50 / p90 of the detected onsets [s]; also the paper's
  trial-wise scores (:class:`~forte_perception.evaluation.slip_metrics.TrialScores`).

**Recommendation rule** (:func:`recommend`): among the settings the perception node can
load (only fields that have a node parameter, :data:`NODE_PARAMETERS`, differ from the
default :class:`~forte_perception.slip.params.SlipParams`), those with precision >=
``precision_floor`` (default 0.9); of these the highest F1; ties (equal F1) go to the lower
latency p50 (a p50 less than one detector update, ``hop / fs`` = 2 ms, above the lowest is
a tie: the onsets fall between updates, so a smaller difference is the median's
quantisation, not the setting's speed), then to the threshold closest to its default (T; h
in the sequential mode), then to fewer false runs. If no setting reaches the floor, the
highest F1 of all loadable settings, and the result says so.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from forte_perception.evaluation.labelled_recordings import LabelledRecording
from forte_perception.evaluation.slip_metrics import (
    MAX_LATENCY,
    TrialScores,
    f1_score,
    flag_runs,
    format_value,
    match_onsets,
    outside_windows,
    ratio,
)
from forte_perception.median import MEDIAN_WINDOW, running_median
from forte_perception.slip.detector import SlipParams, slip_features
from forte_perception.slip.sequential import SequentialDetector, SequentialParams
from forte_ros.contract import SAMPLE_RATE

__all__ = ['DEFAULT_ROBUST_GRID', 'DEFAULT_SEQUENTIAL_THRESHOLDS', 'DEFAULT_THRESHOLDS',
           'LATENCY_TIE', 'NODE_NAME', 'NODE_PARAMETERS', 'PRECISION_FLOOR', 'Recommendation',
           'SweepRow', 'node_settable', 'overlay', 'overlay_yaml', 'parameter_grid',
           'params_from_overlay', 'prefilter', 'recommend', 'score', 'sweep', 'table',
           'write_overlay']

#: Node name of the perception node in every graph (forte_bringup.graph), the overlay's key.
NODE_NAME = 'perception'
#: SlipParams field -> parameter of the perception node that sets it
#: (forte_perception/ros/perception_node.py; checked by the tests).
NODE_PARAMETERS = {'window': 'slip_window', 'hop': 'slip_hop', 'f_min': 'slip_f_min',
                   'f_max': 'slip_f_max', 'history': 'slip_history', 'delta': 'slip_delta',
                   'alpha': 'slip_alpha', 'threshold': 'slip_threshold', 'mode': 'slip_mode',
                   'single_threshold': 'slip_single_threshold',
                   'single_min_rising': 'slip_single_min_rising',
                   'veto_ratio': 'slip_veto_ratio',
                   'sequential_threshold': 'slip_sequential_threshold',
                   'sequential_drift': 'slip_sequential_drift',
                   'sequential_single_offset': 'slip_sequential_single_offset'}
#: Thresholds T swept by default [dB^2] (the paper's T = 2 among them).
DEFAULT_THRESHOLDS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0)
#: The sequential mode's CUSUM thresholds h swept by default [dB s] (its default 0.05 among
#: them); T does not act on the sequential mode's events.
DEFAULT_SEQUENTIAL_THRESHOLDS = (0.02, 0.05, 0.1, 0.2)
#: The robust mode's own parameters swept by default (with every T): the one-finger
#: threshold [dB^2] and the level-shift veto ratio [1]; defaults 3.0 and 0.33 included.
DEFAULT_ROBUST_GRID = {'single_threshold': (3.0, 4.5, 6.0), 'veto_ratio': (0.2, 0.33, 0.5)}
#: Precision a recommended setting must reach (flag runs) [1].
PRECISION_FLOOR = 0.9
#: Latency p50s closer than one detector update of the default parameters tie [s].
LATENCY_TIE = SlipParams().hop / SAMPLE_RATE


@dataclass
class SweepRow:
    """The scores of one parameter setting over all recordings.

    Attributes
    ----------
    params : SlipParams
        The setting.
    varied : dict of str -> float
        The swept fields and their values in this setting.
    onsets, detected : int
        Labelled onsets, onsets detected within the latency window [count].
    runs, false_runs : int
        Flag runs, flag runs starting outside every onset window [count].
    latencies_s : ndarray, shape (detected,)
        Onset-to-flag latency of each detected onset [s].
    trials : TrialScores
        Trial-wise confusion counts (paper).
    """

    params: SlipParams
    varied: dict
    onsets: int
    detected: int
    runs: int
    false_runs: int
    latencies_s: np.ndarray
    trials: TrialScores

    @property
    def precision(self) -> float:
        """True flag runs / flag runs; NaN without flags."""
        return ratio(self.runs - self.false_runs, self.runs)

    @property
    def recall(self) -> float:
        """Detected onsets / onsets; NaN without onsets."""
        return ratio(self.detected, self.onsets)

    @property
    def f1(self) -> float:
        """:func:`~forte_perception.evaluation.slip_metrics.f1_score` of the two."""
        return f1_score(self.precision, self.recall)

    def latency(self, q: float) -> float:
        """Percentile ``q`` of the latencies [s] (linear interpolation); NaN without any."""
        return float(np.percentile(self.latencies_s, q)) if self.latencies_s.size \
            else math.nan

    def to_dict(self) -> dict:
        """JSON-ready summary (NaN kept as float NaN)."""
        return {'varied': dict(self.varied), 'mode': self.params.mode,
                'onsets': self.onsets, 'detected': self.detected, 'runs': self.runs,
                'false_runs': self.false_runs, 'precision': self.precision,
                'recall': self.recall, 'f1': self.f1, 'latency_p50_s': self.latency(50),
                'latency_p90_s': self.latency(90), 'trials': self.trials.to_dict(),
                'node_settable': node_settable(self.params)}


def node_settable(params: SlipParams) -> bool:
    """True when ``params`` differs from the default SlipParams only in fields that have a
    perception node parameter (:data:`NODE_PARAMETERS`), so an overlay can load it."""
    default = SlipParams()
    return all(getattr(params, f.name) == getattr(default, f.name) for f in fields(SlipParams)
               if f.name not in NODE_PARAMETERS)


def parameter_grid(base: SlipParams, axes: Mapping[str, Sequence], fs: float
                   ) -> tuple[list[tuple[SlipParams, dict]], list[tuple[dict, str]]]:
    """Every combination of the ``axes`` values applied to ``base``.

    Parameters
    ----------
    base : SlipParams
        The fields not swept (its ``mode`` selects the detector).
    axes : mapping of str -> sequence
        SlipParams field name -> values, e.g. ``{'threshold': (1, 2, 3)}``.
    fs : float
        Sampling rate the settings are checked at [Hz].

    Returns
    -------
    settings : list of (SlipParams, dict)
        The valid settings and their swept values, in grid order.
    skipped : list of (dict, str)
        The combinations :meth:`SlipParams.validate` refuses (e.g. a one-finger threshold
        below T), with the reason.

    Raises
    ------
    ValueError
        An axis that is not a SlipParams field.
    """
    names = list(axes)
    unknown = set(names) - {f.name for f in fields(SlipParams)}
    if unknown:
        raise ValueError(f'not slip parameters: {sorted(unknown)}')
    settings, skipped = [], []
    for values in itertools.product(*(axes[name] for name in names)):
        varied = dict(zip(names, values, strict=True))
        params = replace(base, **varied)
        try:
            params.validate(fs)
        except ValueError as exc:
            skipped.append((varied, str(exc)))
            continue
        settings.append((params, varied))
    return settings, skipped


def prefilter(recordings: Iterable[LabelledRecording], median_window: int = MEDIAN_WINDOW
              ) -> list[LabelledRecording]:
    """The recordings with their frames median-filtered once (``filtered=True``), as the
    perception pipeline gives them to the detector; filtered ones are kept as they are."""
    return [rec if rec.filtered else replace(rec, frames=running_median(rec.frames,
                                                                        median_window),
                                             filtered=True)
            for rec in recordings]


def _trial_bounds(rec: LabelledRecording) -> list[tuple[int, int]]:
    n = rec.frames.shape[0]
    if rec.trial is None:
        return [(0, n)]
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(rec.trial)) + 1, [n]])
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))


def _flags(filtered: np.ndarray, fs: float, params: SlipParams) -> np.ndarray:
    """Sample indices of the slip flags of one trial (median-filtered frames (n, 6)): the
    batch PSD detector in the paper and robust modes, the streaming sequential detector (no
    servo gate: the recordings carry no command stream) in the sequential mode."""
    if params.mode == 'sequential':
        detector = SequentialDetector(fs, params.hop, (params.f_min, params.f_max),
                                      SequentialParams.from_slip(params))
        ends, slip, _ = detector.update(filtered)
        return ends[slip]
    res = slip_features(filtered, fs=fs, params=params)
    return res.sample_index[res.slip]


def score(recordings: Sequence[LabelledRecording], params: SlipParams, varied: dict | None = None,
          max_latency: float = MAX_LATENCY) -> SweepRow:
    """Scores of one setting over median-filtered recordings (module docstring).

    Parameters
    ----------
    recordings : sequence of LabelledRecording
        With ``filtered=True`` (:func:`prefilter`).
    params : SlipParams
    varied : dict, optional
        The swept values, for the record.
    max_latency : float
        Longest onset-to-flag delay of a detection [s].

    Raises
    ------
    ValueError
        A recording that is not median-filtered.
    """
    onsets_total = detected = runs_total = false_total = 0
    latencies: list[np.ndarray] = []
    truth_and_flag = []
    for rec in recordings:
        if not rec.filtered:
            raise ValueError(f'{rec.name}: score() needs filtered frames (use prefilter)')
        window = int(round(max_latency * rec.fs))
        for a, b in _trial_bounds(rec):
            onsets = np.sort(rec.onsets[(rec.onsets >= a) & (rec.onsets < b)]) - a
            flags = _flags(rec.frames[a:b], rec.fs, params)
            if rec.mask is not None:
                flags = flags[rec.mask[a + flags]]
            latency = match_onsets(onsets, flags, window, before_next_onset=True)
            caught = latency[~np.isnan(latency)]
            latencies.append(caught / rec.fs)
            runs = flag_runs(flags, params.hop)
            false = outside_windows(runs[:, 0], runs[:, 0],
                                    np.stack([onsets, onsets + window], axis=1))
            onsets_total += onsets.size
            detected += caught.size
            runs_total += runs.shape[0]
            false_total += int(false.sum())
            truth_and_flag.append((onsets.size > 0, flags.size > 0))
    return SweepRow(params, dict(varied or {}), onsets_total, detected, runs_total,
                    false_total, np.concatenate(latencies) if latencies else np.zeros(0),
                    TrialScores.count(truth_and_flag))


def sweep(recordings: Sequence[LabelledRecording], settings: Sequence[tuple[SlipParams, dict]],
          max_latency: float = MAX_LATENCY, median_window: int = MEDIAN_WINDOW
          ) -> list[SweepRow]:
    """:func:`score` of every setting (the median filter runs once per recording)."""
    filtered = prefilter(recordings, median_window)
    return [score(filtered, params, varied, max_latency) for params, varied in settings]


@dataclass
class Recommendation:
    """The recommended setting and why.

    Attributes
    ----------
    row : SweepRow
    floor_met : bool
        Its precision reaches the floor (else it is the best F1 of all loadable settings).
    rule : str
        The rule, in words, with the floor used.
    """

    row: SweepRow
    floor_met: bool
    rule: str


def _best(rows: Sequence[SweepRow], latency_tie: float) -> SweepRow:
    """The highest F1; of equal F1, a latency p50 within ``latency_tie`` [s] of the lowest;
    then the threshold closest to its default; then the fewest false runs."""
    def f1(row: SweepRow) -> float:
        return row.f1 if not math.isnan(row.f1) else -1.0

    def p50(row: SweepRow) -> float:
        return row.latency(50) if not math.isnan(row.latency(50)) else math.inf

    def distance(row: SweepRow) -> float:
        name = 'sequential_threshold' if row.params.mode == 'sequential' else 'threshold'
        return abs(getattr(row.params, name) - getattr(SlipParams(), name))

    top = max(f1(row) for row in rows)
    tied = [row for row in rows if f1(row) == top]
    fastest = min(p50(row) for row in tied)
    if math.isfinite(fastest):
        tied = [row for row in tied if p50(row) - fastest < latency_tie]
    return min(tied, key=lambda row: (distance(row), row.false_runs))


def recommend(rows: Sequence[SweepRow], precision_floor: float = PRECISION_FLOOR,
              latency_tie: float = LATENCY_TIE) -> Recommendation:
    """The recommended setting of a sweep (rule in the module docstring; ``latency_tie``
    [s]: latency p50s closer than this to the lowest tie).

    Raises
    ------
    ValueError
        No row can be loaded by the node (every setting changes a field without a node
        parameter).
    """
    loadable = [r for r in rows if node_settable(r.params)]
    if not loadable:
        raise ValueError('no swept setting can be loaded by the perception node; include the '
                         'default robust parameters in the grid')
    rule = (f'loadable settings with precision >= {precision_floor:g}: highest F1, then lowest '
            f'latency p50 (within {latency_tie * 1e3:g} ms of it ties), then the threshold (T, '
            'or h in the sequential mode) closest to the default, then fewest false runs')
    passing = [r for r in loadable if not math.isnan(r.precision)
               and r.precision >= precision_floor]
    chosen = passing or loadable
    best = _best(chosen, latency_tie)
    if not passing:
        rule += '; no setting reached the floor: highest F1 of all loadable settings'
    return Recommendation(best, bool(passing), rule)


def overlay(params: SlipParams, node_name: str = NODE_NAME) -> dict:
    """The parameter overlay that loads ``params`` into the perception node.

    Returns
    -------
    dict
        ``{node_name: {'ros__parameters': {...}}}`` with ``slip_mode``, ``slip_threshold``
        and every other node parameter whose field differs from the default SlipParams.

    Raises
    ------
    ValueError
        ``params`` changes a field the node has no parameter for.
    """
    if not node_settable(params):
        raise ValueError('these slip parameters change fields the perception node does not '
                         f'declare (it has {sorted(NODE_PARAMETERS.values())})')
    default = SlipParams()
    values = {'slip_mode': params.mode, 'slip_threshold': float(params.threshold)}
    for name, parameter in NODE_PARAMETERS.items():
        value = getattr(params, name)
        if parameter not in values and value != getattr(default, name):
            values[parameter] = value
    return {node_name: {'ros__parameters': values}}


def params_from_overlay(document: Mapping, node_name: str = NODE_NAME,
                        base: SlipParams | None = None) -> SlipParams:
    """The SlipParams a perception node gets from an overlay document (parsed YAML):
    ``base`` (default ``SlipParams()``) with the ``slip_*`` parameters of ``node_name``'s
    block applied; other parameters are ignored.

    Raises
    ------
    ValueError
        No ``node_name`` block with ``ros__parameters``, or an unusable setting.
    """
    block = document.get(node_name) if isinstance(document, Mapping) else None
    values = block.get('ros__parameters') if isinstance(block, Mapping) else None
    if not isinstance(values, Mapping):
        raise ValueError(f'overlay has no {node_name}: ros__parameters block')
    fields_by_parameter = {parameter: name for name, parameter in NODE_PARAMETERS.items()}
    changes = {fields_by_parameter[k]: v for k, v in values.items() if k in fields_by_parameter}
    params = replace(base or SlipParams(), **changes)
    params.validate()
    return params


def _yaml_scalar(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        text = repr(value)
        mantissa, _, exponent = text.partition('e')
        if exponent and '.' not in mantissa:      # YAML 1.1 needs 1.0e-05, not 1e-05
            text = f'{mantissa}.0e{exponent}'
        return text
    return "'" + str(value).replace("'", "''") + "'"


def overlay_yaml(document: dict, comment: str = '') -> str:
    """A two-level overlay ``{node: {'ros__parameters': {name: scalar}}}`` as YAML text,
    preceded by ``comment`` as ``#`` lines (no YAML library needed)."""
    lines = [f'# {line}'.rstrip() for line in comment.splitlines()]
    for node, block in document.items():
        lines += [f'{node}:', '  ros__parameters:']
        lines += [f'    {name}: {_yaml_scalar(value)}'
                  for name, value in block['ros__parameters'].items()]
    return '\n'.join(lines) + '\n'


def write_overlay(path: str | Path, params: SlipParams, comment: str = '',
                  node_name: str = NODE_NAME) -> dict:
    """Write :func:`overlay` of ``params`` to ``path`` (folders created); returns it."""
    document = overlay(params, node_name)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(overlay_yaml(document, comment), encoding='utf-8')
    return document


_COLUMNS = ('setting', 'loadable', 'onsets', 'detected', 'recall', 'runs', 'false',
            'precision', 'F1', 'p50 [ms]', 'p90 [ms]', 'trial P', 'trial R')


def table(rows: Sequence[SweepRow], recommended: SweepRow | None = None) -> str:
    """The sweep as a markdown table, one row per setting; ``n/a`` = undefined; the
    recommended row is marked ``**<-**``."""
    lines = ['| ' + ' | '.join(_COLUMNS) + ' |', '|' + '---|' * len(_COLUMNS)]
    for row in rows:
        setting = ', '.join(f'{k}={v:g}' if isinstance(v, (int, float)) else f'{k}={v}'
                            for k, v in row.varied.items()) or 'default'
        if row is recommended:
            setting += ' **<-**'
        cells = (setting, 'yes' if node_settable(row.params) else 'no', str(row.onsets),
                 str(row.detected), format_value(row.recall), str(row.runs),
                 str(row.false_runs), format_value(row.precision), format_value(row.f1),
                 format_value(1e3 * row.latency(50), 0), format_value(1e3 * row.latency(90), 0),
                 format_value(row.trials.precision), format_value(row.trials.recall))
        lines.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)
