"""A force calibration session on disk: every finished trial kept, resumable (pure).

Layout of a session folder::

    session.json            settings, plan seed, theta_zeroF per indentor, sensor identity,
                            dropped attempts with their reasons (rewritten atomically)
    trials/trial_0007.npz   one finished trial: frames (n, 6) float32, force (n,) float32,
                            and its plan (written to a temporary name, fsync'ed, renamed)
    bags/run_000/           the MCAP bag of each run of the procedure (rosbag2 folder)
    calibration.npz         the contract's dataset (docs/contracts.md) once complete

A trial is finished when its file exists: the rename is atomic, so an interruption at any
moment loses at most the trial that was running, never a recorded one, and leaves no half
file that could be taken for a trial. Resuming opens the folder, checks that the settings
are the session's own (a different protocol would mix incompatible trials) and skips every
finished trial. ``session.json`` is only bookkeeping: the trial files are the record.
"""
from __future__ import annotations

import json
import os
import tempfile
from dataclasses import asdict
from pathlib import Path

import numpy as np

from forte_commissioning.force_plan import ForceCalibrationConfig, TrialPlan, plan_session
from forte_ros.contract import CHANNEL_NAMES, SAMPLE_RATE
from forte_sim.dataset import DATASET_KEYS

__all__ = ['SESSION_VERSION', 'SessionError', 'SessionStore', 'settings_record']

#: Format version of ``session.json``.
SESSION_VERSION = 1
#: Settings that define which trials a session holds (must match on resume).
_PLAN_KEYS = ('protocol', 'indentors')


class SessionError(ValueError):
    """The session folder cannot be used (different settings, damaged file)."""


def settings_record(config: ForceCalibrationConfig) -> dict:
    """JSON-serialisable form of the settings."""
    record = asdict(config)
    record['indentors'] = list(config.indentors)
    return record


def _write_atomic(path: Path, writer) -> None:
    """Write through ``writer(file_object)`` to a temporary file, fsync, then rename."""
    handle, temporary = tempfile.mkstemp(prefix=f'.{path.name}.', dir=path.parent)
    try:
        with os.fdopen(handle, 'wb') as stream:
            writer(stream)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    directory = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(directory)
    finally:
        os.close(directory)


