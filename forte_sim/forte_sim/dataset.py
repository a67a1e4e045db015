"""Simulated force calibration rig -> the calibration dataset of docs/contracts.md.

Protocol per trial (paper Sec. IV-A): the gripper rests open for the tare period, closes
at its profile velocity to an angle drawn uniformly between fully closed (0 rad) and just
touching the indentor (theta_zeroF), holds (the finger relaxes), opens again and rests.
The load cell (mean of the two finger forces plus its own noise) is the ground truth.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forte_ros.contract import CHANNEL_NAMES, SAMPLE_RATE
from forte_ros.sensor_identity import SIMULATED_SENSOR
from forte_sim.catalogue import INDENTORS
from forte_sim.scene import make_scene

#: Keys of the dataset file, in the contract's order.
DATASET_KEYS = ('frames', 'force', 'trial', 'indentor', 'indentor_names', 'fs',
                'channel_names', 'tare_samples')
#: Optional keys: ``sensor_identity``, the JSON of the sensor's identity
#: (:class:`forte_ros.sensor_identity.SensorIdentity`); the simulator's here.
OPTIONAL_KEYS = ('sensor_identity',)


@dataclass(frozen=True)
class CalibrationProtocol:
    """Timing of one calibration trial.

    Attributes
    ----------
    trials_per_indentor : int
        Trials per indentor shape (paper: 40).
    quiet_seconds : float
        Open and still at the start; its samples are the trial's tare baseline [s].
    hold_seconds : float
        Hold at the drawn angle after the closing command [s].
    release_seconds : float
        Open again and rest at the end [s].
    seed : int
        Seed of the angle draws and of every trial's scene.
    """

    trials_per_indentor: int = 40
    quiet_seconds: float = 1.0
    hold_seconds: float = 12.0
    release_seconds: float = 2.0
    seed: int = 0

    @property
    def tare_samples(self) -> int:
        """Quiet samples at the start of each trial [count]."""
        return int(round(self.quiet_seconds * SAMPLE_RATE))


#: The --quick protocol: 6 indentors x 8 trials of 1 + 6 + 1.5 s.
QUICK_PROTOCOL = CalibrationProtocol(trials_per_indentor=8, hold_seconds=6.0,
                                     release_seconds=1.5)


def run_calibration_trial(indentor: str, closure: float, seed: int, trial: int,
                          protocol: CalibrationProtocol) -> tuple[np.ndarray, np.ndarray]:
    """Simulate one calibration trial.

    Parameters
    ----------
    indentor : str
        Name in :data:`INDENTORS`.
    closure : float
        Position of the target angle between theta_zeroF (0) and fully closed (1) [-].
    seed : int
        Scene seed.
    trial : int
        Trial id.
    protocol : CalibrationProtocol

    Returns
    -------
    frames : numpy.ndarray, shape (n, 6), float64
        Raw readings.
    force : numpy.ndarray, shape (n,)
        Load cell force [N].
    """
    scene = make_scene('calibration', indentor=indentor, seed=seed, trial=trial)
    target = scene.theta_zero_force * (1.0 - closure)
    phases = ((protocol.tare_samples, scene.initial_angle),
              (int(round(protocol.hold_seconds * SAMPLE_RATE)), target),
              (int(round(protocol.release_seconds * SAMPLE_RATE)), scene.initial_angle))
    frames, force = [], []
    for count, command in phases:
        chunk, truth = scene.step(count, command, 0.0)
        frames.append(chunk)
        force.append(truth.load_cell_force)
    return np.concatenate(frames), np.concatenate(force)


def generate_calibration_dataset(protocol: CalibrationProtocol = CalibrationProtocol(),
                                 indentors: Iterable[str] | None = None,
                                 progress: Callable[[int, int], None] | None = None
                                 ) -> dict[str, np.ndarray]:
    """Simulate the whole calibration rig campaign.

    Parameters
    ----------
    protocol : CalibrationProtocol
    indentors : iterable of str, optional
        Indentor names (default: all 6 of :data:`INDENTORS`).
    progress : callable, optional
        Called as ``progress(done_trials, total_trials)``.

    Returns
    -------
    dict
        The arrays of the contract's dataset (keys :data:`DATASET_KEYS` and the
        simulator's ``sensor_identity``).
    """
    names = list(indentors) if indentors is not None else list(INDENTORS)
    for name in names:
        if name not in INDENTORS:
            raise ValueError(f'unknown indentor {name!r}; expected one of {tuple(INDENTORS)}')
    if protocol.trials_per_indentor < 1:
        raise ValueError('trials_per_indentor must be >= 1')
    rng = np.random.default_rng((protocol.seed, 0xCA1))
    total = len(names) * protocol.trials_per_indentor
    frames, force, trial_ids, indentor_ids = [], [], [], []
    trial = 0
    for index, name in enumerate(names):
        for _ in range(protocol.trials_per_indentor):
            closure = float(rng.uniform(0.0, 1.0))
            seed = int(rng.integers(0, 2 ** 31 - 1))
            raw, load = run_calibration_trial(name, closure, seed, trial, protocol)
            frames.append(raw.astype(np.float32))
            force.append(load.astype(np.float32))
            trial_ids.append(np.full(len(raw), trial, dtype=np.int32))
            indentor_ids.append(np.full(len(raw), names.index(name), dtype=np.int32))
            trial += 1
            if progress is not None:
                progress(trial, total)
        del index
    return {
        'frames': np.concatenate(frames),
        'force': np.concatenate(force),
        'trial': np.concatenate(trial_ids),
        'indentor': np.concatenate(indentor_ids),
        'indentor_names': np.array(names),
        'fs': np.float64(SAMPLE_RATE),
        'channel_names': np.array(CHANNEL_NAMES),
        'tare_samples': np.int64(protocol.tare_samples),
        'sensor_identity': np.array(json.dumps(SIMULATED_SENSOR.to_dict())),
    }


def save_dataset(path: str | Path, dataset: dict[str, np.ndarray],
                 compressed: bool = True) -> Path:
    """Write the dataset as one .npz (no pickles); written to a temporary name first.

    Parameters
    ----------
    path : str or Path
        Output file (``.npz`` appended by numpy if missing).
    dataset : dict
        As returned by :func:`generate_calibration_dataset`.
    compressed : bool
        Use zip deflate.

    Returns
    -------
    Path
        The written file.
    """
    missing = [key for key in DATASET_KEYS if key not in dataset]
    if missing:
        raise ValueError(f'dataset lacks {missing}')
    target = Path(path)
    if target.suffix != '.npz':
        target = target.with_name(target.name + '.npz')
    partial = target.with_name(target.name + '.partial.npz')
    writer = np.savez_compressed if compressed else np.savez
    keys = DATASET_KEYS + tuple(key for key in OPTIONAL_KEYS if key in dataset)
    writer(partial, **{key: dataset[key] for key in keys})
    partial.replace(target)
    return target


def load_dataset(path: str | Path) -> dict[str, np.ndarray]:
    """Read and check a calibration dataset file.

    Raises
    ------
    ValueError
        Missing keys, inconsistent lengths or non-contiguous trials.
    """
    with np.load(path, allow_pickle=False) as data:
        missing = [key for key in DATASET_KEYS if key not in data.files]
        if missing:
            raise ValueError(f'{path}: missing keys {missing}')
        dataset = {key: data[key] for key in DATASET_KEYS + OPTIONAL_KEYS if key in data.files}
    count = len(dataset['frames'])
    if dataset['frames'].ndim != 2 or dataset['frames'].shape[1] != 6:
        raise ValueError(f'{path}: frames must be (n, 6), got {dataset["frames"].shape}')
    for key in ('force', 'trial', 'indentor'):
        if len(dataset[key]) != count:
            raise ValueError(f'{path}: {key} has {len(dataset[key])} rows, frames {count}')
    starts = np.flatnonzero(np.diff(dataset['trial'])) + 1
    run_ids = dataset['trial'][np.concatenate(([0], starts))] if count else np.zeros(0)
    if len(np.unique(run_ids)) != len(run_ids):
        raise ValueError(f'{path}: trial ids are not contiguous runs')
    return dataset
