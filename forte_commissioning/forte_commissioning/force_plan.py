"""The force calibration protocol on the gripper: settings, trial plan, theta_zeroF rule.

Paper, Sec. IV-A: for each of the 6 indentors, 40 trials; in each trial the gripper closes
by a random amount, drawn uniformly between fully closed (theta_closed = 0) and just
touching (theta_zeroF), against a load cell. theta_zeroF is "the servo position when the
fingers *just* touch the object, applying zero force"; every indentor has its own.

**Contact rule for theta_zeroF** (:class:`ContactRule`, once per indentor): the gripper rests
open for ``quiet_seconds`` (baselines: the mean of every sensor channel and of the load
cell), then closes at ``search_velocity`` (slow: 0.05 rad/s moves the fingertips 7 mm/s).
Contact is the first sample at which either

- the paper's contact rule fires on the sensor: the tared, median-11 filtered reading of any
  channel changes by more than ``contact_threshold`` (tau = 0.5 % of full scale = 0.01) over
  the last ``contact_window`` (w = 200) samples, or
- the tared load cell exceeds ``contact_force`` (0.05 N, ten times the rig's noise) on
  ``contact_confirm`` consecutive load-cell samples (the first of them is the time);

theta_zeroF is the servo's reported joint position at that sample time (``joint_states``,
interpolated between the two messages around it). The gripper then opens to
theta_zeroF + ``open_margin``, the open pose of every trial. On the simulated rig the load
cell fires first for 5 of the 6 indentors (the sensor rule for the edge, at 0.07 N); the
angle found is where the *first* finger touches, 2-5 mrad inside that touch, and so up to
22 mrad outside the nominal width / gap-per-radian when the indentor sits off-centre
(+-1.5 mm).

**Trial** (:func:`plan_session`): open and still for ``quiet_seconds`` (the trial's tare
baseline: the dataset's ``tare_samples``), close at the servo's default speed to
theta_zeroF x (1 - closure) with ``closure`` uniform in [0, 1), hold ``hold_seconds``, open
again and rest ``release_seconds``. The draws (closure, then a scene seed, per trial, in
indentor order) come from the same generator as :func:`forte_sim.dataset.
generate_calibration_dataset`, so a simulated session and the offline rig draw the same
closures and seat the indentor the same way, trial by trial.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forte_perception.median import MEDIAN_WINDOW, RunningMedian
from forte_perception.pipeline import contact_exceed
from forte_ros.contract import N_CHANNELS, SAMPLE_RATE
from forte_sim.catalogue import INDENTORS
from forte_sim.dataset import CalibrationProtocol

__all__ = ['ContactRule', 'ForceCalibrationConfig', 'TrialPlan', 'plan_session']

#: Stream of the plan's generator: the same as forte_sim.dataset's campaign draws.
PLAN_STREAM = 0xCA1


@dataclass(frozen=True)
class ForceCalibrationConfig:
    """Settings of a force calibration session (the node's parameters hold the same).

    Attributes
    ----------
    protocol : CalibrationProtocol
        Trials per indentor, quiet / hold / release times [s], seed of the draws.
    indentors : tuple of str
        Indentor names, in the order they are mounted.
    mount_angle : float
        The gripper opens to this angle for the operator to mount the next indentor; the
        theta_zeroF search starts from where it is then [rad].
    open_margin : float
        Open pose beyond theta_zeroF [rad] (0.09 rad: about 12 mm of fingertip gap).
    search_velocity : float
        Servo speed of the theta_zeroF search [rad/s].
    search_floor : float
        The search closes towards this angle and fails when it gets there [rad].
    contact_threshold : float
        tau of the sensor contact rule [normalised units].
    contact_window : int
        w of the sensor contact rule [samples].
    contact_force : float
        Load-cell contact level above its quiet mean [N].
    contact_confirm : int
        Consecutive load-cell samples above ``contact_force`` [count].
    load_cell_max_gap : float
        Longest load-cell interval a frame is interpolated across [s].
    tare_load_cell : bool
        Subtract each trial's quiet load-cell mean (a real cell's zero drifts).
    max_attempts : int
        Attempts per planned trial (a dropped trial is repeated) [count].
    """

    protocol: CalibrationProtocol = field(default_factory=CalibrationProtocol)
    indentors: tuple[str, ...] = tuple(INDENTORS)
    mount_angle: float = 0.6
    open_margin: float = 0.09
    search_velocity: float = 0.05
    search_floor: float = 0.0
    contact_threshold: float = 0.01
    contact_window: int = 200
    contact_force: float = 0.05
    contact_confirm: int = 2
    load_cell_max_gap: float = 0.05
    tare_load_cell: bool = True
    max_attempts: int = 3

    def problems(self) -> list[str]:
        """Reasons the settings are unusable (empty: usable)."""
        found = []
        p = self.protocol
        if p.trials_per_indentor < 1:
            found.append('trials_per_indentor must be >= 1')
        for name, value in (('quiet_seconds', p.quiet_seconds), ('hold_seconds',
                            p.hold_seconds), ('release_seconds', p.release_seconds)):
            if not value > 0:
                found.append(f'{name} must be > 0 s')
        if not self.indentors:
            found.append('no indentor to calibrate')
        if len(set(self.indentors)) != len(self.indentors):
            found.append(f'an indentor is listed twice: {list(self.indentors)}')
        if not self.search_velocity > 0:
            found.append('search_velocity must be > 0 rad/s')
        if self.max_attempts < 1:
            found.append('max_attempts must be >= 1')
        return found

    @property
    def tare_samples(self) -> int:
        """Quiet samples at the start of each trial [count]."""
        return self.protocol.tare_samples

    def samples(self, seconds: float) -> int:
        """``seconds`` of sensor samples [count]."""
        return int(round(seconds * SAMPLE_RATE))


@dataclass(frozen=True)
class TrialPlan:
    """One planned trial.

    Attributes
    ----------
    trial : int
        Trial id, unique over the session (the dataset's ``trial``).
    indentor : str
        Indentor name.
    indentor_index : int
        Index into the session's indentor list.
    repeat : int
        Number of this trial on its indentor, from 0.
    closure : float
        Target position between theta_zeroF (0) and fully closed (1) [-].
    seed : int
        Scene seed of the simulated rig (seating of the indentor, noise); unused on a robot.
    """

    trial: int
    indentor: str
    indentor_index: int
    repeat: int
    closure: float
    seed: int

    def target(self, theta_zero_force: float) -> float:
        """Servo angle of the squeeze [rad]."""
        return theta_zero_force * (1.0 - self.closure)


def plan_session(config: ForceCalibrationConfig) -> list[TrialPlan]:
    """Every trial of the session, in order (deterministic in ``protocol.seed``).

    Returns
    -------
    list of TrialPlan
        ``len(indentors) * trials_per_indentor`` trials, ids 0, 1, ...
    """
    problems = config.problems()
    if problems:
        raise ValueError('; '.join(problems))
    rng = np.random.default_rng((config.protocol.seed, PLAN_STREAM))
    plan = []
    for index, name in enumerate(config.indentors):
        for repeat in range(config.protocol.trials_per_indentor):
            closure = float(rng.uniform(0.0, 1.0))
            seed = int(rng.integers(0, 2 ** 31 - 1))
            plan.append(TrialPlan(len(plan), name, index, repeat, closure, seed))
    return plan


class ContactRule:
    """The theta_zeroF contact rule (module docstring), fed in chunks as data arrive.

    Parameters
    ----------
    sensor_baseline : numpy.ndarray, shape (6,)
        Mean raw reading of each channel while open and still.
    load_baseline : float
        Mean load-cell force while open and still [N] (0 when not tared).
    config : ForceCalibrationConfig
    """

    def __init__(self, sensor_baseline: np.ndarray, load_baseline: float,
                 config: ForceCalibrationConfig) -> None:
        self._baseline = np.asarray(sensor_baseline, dtype=np.float64).reshape(N_CHANNELS)
        self._load_baseline = float(load_baseline)
        self._config = config
        self._median = RunningMedian(MEDIAN_WINDOW, N_CHANNELS)
        self._history = np.zeros((0, N_CHANNELS))
        self._run = 0
        self._run_start: int | None = None

    def sensor(self, frames: np.ndarray) -> int | None:
        """Row of ``frames`` (n, 6) at which the sensor rule first fires, or None."""
        filtered = self._median.update(np.asarray(frames, dtype=np.float64) - self._baseline)
        exceed = contact_exceed(filtered, self._history, self._config.contact_window,
                                self._config.contact_threshold).any(axis=1)
        keep = self._config.contact_window - 1
        self._history = np.concatenate([self._history, filtered])[-keep:]
        hits = np.flatnonzero(exceed)
        return int(hits[0]) if hits.size else None

    def load_cell(self, values: np.ndarray, first_index: int) -> int | None:
        """Index of the first load-cell sample of a confirmed contact, or None.

        Parameters
        ----------
        values : numpy.ndarray, shape (m,)
            New load-cell samples [N] (NaN ends a run).
        first_index : int
            Index of ``values[0]`` in the whole stream (the returned index is in it too).
        """
        for offset, value in enumerate(np.asarray(values, dtype=np.float64)):
            if value - self._load_baseline > self._config.contact_force:
                if self._run == 0:
                    self._run_start = first_index + offset
                self._run += 1
                if self._run >= self._config.contact_confirm:
                    return self._run_start
            else:
                self._run = 0
        return None
