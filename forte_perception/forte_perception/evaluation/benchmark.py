"""Speed against error of slip detector modes on the labelled slip set (issue 14).

A *mode* is a function ``SensorInput -> Detection``: it sees the raw frames, the causal
median-11 filtered frames (as the perception pipeline gives the detector), the sampling
rate and the scene's context signals (commanded servo angle and arm velocity, the servo's
reported angle), never the labels. Modes: ``'paper'``, the paper's detector exactly
(:func:`forte_perception.slip.detector.slip_features` with the paper's
:class:`~forte_perception.slip.detector.SlipParams`); ``'robust'``, the same detector with
``SlipParams(mode='robust')`` (:mod:`forte_perception.slip.robust`); and
``'robust_servo_gate'``, the robust detector whose flags are dropped for
:data:`SERVO_HOLD` s after a change of the commanded servo angle (:func:`servo_gate`: uses
the command, which the detector does not have, so a controller-side option); ``'cusum'``,
issue 26's candidate: a CUSUM on the robust mode's band power relative to each channel's
measured quiet level (:func:`cusum_mode`, :mod:`forte_perception.slip.cusum`);
``'sequential'``, the same CUSUM on the slipping state's fast (30 ms) band power with a
level-shift and a hum veto (:func:`sequential_mode`, :mod:`forte_perception.slip.sequential`).

:func:`run_mode` runs a mode over scenes ``repeats`` times; the detections of the first run
are scored (:mod:`forte_perception.evaluation.slip_metrics`), the CPU time is
``time.process_time`` of the mode's calls only (the median filter is shared by every mode
and computed once), summed per family and per split in each repetition, best repetition,
divided by the detector
updates. :func:`report` pools the outcomes per family, per source and per split, and per
event kind; :func:`markdown` prints them.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from forte_perception.evaluation.labels import SPLITS, SlipScene
from forte_perception.evaluation.slip_metrics import (
    MAX_LATENCY,
    SceneOutcome,
    format_value,
    scene_outcome,
    summarise,
)
from forte_perception.median import MEDIAN_WINDOW, running_median
from forte_perception.slip.cusum import BandPowerCusum, CusumParams
from forte_perception.slip.detector import SlipParams, slip_features
from forte_perception.slip.robust import level_shift_veto
from forte_perception.slip.sequential import SequentialDetector, SequentialParams
from forte_perception.slip.servo_gate import ServoGate

__all__ = ['MODES', 'SERVO_HOLD', 'Detection', 'SensorInput', 'cusum_mode', 'markdown',
           'paper_mode', 'prepare', 'report', 'robust_mode', 'robust_servo_gate_mode', 'run_mode',
           'sequential_mode', 'servo_gate']


@dataclass
class SensorInput:
    """What a detector mode may use for one scene.

    Attributes
    ----------
    raw : ndarray (n, 6)
        Raw readings (normalised, 11-bit).
    filtered : ndarray (n, 6)
        Causal running median of 11 samples of ``raw``.
    fs : float
        [Hz]
    context : dict of str -> ndarray (n,)
        ``servo_command`` [rad], ``arm_velocity`` [m/s], ``joint_position`` [rad] where the
        scene has them.
    """

    raw: np.ndarray
    filtered: np.ndarray
    fs: float
    context: dict


@dataclass
class Detection:
    """A mode's output: update sample indices (m,), slip flags (m,), update spacing."""

    sample_index: np.ndarray
    slip: np.ndarray
    hop: int


def paper_mode(inp: SensorInput) -> Detection:
    """The paper's detector, bit for bit (:func:`forte_perception.slip.detector.slip_features`)."""
    params = SlipParams(mode='paper')
    res = slip_features(inp.filtered, fs=inp.fs, params=params)
    return Detection(res.sample_index, res.slip, int(params.hop))


def robust_mode(inp: SensorInput, params: SlipParams | None = None) -> Detection:
    """The robust detector mode (:mod:`forte_perception.slip.robust`), default parameters
    unless ``params`` is given. Sees the filtered frames only, as the paper mode."""
    params = params or SlipParams(mode='robust')
    res = slip_features(inp.filtered, fs=inp.fs, params=params)
    return Detection(res.sample_index, res.slip, int(params.hop))