class SessionStore:
    """The session folder (module docstring).

    Parameters
    ----------
    folder : str or Path
        Created if missing; an existing session there is resumed.
    config : ForceCalibrationConfig
        Settings; on resume the protocol and indentors must equal the stored ones.

    Raises
    ------
    SessionError
        The folder holds a session with other settings, or an unreadable ``session.json``.
    """

    def __init__(self, folder: str | Path, config: ForceCalibrationConfig) -> None:
        self.folder = Path(folder)
        self.config = config
        self.plan = plan_session(config)
        self.trials_folder = self.folder / 'trials'
        self.trials_folder.mkdir(parents=True, exist_ok=True)
        self._path = self.folder / 'session.json'
        settings = settings_record(config)
        if self._path.exists():
            try:
                self.state = json.loads(self._path.read_text())
            except (OSError, ValueError) as error:
                raise SessionError(f'{self._path}: unreadable ({error})') from error
            stored = self.state.get('settings', {})
            different = [key for key in _PLAN_KEYS if stored.get(key) != settings[key]]
            if different:
                raise SessionError(
                    f'{self.folder} holds a session with other {" and ".join(different)} '
                    f'({", ".join(f"{key}={stored.get(key)}" for key in different)}): use '
                    'another session folder or the same settings')
            self.resumed = True
        else:
            self.state = {'version': SESSION_VERSION, 'settings': settings,
                          'theta_zero_force': {}, 'sensor_identity': None, 'dropped': [],
                          'runs': 0}
            self.resumed = False
        self.state['runs'] = int(self.state.get('runs', 0)) + 1
        self._save_state()

    # ------------------------------------------------------------------ bookkeeping
    def _save_state(self) -> None:
        text = json.dumps(self.state, indent=2).encode()
        _write_atomic(self._path, lambda stream: stream.write(text))

    @property
    def run_index(self) -> int:
        """0 for the first run of the session, 1 after one resume, ..."""
        return self.state['runs'] - 1

    def bag_path(self) -> Path:
        """Bag folder of this run (``bags/run_NNN``)."""
        return self.folder / 'bags' / f'run_{self.run_index:03d}'

    def trial_path(self, trial: int) -> Path:
        """File of a finished trial."""
        return self.trials_folder / f'trial_{trial:04d}.npz'

    def is_done(self, trial: int) -> bool:
        """The trial's file exists (it was recorded completely)."""
        return self.trial_path(trial).exists()

    def pending(self) -> list[TrialPlan]:
        """Planned trials without a file, in plan order."""
        return [plan for plan in self.plan if not self.is_done(plan.trial)]

    def done_count(self) -> int:
        """Finished trials [count]."""
        return sum(self.is_done(plan.trial) for plan in self.plan)

    def zero_force(self, indentor: str) -> float | None:
        """theta_zeroF found for ``indentor`` in this session [rad], or None."""
        value = self.state['theta_zero_force'].get(indentor)
        return None if value is None else float(value)

    def set_zero_force(self, indentor: str, theta: float) -> None:
        """Keep theta_zeroF of an indentor [rad] (a resumed session reuses it)."""
        self.state['theta_zero_force'][indentor] = float(theta)
        self._save_state()

    def set_sensor_identity(self, identity: dict | None) -> None:
        """Keep the sensor's identity (forte_msgs/SensorInfo fields) when one is known."""
        if identity is not None and identity != self.state.get('sensor_identity'):
            self.state['sensor_identity'] = identity
            self._save_state()

    def record_drop(self, plan: TrialPlan, attempt: int, reason: str) -> None:
        """Note a dropped attempt of a trial and why."""
        self.state['dropped'].append({'trial': plan.trial, 'indentor': plan.indentor,
                                      'attempt': attempt, 'run': self.run_index,
                                      'reason': reason})
        self._save_state()

    # ------------------------------------------------------------------ trials
    def save_trial(self, plan: TrialPlan, frames: np.ndarray, force: np.ndarray,
                   theta_zero_force: float, first_stamp_ns: int) -> Path:
        """Keep a finished trial (atomically; see the module docstring).

        Parameters
        ----------
        plan : TrialPlan
        frames : numpy.ndarray, shape (n, 6)
            Raw readings; the first ``tare_samples`` rows are the quiet baseline.
        force : numpy.ndarray, shape (n,)
            Load-cell force at each row [N].
        theta_zero_force : float
            theta_zeroF the target came from [rad].
        first_stamp_ns : int
            Sample time of the first row [ns].
        """
        frames = np.asarray(frames, dtype=np.float32)
        force = np.asarray(force, dtype=np.float32)
        if frames.ndim != 2 or frames.shape[1] != len(CHANNEL_NAMES) or \
                force.shape != (frames.shape[0],):
            raise ValueError(f'trial {plan.trial}: frames {frames.shape}, force {force.shape}')
        meta = json.dumps({**asdict(plan), 'theta_zero_force': float(theta_zero_force),
                           'target': plan.target(theta_zero_force),
                           'first_stamp_ns': int(first_stamp_ns), 'run': self.run_index})
        path = self.trial_path(plan.trial)
        _write_atomic(path, lambda stream: np.savez(stream, frames=frames, force=force,
                                                    meta=np.array(meta)))
        return path

    def load_trial(self, trial: int) -> tuple[np.ndarray, np.ndarray, dict]:
        """(frames (n, 6) float32, force (n,) float32, plan and metadata) of a trial."""
        with np.load(self.trial_path(trial), allow_pickle=False) as data:
            return data['frames'], data['force'], json.loads(str(data['meta']))

    # ------------------------------------------------------------------ dataset
    def dataset(self) -> dict[str, np.ndarray]:
        """The contract's dataset of every finished trial, in trial order.

        Returns
        -------
        dict
            Keys :data:`forte_sim.dataset.DATASET_KEYS`, plus ``sensor_identity`` (JSON of
            the sensor's forte_msgs/SensorInfo fields) when the session knows it.

        Raises
        ------
        SessionError
            No trial is finished.
        """
        frames, force, trial, indentor = [], [], [], []
        for plan in self.plan:
            if not self.is_done(plan.trial):
                continue
            rows, load, _ = self.load_trial(plan.trial)
            frames.append(rows)
            force.append(load)
            trial.append(np.full(len(rows), plan.trial, dtype=np.int32))
            indentor.append(np.full(len(rows), plan.indentor_index, dtype=np.int32))
        if not frames:
            raise SessionError(f'{self.folder}: no finished trial yet')
        dataset = {
            'frames': np.concatenate(frames), 'force': np.concatenate(force),
            'trial': np.concatenate(trial), 'indentor': np.concatenate(indentor),
            'indentor_names': np.array(self.config.indentors),
            'fs': np.float64(SAMPLE_RATE), 'channel_names': np.array(CHANNEL_NAMES),
            'tare_samples': np.int64(self.config.tare_samples)}
        identity = self.state.get('sensor_identity')
        if identity is not None:
            dataset['sensor_identity'] = np.array(json.dumps(identity, sort_keys=True))
        return dataset

    def write_dataset(self, path: str | Path | None = None) -> Path:
        """Write :meth:`dataset` as one ``.npz`` (default ``calibration.npz`` in the folder).

        Returns
        -------
        Path
            The file written (atomically).
        """
        target = Path(path) if path else self.folder / 'calibration.npz'
        if target.suffix != '.npz':
            target = target.with_name(target.name + '.npz')
        target.parent.mkdir(parents=True, exist_ok=True)
        dataset = self.dataset()
        keys = [*DATASET_KEYS, *(['sensor_identity'] if 'sensor_identity' in dataset else [])]
        _write_atomic(target, lambda stream: np.savez_compressed(
            stream, **{key: dataset[key] for key in keys}))
        return target
