"""Simulated FORTE scenes stepped in chunks of 2 kHz samples (pure Python, no rclpy).

Two rates:

- a **mechanics tick** of :data:`TICK_SAMPLES` samples (5 ms, 200 Hz): scalar Python
  state update of servo, fingers (nonlinear spring + stress relaxation in series with the
  object), lateral placement on the table, arm lift (:mod:`.mechanics`), friction with
  stick-slip, rotation, object state (:mod:`.friction`). Stick-slip releases are placed at
  the sample where the tangential load crossed the static limit inside the tick (linear
  interpolation), so their timing is resolved at 2 kHz although the state is updated at
  200 Hz. The quasi-static parts change slowly (servo at <= 0.5 rad/s moves 2.5 mrad per
  tick; arm at 5 mm/s moves 25 um).
- a **vectorised 2 kHz synthesis** per call (:mod:`.synthesis`): interpolate the tick
  states, add the step of every release, run the finger's bending resonance (2nd-order IIR
  with carried state), map deflections and shear to the 6 channel pressures, add noise,
  quantise to 11 bits.

The state lives in :mod:`.state`, the ground truth and its labels in :mod:`.truth`.

Determinism: commands are sampled at tick boundaries, noise comes in fixed blocks
(:mod:`.noise`), and every 2 kHz operation is either pointwise or a sequential IIR with
carried state, so any chunking of ``step`` calls with the same inputs returns the same data.
"""
from __future__ import annotations

import math

import numpy as np

from forte_ros.contract import CHANNEL_NAMES, SAMPLE_PERIOD, SAMPLE_RATE
from forte_sim.catalogue import INDENTORS, OBJECTS, IndentorSpec, ObjectSpec
from forte_sim.friction import FrictionModel
from forte_sim.mechanics import GripperMechanics
from forte_sim.model import (
    DEFAULT_MODEL,
    STANDARD_GRAVITY,
    GripperModel,
    contact_stiffness_scale,
    solve_finger,
)
from forte_sim.state import (
    TICK_SAMPLES,
    ArmState,
    ContactState,
    GripperState,
    ObjectState,
    draw_trial,
)
from forte_sim.synthesis import RECORD_FIELDS, SignalSynthesis, tick_record
from forte_sim.truth import SceneTruth, SlipLabels, chunk_truth

__all__ = ['SCENE_NAMES', 'SLIP_CHARACTERIZATION_OBJECTS', 'TICK_SAMPLES', 'Scene',
           'SceneTruth', 'make_scene']

#: Names of the scenes :func:`make_scene` builds.
SCENE_NAMES = ('grasp', 'slip_characterization', 'calibration', 'empty')

#: Objects of the slip characterisation scene (paper Sec. IV-B).
SLIP_CHARACTERIZATION_OBJECTS = ('apple', 'jam_jar')

_OPEN_MARGIN = 0.09         # open start angle beyond theta_zeroF (about 12 mm of gap) [rad]
_GRASP_BISECTIONS = 40      # bisection steps of stable_grasp_angle