def cusum_mode(inp: SensorInput, cusum: CusumParams | None = None,
               params: SlipParams | None = None, veto: bool = True) -> Detection:
    """The band-power CUSUM of issue 26 (:mod:`forte_perception.slip.cusum`) on the robust
    mode's PSD features (quantisation floor), with the robust mode's level-shift veto asked
    at every alarm unless ``veto`` is False. Flags are the alarms (slip events)."""
    params = params or SlipParams(mode='robust')
    res = slip_features(inp.filtered, fs=inp.fs, params=params)
    ends, psd = res.sample_index, res.psd_max_db
    one = np.ones(1, bool)

    def drop(i: int) -> bool:
        return bool(level_shift_veto(inp.filtered, 0, ends[i:i + 1], psd[i:i + 1], one,
                                     params, inp.fs)[0])

    detector = BandPowerCusum(int(params.hop) / inp.fs, cusum)
    out = detector.update(psd, drop if veto else None)
    return Detection(ends, out.slip, int(params.hop))


#: Flags are ignored for this long after a change of the commanded servo angle [s].
SERVO_HOLD = 0.35


def servo_changes(inp: SensorInput) -> np.ndarray:
    """Sample indices at which the scene's commanded servo angle (context
    ``servo_command``) changes; empty where the scene has none."""
    command = inp.context.get('servo_command')
    if command is None:
        return np.zeros(0, np.int64)
    c = np.nan_to_num(np.asarray(command, np.float64))
    return np.flatnonzero(np.abs(np.diff(c)) > 1e-7) + 1


def servo_gate(det: Detection, inp: SensorInput, hold: float = SERVO_HOLD) -> Detection:
    """Drop the flags of updates ending within ``hold`` s after a change of the commanded
    servo angle (context ``servo_command``; unchanged where the scene has none).

    Not a detector feature: the perception pipeline does not see the servo command. It
    belongs to the controller (which knows when it moves the servo) or to a pipeline input.
    """
    changes = servo_changes(inp)
    if not changes.size or not det.slip.any():
        return det
    idx = np.asarray(det.sample_index)
    last = np.searchsorted(changes, idx, side='right') - 1  # latest change at or before
    since = np.where(last >= 0, idx - changes[np.maximum(last, 0)], np.iinfo(np.int64).max)
    quiet = since >= int(round(hold * inp.fs))
    return Detection(idx, np.asarray(det.slip, bool) & quiet, det.hop)


def robust_servo_gate_mode(inp: SensorInput) -> Detection:
    """The robust mode plus :func:`servo_gate` (uses the servo command: a controller-side
    option, not part of the detector)."""
    return servo_gate(robust_mode(inp), inp)


def sequential_mode(inp: SensorInput, params: SequentialParams | None = None) -> Detection:
    """Issue 26's sequential detector on the fast band power
    (:mod:`forte_perception.slip.sequential`); flags are its slip events. Where the scene
    records the servo command, its changes feed the detector's servo gate, as the
    perception node's ``gripper/command`` does online (a recorded command has no speed: the
    motions' durations are unknown)."""
    params = params or SequentialParams()
    detector = SequentialDetector(inp.fs, SlipParams().hop, params=params)
    gate = ServoGate(int(round(params.servo_hold * inp.fs)))
    for change in servo_changes(inp):
        gate.moved(int(change))
    ends = np.arange(detector.hop - 1, inp.filtered.shape[0], detector.hop)
    ends, slip, _ = detector.update(inp.filtered, ends=ends, gated=gate.gated(ends),
                                    servo=gate.latest(ends))
    return Detection(ends, slip, detector.hop)


#: Detector modes by name.
MODES: dict[str, Callable[[SensorInput], Detection]] = {
    'paper': paper_mode, 'robust': robust_mode, 'robust_servo_gate': robust_servo_gate_mode,
    'cusum': cusum_mode, 'sequential': sequential_mode}


def prepare(scenes: list[SlipScene], median_window: int = MEDIAN_WINDOW) -> list[SensorInput]:
    """The inputs of every scene (the median filter is computed here, once)."""
    return [SensorInput(s.frames, running_median(s.frames, median_window), s.fs, s.context)
            for s in scenes]


def _cost_keys(scene: SlipScene) -> list[tuple[str, str]]:
    return [(scene.split, scene.family), (scene.split, f'all {scene.source}'),
            (scene.split, 'all')]


