"""Offline closed loop: simulated scene + perception pipeline + grasp state machine, no ROS.

The engine of the evaluation harness, the demo plots and the closed-loop tests::

    from forte_evaluation.closed_loop import run_trial
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

The force model (needed by FORTE and NO_SLIP) is the simulated rig's, trained once and cached
(:func:`forte_evaluation.sim_force_model.default_force_model`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

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
from forte_evaluation.sim_force_model import default_force_model

__all__ = ['OBJECT_STATE_NAMES', 'TrialResult', 'run_trial']

#: SimGroundTruth object_state constant -> name.
OBJECT_STATE_NAMES = {0: 'NONE', 1: 'RESTING', 2: 'HELD', 3: 'DROPPED', 4: 'BROKEN',
                      5: 'CRUSHED'}


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
        Total tightening, on slip flags and on gross-slip evidence [rad].
    gross_slip_events : int
        Tightenings on the lift monitor's gross-slip evidence (FORTE) [count].
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
    gross_slip_times : list of float
        Times at which the controller tightened on the lift monitor's gross-slip evidence
        (the quasi-static cue) [s since the goal].
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
    gross_slip_events: int = 0
    slip_onset_times: list[float] = field(default_factory=list)
    slip_onset_types: list[int] = field(default_factory=list)
    slip_flag_times: list[float] = field(default_factory=list)
    slip_reaction_times: list[float] = field(default_factory=list)
    gross_slip_times: list[float] = field(default_factory=list)
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


# ------------------------------------------------------------------------------ the trial
#: Per-update traces kept with ``record_traces`` (see :func:`run_trial`).
TRACE_NAMES = ('time', 'filtered', 'force_estimate', 'force_true', 'psd_max_db',
               'finger_variance', 'slip', 'slipping', 'contact', 'servo_command',
               'joint_position',
               'arm_velocity', 'lift_command', 'lift_true', 'object_height', 'object_state',
               'state')


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


@dataclass
class _Commands:
    """What the scene applies to the next chunk: the state machine's latest commands."""

    servo: float
    max_current: float = 0.0
    profile_velocity: float = 0.0
    arm_velocity: float = 0.0

    def follow(self, outputs) -> None:
        """Take the servo command (when the update has one) and the arm velocity of a step."""
        if outputs.servo is not None:
            self.servo = outputs.servo.position
            self.max_current = outputs.servo.max_current
            self.profile_velocity = outputs.servo.profile_velocity
        self.arm_velocity = outputs.arm_velocity

    def stop(self, outputs) -> None:
        """After a cancel: its servo position (if any), the same limits, the arm stopped."""
        if outputs.servo is not None:
            self.servo = outputs.servo.position
        self.arm_velocity = 0.0


