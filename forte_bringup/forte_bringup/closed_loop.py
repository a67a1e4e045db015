"""Offline closed loop: simulated scene + perception pipeline + grasp state machine, no ROS.

The engine of the evaluation harness, the demo plots and the closed-loop tests::

    from forte_bringup.closed_loop import run_trial
    result = run_trial('soda_can', 'FORTE', seed=3)
    result.outcome, result.object_state, result.success

One trial:

1. ``make_scene('grasp', object_name, seed)``; the gripper starts open at the scene's
   ``initial_angle``.
2. Warm-up: the sensor streams with the gripper still for ``warmup`` seconds, so the
   perception pipeline tares itself (``tare_duration``) and the slip detector fills its
   window, as on the robot before a grasp.
3. A Grasp goal starts the state machine. Then, every ``chunk_samples`` samples (20 = 10 ms,
   the default TactileFrames batch): the scene produces the frames, the pipeline processes
   them, the state machine steps with the perception output and the joint angle (both stamped
   with the time of the chunk's last sample) and its servo command and arm velocity apply to
   the next chunk. The slip reaction therefore reaches the servo one chunk after the chunk
   whose detector update flagged slip, as in the node (within one perception update).
4. When the machine has finished (DONE or FAULT), the scene runs ``settle`` seconds more with
   the last commands so the ground truth can show what happened to the object (e.g. a late
   drop). ``max_duration`` bounds a trial in any case.

The force model (needed by FORTE and NO_SLIP) is trained once from the simulated calibration
rig (:func:`default_force_model`) and cached on disk, keyed by a hash of the simulator's and
perception's source and the training settings, so a change of either retrains it.
"""
from __future__ import annotations

import hashlib
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forte_control.state_machine import (
    ACTIVE_STATES,
    ControlInputs,
    Controller,
    ControllerParams,
    GraspGoal,
    GraspState,
    GraspStateMachine,
    JointInput,
    Outcome,
    perception_input,
)

__all__ = ['OBJECT_STATE_NAMES', 'TrialResult', 'default_force_model', 'run_trial',
           'train_force_model']

#: SimGroundTruth object_state constant -> name.
OBJECT_STATE_NAMES = {0: 'NONE', 1: 'RESTING', 2: 'HELD', 3: 'DROPPED', 4: 'BROKEN',
                      5: 'CRUSHED'}

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


@dataclass
class TrialResult:
    """Outcome and ground truth of one closed-loop trial.

    Attributes
    ----------
    object_name, controller, seed, trial
        What was run (controller as its name: 'FORTE', 'NO_SLIP', 'ON_OFF').
    outcome : str
        The controller's own outcome (Grasp result constant name: LIFTED, DROPPED, ...).
    object_state : str
        Ground-truth object state at the end (HELD, DROPPED, BROKEN, CRUSHED, RESTING), after
        ``settle`` seconds with the last commands.
    object_state_at_outcome : str
        Ground-truth object state at the update in which the controller reached its outcome
        (what its claim is about; the object may still fall during the settle time).
    success : bool
        The controller completed the lift (outcome LIFTED) and the ground truth agrees: the
        object ends held (neither dropped, broken nor crushed) at least ``success_height``
        above the table (the paper's "successfully lifted"). A lift the controller believes
        complete while the object stayed on the table (smooth gross slip it cannot sense) is
        not a success.
    message : str
        The controller's last message.
    fault_flags : int
        GraspState FAULT_* bits latched at the end.
    final_height : float
        True object height above the table at the end [m].
    max_true_force : float
        Largest true finger normal force during the trial [N].
    max_estimated_force : float
        Largest valid estimated force during the trial [N] (NaN if none).
    slip_events : int
        Slip events the controller acted on [count].
    tightening : float
        Total slip tightening [rad].
    lift_height : float
        Commanded lift height integrated by the controller [m].
    slip_onset_times : list of float
        True slip onsets (simulator ground truth) [s since the goal started].
    slip_onset_types : list of int
        SimGroundTruth SLIP_* type of each onset.
    slip_flag_times : list of float
        Times of the perception updates (chunks) whose slip flag was set [s since the goal].
    slip_reaction_times : list of float
        Times at which the controller commanded a slip tightening [s since the goal].
    slip_true, slip_predicted : bool
        Any true onset / any slip flag during the lift (from the start of LIFTING to the end
        of the trial), for trial-wise slip detection scores.
    lift_start_time : float
        Time LIFTING began [s since the goal] (NaN if never).
    duration : float
        Grasp duration (goal to outcome) [s of simulated time].
    simulated_seconds : float
        Simulated time including warm-up and settling [s].
    wall_seconds : float
        Wall-clock time of the trial [s].
    traces : dict of str -> ndarray or None
        Per-update traces when ``record_traces`` (see :func:`run_trial`).
    """

    object_name: str
    controller: str
    seed: int
    trial: int
    outcome: str
    object_state: str
    success: bool
    message: str
    fault_flags: int
    final_height: float
    max_true_force: float
    max_estimated_force: float
    slip_events: int
    tightening: float
    lift_height: float
    slip_onset_times: list[float] = field(default_factory=list)
    slip_onset_types: list[int] = field(default_factory=list)
    slip_flag_times: list[float] = field(default_factory=list)
    slip_reaction_times: list[float] = field(default_factory=list)
    slip_true: bool = False
    slip_predicted: bool = False
    lift_start_time: float = math.nan
    object_state_at_outcome: str = ''
    duration: float = math.nan
    simulated_seconds: float = 0.0
    wall_seconds: float = 0.0
    traces: dict | None = None

    def as_dict(self) -> dict:
        """JSON-friendly dict (without the traces)."""
        out = {k: v for k, v in self.__dict__.items() if k != 'traces'}
        return out