def run_mode(scenes: list[SlipScene], mode: str | Callable = 'paper', repeats: int = 3,
             inputs: list[SensorInput] | None = None,
             max_latency: float = MAX_LATENCY) -> tuple[list[SceneOutcome], dict]:
    """Run a mode on every scene ``repeats`` times.

    Returns
    -------
    outcomes : list of SceneOutcome
        Scored detections of the first repetition.
    cpu : dict
        ``(split, key) -> best total CPU time [s]`` for key = a family, ``'all signal'``,
        ``'all sim'``, ``'all'``.
    """
    detector = MODES[mode] if isinstance(mode, str) else mode
    inputs = inputs if inputs is not None else prepare(scenes)
    best: dict[tuple[str, str], float] = {}
    outcomes: list[SceneOutcome] = []
    for rep in range(max(repeats, 1)):
        spent: dict[tuple[str, str], float] = {}
        for scene, inp in zip(scenes, inputs, strict=True):
            start = time.process_time()
            det = detector(inp)
            dt = time.process_time() - start
            for key in _cost_keys(scene):
                spent[key] = spent.get(key, 0.0) + dt
            if rep == 0:
                flags = np.asarray(det.sample_index)[np.asarray(det.slip, bool)]
                outcomes.append(scene_outcome(scene, flags, det.hop,
                                              len(det.sample_index), max_latency))
        for key, value in spent.items():
            best[key] = min(best.get(key, math.inf), value)
    return outcomes, best


def _with_cost(metrics: dict, seconds: float | None) -> dict:
    updates = metrics.get('updates', 0)
    metrics['cpu_us_per_update'] = (seconds / updates * 1e6 if seconds is not None
                                    and updates else math.nan)
    return metrics


def report(outcomes: list[SceneOutcome], cpu: dict) -> dict:
    """Pooled metrics per split: ``families``, ``groups`` (all signal, all sim, all) and
    ``kinds`` (per source and event kind), each a dict of metric dicts."""
    out: dict = {}
    for split in SPLITS:
        part = [o for o in outcomes if o.split == split]
        if not part:
            continue
        families = {}
        for family in dict.fromkeys(o.family for o in part):
            chosen = [o for o in part if o.family == family]
            families[family] = _with_cost(summarise(chosen), cpu.get((split, family)))
        groups = {}
        for source in ('signal', 'sim'):
            chosen = [o for o in part if o.source == source]
            if chosen:
                groups[f'all {source}'] = _with_cost(summarise(chosen),
                                                     cpu.get((split, f'all {source}')))
        groups['all'] = _with_cost(summarise(part), cpu.get((split, 'all')))
        kinds = {}
        for source in ('signal', 'sim'):
            chosen = [o for o in part if o.source == source]
            for kind in sorted({k for o in chosen for k in o.event_kinds}):
                def only(o, kind=kind):
                    return np.array([k == kind for k in o.event_kinds], bool)
                kinds[f'{source} {kind}'] = summarise(chosen, only)
        out[split] = {'families': families, 'groups': groups, 'kinds': kinds}
    return out


_COLUMNS = (('scenes', 0), ('events', 0), ('detected', 0), ('recall', 2), ('runs', 0),
            ('false_runs', 0), ('precision', 2), ('f1', 2), ('latency_p50_ms', 0),
            ('latency_p90_ms', 0), ('holding_min', 1), ('false_per_min_holding', 1),
            ('scenes_with_false', 0), ('cpu_us_per_update', 1))
_HEADER = ('| family | scenes | events | detected | recall | flag runs | false | precision | F1 '
           '| latency p50 [ms] | p90 [ms] | holding [min] | false / min holding '
           '| scenes with false | CPU / update [us] |')


def markdown(results: dict, mode: str) -> str:
    """The tables of :func:`report` as markdown, one section per split (``n/a``: undefined,
    :func:`~forte_perception.evaluation.slip_metrics.format_value`)."""
    lines = []
    for split, part in results.items():
        lines += [f'### {mode} mode, {split.replace("_", "-")} part', '', _HEADER,
                  '|' + '---|' * (len(_COLUMNS) + 1)]
        rows = list(part['families'].items()) + [(f'**{k}**', v)
                                                  for k, v in part['groups'].items()]
        for name, m in rows:
            cells = (format_value(m.get(column), digits) for column, digits in _COLUMNS)
            lines.append(f'| {name} | ' + ' | '.join(cells) + ' |')
        lines += ['', '| events by kind | events | detected | recall | latency p50 [ms] '
                  '| p90 [ms] |', '|---|---|---|---|---|---|']
        for name, m in part['kinds'].items():
            lines.append(f'| {name} | {m["events"]} | {m["detected"]} | '
                         f'{format_value(m["recall"])} | '
                         f'{format_value(m["latency_p50_ms"], 0)} | '
                         f'{format_value(m["latency_p90_ms"], 0)} |')
        lines.append('')
    return '\n'.join(lines)