@dataclass
class _TrialLog:
    """What a trial saw and did, times in seconds since the goal (see :class:`TrialResult`)."""

    onset_times: list[float] = field(default_factory=list)
    onset_types: list[int] = field(default_factory=list)
    flag_times: list[float] = field(default_factory=list)
    reaction_times: list[float] = field(default_factory=list)
    gross_times: list[float] = field(default_factory=list)
    lift_start: float = math.nan
    max_true_force: float = 0.0
    max_estimated: float = -math.inf
    finished_at: float = math.nan
    state_at_outcome: str = ''
    traces: dict[str, list] | None = None

    def sense(self, out, truth, t: float, t0: float) -> None:
        """The chunk's true slip onsets, slip flag and largest true and estimated forces."""
        from forte_ros.contract import SAMPLE_PERIOD

        first_time = truth.first_index * SAMPLE_PERIOD - t0
        for index, kind_of_onset in zip(truth.slip_onset_indices, truth.slip_onset_types):
            self.onset_times.append(first_time + index * SAMPLE_PERIOD)
            self.onset_types.append(int(kind_of_onset))
        if out.slip:
            self.flag_times.append(t)
        self.max_true_force = max(self.max_true_force, float(truth.finger_force.max()))
        if out.force_valid and math.isfinite(out.force):
            self.max_estimated = max(self.max_estimated, float(out.force))

    def finish(self, t: float, truth) -> None:
        """The machine reached its outcome at ``t``: note the true object state then."""
        self.finished_at = t
        self.state_at_outcome = _state_name(truth.object_state[-1])

    def trace(self, t: float, out, truth, commands: _Commands, outputs, state: int) -> None:
        """Append one update to every trace."""
        traces = self.traces
        traces['time'].append(t)
        traces['filtered'].append(np.asarray(out.filtered, float).copy())
        traces['force_estimate'].append(float(out.force) if out.force_valid else math.nan)
        traces['force_true'].append(truth.finger_force[-1].copy())
        traces['psd_max_db'].append(np.asarray(out.psd_max_db, float).copy())
        traces['finger_variance'].append(np.asarray(out.finger_variance, float).copy())
        traces['slip'].append(bool(out.slip))
        traces['slipping'].append(bool(out.slipping))
        traces['contact'].append(np.asarray(out.contact, bool).copy())
        traces['servo_command'].append(commands.servo)
        traces['joint_position'].append(float(truth.joint_position[-1]))
        traces['arm_velocity'].append(commands.arm_velocity)
        traces['lift_command'].append(outputs.lift_height)
        traces['lift_true'].append(float(truth.lift_height[-1]))
        traces['object_height'].append(float(truth.object_height[-1]))
        traces['object_state'].append(int(truth.object_state[-1]))
        traces['state'].append(int(state))

    def during_lift(self, times: list[float]) -> list[float]:
        """The ``times`` from the start of LIFTING on (none if it never began)."""
        if math.isnan(self.lift_start):
            return []
        return [x for x in times if x >= self.lift_start]


class _ClosedLoop:
    """One trial's scene, pipeline and state machine, stepped chunk by chunk."""

    def __init__(self, scene, pipeline, machine: GraspStateMachine, chunk_samples: int,
                 record_traces: bool) -> None:
        self.scene = scene
        self.pipeline = pipeline
        self.machine = machine
        self.chunk_samples = chunk_samples
        self.commands = _Commands(servo=scene.initial_angle)
        self.log = _TrialLog(traces={key: [] for key in TRACE_NAMES} if record_traces
                             else None)
        self.t0 = math.nan

    def inputs(self, out, truth, stamp: float) -> ControlInputs:
        """The state machine's inputs: perception output and what the servos report."""
        perception = perception_input(out, stamp)
        # what the servos report: angle and current (never the scene's ground truth)
        joint = JointInput(stamp=stamp, theta=float(truth.joint_position[-1]),
                           effort=float(np.mean(self.scene.joint_effort)))
        return ControlInputs(perception=perception, joint=joint)

    def warm_up(self, seconds: float) -> tuple:
        """Gripper still for ``seconds``: the pipeline tares and fills its windows.

        Returns the last chunk's perception output and ground truth; sets :attr:`t0`, the
        time of the last warm-up sample.
        """
        from forte_ros.contract import SAMPLE_PERIOD

        chunks = int(math.ceil(seconds / (self.chunk_samples * SAMPLE_PERIOD)))
        out = truth = None
        for _ in range(chunks):
            frames, truth = self.scene.step(self.chunk_samples, self.commands.servo, 0.0)
            out = self.pipeline.process(frames)
        self.t0 = self.scene.time - SAMPLE_PERIOD
        return out, truth

    def start(self, goal: GraspGoal, out, truth):
        """Start the goal at :attr:`t0` and take the machine's first step; its outputs."""
        ok, reason = self.machine.start(goal, self.t0, self.inputs(out, truth, self.t0))
        if not ok:
            raise RuntimeError(f'the state machine refused the goal: {reason}')
        outputs = self.machine.step(self.inputs(out, truth, self.t0), self.t0)
        self.commands.follow(outputs)
        return outputs

    def run(self, outputs, max_duration: float, settle: float) -> tuple:
        """Chunks until ``settle`` s after the outcome (cancelling at ``max_duration``).

        Returns the machine's last outputs and the last chunk's ground truth.
        """
        from forte_ros.contract import SAMPLE_PERIOD

        machine, commands, log = self.machine, self.commands, self.log
        end_time = max_duration
        while True:
            frames, truth = self.scene.step(
                self.chunk_samples, commands.servo, commands.arm_velocity,
                max_current=commands.max_current, profile_velocity=commands.profile_velocity)
            out = self.pipeline.process(frames)
            stamp = self.scene.time - SAMPLE_PERIOD
            t = stamp - self.t0
            log.sense(out, truth, t, self.t0)
            if machine.state in ACTIVE_STATES:
                outputs = self._step_machine(out, truth, stamp, t)
                if outputs.state not in ACTIVE_STATES:
                    end_time = min(max_duration + settle, t + settle)
            if log.traces is not None:
                log.trace(t, out, truth, commands, outputs, machine.state)
            if t >= end_time:
                return outputs, truth
            if machine.state in ACTIVE_STATES and t >= max_duration:
                outputs = machine.cancel(stamp)
                commands.stop(outputs)
                log.finish(t, truth)
                end_time = t + settle

    def _step_machine(self, out, truth, stamp: float, t: float):
        """One state machine update on the chunk; its commands apply to the next chunk."""
        outputs = self.machine.step(self.inputs(out, truth, stamp), stamp)
        previous = self.commands.servo
        self.commands.follow(outputs)
        if outputs.servo_changed:  # applies from the next chunk (the sequential mode's gate)
            speed = self.commands.profile_velocity
            self.pipeline.servo_moved(
                motion=abs(self.commands.servo - previous) / speed if speed > 0 else None)
        if outputs.slip_reacted:
            self.log.reaction_times.append(t)
        if outputs.gross_slip_events > len(self.log.gross_times):  # one more this grasp
            self.log.gross_times.append(t)
        if outputs.state == GraspState.LIFTING and math.isnan(self.log.lift_start):
            self.log.lift_start = t
        if outputs.state not in ACTIVE_STATES:
            self.log.finish(t, truth)
        return outputs


