"""The labelled slip evaluation set of issue 14: simulator scenes, and the whole set's cache.

Simulator scenes (:func:`sim_scene`): one scripted lift of one object of the simulator's
catalogue (``forte_sim``, scene ``'grasp'``), recorded raw (the frames the serial
driver would deliver) with the simulator's ground truth. Scripted commands, not a
controller: a controller reacting to the paper detector's flags (FORTE tightens on slip)
would make the recording depend on the detector under test. Protocol (2 kHz samples, servo
profile velocity 0.5 rad/s):

1. 1.0 s open and still (``scene.initial_angle``);
2. close to the grip angle and hold 1.5 s: ``'marginal'`` = ``scene.slip_test_angle`` (the
   paper's slip characterisation: between theta_grasp and theta_zeroF, so the object
   slips when lifted), ``'firm'`` = ``scene.stable_grasp_angle() - 0.01`` rad;
3. lift for 6 s at 1 mm/s (seeds 0, 1) or 5 mm/s (seeds 2, 3), grip held;
4. arm stopped, grip held, 1.5 s.

Labels from the ground truth: every labelled slip onset (``SceneTruth.slip_onset_indices``)
starts an event that ends after its last sample with a slip type before the next onset;
kind = the onset's SLIP_* type; fingers: both for gross, stick-slip (a release also shakes
the other finger through the object) and rotational slip, "one finger, unknown which"
for incipient slip (the truth does not say which). Busy (not holding still): the gripper
moving (servo angle changing by more than 1 urad per sample), the lift from its start until
0.5 s after the object is lifted off the table (the load moves onto the contacts; the whole
lift if it never lifts off), 0.3 s after the arm stops, 0.5 s after the object breaks or is
crushed; each plus the detector's reach (0.25 s). Context: commanded servo angle and arm
velocity, and the servo's reported angle.

Split: in each category of the catalogue the objects alternate (first, third, ... tune;
second, fourth, ... held-out); tune seeds 0 and 2, held-out seeds 1 and 3; two grips each.

The whole set (:func:`build_set`) = the signal-level scenes of
:mod:`forte_perception.evaluation.scenes` + these, both splits, cached in
``out/slip_dataset/slip_set_<hash>.npz``; the hash covers the generator sources (the signal
generators, the label format, this module and the simulator package) and the numpy
version, so a change to any of them rebuilds the set.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np

from forte_perception.evaluation import labels as slip_labels
from forte_perception.evaluation import scenes as slip_scenes
from forte_perception.evaluation.labels import (
    EVALUATE_FROM,
    FINGER_BOTH,
    FINGER_UNKNOWN_ONE,
    SPLITS,
    SlipScene,
    load_scenes,
    save_scenes,
    subtract_intervals,
)
from forte_ros.contract import SAMPLE_RATE as FS

__all__ = ['GRIPS', 'SIM_SEEDS', 'build_set', 'dataset_hash', 'sim_keys', 'sim_objects',
           'sim_scene', 'sim_scenes', 'source_files']

#: Seeds of each split.
SIM_SEEDS = {'tune': (0, 2), 'held_out': (1, 3)}
GRIPS = ('marginal', 'firm')
FIRM_MARGIN = 0.01          # [rad] firm grip: this much closer than theta_grasp
PROFILE_VELOCITY = 0.5      # [rad/s]
_KIND = {1: 'incipient', 2: 'gross', 3: 'stick_slip', 4: 'rotational'}
_REACH = int(0.25 * FS)
_GRACE = int(0.5 * FS)


def sim_objects(split: str) -> list[str]:
    """Objects of a split: per category, alternating in catalogue order."""
    from forte_sim import CATEGORIES, objects_in_category

    first = SPLITS.index(split)
    return [name for category in CATEGORIES
            for name in objects_in_category(category)[first::2]]


def sim_keys(split: str | None = None) -> list[tuple[str, int, str]]:
    """(object, seed, grip) of every simulator scene of the set (or of one split)."""
    return [(name, seed, grip) for part in ([split] if split else SPLITS)
            for name in sim_objects(part) for seed in SIM_SEEDS[part] for grip in GRIPS]


def _intervals(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def _run_protocol(scene, grip_angle: float, lift_velocity: float) -> tuple:
    """Step the phases; frames (n, 6), per-sample truth dict, onsets, phase starts."""
    phases = ((1.0, scene.initial_angle, 0.0), (1.5, grip_angle, 0.0),
              (6.0, grip_angle, lift_velocity), (1.5, grip_angle, 0.0))
    frames, onsets, starts = [], [], []
    truth = {key: [] for key in ('slip_type', 'object_state', 'joint_position',
                                 'servo_command', 'arm_velocity')}
    for seconds, command, velocity in phases:
        starts.append(scene.sample_index)
        n = int(seconds * FS)
        chunk, t = scene.step(n, command, velocity, profile_velocity=PROFILE_VELOCITY)
        frames.append(chunk)
        onsets += [(t.first_index + int(i), int(k))
                   for i, k in zip(t.slip_onset_indices, t.slip_onset_types, strict=True)]
        truth['slip_type'].append(t.slip_type)
        truth['object_state'].append(t.object_state)
        truth['joint_position'].append(t.joint_position)
        truth['servo_command'].append(np.full(n, command))
        truth['arm_velocity'].append(np.full(n, velocity))
    truth = {key: np.concatenate(value) for key, value in truth.items()}
    return np.vstack(frames), truth, sorted(onsets), starts


def _events(onsets: list[tuple[int, int]], slip_type: np.ndarray) -> list[tuple]:
    """(onset, end, fingers, kind) of every labelled episode."""
    events = []
    n = slip_type.size
    for i, (onset, kind) in enumerate(onsets):
        stop = onsets[i + 1][0] if i + 1 < len(onsets) else n
        slipping = np.flatnonzero(slip_type[onset:stop] != 0)
        end = onset + (int(slipping[-1]) + 1 if slipping.size else 1)
        fingers = FINGER_UNKNOWN_ONE if kind == 1 else FINGER_BOTH
        events.append((onset, end, fingers, _KIND.get(kind, 'gross')))
    return events


def _busy(truth: dict, lift_start: int, lift_stop: int) -> list[tuple[int, int]]:
    """Intervals that are neither slip nor holding still (module docstring)."""
    from forte_sim import OBJECT_BROKEN, OBJECT_CRUSHED, OBJECT_HELD

    moving = np.abs(np.diff(truth['joint_position'], prepend=truth['joint_position'][0])) > 1e-6
    busy = _intervals(moving)
    held = np.flatnonzero(truth['object_state'][lift_start:] == OBJECT_HELD)
    lifted = lift_start + int(held[0]) + _GRACE if held.size else lift_stop
    busy.append((lift_start, min(lifted, lift_stop)))
    busy.append((lift_stop, lift_stop + int(0.3 * FS)))
    state = truth['object_state']
    failed = np.isin(state, (OBJECT_BROKEN, OBJECT_CRUSHED))
    if failed.any():
        first = int(np.argmax(failed))
        busy.append((first, first + _GRACE))
    return busy


def sim_scene(object_name: str, seed: int, grip: str) -> SlipScene:
    """One scripted simulator lift (module docstring) as a labelled scene.

    Raises
    ------
    ValueError
        Unknown grip, or an object / seed combination outside the split definition.
    """
    from forte_sim import OBJECTS, make_scene

    if grip not in GRIPS:
        raise ValueError(f'grip must be one of {GRIPS}, got {grip!r}')
    split = next((s for s in SPLITS if object_name in sim_objects(s)), None)
    if split is None or seed not in SIM_SEEDS[split]:
        raise ValueError(f'{object_name} seed {seed} is not in the set\'s split')
    scene = make_scene('grasp', object_name=object_name, seed=seed)
    angle = (scene.slip_test_angle if grip == 'marginal'
             else scene.stable_grasp_angle() - FIRM_MARGIN)
    velocity = 0.001 if seed < 2 else 0.005
    frames, truth, onsets, starts = _run_protocol(scene, angle, velocity)
    n = frames.shape[0]
    events = _events(onsets, truth['slip_type'])
    busy = _busy(truth, starts[2], starts[3])
    remove = [(a, b + _GRACE) for a, b, *_ in events] + [(a, b + _REACH) for a, b in busy]
    category = OBJECTS[object_name].category
    return SlipScene(
        name=f'sim_{category}/{object_name}/{seed}/{grip}', family=f'sim_{category}',
        split=split, source='sim', object_name=object_name, seed=seed, frames=frames,
        events=np.array([e[:2] for e in events], np.int64).reshape(-1, 2),
        event_fingers=[e[2] for e in events], event_kinds=tuple(e[3] for e in events),
        event_strength=np.full(len(events), np.nan),
        holding=subtract_intervals(EVALUATE_FROM, n, remove), fs=float(FS),
        evaluate_from=EVALUATE_FROM,
        context={key: truth[key] for key in ('servo_command', 'arm_velocity',
                                             'joint_position')},
        params={'grip': grip, 'grip_angle': angle, 'lift_velocity': velocity,
                'final_object_state': int(truth['object_state'][-1]),
                'onsets': len(onsets)})


def sim_scenes(split: str | None = None) -> list[SlipScene]:
    """Every simulator scene of the set (or of one split)."""
    return [sim_scene(*key) for key in sim_keys(split)]


def source_files() -> list[Path]:
    """The files whose content defines the set (hashed into the cache name)."""
    import forte_sim

    sim_dir = Path(forte_sim.__file__).parent
    from forte_perception.evaluation import scene_parts, stick_slip

    return ([Path(module.__file__) for module in (slip_scenes, scene_parts, stick_slip,
                                                   slip_labels)] + [Path(__file__)]
            + sorted(sim_dir.glob('*.py')))


def dataset_hash() -> str:
    """16 hex digits of SHA-256 over the generator sources and the numpy version."""
    digest = hashlib.sha256(np.__version__.encode())
    for path in source_files():
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def build_set(cache_dir: str | Path = 'out/slip_dataset', rebuild: bool = False,
              log=print) -> tuple[list[SlipScene], dict]:
    """The whole set, both splits, from the cache or generated (then cached).

    Returns
    -------
    scenes : list of SlipScene
    info : dict
        ``hash``, ``path``, ``cached`` (bool), ``seconds`` (wall time to load or build).
    """
    started = time.perf_counter()
    key = dataset_hash()
    path = Path(cache_dir) / f'slip_set_{key}.npz'
    if path.exists() and not rebuild:
        scenes = load_scenes(path)
        cached = True
    else:
        log(f'[slip_dataset] building the set ({key}): signal-level scenes ...')
        scenes = slip_scenes.signal_scenes()
        log(f'[slip_dataset] {len(scenes)} signal scenes; simulator scenes ...')
        scenes += sim_scenes()
        path.parent.mkdir(parents=True, exist_ok=True)
        save_scenes(path, scenes)
        cached = False
    return scenes, {'hash': key, 'path': str(path), 'cached': cached,
                    'seconds': time.perf_counter() - started}
