"""Simulated FORTE scenes stepped in chunks of 2 kHz samples (pure Python, no rclpy).

Two rates:

- a **mechanics tick** of :data:`TICK_SAMPLES` samples (5 ms, 200 Hz): scalar Python
  state update of servo, fingers (nonlinear spring + stress relaxation in series with the
  object), lateral placement on the table, arm lift, friction with stick-slip, rotation,
  object state. Stick-slip releases are placed at the sample where the tangential load
  crossed the static limit inside the tick (linear interpolation), so their timing is
  resolved at 2 kHz although the state is updated at 200 Hz. The quasi-static parts change
  slowly (servo at <= 0.5 rad/s moves 2.5 mrad per tick; arm at 5 mm/s moves 25 um).
- a **vectorised 2 kHz synthesis** per call: interpolate the tick states, add the step of
  every release, run the finger's bending resonance (2nd-order IIR with carried state),
  map deflections and shear to the 6 channel pressures, add noise, quantise to 11 bits.

Determinism: commands are sampled at tick boundaries, noise comes in fixed blocks
(:mod:`.noise`), and every 2 kHz operation is either pointwise or a sequential IIR with
carried state, so any chunking of ``step`` calls with the same inputs returns the same data.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from .catalogue import INDENTORS, OBJECTS, IndentorSpec, ObjectSpec
from .model import (
    CHANNEL_NAMES,
    DEFAULT_MODEL,
    SAMPLE_PERIOD,
    SAMPLE_RATE,
    STANDARD_GRAVITY,
    GripperModel,
    channel_gains,
    contact_stiffness_scale,
    finger_force_elastic,
    pressure_response,
    quantise,
    resonator_coefficients,
    solve_finger,
)
from .noise import SensorNoise

try:  # the compiled core of scipy.signal.lfilter, without its per-call argument handling
    from scipy.signal._sigtools import _linear_filter as _compiled_linear_filter
except ImportError:  # pragma: no cover - other scipy layouts: the public function
    _compiled_linear_filter = None


def _iir(b: np.ndarray, a: np.ndarray, x: np.ndarray,
         state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """scipy.signal.lfilter along axis 0 with initial state (same arithmetic, less overhead)."""
    if _compiled_linear_filter is not None:
        return _compiled_linear_filter(b, a, x, 0, state)
    return lfilter(b, a, x, axis=0, zi=state)

#: Samples per mechanics tick (5 ms at 2 kHz).
TICK_SAMPLES = 10
TICK = TICK_SAMPLES * SAMPLE_PERIOD

_TICK_INDEX = np.arange(1 << 16) // TICK_SAMPLES
_TICK_FRACTION = (np.arange(1 << 16) % TICK_SAMPLES) / TICK_SAMPLES

# slip_type constants (same values as forte_msgs/SimGroundTruth)
SLIP_NONE = 0
SLIP_INCIPIENT = 1
SLIP_GROSS = 2
SLIP_STICK_SLIP = 3
SLIP_ROTATIONAL = 4

# object_state constants (same values as forte_msgs/SimGroundTruth)
OBJECT_NONE = 0
OBJECT_RESTING = 1
OBJECT_HELD = 2
OBJECT_DROPPED = 3
OBJECT_BROKEN = 4
OBJECT_CRUSHED = 5

#: Names of the scenes :func:`make_scene` builds.
SCENE_NAMES = ('grasp', 'slip_characterization', 'calibration', 'empty')

#: Objects of the slip characterisation scene (paper Sec. IV-B).
SLIP_CHARACTERIZATION_OBJECTS = ('apple', 'jam_jar')

_HELD_HEIGHT = 0.002        # object counts as held above this height [m]
_QUIET_BEFORE_ONSET = 0.1   # slip-free time before a new slip episode is labelled [s]
_STICK_SLIP_MIN = 0.03      # mu_static - mu_kinetic below this slides smoothly [-]
_ROTATION_TIME = 0.15       # time constant of rotational slip [s]
_SETTLED_OFFSET = 0.003     # rotation within this of its equilibrium has stopped [rad]
_GRIP_MARGIN = 0.003        # slide distance margin before the contact runs off [m]
_TEXTURE_SPACING = 0.0005   # correlation length of the surface friction variation [m]
_TEXTURE_POINTS = 400       # covers 0.2 m of sliding
_TEXTURE_VARIATION = 0.4    # relative spread of the static friction excess [-]
_AGING_TIME = 0.15          # static friction recovery time of a stuck contact [s]
_MIN_RELEASE = 0.004        # static minus kinetic capacity below which slip is smooth [N]
_SEATING_SPREAD = 0.08      # indentor height jitter on the finger, +- [-]
_CENTRING_SPREAD = 1.5      # indentor centring jitter, +- [mm]
_RIG_TEMPERATURE_SPREAD = 0.5   # indentor minus finger temperature, std [K]
_RESIDUAL_RELAXATION = 1.0  # relaxation left from earlier grasps, up to [N]
_LATERAL_STEP = 0.025       # largest sideways slide of the object per tick (5 mm/s) [mm]
_LATERAL_TOLERANCE = 1e-4   # force imbalance ignored by the lateral placement [N]
_STICK_SLIP_HOLD = 0.1      # a release labels stick-slip for this long [s]
_RELEASE_COUPLING = 0.5     # share of a release step felt by the other finger [-]


@dataclass
class SceneTruth:
    """Ground truth of one chunk (evaluation only; control code must never read it).

    Per-sample arrays have one row per frame of the chunk.

    Attributes
    ----------
    first_index : int
        Sample index (since the scene started) of the first frame of the chunk.
    finger_force : numpy.ndarray, shape (n, 2)
        True normal force of the left and right finger [N].
    load_cell_force : numpy.ndarray, shape (n,)
        Load cell reading [N] (calibration rig); NaN in scenes without a load cell.
    joint_position : numpy.ndarray, shape (n,)
        Actual servo angle [rad].
    lift_height : numpy.ndarray, shape (n,)
        Gripper height above the start pose [m].
    object_height : numpy.ndarray, shape (n,)
        Object height above the table [m].
    object_slip : numpy.ndarray, shape (n,)
        Object displacement downward relative to the fingers [m].
    object_rotation : numpy.ndarray, shape (n,)
        Object rotation relative to the fingers about the grasp axis [rad].
    slip_type : numpy.ndarray, shape (n,), uint8
        SLIP_* constant at each sample.
    object_state : numpy.ndarray, shape (n,), uint8
        OBJECT_* constant at each sample.
    slip_onset_indices : numpy.ndarray, shape (k,), int64
        Row indices within this chunk where a slip episode started.
    slip_onset_types : numpy.ndarray, shape (k,), uint8
        SLIP_* type of each of those onsets.
    slip_onsets : int
        Slip onsets since the scene started, including this chunk [count].
    """

    first_index: int
    finger_force: np.ndarray
    load_cell_force: np.ndarray
    joint_position: np.ndarray
    lift_height: np.ndarray
    object_height: np.ndarray
    object_slip: np.ndarray
    object_rotation: np.ndarray
    slip_type: np.ndarray
    object_state: np.ndarray
    slip_onset_indices: np.ndarray
    slip_onset_types: np.ndarray
    slip_onsets: int

    def latest(self) -> dict:
        """Values at the last sample of the chunk (the fields of SimGroundTruth).

        Returns
        -------
        dict
            finger_force (tuple of 2 floats), load_cell_force, slip_type, slip_onsets,
            object_state, lift_height, object_height, object_slip, object_rotation,
            joint_position.
        """
        return {
            'finger_force': (float(self.finger_force[-1, 0]), float(self.finger_force[-1, 1])),
            'load_cell_force': float(self.load_cell_force[-1]),
            'slip_type': int(self.slip_type[-1]),
            'slip_onsets': int(self.slip_onsets),
            'object_state': int(self.object_state[-1]),
            'lift_height': float(self.lift_height[-1]),
            'object_height': float(self.object_height[-1]),
            'object_slip': float(self.object_slip[-1]),
            'object_rotation': float(self.object_rotation[-1]),
            'joint_position': float(self.joint_position[-1]),
        }


@dataclass
class _Trial:
    """Per-trial draws from the seed (placement, material spread)."""

    lateral_offset: float     # [mm]
    contact_location: float   # [-]
    contact_spread: float     # [-]
    mu_scale: float           # [-]
    com_offset: float         # [m]
    temperature: float        # object minus finger temperature [K]
    break_scale: float        # [-]
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(6))


# per-tick records kept for the 2 kHz synthesis
_RECORD_FIELDS = ('theta', 'deflection_left', 'deflection_right', 'force_left', 'force_right',
                  'shear_left', 'shear_right', 'temperature_left', 'temperature_right',
                  'lift', 'height', 'slip', 'rotation')


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
        rng = np.random.default_rng((self.seed, 0x7121A1))
        if obj is not None:
            location = float(np.clip(obj.contact_location + rng.uniform(-0.05, 0.05), 0.0, 1.0))
            draws = _Trial(
                lateral_offset=float(rng.uniform(-2.0, 2.0)),
                contact_location=location,
                contact_spread=0.15,
                mu_scale=float(rng.uniform(0.92, 1.08)),
                com_offset=float(rng.uniform(0.0, 1.0) * obj.com_offset),
                temperature=float(rng.normal(0.0, 0.3)),
                break_scale=float(rng.uniform(0.9, 1.1)),
            )
            width = obj.width
        elif indentor is not None:
            # the indentor is seated by hand: its height on the fingers and its centring
            # vary from trial to trial, and it may be warmer or colder than the fingers
            location = indentor.contact_location + rng.uniform(-_SEATING_SPREAD,
                                                               _SEATING_SPREAD)
            draws = _Trial(lateral_offset=float(rng.uniform(-_CENTRING_SPREAD,
                                                            _CENTRING_SPREAD)),
                           contact_location=float(np.clip(location, 0.0, 1.0)),
                           contact_spread=indentor.contact_spread, mu_scale=1.0,
                           com_offset=0.0,
                           temperature=float(rng.normal(0.0, _RIG_TEMPERATURE_SPREAD)),
                           break_scale=1.0)
            width = indentor.width
        else:
            draws = _Trial(0.0, 0.4, 0.15, 1.0, 0.0, 0.0, 1.0)
            width = 0.0
        draws.offsets = rng.uniform(-model.offset_range, model.offset_range, 6)
        self._texture = [float(value) for value in np.clip(
            1.0 + _TEXTURE_VARIATION * rng.standard_normal(_TEXTURE_POINTS), 0.2, 2.0)]
        self._draws = draws
        self._width0_mm = width * 1000.0
        self._width_mm = self._width0_mm
        self.theta_zero_force = width / model.gap_per_radian
        #: Open start angle [rad] (fingers clear of the object by about 12 mm of gap).
        self.initial_angle = float(min(model.theta_max, self.theta_zero_force + 0.09)) \
            if width > 0.0 else model.theta_max
        self._scale = contact_stiffness_scale(draws.contact_location)
        self._object_stiffness = obj.stiffness if obj is not None else None
        gains = [channel_gains(model, draws.contact_location, draws.contact_spread, finger)
                 for finger in (0, 1)]
        self._normal_gain = np.concatenate(gains)                      # (6,)
        self._shear_gain = np.array(model.shear_gain * 2)              # (6,)
        self._vibration_gain = np.array(model.vibration_gain * 2)      # (6,)
        self._temperature_gain = model.temperature_gain * np.array((1.0, 0.6, 0.3) * 2)
        self._noise = SensorNoise(model, self.seed)
        mass = obj.mass if obj is not None else 0.0
        #: Bending-mode frequency excited by stick-slip releases [Hz].
        self.vibration_frequency = model.bending_frequency / math.sqrt(
            1.0 + mass / model.bending_mass)
        self._resonator_b, self._resonator_a = resonator_coefficients(
            self.vibration_frequency, model.vibration_damping)
        self._resonator_state = np.zeros((2, 2))      # (filter order, finger)
        # --- mechanical state (tick rate)
        self._theta = self.initial_angle
        self._command = self.initial_angle
        self._arm_command = 0.0
        self._profile_velocity = model.default_profile_velocity
        self._max_current = model.default_max_current
        self._arm_velocity = 0.0
        self._lift = 0.0
        self._height = 0.0
        self._object_velocity = 0.0
        self._lateral = draws.lateral_offset          # object offset toward right [mm]
        self._deflection = [0.0, 0.0]                 # [mm]
        self._force = [0.0, 0.0]                      # [N]
        self._local_stiffness = [0.0, 0.0]            # [N/mm]
        self._relax1 = [0.0, 0.0]
        # the fingers still recover from earlier squeezes (long relaxation branch)
        residual = float(rng.uniform(0.0, _RESIDUAL_RELAXATION))
        self._relax2 = [residual, residual]
        self._slide = [0.0, 0.0]                      # finger travel up the object [m]
        self._shear = [0.0, 0.0]                      # tangential force on the object [N]
        self._jumps = [0.0, 0.0]                      # cumulative release steps [N]
        self._sliding = [False, False]
        self._stuck_since = [0, 0]                    # sample the contact last stuck
        self._rotation = 0.0
        self._rotating = False
        self._temperature = [0.0, 0.0]
        self._lifted = False
        self._falling = False
        self._max_height = 0.0
        self._contact_lost = False
        self._had_contact = False
        self._object_state = OBJECT_RESTING if obj is not None else OBJECT_NONE
        self._slip_type = SLIP_NONE
        self._last_slip_sample = -10 ** 9
        self._current = [model.friction_current, model.friction_current]
        self._velocity = 0.0
        # --- bookkeeping
        self._tick_index = 0              # ticks simulated
        self._delivered = 0               # samples returned by step()
        self._buffer: dict[str, np.ndarray] | None = None
        self._buffer_start = 0
        self._events: list[tuple[int, int, float]] = []   # (sample, finger, jumps after)
        self._onsets: list[tuple[int, int]] = []          # (sample, slip type)
        self._onset_count_delivered = 0
        self._last_record = self._record_values()
        self._last_tick = np.array(self._record_values())
        self._last_release = -10 ** 9
        self.clamped_commands = 0
        self._relax_decay = tuple(1.0 - math.exp(-TICK / tau) for tau in model.relaxation_times)
        self._temperature_decay = 1.0 - math.exp(-TICK / model.temperature_time)
        self._rotation_decay = 1.0 - math.exp(-TICK / _ROTATION_TIME)
        if obj is not None:
            self._mu_static = obj.mu_static * draws.mu_scale * obj.wrap_gain
            self._mu_kinetic = obj.mu_kinetic * draws.mu_scale * obj.wrap_gain
            self._stick_slip = (obj.mu_static - obj.mu_kinetic) >= _STICK_SLIP_MIN
            self._break_force = (obj.break_force * draws.break_scale
                                 if obj.break_force is not None else math.inf)
            self._grip_length = max(obj.height / 2.0 - _GRIP_MARGIN, 0.002)
        else:
            self._mu_static = self._mu_kinetic = 0.0
            self._stick_slip = False
            self._break_force = math.inf
            self._grip_length = math.inf

    # ------------------------------------------------------------------ public API
    @property
    def joint_position(self) -> float:
        """Actual servo angle at the last delivered sample [rad] (0 = closed)."""
        return float(self._last_record[0])

    @property
    def joint_velocity(self) -> float:
        """Servo angular velocity over the last mechanics tick [rad/s]."""
        return self._velocity

    @property
    def joint_effort(self) -> tuple[float, float]:
        """Servo currents of the left and right finger servo [A]."""
        return (self._current[0], self._current[1])

    @property
    def time(self) -> float:
        """Time stamp of the next sample since the scene started [s]."""
        return self._delivered * SAMPLE_PERIOD

    @property
    def sample_index(self) -> int:
        """Index of the next sample [count] (= samples delivered so far)."""
        return self._delivered

    @property
    def has_load_cell(self) -> bool:
        """True for the calibration rig."""
        return self.indentor is not None

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
        low, high = 0.0, self.theta_zero_force
        for _ in range(40):
            middle = 0.5 * (low + high)
            overlap = self._width0_mm - self.model.gap_per_radian * 1000.0 * middle
            _, force, _ = solve_finger(self.model, 0.5 * overlap, 0.0, 0.0, self._scale,
                                       self._object_stiffness, 0.5 * overlap)
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

    @property
    def sensor_offsets(self) -> np.ndarray:
        """Zero offsets of the 6 transducers in this scene (untared readings) [normalised]."""
        return self._draws.offsets.copy()

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
        for label, value in (('servo_command_rad', servo_command_rad),
                             ('arm_velocity_z', arm_velocity_z)):
            if not math.isfinite(value):
                raise ValueError(f'{label} must be finite, got {value}')
        command = float(servo_command_rad)
        if command < 0.0 or command > self.model.theta_max:
            self.clamped_commands += 1
            command = min(max(command, 0.0), self.model.theta_max)
        self._command = command
        self._arm_command = float(arm_velocity_z)
        if max_current is not None and max_current != 0.0:
            if not math.isfinite(max_current) or max_current < 0.0:
                raise ValueError(f'max_current must be finite and >= 0, got {max_current}')
            self._max_current = float(max_current)
        if profile_velocity is not None and profile_velocity != 0.0:
            if not math.isfinite(profile_velocity) or profile_velocity < 0.0:
                raise ValueError(f'profile_velocity must be finite and >= 0, '
                                 f'got {profile_velocity}')
            self._profile_velocity = float(profile_velocity)
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
        chunk = {key: value[start:stop] for key, value in self._buffer.items()}
        self._buffer_start = stop
        first = self._delivered
        self._delivered += n_samples
        onsets = [(sample - first, kind) for sample, kind in self._onsets
                  if first <= sample < self._delivered]
        self._onset_count_delivered += len(onsets)
        self._last_record = (float(chunk['theta'][-1]),)
        truth = SceneTruth(
            first_index=first,
            finger_force=chunk['finger_force'],
            load_cell_force=chunk['load_cell'],
            joint_position=chunk['theta'],
            lift_height=chunk['lift'],
            object_height=chunk['height'],
            object_slip=chunk['slip'],
            object_rotation=chunk['rotation'],
            slip_type=chunk['slip_type'],
            object_state=chunk['object_state'],
            slip_onset_indices=np.array([index for index, _ in onsets], dtype=np.int64),
            slip_onset_types=np.array([kind for _, kind in onsets], dtype=np.uint8),
            slip_onsets=self._onset_count_delivered,
        )
        self._onsets = [item for item in self._onsets if item[0] >= self._delivered]
        return chunk['frames'], truth

    # ------------------------------------------------------------------ mechanics
    def _record_values(self) -> tuple:
        return (self._theta, self._deflection[0], self._deflection[1], self._force[0],
                self._force[1], self._shear[0] - self._jumps[0], self._shear[1] - self._jumps[1],
                self._temperature[0], self._temperature[1], self._lift, self._height,
                0.5 * (self._slide[0] + self._slide[1]), self._rotation)

    def _contact_width(self) -> float:
        """Object width at the current contact line [mm] (0 once the contact ran off)."""
        if self._contact_lost:
            return 0.0
        obj = self.object
        if obj is None or not self.dynamics:
            return self._width_mm
        slide = 0.5 * (self._slide[0] + self._slide[1])
        if slide > self._grip_length:
            return 0.0
        if obj.shape == 'round':
            ratio = slide / (obj.height / 2.0)
            return self._width_mm * math.sqrt(max(0.0, 1.0 - ratio * ratio))
        return self._width_mm

    def _solve_fingers(self, theta: float, lateral: float) -> tuple[list, list, list]:
        model = self.model
        overlap = self._contact_width() - model.gap_per_radian * 1000.0 * theta
        deflections, forces, stiffness = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
        for finger, sign in ((0, -1.0), (1, 1.0)):
            penetration = 0.5 * overlap + sign * lateral
            d, f, k = solve_finger(model, penetration, self._relax1[finger],
                                   self._relax2[finger], self._scale, self._object_stiffness,
                                   self._deflection[finger])
            deflections[finger], forces[finger], stiffness[finger] = d, f, k
        return deflections, forces, stiffness

    def _simulate(self, ticks: int) -> dict[str, np.ndarray]:
        first_sample = self._tick_index * TICK_SAMPLES
        records = np.empty((ticks + 1, len(_RECORD_FIELDS)))
        records[0] = self._last_tick
        slip_types = np.empty(ticks, dtype=np.uint8)
        object_states = np.empty(ticks, dtype=np.uint8)
        self._events = []
        jumps_before = (self._jumps[0], self._jumps[1])
        for index in range(ticks):
            self._tick()
            records[index + 1] = self._record_values()
            slip_types[index] = self._slip_type
            object_states[index] = self._object_state
        self._last_tick = records[-1].copy()
        return self._synthesise(first_sample, ticks, records, slip_types, object_states,
                                self._events, jumps_before)

    def _tick(self) -> None:
        model = self.model
        tick_start = self._tick_index * TICK_SAMPLES
        self._tick_index += 1
        # --- servo: profile velocity toward the goal, current-limited stall
        theta_old = self._theta
        limit = self._profile_velocity * TICK
        theta = theta_old + min(max(self._command - theta_old, -limit), limit)
        lateral = self._lateral
        deflections, forces, stiffness = self._solve_fingers(theta, lateral)
        torque_limit = model.torque_constant * max(self._max_current - model.friction_current,
                                                   0.0)
        force_limit = torque_limit / model.lever_arm
        if theta < theta_old and max(forces) > force_limit:
            low, high = theta, theta_old
            for _ in range(12):
                middle = 0.5 * (low + high)
                _, trial_forces, _ = self._solve_fingers(middle, lateral)
                if max(trial_forces) > force_limit:
                    low = middle
                else:
                    high = middle
            theta = high
            deflections, forces, stiffness = self._solve_fingers(theta, lateral)
        # --- lateral placement: table friction holds the object until the imbalance wins
        if self.dynamics and (forces[0] > 0.0 or forces[1] > 0.0):
            obj = self.object
            if self._lifted or self._falling:
                resist = 0.0
            else:
                resist = model.table_friction * max(
                    obj.mass * STANDARD_GRAVITY - self._shear[0] - self._shear[1], 0.0)
            imbalance = forces[0] - forces[1]
            if abs(imbalance) > resist + _LATERAL_TOLERANCE:
                target = imbalance - math.copysign(resist, imbalance)
                total = stiffness[0] + stiffness[1]
                if total > 0.0:
                    # the object slides sideways at a finite speed, not in one jump
                    shift = target / total
                    lateral += min(max(shift, -_LATERAL_STEP), _LATERAL_STEP)
                    self._lateral = lateral
                    deflections, forces, stiffness = self._solve_fingers(theta, lateral)
        self._velocity = (theta - theta_old) / TICK
        self._theta = theta
        self._deflection = deflections
        self._force = forces
        self._local_stiffness = stiffness
        for finger in (0, 1):
            current = (model.friction_current
                       + forces[finger] * model.lever_arm / model.torque_constant)
            self._current[finger] = min(current, self._max_current)
            elastic = finger_force_elastic(model, deflections[finger], self._scale)
            self._relax1[finger] += (elastic - self._relax1[finger]) * self._relax_decay[0]
            self._relax2[finger] += (elastic - self._relax2[finger]) * self._relax_decay[1]
            contact = 1.0 if forces[finger] > 0.0 else 0.0
            self._temperature[finger] += ((contact * self._draws.temperature
                                           - self._temperature[finger])
                                          * self._temperature_decay)
        # --- object failure
        if self.object is not None and self._object_state not in (OBJECT_BROKEN,
                                                                   OBJECT_CRUSHED):
            if max(forces) > self._break_force:
                if self.object.failure == 'crushed':
                    self._object_state = OBJECT_CRUSHED
                    compression = max(forces) / (self._object_stiffness or math.inf)
                    self._width_mm -= 0.5 * compression
                else:
                    self._object_state = OBJECT_BROKEN
                    self._width_mm *= 0.85
        # --- arm
        change = self._arm_command - self._arm_velocity
        limit = model.arm_acceleration * TICK
        change = min(max(change, -limit), limit)
        self._arm_velocity += change
        acceleration = change / TICK
        lift_before = self._lift
        self._lift += self._arm_velocity * TICK
        if self._lift < 0.0:
            self._lift = 0.0
            self._arm_velocity = max(self._arm_velocity, 0.0)
        if self.dynamics:
            self._friction(tick_start, acceleration, self._lift - lift_before)

    def _friction(self, tick_start: int, acceleration: float, lift_change: float) -> None:
        """Tangential contact mechanics of one tick: stick, stick-slip, sliding, falling.

        Each finger's shear on the object changes by its tangential stiffness times the
        finger's motion relative to the object; it is limited by static friction while
        stuck (aging contact) and equals kinetic friction while sliding.
        """
        model = self.model
        obj = self.object
        forces = self._force
        now = tick_start + TICK_SAMPLES
        rotation_factor = 1.0 - 0.5 * math.sin(min(abs(self._rotation), math.pi / 2.0))
        stiffness = [model.tangential_stiffness + model.tangential_stiffening * force
                     for force in forces]
        kinetic = [self._mu_kinetic * force * rotation_factor for force in forces]
        static = []
        for finger in (0, 1):
            # static friction grows back with the age of the stuck contact (aging)
            age = (now - self._stuck_since[finger]) * SAMPLE_PERIOD
            excess = ((self._mu_static - self._mu_kinetic)
                      * self._texture_at(self._slide[finger])
                      * (1.0 - math.exp(-age / _AGING_TIME)))
            static.append((self._mu_kinetic + excess) * forces[finger] * rotation_factor)
        ejection = math.sin(obj.taper_angle) * (forces[0] + forces[1])
        weight = obj.mass * STANDARD_GRAVITY
        previous = list(self._shear)
        released = False
        in_contact = forces[0] > 0.0 or forces[1] > 0.0
        for finger in (0, 1):
            if forces[finger] <= 0.0:
                # no contact: the finger moves freely along the object
                self._shear[finger] = 0.0
                self._sliding[finger] = False
                self._stuck_since[finger] = now
        if not in_contact and (self._lifted or self._falling):
            self._falling = True
            self._lifted = False
        if self._falling:
            support = kinetic[0] + kinetic[1] - ejection
            if in_contact and support >= weight:
                self._falling = False
                self._lifted = True
                self._sliding = [True, True]
            else:
                height_before = self._height
                self._object_velocity += (support / obj.mass - STANDARD_GRAVITY) * TICK
                self._height += self._object_velocity * TICK
                relative = lift_change - (self._height - height_before)
                for finger in (0, 1):
                    self._slide[finger] += relative
                    if forces[finger] > 0.0:
                        self._sliding[finger] = True
                        self._shear[finger] = kinetic[finger]
                if self._height <= 0.0:
                    self._height = 0.0
                    self._object_velocity = 0.0
                    self._falling = False
                    self._lifted = False
                    if self._object_state == OBJECT_HELD:
                        self._object_state = OBJECT_DROPPED
        if not self._falling and not self._lifted:
            # resting on the table: each finger loads its own contact
            for finger in (0, 1):
                if forces[finger] <= 0.0:
                    self._slide[finger] += lift_change
                    continue
                candidate = previous[finger] + stiffness[finger] * lift_change
                limit_value = kinetic[finger] if self._sliding[finger] else static[finger]
                if candidate > limit_value:
                    if self._sliding[finger] or not self._can_release(static[finger],
                                                                      kinetic[finger]):
                        self._sliding[finger] = True
                        self._shear[finger] = kinetic[finger]
                        self._slide[finger] += (candidate - kinetic[finger]) / stiffness[finger]
                    else:
                        released = True
                        self._shear[finger] = candidate
                        self._release(finger, candidate, static[finger], kinetic[finger],
                                      previous[finger], tick_start, stiffness[finger])
                elif candidate < -limit_value:
                    # the arm lowers the fingers along the object the table holds: friction
                    # opposes the motion both ways, so the shear reverses only down to
                    # -friction and the contact slides (smoothly) beyond
                    self._sliding[finger] = True
                    self._shear[finger] = -kinetic[finger]
                    self._slide[finger] += (candidate + kinetic[finger]) / stiffness[finger]
                else:
                    if self._sliding[finger]:
                        self._sliding[finger] = False
                        self._stuck_since[finger] = now
                    self._shear[finger] = candidate
            if in_contact and self._shear[0] + self._shear[1] >= weight:
                self._lifted = True
            lift_change = 0.0   # consumed
        if self._lifted and not self._falling:
            load = obj.mass * (STANDARD_GRAVITY + acceleration) + ejection
            was_sliding = list(self._sliding)
            # tentatively stick every finger in contact at its present shear
            stuck = [forces[finger] > 0.0 for finger in (0, 1)]
            for finger in (0, 1):
                if self._sliding[finger]:
                    self._shear[finger] = min(self._shear[finger], kinetic[finger])
            moved = lift_change      # finger motion relative to the object so far
            residual_motion = 0.0
            for _ in range(8):
                total_stiffness = sum(stiffness[f] for f in (0, 1) if stuck[f])
                fixed = sum(kinetic[f] for f in (0, 1) if forces[f] > 0.0 and not stuck[f])
                if total_stiffness <= 0.0:
                    if fixed >= load:
                        stuck = [forces[f] > 0.0 for f in (0, 1)]
                        continue
                    self._falling = True
                    self._object_velocity = self._arm_velocity
                    break
                held = sum(self._shear[f] for f in (0, 1) if stuck[f])
                relative = (load - fixed - held) / total_stiffness
                residual_motion += relative
                for finger in (0, 1):
                    if stuck[finger]:
                        self._shear[finger] += stiffness[finger] * relative
                    elif forces[finger] > 0.0:
                        self._shear[finger] = kinetic[finger]
                        self._slide[finger] += relative
                worst, worst_ratio = -1, 1.0
                for finger in (0, 1):
                    if not stuck[finger]:
                        continue
                    limit_value = kinetic[finger] if was_sliding[finger] else static[finger]
                    ratio = self._shear[finger] / limit_value if limit_value > 0 else math.inf
                    if ratio > worst_ratio + 1e-12:
                        worst, worst_ratio = finger, ratio
                if worst < 0:
                    break
                if not was_sliding[worst] and self._can_release(static[worst], kinetic[worst]):
                    released = True
                    self._release(worst, self._shear[worst], static[worst], kinetic[worst],
                                  previous[worst], tick_start, stiffness[worst])
                    was_sliding[worst] = False
                else:
                    stuck[worst] = False
                    self._slide[worst] += ((self._shear[worst] - kinetic[worst])
                                           / stiffness[worst])
                    self._shear[worst] = kinetic[worst]
            # the object moves with the arm minus the fingers' motion relative to it
            self._height += moved - residual_motion
            for finger in (0, 1):
                now_sliding = forces[finger] > 0.0 and not stuck[finger]
                if self._sliding[finger] and not now_sliding:
                    self._stuck_since[finger] = now
                self._sliding[finger] = now_sliding and not self._falling
            if self._height <= 0.0 and not self._falling:
                self._height = 0.0
                self._lifted = False
        self._height = max(self._height, 0.0)
        self._max_height = max(self._max_height, self._height)
        # --- rotation about the grasp axis (only once off the table)
        if self._lifted and self._draws.com_offset > 0.0 and in_contact:
            torque = obj.mass * STANDARD_GRAVITY * self._draws.com_offset
            total = forces[0] + forces[1]
            static_torque = obj.mu_static * self._draws.mu_scale * total * obj.torsion_radius
            kinetic_torque = obj.mu_kinetic * self._draws.mu_scale * total * obj.torsion_radius
            if not self._rotating and torque * math.cos(self._rotation) > static_torque:
                self._rotating = True
            if self._rotating:
                equilibrium = math.acos(min(kinetic_torque / torque, 1.0))
                if equilibrium > self._rotation:
                    self._rotation += (equilibrium - self._rotation) * self._rotation_decay
                if equilibrium - self._rotation < _SETTLED_OFFSET:
                    self._rotating = False
        else:
            self._rotating = False
        # --- contact running off the object, object state
        slide = 0.5 * (self._slide[0] + self._slide[1])
        if in_contact:
            self._had_contact = True
        if not self._contact_lost and (slide > self._grip_length or (
                self._had_contact and not in_contact and slide > _GRIP_MARGIN)):
            self._contact_lost = True
        if self._object_state in (OBJECT_RESTING, OBJECT_HELD):
            if self._contact_lost:
                self._object_state = OBJECT_DROPPED
            elif self._lifted and self._height > _HELD_HEIGHT:
                self._object_state = OBJECT_HELD
            elif not self._lifted and not self._falling and self._height <= 0.0:
                self._object_state = OBJECT_RESTING     # put back down on the table
        # --- slip classification and onset labels
        if self._falling:
            kind = SLIP_GROSS
        elif released or (now - self._last_release < _STICK_SLIP_HOLD * SAMPLE_RATE):
            kind = SLIP_STICK_SLIP
        elif self._rotating:
            kind = SLIP_ROTATIONAL
        elif self._sliding[0] and self._sliding[1]:
            kind = SLIP_GROSS
        elif self._sliding[0] or self._sliding[1]:
            kind = SLIP_INCIPIENT
        else:
            kind = SLIP_NONE
        if self._contact_lost and not self._falling:
            kind = SLIP_NONE
        if kind != SLIP_NONE:
            if now - self._last_slip_sample > _QUIET_BEFORE_ONSET * SAMPLE_RATE:
                onset = tick_start
                for sample, _, _ in reversed(self._events):
                    if sample < tick_start:
                        break
                    onset = sample
                self._onsets.append((onset, kind))
            self._last_slip_sample = now
        self._slip_type = kind

    def _texture_at(self, slide: float) -> float:
        """Local static-friction excess factor at a slide position along the object [-].

        Surfaces are not uniform: the excess of static over kinetic friction varies along
        the object (piecewise linear between random values every 0.5 mm, mean 1), which
        makes stick-slip irregular as on real objects.
        """
        position = max(slide, 0.0) / _TEXTURE_SPACING
        index = int(position)
        if index + 1 >= len(self._texture):
            return 1.0
        fraction = position - index
        return self._texture[index] * (1.0 - fraction) + self._texture[index + 1] * fraction

    def _can_release(self, static: float, kinetic: float) -> bool:
        """True if a contact exceeding ``static`` releases with a stick-slip jump."""
        return self._stick_slip and static - kinetic > _MIN_RELEASE

    def _release(self, finger: int, load: float, static: float, kinetic: float,
                 previous: float, tick_start: int, stiffness: float) -> None:
        """Stick-slip release: the contact slips until the shear drops to 2 kinetic - static."""
        after = max(2.0 * kinetic - static, 0.0)
        span = load - previous
        fraction = (static - previous) / span if span > 1e-12 else 0.0
        offset = int(min(max(fraction, 0.0), 0.999) * TICK_SAMPLES)
        self._slide[finger] += (load - after) / stiffness
        self._shear[finger] = after
        self._jumps[finger] += after - load
        self._events.append((tick_start + offset, finger, self._jumps[finger]))
        self._last_release = tick_start + offset
        self._stuck_since[finger] = tick_start + offset

    # ------------------------------------------------------------------ 2 kHz synthesis
    def _synthesise(self, first_sample: int, ticks: int, records: np.ndarray,
                    slip_types: np.ndarray, object_states: np.ndarray,
                    events: list[tuple[int, int, float]],
                    jumps_before: tuple[float, float]) -> dict[str, np.ndarray]:
        count = ticks * TICK_SAMPLES
        # linear interpolation of every tick quantity between tick boundaries: the value
        # of a sample depends only on its two boundary records and its place in the tick
        tick = _TICK_INDEX[:count] if count <= len(_TICK_INDEX) else (
            np.arange(count) // TICK_SAMPLES)
        fraction = _TICK_FRACTION[:count] if count <= len(_TICK_FRACTION) else (
            (np.arange(count) % TICK_SAMPLES) / TICK_SAMPLES)
        start = records[:-1][tick]
        fine = start + (records[1:][tick] - start) * fraction[:, None]
        model = self.model
        pressure = pressure_response(model, fine[:, 1:3])                 # (n, 2)
        raw = np.repeat(pressure, 3, axis=1) * self._normal_gain
        raw += np.repeat(fine[:, 7:9], 3, axis=1) * self._temperature_gain
        if self.dynamics:
            if events:
                samples = np.arange(first_sample, first_sample + count)
                jumps = np.column_stack([
                    self._jump_series(samples, finger, events, jumps_before[finger])
                    for finger in (0, 1)])
            else:
                jumps = np.empty((count, 2))
                jumps[:, 0] = jumps_before[0]
                jumps[:, 1] = jumps_before[1]
            shear = fine[:, 5:7] + jumps
            # the bending mode rings after every release step (smooth loading does not
            # excite it); a release jolts the object, which shakes the other finger too
            drive = jumps + _RELEASE_COUPLING * jumps[:, ::-1]
            dynamic, self._resonator_state = _iir(self._resonator_b, self._resonator_a, drive,
                                                  self._resonator_state)
            raw += (np.repeat(shear, 3, axis=1) * self._shear_gain
                    + np.repeat(dynamic - drive, 3, axis=1) * self._vibration_gain)
        raw += self._draws.offsets
        raw += self._noise.read(first_sample, first_sample + count)
        frames = quantise(raw)
        force = fine[:, 3:5]
        if self.indentor is not None:
            load_cell = self._load_cell_noise(force.mean(axis=1), first_sample)
        else:
            load_cell = np.full(count, np.nan)
        if self.object is None and self.indentor is None:
            state = np.full(count, OBJECT_NONE, dtype=np.uint8)
        else:
            state = object_states[tick]
        return {
            'frames': frames,
            'theta': fine[:, 0],
            'finger_force': force,
            'load_cell': load_cell,
            'lift': fine[:, 9],
            'height': fine[:, 10],
            'slip': fine[:, 11],
            'rotation': fine[:, 12],
            'slip_type': slip_types[tick],
            'object_state': state,
        }

    def _load_cell_noise(self, force: np.ndarray, first_sample: int) -> np.ndarray:
        """Load cell reading: mean finger force plus noise drawn in fixed 1 s blocks."""
        noise = np.empty_like(force)
        block = 2000
        stop = first_sample + len(force)
        position = first_sample
        while position < stop:
            block_index = position // block
            block_start = block_index * block
            rng = np.random.default_rng((self.seed, 0x10AD, block_index))
            values = rng.standard_normal(block) * self.model.load_cell_noise
            lo = position - block_start
            hi = min(stop, block_start + block) - block_start
            noise[position - first_sample:position - first_sample + hi - lo] = values[lo:hi]
            position = block_start + hi
        return force + noise

    @staticmethod
    def _jump_series(samples: np.ndarray, finger: int, events: list[tuple[int, int, float]],
                     before: float) -> np.ndarray:
        """Cumulative release steps of one finger at each sample (piecewise constant)."""
        own = [(sample, total) for sample, who, total in events if who == finger]
        if not own:
            return np.full(len(samples), before)
        indices = np.array([sample for sample, _ in own], dtype=np.float64)
        totals = np.array([before] + [total for _, total in own])
        position = np.searchsorted(indices, samples, side='right')
        return totals[position]


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
        raise ValueError(f'unknown object {object_name!r}; see forte_driver.sim.OBJECTS')
    return Scene(scene, seed, obj=OBJECTS[object_name], dynamics=True, trial=trial, model=model)
