"""The force model of simulated closed-loop trials: trained on the simulated calibration rig.

The force model (needed by FORTE and NO_SLIP; :mod:`forte_evaluation.closed_loop`, the demo,
the benchmarks and the sim graph launched without ``force_model:=`` use it) is trained once
from the simulated calibration rig (:func:`default_force_model`) and cached on disk, keyed by
a hash of the simulator's and perception's source and the training settings, so a change of
either retrains it. The training is deterministic (seeded rig, libsvm): every make of one
key has the same support vectors, bit for bit (only the recorded fit time differs).

The cache file (:func:`force_model_path`): ``$FORTE_CACHE_DIR/force_model_<key>.npz``
(default ``<tmp>/forte-cache``), about 0.6 MB (about 3000 support vectors of 24 features).
Made, or remade, by::

    python -m forte_evaluation.sim_force_model            # prints its path (makes it if missing)
    python -m forte_evaluation.sim_force_model --refresh  # trains it again (6-13 s on 2 cores)
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forte_ros.sensor_identity import SIMULATED_SENSOR

__all__ = ['FORCE_TRAINING', 'calibration_features', 'default_force_model',
           'default_force_model_file', 'force_model_path', 'train_force_model']

#: Training settings of the cached force model (part of the cache key).
FORCE_TRAINING = {
    'trials_per_indentor': 8,   # 6 indentors -> 48 trials
    'quiet_seconds': 1.0,       # tare period at the start of each trial
    'close_seconds': 0.5,       # closing ramp to a random angle
    'hold_seconds': 4.0,        # hold at the angle (relaxation)
    'stride': 40,               # feature subsampling for training [samples]
    'seed': 12345,
    'C': 10.0,
    'epsilon': 0.02,
}

_MODEL_CACHE: dict[str, object] = {}


def _source_hash() -> str:
    """Hash of the simulator and perception sources, this module and the training settings."""
    import forte_perception
    import forte_sim as sim

    digest = hashlib.sha256(repr(sorted(FORCE_TRAINING.items())).encode())
    for package in (Path(sim.__file__).parent, Path(forte_perception.__file__).parent):
        for path in sorted(package.glob('*.py')):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    digest.update(Path(__file__).read_bytes())
    return digest.hexdigest()[:16]


def _cache_dir() -> Path:
    folder = os.environ.get('FORTE_CACHE_DIR')
    path = Path(folder) if folder else Path(tempfile.gettempdir()) / 'forte-cache'
    path.mkdir(parents=True, exist_ok=True)
    return path


def calibration_features(settings: dict | None = None) -> tuple[np.ndarray, np.ndarray,
                                                                np.ndarray]:
    """Simulated calibration rig -> training features, as the contract's trainer does.

    Per trial (every indentor x ``trials_per_indentor``): quiet period, closing ramp to an
    angle drawn uniformly between fully closed and just touching, hold. Each trial is tared
    by the mean of its quiet raw samples, median-filtered (11, causal, streaming) and its 24
    force features computed at full rate, then subsampled by ``stride``.

    Returns
    -------
    features : ndarray, shape (m, 24)
    force : ndarray, shape (m,)
        Load-cell force [N].
    trial : ndarray, shape (m,)
        Trial id.
    """
    from forte_perception.force import force_features
    from forte_perception.median import RunningMedian
    from forte_ros.contract import SAMPLE_RATE
    from forte_sim import INDENTORS, make_scene

    s = dict(FORCE_TRAINING, **(settings or {}))
    rng = np.random.default_rng(s['seed'])
    quiet = int(s['quiet_seconds'] * SAMPLE_RATE)
    close = int(s['close_seconds'] * SAMPLE_RATE)
    hold = int(s['hold_seconds'] * SAMPLE_RATE)
    chunk = 400
    features, force, trials = [], [], []
    trial_id = 0
    for name in INDENTORS:
        for _ in range(s['trials_per_indentor']):
            scene = make_scene('calibration', indentor=name, seed=s['seed'] + trial_id,
                               trial=trial_id)
            start = scene.initial_angle
            target = float(rng.uniform(0.0, scene.theta_zero_force))
            frames, loads = [], []
            done = 0
            total = quiet + close + hold
            while done < total:
                n = min(chunk, total - done)
                if done < quiet:
                    command = start
                else:
                    command = start + (target - start) * min((done - quiet + n) / close, 1.0)
                block, truth = scene.step(n, command, 0.0)
                frames.append(block)
                loads.append(truth.load_cell_force)
                done += n
            raw = np.concatenate(frames)
            load = np.concatenate(loads)
            baseline = raw[:quiet].mean(axis=0)
            median = RunningMedian(11, 6)
            filtered = median.update(raw) - baseline
            feats = force_features(filtered, fs=SAMPLE_RATE)
            pick = np.arange(quiet // 2, total, s['stride'])
            features.append(feats[pick])
            force.append(load[pick])
            trials.append(np.full(pick.size, trial_id))
            trial_id += 1
    return np.concatenate(features), np.concatenate(force), np.concatenate(trials)


def train_force_model(settings: dict | None = None):
    """Train a :class:`forte_perception.force.ForceModel` on the simulated calibration rig."""
    from forte_perception.force import ForceModel

    s = dict(FORCE_TRAINING, **(settings or {}))
    features, force, _ = calibration_features(s)
    return ForceModel.fit(features, force, C=s['C'], epsilon=s['epsilon'],
                          force_range=(0.0, 10.0),
                          metadata={'source': 'forte_evaluation.closed_loop simulated rig',
                                    'settings': {k: v for k, v in s.items()},
                                    'sensor': SIMULATED_SENSOR.to_dict()})


def default_force_model(refresh: bool = False):
    """The cached force model for closed-loop trials (trained on first use, ~10 s).

    Cached in memory and in ``$FORTE_CACHE_DIR`` (default ``<tmp>/forte-cache``) under a key
    that changes with the simulator / perception sources and :data:`FORCE_TRAINING`.
    """
    from forte_perception.force import ForceModel

    key = _source_hash()
    if not refresh and key in _MODEL_CACHE:
        return _MODEL_CACHE[key]
    path = _cache_dir() / f'force_model_{key}.npz'
    model = None
    if path.exists() and not refresh:
        try:
            model = ForceModel.load(path)
        except (ValueError, OSError, KeyError):
            model = None  # damaged cache: retrain
    if model is None:
        model = train_force_model()
        partial = path.with_suffix(f'.{os.getpid()}.tmp')
        model.save(partial)
        os.replace(partial, path)  # atomic: concurrent workers never read half a file
    _MODEL_CACHE[key] = model
    return model



def force_model_path() -> Path:
    """Path of the cached force model of the current sources (it may not exist yet).

    Cheap (hashes the sources, trains nothing): ``$FORTE_CACHE_DIR/force_model_<key>.npz``,
    default folder ``<tmp>/forte-cache``.
    """
    return _cache_dir() / f'force_model_{_source_hash()}.npz'


def default_force_model_file(refresh: bool = False) -> Path:
    """The cached force model file, made first if missing (6-13 s on 2 cores).

    Used by the sim graph when no ``force_model`` is given (:mod:`forte_bringup.graph`).

    Parameters
    ----------
    refresh : bool
        Train it again even if the file exists.

    Returns
    -------
    Path
        :func:`force_model_path`, which exists on return.
    """
    path = force_model_path()
    if refresh or not path.is_file():
        model = default_force_model(refresh=refresh)
        if not path.is_file():  # held in memory only (the file was removed): write it
            partial = path.with_suffix(f'.{os.getpid()}.tmp')
            model.save(partial)
            os.replace(partial, path)
    return path


def main(argv: list[str] | None = None) -> int:
    """``python -m forte_evaluation.sim_force_model``: make the cached model, print its path."""
    parser = argparse.ArgumentParser(
        prog='python -m forte_evaluation.sim_force_model',
        description="Make (if missing) the simulated rig's force model the sim graph uses "
                    'by default, and print its path.')
    parser.add_argument('--refresh', action='store_true', help='train it again')
    options = parser.parse_args(argv)
    existed = force_model_path().is_file()
    started = time.perf_counter()
    path = default_force_model_file(refresh=options.refresh)
    made = options.refresh or not existed
    print(f'{path} ({path.stat().st_size / 1e6:.2f} MB, '
          + (f'trained in {time.perf_counter() - started:.1f} s)' if made else 'cached)'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