class Scene:
    """A simulated FORTE scene: gripper, sensor, and optionally an object and an arm.

    Build scenes with :func:`make_scene`. Step them with :meth:`step`.

    Parameters
    ----------
    name : str
        Scene name (one of :data:`SCENE_NAMES`).
    seed : int
        Seed of every random draw of the scene (placement, noise).
    obj : ObjectSpec or None
        Grasped object; None for the calibration rig and the empty scene.
    indentor : IndentorSpec or None
        Load-cell indentor of the calibration rig.
    dynamics : bool
        Simulate table, lift, friction, rotation (grasp scenes). False: the rig only.
    trial : int
        Trial index reported in the ground truth.
    model : GripperModel
        Gripper and sensor parameters.
    """

    def __init__(self, name: str, seed: int, obj: ObjectSpec | None = None,
                 indentor: IndentorSpec | None = None, dynamics: bool = True,
                 trial: int = 0, model: GripperModel = DEFAULT_MODEL) -> None:
        self.name = name
        self.seed = int(seed)
        self.trial = int(trial)
        self.model = model
        self.object = obj
        self.indentor = indentor
        self.dynamics = bool(dynamics and obj is not None)
        self.channel_names = CHANNEL_NAMES
        self.sample_rate = SAMPLE_RATE
        draws, width = draw_trial(self.seed, obj, indentor, model)
        self._draws = draws
        self._width0_mm = width * 1000.0
        self.theta_zero_force = width / model.gap_per_radian
        #: Open start angle [rad] (fingers clear of the object by about 12 mm of gap).
        self.initial_angle = float(min(model.theta_max, self.theta_zero_force + _OPEN_MARGIN)) \
            if width > 0.0 else model.theta_max
        self._mechanics = GripperMechanics(model, contact_stiffness_scale(draws.contact_location),
                                           obj, draws)
        self._friction = FrictionModel(obj, draws, model) if self.dynamics else None
        self._synthesis = SignalSynthesis(model, self.seed, draws,
                                          obj.mass if obj is not None else 0.0,
                                          self.dynamics, indentor is not None)
        #: Bending-mode frequency excited by stick-slip releases [Hz].
        self.vibration_frequency = self._synthesis.vibration_frequency
        # --- mechanical state (tick rate)
        self._gripper = GripperState(
            theta=self.initial_angle, command=self.initial_angle,
            profile_velocity=model.default_profile_velocity,
            max_current=model.default_max_current,
            current=[model.friction_current, model.friction_current],
            # the fingers still recover from earlier squeezes (long relaxation branch)
            relax_slow=[draws.residual_relaxation, draws.residual_relaxation])
        self._arm = ArmState()
        self._object_state = ObjectState.at_rest(self._width0_mm, draws.lateral_offset,
                                                 obj is not None)
        self._contact = ContactState()
        self._labels = SlipLabels()
        # --- bookkeeping
        self._tick_index = 0              # ticks simulated
        self._delivered = 0               # samples returned by step()
        self._buffer: dict[str, np.ndarray] | None = None
        self._buffer_start = 0
        self._joint_position = self.initial_angle
        self._last_tick = np.array(self._tick_record())
        #: Servo commands outside [0, theta_max] clipped so far [count].
        self.clamped_commands = 0

    # ------------------------------------------------------------------ public API
    @property
    def joint_position(self) -> float:
        """Actual servo angle at the last delivered sample [rad] (0 = closed)."""
        return float(self._joint_position)

    @property
    def joint_velocity(self) -> float:
        """Servo angular velocity over the last mechanics tick [rad/s]."""
        return self._gripper.velocity

    @property
    def joint_effort(self) -> tuple[float, float]:
        """Servo currents of the left and right finger servo [A] (magnitudes)."""
        return (self._gripper.current[0], self._gripper.current[1])

    @property
    def joint_current_along_theta(self) -> tuple[float, float]:
        """Servo currents of the left and right finger along theta [A], as a servo reports
        them: the servo pushes toward its goal, so the current is negative (closing) while
        the goal is at or below the angle (closing, squeezing, holding a grip) and positive
        while it opens. ``joint_states`` effort is this x the servo torque constant."""
        sign = -1.0 if self._gripper.command <= self.joint_position else 1.0
        return (sign * self._gripper.current[0] + 0.0, sign * self._gripper.current[1] + 0.0)

    @property
    def time(self) -> float:
        """Time stamp of the next sample since the scene started [s]."""
        return self._delivered * SAMPLE_PERIOD

    @property
    def sample_index(self) -> int:
        """Index of the next sample [count] (= samples delivered so far)."""
        return self._delivered

    def stable_grasp_angle(self) -> float:
        """Servo angle theta_grasp from which a centred object is held by friction [rad].

        The largest angle at which the two fingers' static friction capacity (just after
        closing, before relaxation) carries the object's weight; NaN without an object.
        """
        obj = self.object
        if obj is None:
            return math.nan
        weight = obj.mass * STANDARD_GRAVITY
        mu = obj.mu_static * self._draws.mu_scale * obj.wrap_gain
        mechanics = self._mechanics
        low, high = 0.0, self.theta_zero_force
        for _ in range(_GRASP_BISECTIONS):
            middle = 0.5 * (low + high)
            overlap = self._width0_mm - self.model.gap_per_radian * 1000.0 * middle
            _, force, _ = solve_finger(self.model, 0.5 * overlap, 0.0, 0.0, mechanics.scale,
                                       mechanics.object_stiffness, 0.5 * overlap)
            if 2.0 * mu * force >= weight:
                low = middle
            else:
                high = middle
        return low

    @property
    def slip_test_angle(self) -> float:
        """Servo angle for a slip characterisation trial [rad] (paper Sec. IV-B).

        Drawn from the seed uniformly in [theta_grasp, theta_zeroF): less grip than needed,
        so the object slips when lifted. NaN without an object.
        """
        if self.object is None:
            return math.nan
        grasp = self.stable_grasp_angle()
        draw = float(np.random.default_rng((self.seed, 0x511B)).uniform(0.0, 1.0))
        return grasp + draw * (self.theta_zero_force - grasp)

    def step(self, n_samples: int, servo_command_rad: float, arm_velocity_z: float = 0.0,
             *, max_current: float | None = None,
             profile_velocity: float | None = None) -> tuple[np.ndarray, SceneTruth]:
        """Advance the scene by ``n_samples`` sensor samples.

        Parameters
        ----------
        n_samples : int
            Number of 2 kHz samples to produce (>= 1).
        servo_command_rad : float
            Gripper servo goal angle [rad], 0 = fully closed; clipped to [0, theta_max]
            like the servo's own position limits (counted in ``clamped_commands``).
        arm_velocity_z : float
            Commanded vertical arm velocity [m/s], positive = up.
        max_current : float, optional
            Servo current limit [A] (current-based position mode); None or 0 keeps the
            previous value (default 1.0 A).
        profile_velocity : float, optional
            Servo profile velocity [rad/s]; None or 0 keeps the previous value.

        Returns
        -------
        frames : numpy.ndarray, shape (n_samples, 6), float64
            Raw normalised sensor readings (11-bit quantised, not tared).
        truth : SceneTruth
            Ground truth of the chunk.

        Raises
        ------
        ValueError
            On a non-positive sample count or a non-finite command.
        """
        n_samples = int(n_samples)
        if n_samples < 1:
            raise ValueError(f'n_samples must be >= 1, got {n_samples}')
        self._accept_commands(servo_command_rad, arm_velocity_z, max_current, profile_velocity)
        chunk = self._take_samples(n_samples)
        first = self._delivered
        self._delivered += n_samples
        self._joint_position = float(chunk['theta'][-1])
        onsets, onset_count = self._labels.deliver(first, self._delivered)
        return chunk['frames'], chunk_truth(chunk, first, onsets, onset_count)

    # ------------------------------------------------------------------ commands, samples
    def _accept_commands(self, servo_command_rad: float, arm_velocity_z: float,
                         max_current: float | None, profile_velocity: float | None) -> None:
        """Check and store the commands of a :meth:`step` (see there)."""
        for label, value in (('servo_command_rad', servo_command_rad),
                             ('arm_velocity_z', arm_velocity_z)):
            if not math.isfinite(value):
                raise ValueError(f'{label} must be finite, got {value}')
        gripper = self._gripper
        command = float(servo_command_rad)
        if command < 0.0 or command > self.model.theta_max:
            self.clamped_commands += 1
            command = min(max(command, 0.0), self.model.theta_max)
        gripper.command = command
        self._arm.command = float(arm_velocity_z)
        if max_current is not None and max_current != 0.0:
            if not math.isfinite(max_current) or max_current < 0.0:
                raise ValueError(f'max_current must be finite and >= 0, got {max_current}')
            gripper.max_current = float(max_current)
        if profile_velocity is not None and profile_velocity != 0.0:
            if not math.isfinite(profile_velocity) or profile_velocity < 0.0:
                raise ValueError(f'profile_velocity must be finite and >= 0, '
                                 f'got {profile_velocity}')
            gripper.profile_velocity = float(profile_velocity)

    def _take_samples(self, n_samples: int) -> dict[str, np.ndarray]:
        """The next ``n_samples`` synthesised samples, simulating whole ticks as needed."""
        have = 0 if self._buffer is None else len(self._buffer['frames']) - self._buffer_start
        if have < n_samples:
            ticks = -(-(n_samples - have) // TICK_SAMPLES)
            fresh = self._simulate(ticks)
            if self._buffer is None or have == 0:
                self._buffer = fresh
            else:
                self._buffer = {key: np.concatenate((value[self._buffer_start:], fresh[key]))
                                for key, value in self._buffer.items()}
            self._buffer_start = 0
        start = self._buffer_start
        stop = start + n_samples
        self._buffer_start = stop
        return {key: value[start:stop] for key, value in self._buffer.items()}

    # ------------------------------------------------------------------ mechanics
    def _tick_record(self) -> tuple:
        return tick_record(self._gripper, self._arm, self._object_state, self._contact)

    def _simulate(self, ticks: int) -> dict[str, np.ndarray]:
        """Run ``ticks`` mechanics ticks and synthesise their samples."""
        first_sample = self._tick_index * TICK_SAMPLES
        records = np.empty((ticks + 1, len(RECORD_FIELDS)))
        records[0] = self._last_tick
        slip_types = np.empty(ticks, dtype=np.uint8)
        object_states = np.empty(ticks, dtype=np.uint8)
        contact = self._contact
        contact.events = []
        jumps_before = (contact.jumps[0], contact.jumps[1])
        for index in range(ticks):
            self._tick()
            records[index + 1] = self._tick_record()
            slip_types[index] = self._labels.slip_type
            object_states[index] = self._object_state.status
        self._last_tick = records[-1].copy()
        return self._synthesis.synthesise(first_sample, records, slip_types, object_states,
                                          contact.events, jumps_before)

    def _contact_width(self) -> float:
        """Object width at the current contact line [mm] (0 once the contact ran off)."""
        if self._friction is None:
            return self._object_state.width_mm
        return self._friction.contact_width(self._contact, self._object_state)

    def _tick(self) -> None:
        """One mechanics tick: servo and fingers, placement, failure, arm, friction."""
        mechanics = self._mechanics
        gripper, body = self._gripper, self._object_state
        tick_start = self._tick_index * TICK_SAMPLES
        self._tick_index += 1
        width_mm = self._contact_width()
        theta, fingers = mechanics.move_servo(gripper, width_mm, body.lateral)
        if self.dynamics and (fingers.forces[0] > 0.0 or fingers.forces[1] > 0.0):
            fingers = mechanics.place_laterally(gripper, body, self._contact.shear, width_mm,
                                                theta, fingers)
        mechanics.settle_fingers(gripper, theta, fingers)
        mechanics.check_failure(body, fingers.forces)
        acceleration, lift_change = mechanics.move_arm(self._arm)
        if self._friction is not None:
            self._friction.tick(self._contact, body, self._labels, gripper.force,
                                self._arm.velocity, tick_start, acceleration, lift_change)


def make_scene(scene: str, object_name: str | None = None, seed: int = 0, *,
               indentor: str | None = None, trial: int = 0,
               model: GripperModel = DEFAULT_MODEL) -> Scene:
    """Build a simulated scene.

    Parameters
    ----------
    scene : str
        ``'grasp'`` (any object of :data:`OBJECTS` on the table, arm lift),
        ``'slip_characterization'`` (``'apple'`` or ``'jam_jar'``; same physics as grasp,
        the protocol is the caller's: close to :attr:`Scene.slip_test_angle`, lift at
        1 mm/s), ``'calibration'`` (load-cell rig with an indentor of :data:`INDENTORS`,
        given as ``indentor`` or ``object_name``; no object dynamics) or ``'empty'``
        (gripper in free air).
    object_name : str, optional
        Object type (grasp scenes) or indentor name (calibration).
    seed : int
        Seed of every random draw (placement, material spread, noise).
    indentor : str, optional
        Indentor name for the calibration scene (default ``'flat_wide'``).
    trial : int
        Trial index reported in the ground truth.
    model : GripperModel
        Gripper and sensor parameters.

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        Unknown scene, object or indentor name.
    """
    if scene not in SCENE_NAMES:
        raise ValueError(f'unknown scene {scene!r}; expected one of {SCENE_NAMES}')
    if scene == 'calibration':
        name = indentor or object_name or 'flat_wide'
        if name not in INDENTORS:
            raise ValueError(f'unknown indentor {name!r}; expected one of {tuple(INDENTORS)}')
        return Scene(scene, seed, indentor=INDENTORS[name], dynamics=False, trial=trial,
                     model=model)
    if scene == 'empty':
        return Scene(scene, seed, trial=trial, model=model)
    if object_name is None:
        object_name = 'apple'
    if scene == 'slip_characterization' and object_name not in SLIP_CHARACTERIZATION_OBJECTS:
        raise ValueError(f'slip_characterization uses {SLIP_CHARACTERIZATION_OBJECTS}, '
                         f'got {object_name!r}')
    if object_name not in OBJECTS:
        raise ValueError(f'unknown object {object_name!r}; see forte_sim.OBJECTS')
    return Scene(scene, seed, obj=OBJECTS[object_name], dynamics=True, trial=trial, model=model)
