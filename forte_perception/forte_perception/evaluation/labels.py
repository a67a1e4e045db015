"""Labelled slip scenes: the format of the slip evaluation set (issue 14), its file, its split.

A :class:`SlipScene` is one recording of the six raw sensor channels with what really
happened in it:

- **slip events**: intervals ``[onset, end)`` [samples] in which the object slips, with the
  finger(s) that slip, the kind of slip and, where the generator knows it, its strength;
- **holding still**: intervals in which the grasp is static: the object does not move
  against the fingers and neither a commanded motion nor a labelled distractor changes the
  load (a lift at constant velocity with stuck contacts counts as holding still). Time that
  is neither (closing, ramps, low-frequency motion, the detector's reach after them, and
  ``0.5 s`` after a slip event) is *busy*: flags there are false events but not false flags
  while holding still;
- **context**: per-sample signals the robot has besides the sensor (commanded servo angle
  [rad], commanded arm velocity [m/s], in simulator scenes also the servo's reported angle
  [rad]); a detector may use them, never the labels.

Flags before ``evaluate_from`` (the detector's warm-up) are not evaluated. The scenes come
from :mod:`forte_perception.evaluation.scenes` (signal-level generators) and from
``forte_evaluation.slip_dataset`` (the simulator).

Split (written down before any tuning): every scene belongs to ``'tune'`` or
``'held_out'``, by object (a finger profile of the signal generators, an object type of the
simulator) *and* seed: tune = tune objects with even seeds, held-out = the other objects
with odd seeds. No object and no seed is in both parts.

File: one compressed ``.npz`` without pickle; frames as int16 ADC codes (value x 1024,
exact for the 11-bit quantised readings), context as float32, all scenes concatenated,
labels and identity as a JSON header.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forte_ros.contract import COUNTS_PER_FULL_SCALE, SAMPLE_RATE

__all__ = ['CONTEXT_KEYS', 'EVALUATE_FROM', 'FINGER_BOTH', 'FINGER_LEFT', 'FINGER_RIGHT',
           'FINGER_UNKNOWN_ONE', 'SLIP_KINDS', 'SPLITS', 'SlipScene', 'load_scenes',
           'save_scenes', 'subtract_intervals']

#: The two parts of the set.
SPLITS = ('tune', 'held_out')
#: Finger bitmask of an event: left (finger 0), right (finger 1), both; 0 = one finger,
#: unknown which (the simulator's incipient slip).
FINGER_LEFT, FINGER_RIGHT, FINGER_BOTH, FINGER_UNKNOWN_ONE = 1, 2, 3, 0
#: Event kinds (the simulator's SLIP_* names; the signal generators use two of them).
SLIP_KINDS = ('incipient', 'gross', 'stick_slip', 'rotational')
#: Per-sample context signals a scene may carry.
CONTEXT_KEYS = ('servo_command', 'arm_velocity', 'joint_position')
#: First evaluated sample [samples] (0.5 s at 2 kHz; the paper detector's first decision is
#: at sample 455).
EVALUATE_FROM = 1000
#: Format name and version of the file header.
FORMAT = ('forte_slip_scenes', 1)
_CODE = float(COUNTS_PER_FULL_SCALE)  # ADC codes per normalised unit


@dataclass
class SlipScene:
    """One labelled recording (see the module docstring).

    Attributes
    ----------
    name : str
        Unique name, ``family/object/seed`` (plus a variant for simulator scenes).
    family : str
        Generator family (signal) or ``sim_<category>`` (simulator).
    split : str
        ``'tune'`` or ``'held_out'``.
    source : str
        ``'signal'`` or ``'sim'``.
    object_name : str
        Finger profile (signal) or object type (simulator).
    seed : int
    frames : ndarray, shape (n, 6)
        Raw readings, normalised, 11-bit quantised (step 2/2048), not tared, not filtered.
    events : ndarray, shape (k, 2), int64
        Slip intervals ``[onset, end)`` [samples], sorted by onset.
    event_fingers : ndarray, shape (k,), int64
        ``FINGER_*`` bitmask per event.
    event_kinds : tuple of str
        One of :data:`SLIP_KINDS` per event.
    event_strength : ndarray, shape (k,)
        Peak vibration amplitude of stick-slip on the strongest channel, or the total
        decay of smooth gross slip on the strongest channel [LSB]; NaN where unknown.
    holding : ndarray, shape (h, 2), int64
        Holding-still intervals ``[start, stop)`` [samples], sorted, disjoint.
    fs : float
        Sampling rate [Hz].
    evaluate_from : int
        First sample whose flags are evaluated.
    context : dict of str -> ndarray (n,)
        Keys of :data:`CONTEXT_KEYS` the scene has.
    params : dict
        The generator's parameters (JSON-friendly), for the record.
    """

    name: str
    family: str
    split: str
    source: str
    object_name: str
    seed: int
    frames: np.ndarray
    events: np.ndarray
    event_fingers: np.ndarray
    event_kinds: tuple[str, ...]
    event_strength: np.ndarray
    holding: np.ndarray
    fs: float = SAMPLE_RATE
    evaluate_from: int = EVALUATE_FROM
    context: dict[str, np.ndarray] = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.events = np.asarray(self.events, np.int64).reshape(-1, 2)
        self.event_fingers = np.asarray(self.event_fingers, np.int64).reshape(-1)
        self.event_strength = np.asarray(self.event_strength, np.float64).reshape(-1)
        self.holding = np.asarray(self.holding, np.int64).reshape(-1, 2)
        self.event_kinds = tuple(self.event_kinds)
        k = self.events.shape[0]
        if not (self.event_fingers.size == self.event_strength.size == len(self.event_kinds)
                == k):
            raise ValueError(f'{self.name}: one finger, kind and strength per event')
        if self.split not in SPLITS:
            raise ValueError(f'{self.name}: split must be one of {SPLITS}, got {self.split!r}')
        if unknown := set(self.event_kinds) - set(SLIP_KINDS):
            raise ValueError(f'{self.name}: unknown event kinds {sorted(unknown)}')

    @property
    def n_samples(self) -> int:
        """Samples in the scene."""
        return int(self.frames.shape[0])

    @property
    def seconds(self) -> float:
        """Duration [s]."""
        return self.n_samples / self.fs


def subtract_intervals(start: int, stop: int, remove: list[tuple[int, int]]
                       ) -> np.ndarray:
    """``[start, stop)`` minus the union of the ``remove`` intervals, shape (h, 2) int64."""
    mask = np.ones(max(stop - start, 0), bool)
    for a, b in remove:
        lo, hi = max(a, start), min(b, stop)
        if hi > lo:
            mask[lo - start:hi - start] = False
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1) + start
    stops = np.flatnonzero(edges == -1) + start
    return np.stack([starts, stops], axis=1).astype(np.int64) if starts.size else \
        np.zeros((0, 2), np.int64)


def _header(scene: SlipScene) -> dict:
    return {'name': scene.name, 'family': scene.family, 'split': scene.split,
            'source': scene.source, 'object_name': scene.object_name, 'seed': scene.seed,
            'n': scene.n_samples, 'events': scene.events.tolist(),
            'event_fingers': scene.event_fingers.tolist(),
            'event_kinds': list(scene.event_kinds),
            'event_strength': [None if np.isnan(v) else float(v)
                               for v in scene.event_strength],
            'holding': scene.holding.tolist(), 'fs': scene.fs,
            'evaluate_from': scene.evaluate_from, 'context': sorted(scene.context),
            'params': scene.params}


def save_scenes(path: str | Path, scenes: list[SlipScene]) -> None:
    """Write scenes to one ``.npz`` (format in the module docstring).

    Raises
    ------
    ValueError
        If a frame value is not on the 11-bit grid (then it cannot be stored as a code).
    """
    codes = []
    context = {key: [] for key in CONTEXT_KEYS}
    for scene in scenes:
        c = np.rint(scene.frames * _CODE)
        if not np.array_equal(c / _CODE, scene.frames) or np.abs(c).max(initial=0) > 1024:
            raise ValueError(f'{scene.name}: frames are not 11-bit quantised readings')
        codes.append(c.astype(np.int16))
        for key in CONTEXT_KEYS:
            context[key].append(np.asarray(scene.context.get(key, np.full(scene.n_samples,
                                                                              np.nan)),
                                           np.float32))
    header = {'format': FORMAT[0], 'version': FORMAT[1],
              'scenes': [_header(scene) for scene in scenes]}
    arrays = {'codes': np.concatenate(codes) if codes else np.zeros((0, 6), np.int16),
              'header': np.array(json.dumps(header))}
    for key, parts in context.items():
        arrays[key] = np.concatenate(parts) if parts else np.zeros(0)
    path = Path(path)
    tmp = path.with_name(path.name + '.tmp.npz')
    np.savez_compressed(tmp, **arrays)
    tmp.replace(path)


def load_scenes(path: str | Path) -> list[SlipScene]:
    """Read the scenes written by :func:`save_scenes`; ValueError on another format."""
    with np.load(path, allow_pickle=False) as data:
        header = json.loads(str(data['header']))
        if (header.get('format'), header.get('version')) != FORMAT:
            raise ValueError(f'{path}: not a {FORMAT[0]} v{FORMAT[1]} file')
        frames = data['codes'].astype(np.float64) / _CODE
        context = {key: data[key].astype(np.float64) for key in CONTEXT_KEYS}
    scenes, pos = [], 0
    for h in header['scenes']:
        n = int(h['n'])
        ctx = {key: context[key][pos:pos + n] for key in h['context']}
        strength = [np.nan if v is None else v for v in h['event_strength']]
        scenes.append(SlipScene(
            h['name'], h['family'], h['split'], h['source'], h['object_name'], int(h['seed']),
            frames[pos:pos + n], np.array(h['events'], np.int64), h['event_fingers'],
            tuple(h['event_kinds']), np.array(strength, float), np.array(h['holding']),
            float(h['fs']), int(h['evaluate_from']), ctx, h['params']))
        pos += n
    return scenes
