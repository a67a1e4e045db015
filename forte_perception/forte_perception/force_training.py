"""Force model training and trial-wise cross-validation on a calibration dataset.

Dataset: one ``.npz`` as defined in docs/contracts.md (``frames`` (n, 6) raw, ``force`` (n,)
[N], ``trial`` (n,) contiguous runs, ``indentor`` (n,), ``indentor_names`` (k,), ``fs``,
``channel_names`` (6,), ``tare_samples``).

Per trial (as the pipeline does online): tare by the mean of the first ``tare_samples`` raw
samples, causal median 11, the 24 force features at full rate (means over the samples
available since the trial start until a window is full), then every ``stride``-th sample
from the end of the tare period on is a training row.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forte_perception.force import ForceModel, force_features
from forte_perception.median import MEDIAN_WINDOW, RunningMedian
from forte_ros.contract import CHANNEL_NAMES
from forte_ros.sensor_identity import SensorIdentity, check_identity

__all__ = ['CalibrationRows', 'cross_validate', 'load_calibration', 'make_rows',
           'train_model', 'training_sensor']

REQUIRED_KEYS = ('frames', 'force', 'trial', 'indentor', 'indentor_names', 'fs',
                 'channel_names', 'tare_samples')


def load_calibration(path: str | Path) -> dict[str, np.ndarray]:
    """Read and check a calibration dataset (no pickle).

    Raises
    ------
    ValueError
        Missing keys, inconsistent lengths, wrong channel order, non-contiguous trials,
        non-finite values.
    """
    with np.load(path, allow_pickle=False) as data:
        missing = [k for k in REQUIRED_KEYS if k not in data.files]
        if missing:
            raise ValueError(f'{path}: missing keys {missing}')
        ds = {k: data[k] for k in REQUIRED_KEYS}
        if 'sensor_identity' in data.files:
            ds['sensor_identity'] = data['sensor_identity']
    _check_identity_key(path, ds)
    n = ds['frames'].shape[0]
    if ds['frames'].ndim != 2 or ds['frames'].shape[1] != 6:
        raise ValueError(f'{path}: frames must be (n, 6), got {ds["frames"].shape}')
    for key in ('force', 'trial', 'indentor'):
        if ds[key].shape != (n,):
            raise ValueError(f'{path}: {key} must be ({n},), got {ds[key].shape}')
    if tuple(str(c) for c in ds['channel_names']) != CHANNEL_NAMES:
        raise ValueError(f'{path}: channel_names {list(ds["channel_names"])} are not the '
                         f'contract order {list(CHANNEL_NAMES)}')
    if not (np.isfinite(ds['frames']).all() and np.isfinite(ds['force']).all()):
        raise ValueError(f'{path}: frames or force contain NaN/inf')
    starts = np.concatenate([[0], np.flatnonzero(np.diff(ds['trial'])) + 1])
    if n and np.unique(ds['trial'][starts]).size != starts.size:
        raise ValueError(f'{path}: trial ids are not contiguous runs')
    if ds['indentor'].size and (ds['indentor'].min() < 0
                                or ds['indentor'].max() >= len(ds['indentor_names'])):
        raise ValueError(f'{path}: indentor index outside indentor_names')
    return ds


def _check_identity_key(path: str | Path, dataset: dict[str, np.ndarray]) -> None:
    """The optional ``sensor_identity`` must parse and agree with ``fs`` / channel order."""
    if 'sensor_identity' not in dataset:
        return
    try:
        identity = SensorIdentity.from_dict(json.loads(str(dataset['sensor_identity'])))
    except (ValueError, TypeError) as exc:
        raise ValueError(f'{path}: sensor_identity: {exc}') from exc
    recorded = {'sample_rate': float(dataset['fs']),
                'channel_names': [str(name) for name in dataset['channel_names']]}
    refusals = check_identity(recorded, identity).refusals
    if refusals:
        raise ValueError(f'{path}: sensor_identity disagrees with the data: '
                         + '; '.join(refusals))


def training_sensor(dataset: dict[str, np.ndarray]) -> dict:
    """What a model trained on ``dataset`` was trained on, for its ``metadata['sensor']``.

    Parameters
    ----------
    dataset : dict
        From :func:`load_calibration`.

    Returns
    -------
    dict
        ``sample_rate`` [Hz] and ``channel_names`` of the data, and the recorded sensor
        identity's fields (``device_id``, ``firmware``, ``counts_per_full_scale``, ...)
        when the dataset has one (``forte_ros.sensor_identity.check_identity`` compares
        it with the sensor a node runs on).
    """
    sensor: dict = {}
    if 'sensor_identity' in dataset:
        sensor.update(SensorIdentity.from_dict(
            json.loads(str(dataset['sensor_identity']))).to_dict())
    sensor['sample_rate'] = float(dataset['fs'])
    sensor['channel_names'] = [str(name) for name in dataset['channel_names']]
    return sensor


@dataclass
class CalibrationRows:
    """Training rows: features (m, 24), force (m,) [N], trial (m,), indentor (m,)."""

    features: np.ndarray
    force: np.ndarray
    trial: np.ndarray
    indentor: np.ndarray
    indentor_names: tuple[str, ...]


def make_rows(dataset: dict[str, np.ndarray], stride: int = 200,
              median_window: int = MEDIAN_WINDOW) -> CalibrationRows:
    """Per-trial tare, median, force features; every ``stride``-th sample after the tare."""
    fs = float(dataset['fs'])
    tare = int(dataset['tare_samples'])
    trial = dataset['trial']
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(trial)) + 1, [trial.size]])
    feats, force, trials, indentors = [], [], [], []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        raw = dataset['frames'][a:b].astype(np.float64)
        if raw.shape[0] <= tare:
            continue
        baseline = raw[:tare].mean(axis=0)
        filtered = RunningMedian(median_window, 6).update(raw - baseline)
        rows = force_features(filtered, fs=fs)
        pick = np.arange(tare, b - a, int(stride))
        feats.append(rows[pick])
        force.append(dataset['force'][a:b][pick].astype(np.float64))
        trials.append(np.full(pick.size, trial[a]))
        indentors.append(dataset['indentor'][a:b][pick])
    return CalibrationRows(np.concatenate(feats), np.concatenate(force),
                           np.concatenate(trials), np.concatenate(indentors),
                           tuple(str(s) for s in dataset['indentor_names']))


def _metrics(err: np.ndarray) -> dict[str, float]:
    return {'rmse': float(math.sqrt(np.mean(err ** 2))) if err.size else math.nan,
            'mae': float(np.mean(np.abs(err))) if err.size else math.nan,
            'rows': int(err.size)}


def cross_validate(rows: CalibrationRows, folds: int = 10, kind: str = 'history',
                   **fit_args) -> dict:
    """Trial-wise k-fold cross-validation (GroupKFold by trial; whole trials held out).

    Returns
    -------
    dict
        ``overall`` {rmse, mae, rows}, ``per_indentor`` {name: {rmse, mae, rows}},
        ``per_fold_rmse`` (list), ``kind``, ``folds``.
    """
    from sklearn.model_selection import GroupKFold

    n_trials = np.unique(rows.trial).size
    if n_trials < folds:
        raise ValueError(f'{n_trials} trials cannot make {folds} folds')
    x = rows.features if kind == 'history' else rows.features[:, :6]
    predicted = np.empty_like(rows.force)
    per_fold = []
    for train, test in GroupKFold(n_splits=folds).split(x, rows.force, rows.trial):
        model = ForceModel.fit(x[train], rows.force[train], kind=kind, **fit_args)
        predicted[test] = model.predict(x[test])
        per_fold.append(_metrics(predicted[test] - rows.force[test])['rmse'])
    err = predicted - rows.force
    per_indentor = {name: _metrics(err[rows.indentor == i])
                    for i, name in enumerate(rows.indentor_names)
                    if np.any(rows.indentor == i)}
    return {'kind': kind, 'folds': folds, 'overall': _metrics(err),
            'per_indentor': per_indentor, 'per_fold_rmse': per_fold}


def train_model(rows: CalibrationRows, kind: str = 'history',
                force_range: tuple[float, float] | None = None,
                metadata: dict | None = None, **fit_args) -> ForceModel:
    """Fit the final model on every row."""
    x = rows.features if kind == 'history' else rows.features[:, :6]
    return ForceModel.fit(x, rows.force, kind=kind, force_range=force_range,
                          metadata=metadata, **fit_args)


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file (hex), for the model's training metadata."""
    digest = hashlib.sha256()
    with open(path, 'rb') as f:
        for block in iter(lambda: f.read(1 << 20), b''):
            digest.update(block)
    return digest.hexdigest()