def _trial_result(loop: _ClosedLoop, outputs, truth, identity: dict,
                  success_height: float, wall_start: float) -> TrialResult:
    """The :class:`TrialResult` of a finished loop (``identity``: name, controller, seeds)."""
    log = loop.log
    final = truth.latest()
    object_state = _state_name(final['object_state'])
    outcome = Outcome(int(outputs.outcome)).name
    success = (outcome == 'LIFTED' and object_state == 'HELD'
               and final['object_height'] >= success_height)
    traces = log.traces
    if traces is not None:
        traces = {key: np.asarray(value) for key, value in traces.items()}
    return TrialResult(
        **identity, outcome=outcome, object_state=object_state,
        success=bool(success), message=outputs.message, fault_flags=int(outputs.fault_flags),
        final_height=float(final['object_height']), max_true_force=log.max_true_force,
        max_estimated_force=(log.max_estimated if math.isfinite(log.max_estimated)
                             else math.nan),
        slip_events=int(outputs.slip_events), tightening=float(outputs.tightening),
        gross_slip_events=int(outputs.gross_slip_events),
        lift_height=float(outputs.lift_height), slip_onset_times=log.onset_times,
        slip_onset_types=log.onset_types, slip_flag_times=log.flag_times,
        slip_reaction_times=log.reaction_times, gross_slip_times=log.gross_times,
        slip_true=bool(log.during_lift(log.onset_times)),
        slip_predicted=bool(log.during_lift(log.flag_times)),
        lift_start_time=log.lift_start, object_state_at_outcome=log.state_at_outcome,
        duration=log.finished_at,
        simulated_seconds=float(loop.scene.time),
        wall_seconds=time.perf_counter() - wall_start,
        traces=traces)


def _pipeline(config, tare_duration: float, slip_mode: str | None, model):
    """The trial's perception pipeline: ``config``, or the paper's parameters with
    ``tare_duration`` [s] and ``slip_mode`` (default: the node's, RECOMMENDED_MODE)."""
    from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
    from forte_perception.slip.params import RECOMMENDED_MODE, SlipParams

    if config is None:
        config = PipelineConfig(tare_duration=tare_duration,
                                slip=SlipParams(mode=slip_mode or RECOMMENDED_MODE))
    return PerceptionPipeline(config, model)


