"""State of a simulated scene at the mechanics tick rate, and the per-trial random draws.

The scene keeps one instance of each state class and the mechanics (:mod:`.mechanics`) and
friction (:mod:`.friction`) models update them once per tick:

- :class:`GripperState`: the servo and the two fin-ray fingers (normal direction);
- :class:`ArmState`: the vertical arm lift;
- :class:`ObjectState`: the object (or the calibration rig's indentor) between the fingers;
- :class:`ContactState`: the tangential state of the two finger contacts on the object.

Per-finger quantities are lists ``[left, right]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from forte_ros.contract import SAMPLE_PERIOD
from forte_sim.catalogue import IndentorSpec, ObjectSpec
from forte_sim.model import GripperModel
from forte_sim.truth import OBJECT_NONE, OBJECT_RESTING

#: Samples per mechanics tick (5 ms at 2 kHz).
TICK_SAMPLES = 10
#: Duration of a mechanics tick [s].
TICK = TICK_SAMPLES * SAMPLE_PERIOD

_TEXTURE_POINTS = 400       # surface friction samples, every 0.5 mm: 0.2 m of sliding
_TEXTURE_VARIATION = 0.4    # relative spread of the static friction excess [-]
_SEATING_SPREAD = 0.08      # indentor height jitter on the finger, +- [-]
_CENTRING_SPREAD = 1.5      # indentor centring jitter, +- [mm]
_RIG_TEMPERATURE_SPREAD = 0.5   # indentor minus finger temperature, std [K]
_RESIDUAL_RELAXATION = 1.0  # relaxation left from earlier grasps, up to [N]


def _per_finger(value: float | bool | int = 0.0) -> Any:
    """Dataclass field defaulting to a fresh per-finger list ``[value, value]``."""
    return field(default_factory=lambda: [value, value])


@dataclass(slots=True)
class TrialDraws:
    """Per-trial draws from the seed (placement, material spread, sensor offsets).

    Attributes
    ----------
    lateral_offset : float
        Object offset toward the right finger at the start [mm].
    contact_location : float
        Where the object presses on the fingers, 0 = tip, 1 = root [-].
    contact_spread : float
        Extent of the contact along the finger [-].
    mu_scale : float
        Factor on the object's friction coefficients [-].
    com_offset : float
        Centre-of-mass offset from the grasp axis [m].
    temperature : float
        Object minus finger temperature [K].
    break_scale : float
        Factor on the object's break force [-].
    offsets : numpy.ndarray, shape (6,)
        Zero offsets of the 6 transducers [normalised].
    texture : list of float
        Static friction excess factor along the object, every 0.5 mm [-].
    residual_relaxation : float
        Slow relaxation left in the fingers from earlier grasps [N].
    """

    lateral_offset: float
    contact_location: float
    contact_spread: float
    mu_scale: float
    com_offset: float
    temperature: float
    break_scale: float
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(6))
    texture: list[float] = field(default_factory=list)
    residual_relaxation: float = 0.0


def draw_trial(seed: int, obj: ObjectSpec | None, indentor: IndentorSpec | None,
               model: GripperModel) -> tuple[TrialDraws, float]:
    """Every per-trial random draw of a scene, in a fixed order from one generator.

    Parameters
    ----------
    seed : int
        Scene seed.
    obj : ObjectSpec or None
        Grasped object.
    indentor : IndentorSpec or None
        Calibration rig indentor (used when ``obj`` is None).
    model : GripperModel
        Sensor offset range.

    Returns
    -------
    draws : TrialDraws
    width : float
        Width of what is between the fingers [m] (0 for the empty scene).
    """
    rng = np.random.default_rng((seed, 0x7121A1))
    if obj is not None:
        location = float(np.clip(obj.contact_location + rng.uniform(-0.05, 0.05), 0.0, 1.0))
        draws = TrialDraws(
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
        location = indentor.contact_location + rng.uniform(-_SEATING_SPREAD, _SEATING_SPREAD)
        draws = TrialDraws(
            lateral_offset=float(rng.uniform(-_CENTRING_SPREAD, _CENTRING_SPREAD)),
            contact_location=float(np.clip(location, 0.0, 1.0)),
            contact_spread=indentor.contact_spread, mu_scale=1.0, com_offset=0.0,
            temperature=float(rng.normal(0.0, _RIG_TEMPERATURE_SPREAD)), break_scale=1.0)
        width = indentor.width
    else:
        draws = TrialDraws(0.0, 0.4, 0.15, 1.0, 0.0, 0.0, 1.0)
        width = 0.0
    draws.offsets = rng.uniform(-model.offset_range, model.offset_range, 6)
    draws.texture = [float(value) for value in np.clip(
        1.0 + _TEXTURE_VARIATION * rng.standard_normal(_TEXTURE_POINTS), 0.2, 2.0)]
    draws.residual_relaxation = float(rng.uniform(0.0, _RESIDUAL_RELAXATION))
    return draws, width


@dataclass(slots=True)
class GripperState:
    """The servo and the two fin-ray fingers.

    Attributes
    ----------
    theta : float
        Actual servo angle [rad], 0 = closed.
    command : float
        Servo goal angle [rad].
    profile_velocity : float
        Servo profile velocity [rad/s].
    max_current : float
        Servo current limit [A].
    current : list of float
        Servo current of each finger [A].
    velocity : float
        Servo angular velocity over the last tick [rad/s].
    deflection : list of float
        Finger deflection [mm].
    force : list of float
        Finger normal force on the object [N].
    relax_fast, relax_slow : list of float
        Elastic force followed by the fast and slow stress relaxation branches [N].
    temperature : list of float
        Finger temperature change from touching the object [K].
    """

    theta: float
    command: float
    profile_velocity: float
    max_current: float
    current: list[float]
    velocity: float = 0.0
    deflection: list[float] = _per_finger()
    force: list[float] = _per_finger()
    relax_fast: list[float] = _per_finger()
    relax_slow: list[float] = _per_finger()
    temperature: list[float] = _per_finger()


@dataclass(slots=True)
class ArmState:
    """The arm that lifts the gripper vertically.

    Attributes
    ----------
    command : float
        Commanded vertical velocity [m/s], positive = up.
    velocity : float
        Actual vertical velocity (acceleration-limited) [m/s].
    lift : float
        Gripper height above the start pose [m].
    """

    command: float = 0.0
    velocity: float = 0.0
    lift: float = 0.0


@dataclass(slots=True)
class ObjectState:
    """The object (or the calibration rig's indentor) between the fingers.

    Attributes
    ----------
    width_mm : float
        Width across the grasp line [mm] (shrinks when crushed or broken).
    lateral : float
        Offset toward the right finger [mm].
    height : float
        Height above the table [m].
    velocity : float
        Vertical velocity while falling [m/s].
    rotation : float
        Rotation relative to the fingers about the grasp axis [rad].
    rotating : bool
        Rotational slip in progress.
    lifted : bool
        Carried by the fingers, off the table.
    falling : bool
        Falling (the fingers cannot carry it).
    contact_lost : bool
        The contact ran off the object.
    had_contact : bool
        A finger has touched the object.
    status : int
        OBJECT_* constant.
    """

    width_mm: float
    lateral: float = 0.0
    height: float = 0.0
    velocity: float = 0.0
    rotation: float = 0.0
    rotating: bool = False
    lifted: bool = False
    falling: bool = False
    contact_lost: bool = False
    had_contact: bool = False
    status: int = OBJECT_NONE

    @classmethod
    def at_rest(cls, width_mm: float, lateral: float, has_object: bool) -> ObjectState:
        """Start state: on the table (an object) or no object state (rig, empty scene)."""
        return cls(width_mm=width_mm, lateral=lateral,
                   status=OBJECT_RESTING if has_object else OBJECT_NONE)


@dataclass(slots=True)
class ContactState:
    """Tangential state of the two finger contacts on the object.

    Attributes
    ----------
    slide : list of float
        Finger travel up the object [m].
    shear : list of float
        Tangential force on the object [N].
    jumps : list of float
        Cumulative stick-slip release steps [N].
    sliding : list of bool
        The contact slides.
    stuck_since : list of int
        Sample at which the contact last stuck.
    events : list of (int, int, float)
        Releases of the current :meth:`Scene.step` simulation: (sample, finger,
        cumulative jumps of that finger after it).
    last_release : int
        Sample of the latest release.
    """

    slide: list[float] = _per_finger()
    shear: list[float] = _per_finger()
    jumps: list[float] = _per_finger()
    sliding: list[bool] = _per_finger(False)
    stuck_since: list[int] = _per_finger(0)
    events: list[tuple[int, int, float]] = field(default_factory=list)
    last_release: int = -10 ** 9