# ------------------------------------------------------------------------------ force model
def _source_hash() -> str:
    """Hash of the simulator and perception sources and the training settings."""
    import forte_driver.sim as sim
    import forte_perception

    digest = hashlib.sha256(repr(sorted(FORCE_TRAINING.items())).encode())
    for package in (Path(sim.__file__).parent, Path(forte_perception.__file__).parent):
        for path in sorted(package.glob('*.py')):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
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
    from forte_driver.sim import INDENTORS, SAMPLE_RATE, make_scene
    from forte_perception.force import force_features
    from forte_perception.median import RunningMedian

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
                          metadata={'source': 'forte_bringup.closed_loop simulated rig',
                                    'settings': {k: v for k, v in s.items()}})


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


# ------------------------------------------------------------------------------ the trial
def _controller(value) -> Controller:
    if isinstance(value, Controller):
        return value
    if isinstance(value, str):
        name = value.strip().upper().replace('-', '_').replace(' ', '_')
        aliases = {'W/O_SLIP': 'NO_SLIP', 'WO_SLIP': 'NO_SLIP', 'ONOFF': 'ON_OFF'}
        name = aliases.get(name, name)
        if name not in Controller.__members__:
            raise ValueError(f'unknown controller {value!r}; expected FORTE, NO_SLIP or ON_OFF')
        return Controller[name]
    return Controller(int(value))


def _state_name(value) -> str:
    """SimGroundTruth object_state constant -> name."""
    return OBJECT_STATE_NAMES.get(int(value), str(int(value)))