def controller_params_for(slip_mode: str | None) -> ControllerParams:
    """The controller a slip mode is measured with: for the paper's detector the paper's
    loading (to the force target, ``min_finger_share=0``) and reaction (one tightening per
    slip event, ``slip_reaction='events'``), so ``slip_mode`` paper is the paper's method end
    to end; FORTE's (the defaults) otherwise."""
    if slip_mode == 'paper':
        return ControllerParams(slip_reaction='events', min_finger_share=0.0)
    return ControllerParams()


def run_trial(object_name: str, controller, seed: int = 0,
              params: ControllerParams | None = None, *, trial: int = 0,
              goal: GraspGoal | None = None, model=None, pipeline_config=None,
              chunk_samples: int = 20, warmup: float = 0.6, tare_duration: float = 0.5,
              settle: float = 1.0, max_duration: float = 60.0, success_height: float = 0.005,
              record_traces: bool = False, lift_check=None, slip_mode: str | None = None
              ) -> TrialResult:
    """Run one closed-loop grasp trial of ``object_name`` with ``controller``.

    Parameters
    ----------
    object_name : str
        An object of ``forte_sim.OBJECTS``.
    controller : str, int or Controller
        'FORTE', 'NO_SLIP' (the paper's W/o Slip) or 'ON_OFF'.
    seed : int
        Scene seed (placement, material spread, noise); same seed, same trial.
    params : ControllerParams, optional
        Controller configuration (default: :func:`controller_params_for` ``slip_mode``).
    trial : int
        Trial index reported in the ground truth.
    goal : GraspGoal, optional
        Goal overrides (its ``controller`` is replaced by ``controller``).
    model : ForceModel, optional
        Force model; default :func:`default_force_model` (not needed by ON_OFF, but the
        pipeline still estimates force for the record when one is given or cached).
    pipeline_config : forte_perception.pipeline.PipelineConfig, optional
        Default: the paper's, ``tare_duration``, ``slip_mode``.
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
    lift_check : forte_control.state_machine.lift_check.LiftCheckParams, optional
        Thresholds of the lift verification (default: its defaults; ``verify_lift=False``
        for the controller before it, which claimed LIFTED from the commanded lift alone).
    slip_mode : str, optional
        Slip detector mode of the default pipeline configuration (default: the node's,
        ``forte_perception.slip.params.RECOMMENDED_MODE``).
    record_traces : bool
        Keep per-update traces (``TrialResult.traces``): ``time`` (k,) [s since goal],
        ``filtered`` (k, 6), ``force_estimate`` (k,) [N] (NaN if invalid), ``force_true``
        (k, 2) [N], ``psd_max_db`` (k, 6) [dB], ``finger_variance`` (k, 2) [dB^2],
        ``slip`` (k,), ``slipping`` (k,), ``contact`` (k, 2), ``servo_command`` (k,) [rad],
        ``joint_position`` (k,) [rad], ``arm_velocity`` (k,) [m/s], ``lift_command`` (k,)
        [m], ``lift_true`` (k,) [m], ``object_height`` (k,) [m], ``object_state`` (k,),
        ``state`` (k,) (GraspState).

    Returns
    -------
    TrialResult
    """
    from forte_sim import make_scene

    wall_start = time.perf_counter()
    kind = _controller(controller)
    if chunk_samples < 1:
        raise ValueError(f'chunk_samples must be >= 1, got {chunk_samples}')
    if warmup <= tare_duration:
        raise ValueError(f'warmup {warmup} s must exceed tare_duration {tare_duration} s')
    if model is None:  # ON_OFF uses it too (outcome only), so all controllers see the same
        model = default_force_model()
    pipeline = _pipeline(pipeline_config, tare_duration, slip_mode, model)
    scene = make_scene('grasp', object_name=object_name, seed=seed, trial=trial)
    machine = GraspStateMachine(params or controller_params_for(slip_mode), lift_check)
    loop = _ClosedLoop(scene, pipeline, machine, chunk_samples, record_traces)
    out, truth = loop.warm_up(warmup)
    goal = GraspGoal(**{**(goal.__dict__ if goal is not None else {}), 'controller': kind})
    outputs = loop.start(goal, out, truth)
    outputs, truth = loop.run(outputs, max_duration, settle)
    identity = {'object_name': object_name, 'controller': kind.name, 'seed': int(seed),
                'trial': int(trial)}
    return _trial_result(loop, outputs, truth, identity, success_height, wall_start)
