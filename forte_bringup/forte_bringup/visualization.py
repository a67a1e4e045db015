"""FORTE's live state as plain drawing data: per-pad force arrows, slip highlight, grasp text.

Pure Python (no rclpy, no messages): :mod:`forte_bringup.visualization_node` copies the
fields of ``tactile/state`` (forte_msgs/TactileState) and ``grasp/state``
(forte_msgs/GraspState) into :class:`TactileSnapshot` and :class:`GraspSnapshot`, calls
:func:`compose` and turns the :class:`View` into messages (one
``geometry_msgs/WrenchStamped`` per pad, and a ``visualization_msgs/MarkerArray`` where that
package exists).

Conventions (frames of docs/contracts.md, with the graph's TF prefix):

- The pad force is the grip force estimate (TactileState ``force`` [N]) on each pad whose
  finger reports contact: a two-finger grasp squeezes the object with equal and opposite
  normal forces. It is the force the pad applies to the object, along the pad's ``+x`` (the
  outward contact normal, toward the object), in the pad frame ``<prefix>forte_<side>_pad``.
  An invalid estimate (``force_valid`` false, NaN) or a finger without contact gives 0 N and
  no arrow; a negative estimate is drawn as 0 N.
- Slip (TactileState ``slip``, one state long) is held for ``slip_hold`` seconds
  (:class:`SlipLatch`) so that a display refreshing at 30 Hz shows it; while held, both pads
  in contact are highlighted and their arrows change colour.
- The grasp-state text (:func:`grasp_text`) names the phase, the controller, the forces, the
  slip events and any fault; it sits above the fingertips in ``<prefix>forte_base_link``.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from forte_ros.contract import BASE_FRAME, FINGER_NAMES, PAD_FRAMES, prefixed

__all__ = ['CONTROLLER_NAMES', 'FAULT_FLAGS', 'FAULT_STATE', 'OUTCOME_NAMES', 'PAD_SIDES',
           'STATE_NAMES', 'Arrow',
           'GraspSnapshot', 'Highlight', 'Label', 'PadForce', 'SlipLatch', 'TactileSnapshot',
           'View', 'VisualizationConfig', 'compose', 'fault_names', 'grasp_text', 'pad_forces']

#: GraspState ``state`` constants by value (forte_msgs/GraspState).
STATE_NAMES = ('IDLE', 'CLOSING', 'LOADING', 'LIFTING', 'HOLDING', 'RELEASING', 'DONE', 'FAULT')
#: Grasp goal ``controller`` constants by value.
CONTROLLER_NAMES = ('FORTE', 'NO_SLIP', 'ON_OFF')
#: GraspState ``last_outcome`` constants by value (OUTCOME_ stripped).
OUTCOME_NAMES = ('NONE', 'LIFTED', 'DROPPED', 'NO_CONTACT', 'FORCE_LIMIT', 'TIMEOUT',
                 'CANCELED', 'FAULT', 'NOT_CARRIED', 'CLOSED_ON_OBJECT')
#: GraspState ``fault_flags`` bits: (name without FAULT_, bit value).
FAULT_FLAGS = (('STALE_PERCEPTION', 1), ('STALE_JOINT_STATE', 2), ('FORCE_LIMIT', 4),
               ('TIGHTENING_LIMIT', 8), ('LIFT_LIMIT', 16), ('INVALID_INPUT', 32),
               ('SERVO', 64))

#: Finger names in pad order, for topic and marker names (``left``, ``right``).
PAD_SIDES = FINGER_NAMES
#: The GraspState ``state`` of a latched fault.
FAULT_STATE = STATE_NAMES.index('FAULT')

Rgba = tuple[float, float, float, float]
Vector = tuple[float, float, float]

#: Colours (red, green, blue, alpha in 0..1).
FORCE_COLOUR: Rgba = (0.2, 0.8, 0.3, 1.0)
SLIP_COLOUR: Rgba = (1.0, 0.45, 0.0, 1.0)
HIGHLIGHT_COLOUR: Rgba = (1.0, 0.1, 0.1, 0.45)
TEXT_COLOUR: Rgba = (1.0, 1.0, 1.0, 1.0)
FAULT_TEXT_COLOUR: Rgba = (1.0, 0.25, 0.25, 1.0)


@dataclass(frozen=True)
class VisualizationConfig:
    """How the state is drawn (the visualization node's parameters).

    Attributes
    ----------
    prefix : str
        TF prefix of the gripper's frames ('' = the names of docs/contracts.md).
    arrow_scale : float
        Arrow length per newton [m/N].
    max_arrow_length : float
        Longest arrow [m] (larger forces are drawn at this length).
    slip_hold : float
        How long a slip flag stays shown [s].
    max_rate : float
        Most wrench / marker updates per second [Hz].
    label_height : float
        Height of the grasp-state text's letters [m].
    label_offset : float
        Height of the text above the gripper body's origin, along its ``+z`` [m].
    """

    prefix: str = ''
    arrow_scale: float = 0.01
    max_arrow_length: float = 0.15
    slip_hold: float = 0.5
    max_rate: float = 30.0
    label_height: float = 0.012
    label_offset: float = 0.23


@dataclass(frozen=True)
class TactileSnapshot:
    """The fields of a TactileState the views use.

    Attributes
    ----------
    force : float
        Grip force estimate [N] (NaN when invalid).
    force_valid : bool
        The estimate is valid.
    contact : tuple of bool
        Contact flag per finger (left, right).
    slip : bool
        A slip detector update of this state flagged slip.
    slip_active : bool
        The slip detector's latest update was decidable.
    finger_variance : tuple of float
        Moving variance per finger (left, right) [dB^2]; NaN when unusable.
    """

    force: float
    force_valid: bool
    contact: tuple[bool, bool]
    slip: bool = False
    slip_active: bool = True
    finger_variance: tuple[float, float] = (math.nan, math.nan)


@dataclass(frozen=True)
class GraspSnapshot:
    """The fields of a GraspState the views use (units of forte_msgs/GraspState)."""

    state: int
    controller: int = 0
    last_outcome: int = 0
    target_force: float = 0.0
    estimated_force: float = math.nan
    force_valid: bool = False
    slip_events: int = 0
    fault_flags: int = 0
    message: str = ''


@dataclass(frozen=True)
class PadForce:
    """The force one pad applies to the object, in its frame.

    Attributes
    ----------
    frame : str
        Pad frame (with prefix).
    force : tuple of float
        Force vector (x, y, z) in ``frame`` [N]: ``(magnitude, 0, 0)``.
    in_contact : bool
        The pad's finger reports contact.
    slipping : bool
        Slip is shown on this pad.
    """

    frame: str
    force: Vector
    in_contact: bool
    slipping: bool

    @property
    def magnitude(self) -> float:
        """Norm of :attr:`force` [N]."""
        return math.sqrt(sum(value * value for value in self.force))


@dataclass(frozen=True)
class Arrow:
    """An arrow from ``start`` to ``end`` in ``frame`` [m]; not drawn unless ``visible``.

    ``shaft_diameter``, ``head_diameter``, ``head_length`` [m] (the ``scale`` of a
    visualization_msgs/Marker ARROW given by two points).
    """

    frame: str
    start: Vector
    end: Vector
    colour: Rgba
    visible: bool
    shaft_diameter: float = 0.004
    head_diameter: float = 0.008
    head_length: float = 0.008


@dataclass(frozen=True)
class Highlight:
    """A translucent sphere of ``diameter`` [m] at ``centre`` in ``frame``, when ``visible``."""

    frame: str
    centre: Vector
    diameter: float
    colour: Rgba
    visible: bool


@dataclass(frozen=True)
class Label:
    """Text at ``position`` in ``frame`` [m], letters ``height`` [m] high."""

    frame: str
    position: Vector
    text: str
    colour: Rgba
    height: float


@dataclass(frozen=True)
class View:
    """Everything drawn for one update: per pad (left, right) its force, arrow and highlight,
    and the grasp-state label."""

    pads: tuple[PadForce, PadForce]
    arrows: tuple[Arrow, Arrow]
    highlights: tuple[Highlight, Highlight]
    label: Label


class SlipLatch:
    """Holds a one-state slip flag for a while, so a display sees it.

    Parameters
    ----------
    hold : float
        How long the flag stays set after the last slip [s], >= 0.
    """

    def __init__(self, hold: float) -> None:
        if not hold >= 0.0:
            raise ValueError(f'slip hold must be >= 0 s, got {hold}')
        self.hold = hold
        self._last_slip: float | None = None

    def update(self, slip: bool, now: float) -> bool:
        """Record one state's flag at time ``now`` [s, any monotonic clock]; True while a
        slip is at most :attr:`hold` seconds old."""
        if slip:
            self._last_slip = now
        return self._last_slip is not None and now - self._last_slip <= self.hold


def pad_forces(tactile: TactileSnapshot, prefix: str = '',
               slipping: bool = False) -> tuple[PadForce, PadForce]:
    """The force of each pad (left, right) from one state.

    Parameters
    ----------
    tactile : TactileSnapshot
        The state.
    prefix : str
        TF prefix of the pad frames.
    slipping : bool
        Slip is shown (e.g. :meth:`SlipLatch.update`); it marks the pads in contact.

    Returns
    -------
    tuple of PadForce
        Left pad, right pad; the magnitude is ``max(force, 0)`` [N] for a finger in contact
        with a valid finite estimate, else 0.
    """
    valid = tactile.force_valid and math.isfinite(tactile.force)
    magnitude = max(tactile.force, 0.0) if valid else 0.0
    out = []
    for finger, frame in enumerate(PAD_FRAMES):
        touching = bool(tactile.contact[finger])
        out.append(PadForce(prefixed(frame, prefix), (magnitude if touching else 0.0, 0.0, 0.0),
                            touching, slipping and touching))
    return out[0], out[1]


def fault_names(flags: int) -> list[str]:
    """Names of the set GraspState fault bits, e.g. ``['FORCE_LIMIT', 'SERVO']``; an unknown
    bit is named by its value (``'BIT_128'``)."""
    names = [name for name, bit in FAULT_FLAGS if flags & bit]
    known = sum(bit for _, bit in FAULT_FLAGS)
    names += [f'BIT_{1 << i}' for i in range(32) if flags & ~known & (1 << i)]
    return names


def _name(names: Sequence[str], value: int) -> str:
    return names[value] if 0 <= value < len(names) else f'#{value}'


def _newtons(value: float) -> str:
    return f'{value:.2f} N' if math.isfinite(value) else 'n/a'


def grasp_text(grasp: GraspSnapshot | None, tactile: TactileSnapshot | None = None,
               slipping: bool = False) -> str:
    """The grasp-state label: phase and controller, forces, slip, fault or last outcome.

    Parameters
    ----------
    grasp : GraspSnapshot or None
        Latest grasp state (None: none received yet).
    tactile : TactileSnapshot, optional
        Latest tactile state (its force when there is no grasp state, its slip activity).
    slipping : bool
        Slip is shown.

    Returns
    -------
    str
        Lines separated by ``\\n``, e.g. ``'LIFTING (FORTE)\\nforce 1.80 N / target 2.00 N\\n'
        'SLIP  events 1'``.
    """
    lines = []
    if grasp is None:
        lines.append('no grasp state')
        if tactile is not None:
            force = tactile.force if tactile.force_valid else math.nan
            lines.append(f'force {_newtons(force)}')
    else:
        lines.append(f'{_name(STATE_NAMES, grasp.state)} '
                     f'({_name(CONTROLLER_NAMES, grasp.controller)})')
        force = grasp.estimated_force if grasp.force_valid else math.nan
        lines.append(f'force {_newtons(force)} / target {_newtons(grasp.target_force)}')
    slip = 'SLIP' if slipping else 'no slip'
    if tactile is not None and not tactile.slip_active:
        slip = 'slip n/a'
    lines.append(slip + (f'  events {grasp.slip_events}' if grasp is not None else ''))
    if grasp is not None and grasp.fault_flags:
        lines.append('fault: ' + ' | '.join(fault_names(grasp.fault_flags)))
        if grasp.message:
            lines.append(grasp.message)
    elif grasp is not None and grasp.last_outcome:
        lines.append(f'last: {_name(OUTCOME_NAMES, grasp.last_outcome)}')
    return '\n'.join(lines)


def _arrow(pad: PadForce, config: VisualizationConfig) -> Arrow:
    length = min(pad.magnitude * config.arrow_scale, config.max_arrow_length)
    return Arrow(pad.frame, (0.0, 0.0, 0.0), (length, 0.0, 0.0),
                 SLIP_COLOUR if pad.slipping else FORCE_COLOUR,
                 visible=pad.in_contact and length > 0.0)


def compose(tactile: TactileSnapshot | None, grasp: GraspSnapshot | None, slipping: bool,
            config: VisualizationConfig = VisualizationConfig()) -> View:
    """Everything drawn for the latest states.

    Parameters
    ----------
    tactile : TactileSnapshot or None
        Latest tactile state (None: nothing received, no force on either pad).
    grasp : GraspSnapshot or None
        Latest grasp state.
    slipping : bool
        Slip is shown (:class:`SlipLatch`).
    config : VisualizationConfig
        Prefix, scales.

    Returns
    -------
    View
    """
    if tactile is None:
        tactile = TactileSnapshot(math.nan, False, (False, False), slip_active=False)
    pads = pad_forces(tactile, config.prefix, slipping)
    arrows = tuple(_arrow(pad, config) for pad in pads)
    highlights = tuple(Highlight(pad.frame, (0.0, 0.0, 0.0), 0.03, HIGHLIGHT_COLOUR,
                                 visible=pad.slipping) for pad in pads)
    fault = grasp is not None and (grasp.fault_flags != 0 or grasp.state == FAULT_STATE)
    label = Label(prefixed(BASE_FRAME, config.prefix), (0.0, 0.0, config.label_offset),
                  grasp_text(grasp, tactile, slipping),
                  FAULT_TEXT_COLOUR if fault else TEXT_COLOUR, config.label_height)
    return View(pads, arrows, highlights, label)