def run_trial(object_name: str, controller, seed: int = 0,
              params: ControllerParams | None = None, *, trial: int = 0,
              goal: GraspGoal | None = None, model=None, pipeline_config=None,
              chunk_samples: int = 20, warmup: float = 0.6, tare_duration: float = 0.5,
              settle: float = 1.0, max_duration: float = 60.0, success_height: float = 0.005,
              record_traces: bool = False, lift_check=None) -> TrialResult:
    """Run one closed-loop grasp trial of ``object_name`` with ``controller``.

    Parameters
    ----------
    object_name : str
        An object of ``forte_driver.sim.OBJECTS``.
    controller : str, int or Controller
        'FORTE', 'NO_SLIP' (the paper's W/o Slip) or 'ON_OFF'.
    seed : int
        Scene seed (placement, material spread, noise); same seed, same trial.
    params : ControllerParams, optional
        Controller configuration (default: :class:`ControllerParams` defaults).
    trial : int
        Trial index reported in the ground truth.
    goal : GraspGoal, optional
        Goal overrides (its ``controller`` is replaced by ``controller``).
    model : ForceModel, optional
        Force model; default :func:`default_force_model` (not needed by ON_OFF, but the
        pipeline still estimates force for the record when one is given or cached).
    pipeline_config : forte_perception.pipeline.PipelineConfig, optional
        Default: the paper's parameters with ``tare_duration``.
    chunk_samples : int
        Samples per perception update (20 = 10 ms).
    warmup : float
        Still, sensing period before the goal [s]; must exceed ``tare_duration``.
    tare_duration : float
        Quiet period the pipeline tares on [s].
    settle : float
        Simulated time after the outcome, commands held, so the truth can settle [s].
    max_duration : float
        Bound on the simulated grasp time [s].
    success_height : float
        Minimum true object height for success [m].
    lift_check : forte_control.lift_check.LiftCheckParams, optional
        Thresholds of the lift verification (default: its defaults; ``verify_lift=False``
        for the controller before it, which claimed LIFTED from the commanded lift alone).
    record_traces : bool
        Keep per-update traces (``TrialResult.traces``): ``time`` (k,) [s since goal],
        ``filtered`` (k, 6), ``force_estimate`` (k,) [N] (NaN if invalid), ``force_true``
        (k, 2) [N], ``psd_max_db`` (k, 6) [dB], ``finger_variance`` (k, 2) [dB^2],
        ``slip`` (k,), ``contact`` (k, 2), ``servo_command`` (k,) [rad], ``joint_position``
        (k,) [rad], ``arm_velocity`` (k,) [m/s], ``lift_command`` (k,) [m],
        ``lift_true`` (k,) [m], ``object_height`` (k,) [m], ``object_state`` (k,),
        ``state`` (k,) (GraspState).

    Returns
    -------
    TrialResult
    """
    from forte_driver.sim import SAMPLE_PERIOD, make_scene
    from forte_perception.pipeline import PerceptionPipeline, PipelineConfig

    wall_start = time.perf_counter()
    kind = _controller(controller)
    if chunk_samples < 1:
        raise ValueError(f'chunk_samples must be >= 1, got {chunk_samples}')
    if warmup <= tare_duration:
        raise ValueError(f'warmup {warmup} s must exceed tare_duration {tare_duration} s')
    if model is None:  # ON_OFF uses it too (outcome only), so all controllers see the same
        model = default_force_model()
    config = pipeline_config or PipelineConfig(tare_duration=tare_duration)
    pipeline = PerceptionPipeline(config, model)
    scene = make_scene('grasp', object_name=object_name, seed=seed, trial=trial)
    machine = GraspStateMachine(params or ControllerParams(), lift_check)
    dt = chunk_samples * SAMPLE_PERIOD

    servo = scene.initial_angle
    max_current = 0.0
    profile_velocity = 0.0
    arm_velocity = 0.0
    # -- warm-up: gripper still, pipeline tares and fills its windows
    warm_chunks = int(math.ceil(warmup / dt))
    out = None
    truth = None
    for _ in range(warm_chunks):
        frames, truth = scene.step(chunk_samples, servo, 0.0)
        out = pipeline.process(frames)
    t0 = scene.time - SAMPLE_PERIOD  # time of the last warm-up sample

    def inputs_from(out, truth, stamp):
        perception = perception_input(out, stamp)
        # what the servos report: angle and current (never the scene's ground truth)
        joint = JointInput(stamp=stamp, theta=float(truth.joint_position[-1]),
                           effort=float(np.mean(scene.joint_effort)))
        return ControlInputs(perception=perception, joint=joint)

    goal = GraspGoal(**{**(goal.__dict__ if goal is not None else {}), 'controller': kind})
    ok, reason = machine.start(goal, t0, inputs_from(out, truth, t0))
    if not ok:
        raise RuntimeError(f'the state machine refused the goal: {reason}')

    traces = {key: [] for key in (
        'time', 'filtered', 'force_estimate', 'force_true', 'psd_max_db', 'finger_variance',
        'slip', 'contact', 'servo_command', 'joint_position', 'arm_velocity', 'lift_command',
        'lift_true', 'object_height', 'object_state', 'state')} if record_traces else None
    onset_times: list[float] = []
    onset_types: list[int] = []
    flag_times: list[float] = []
    reaction_times: list[float] = []
    lift_start = math.nan
    max_true_force = 0.0
    max_estimated = -math.inf
    finished_at = math.nan
    state_at_outcome = ''
    outputs = machine.step(inputs_from(out, truth, t0), t0)
    if outputs.servo is not None:
        servo = outputs.servo.position
        max_current = outputs.servo.max_current
        profile_velocity = outputs.servo.profile_velocity
    arm_velocity = outputs.arm_velocity
    end_time = max_duration
    while True:
        frames, truth = scene.step(chunk_samples, servo, arm_velocity,
                                   max_current=max_current, profile_velocity=profile_velocity)
        out = pipeline.process(frames)
        stamp = scene.time - SAMPLE_PERIOD
        t = stamp - t0
        first_time = truth.first_index * SAMPLE_PERIOD - t0
        for index, kind_of_onset in zip(truth.slip_onset_indices, truth.slip_onset_types):
            onset_times.append(first_time + index * SAMPLE_PERIOD)
            onset_types.append(int(kind_of_onset))
        if out.slip:
            flag_times.append(t)
        max_true_force = max(max_true_force, float(truth.finger_force.max()))
        if out.force_valid and math.isfinite(out.force):
            max_estimated = max(max_estimated, float(out.force))
        if machine.state in ACTIVE_STATES:
            outputs = machine.step(inputs_from(out, truth, stamp), stamp)
            if outputs.servo is not None:
                servo = outputs.servo.position
                max_current = outputs.servo.max_current
                profile_velocity = outputs.servo.profile_velocity
            arm_velocity = outputs.arm_velocity
            if outputs.slip_reacted:
                reaction_times.append(t)
            if outputs.state == GraspState.LIFTING and math.isnan(lift_start):
                lift_start = t
            if outputs.state not in ACTIVE_STATES:
                finished_at = t
                state_at_outcome = _state_name(truth.object_state[-1])
                end_time = min(max_duration + settle, t + settle)
        if record_traces:
            traces['time'].append(t)
            traces['filtered'].append(np.asarray(out.filtered, float).copy())
            traces['force_estimate'].append(float(out.force) if out.force_valid else math.nan)
            traces['force_true'].append(truth.finger_force[-1].copy())
            traces['psd_max_db'].append(np.asarray(out.psd_max_db, float).copy())
            traces['finger_variance'].append(np.asarray(out.finger_variance, float).copy())
            traces['slip'].append(bool(out.slip))
            traces['contact'].append(np.asarray(out.contact, bool).copy())
            traces['servo_command'].append(servo)
            traces['joint_position'].append(float(truth.joint_position[-1]))
            traces['arm_velocity'].append(arm_velocity)
            traces['lift_command'].append(outputs.lift_height)
            traces['lift_true'].append(float(truth.lift_height[-1]))
            traces['object_height'].append(float(truth.object_height[-1]))
            traces['object_state'].append(int(truth.object_state[-1]))
            traces['state'].append(int(machine.state))
        if t >= end_time:
            break
        if machine.state in ACTIVE_STATES and t >= max_duration:
            outputs = machine.cancel(stamp)
            servo = outputs.servo.position if outputs.servo is not None else servo
            arm_velocity = 0.0
            finished_at = t
            state_at_outcome = _state_name(truth.object_state[-1])
            end_time = t + settle

    final = truth.latest()
    object_state = _state_name(final['object_state'])
    during_lift = (lambda times: [x for x in times if x >= lift_start]) \
        if not math.isnan(lift_start) else (lambda times: [])
    outcome = Outcome(int(outputs.outcome)).name
    success = (outcome == 'LIFTED' and object_state == 'HELD'
               and final['object_height'] >= success_height)
    if traces is not None:
        traces = {key: np.asarray(value) for key, value in traces.items()}
    return TrialResult(
        object_name=object_name, controller=kind.name, seed=int(seed), trial=int(trial),
        outcome=outcome, object_state=object_state,
        success=bool(success), message=outputs.message, fault_flags=int(outputs.fault_flags),
        final_height=float(final['object_height']), max_true_force=max_true_force,
        max_estimated_force=max_estimated if math.isfinite(max_estimated) else math.nan,
        slip_events=int(outputs.slip_events), tightening=float(outputs.tightening),
        lift_height=float(outputs.lift_height), slip_onset_times=onset_times,
        slip_onset_types=onset_types, slip_flag_times=flag_times,
        slip_reaction_times=reaction_times,
        slip_true=bool(during_lift(onset_times)), slip_predicted=bool(during_lift(flag_times)),
        lift_start_time=lift_start, object_state_at_outcome=state_at_outcome,
        duration=finished_at,
        simulated_seconds=float(scene.time), wall_seconds=time.perf_counter() - wall_start,
        traces=traces)
