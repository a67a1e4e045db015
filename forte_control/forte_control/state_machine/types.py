"""What the grasp state machine reads and writes: states, outcomes, inputs, outputs, goal.

The enums mirror the constants of ``forte_msgs`` (the tests check they are equal). Pure
Python, no rclpy.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import Any

from forte_ros.contract import effort_to_current

__all__ = [
    'ACTIVE_STATES', 'PAPER_SLIP_INCREMENT', 'ControlInputs', 'ControlOutputs', 'Controller',
    'FaultFlag', 'GraspGoal', 'GraspState', 'JointInput', 'Outcome', 'PerceptionInput',
    'ServoOutput', 'WrenchInput', 'joint_input', 'perception_input',
]

# ---------------------------------------------------------------------------------------
# Constants mirrored from forte_msgs (tests check they equal the message constants)


class GraspState(IntEnum):
    """Phase of the grasp (mirror of ``forte_msgs/msg/GraspState`` state constants)."""

    IDLE = 0
    CLOSING = 1
    LOADING = 2
    LIFTING = 3
    HOLDING = 4
    RELEASING = 5
    DONE = 6
    FAULT = 7


class FaultFlag(IntFlag):
    """Fault bitmask (mirror of ``forte_msgs/msg/GraspState`` FAULT_* constants)."""

    NONE = 0
    STALE_PERCEPTION = 1
    STALE_JOINT_STATE = 2
    FORCE_LIMIT = 4
    TIGHTENING_LIMIT = 8
    LIFT_LIMIT = 16
    INVALID_INPUT = 32
    SERVO = 64


class Outcome(IntEnum):
    """Grasp outcome (mirror of ``forte_msgs/action/Grasp`` result constants)."""

    NONE = 0
    LIFTED = 1
    DROPPED = 2
    NO_CONTACT = 3
    FORCE_LIMIT = 4
    TIMEOUT = 5
    CANCELED = 6
    FAULT = 7
    NOT_CARRIED = 8
    CLOSED_ON_OBJECT = 9


class Controller(IntEnum):
    """Controller of a grasp (mirror of ``forte_msgs/action/Grasp`` goal constants)."""

    FORTE = 0
    NO_SLIP = 1
    ON_OFF = 2


#: States in which a grasp is in progress (motion may be commanded).
ACTIVE_STATES = frozenset({GraspState.CLOSING, GraspState.LOADING, GraspState.LIFTING,
                           GraspState.HOLDING, GraspState.RELEASING})

#: The paper's slip response, 0.88 degree [rad].
PAPER_SLIP_INCREMENT = math.radians(0.88)

# ---------------------------------------------------------------------------------------
# Goal, inputs, outputs


@dataclass(frozen=True)
class GraspGoal:
    """A grasp request (mirror of the ``Grasp`` action goal; 0 means the node default)."""

    controller: Controller = Controller.FORTE
    initial_force: float = 0.0      # [N]
    lift_speed: float = 0.0         # [m/s]
    lift_distance: float = 0.0      # [m]
    slip_increment: float = 0.0     # [rad]
    max_tightening: float = 0.0     # [rad]
    max_force: float = 0.0          # [N]
    timeout: float = 0.0            # [s]
    release_after: bool = False


@dataclass(frozen=True)
class PerceptionInput:
    """Latest perception (the fields of TactileState the controller uses).

    ``slip`` must be true if any detector update since the previous :meth:`step` flagged
    slip (the caller ORs the flags of the messages it received in between).
    """

    stamp: float                                # sample time of the latest sample [s]
    force: float = 0.0                          # estimated grip force [N]
    force_valid: bool = False
    contact: tuple[bool, bool] = (False, False)  # (LEFT, RIGHT)
    slip: bool = False
    slip_active: bool = False
    slipping: bool = False                      # slipping state (held while it slides)
    data_valid: bool = True
    filtered: tuple[float, ...] | None = None   # (6,) tared filtered channels, optional
    finger_variance: tuple[float, float] = (0.0, 0.0)  # [dB^2], reported in feedback


def perception_input(state: Any, stamp: float, slip: bool | None = None) -> PerceptionInput:
    """The controller's view of one perception state.

    Parameters
    ----------
    state : forte_msgs.msg.TactileState or forte_perception.pipeline.PerceptionOutput
        Anything with TactileState's field names (``force``, ``force_valid``, ``contact``,
        ``slip``, ``slip_active``, ``data_valid``, ``filtered``, ``finger_variance``;
        ``slipping`` if it has it, else False).
    stamp : float
        Sample time of the state's latest sample [s].
    slip : bool, optional
        The slip flag to pass on (a node ORs the flags received since its last step);
        default ``state.slip``.
    """
    return PerceptionInput(
        stamp=stamp, force=float(state.force), force_valid=bool(state.force_valid),
        contact=(bool(state.contact[0]), bool(state.contact[1])),
        slip=bool(state.slip) if slip is None else bool(slip),
        slip_active=bool(state.slip_active), slipping=bool(getattr(state, 'slipping', False)),
        data_valid=bool(state.data_valid),
        filtered=tuple(float(value) for value in state.filtered),
        finger_variance=(float(state.finger_variance[0]), float(state.finger_variance[1])))


@dataclass(frozen=True)
class JointInput:
    """Latest gripper joint state."""

    stamp: float                 # sample time [s]
    theta: float                 # servo angle [rad], 0 = fully closed
    servo_error: bool = False    # hardware error reported by the driver
    effort: float | None = None  # servo current [A], mean magnitude; None = not reported
    torque: float | None = None  # joint effort [N m], mean along theta; for reports only


def joint_input(names: Sequence[str], positions: Sequence[float], efforts: Sequence[float],
                joint_names: Sequence[str], stamp: float) -> JointInput | None:
    """The :class:`JointInput` of a sensor_msgs/JointState's fields (no message import).

    Parameters
    ----------
    names, positions, efforts : sequence
        The message's ``name``, ``position`` [rad] and ``effort`` [N m]: the joint torque
        along theta (``joint_states`` of the gripper driver and the simulator, docs/contracts.md).
    joint_names : sequence of str
        The gripper's finger joints to average.
    stamp : float
        The sample time [s].

    Returns
    -------
    JointInput or None
        ``theta`` = mean position of the named finger joints; ``effort`` = servo current [A]
        = mean |effort| / the servo torque constant (the machine compares current
        magnitudes: ``loaded_current``), ``torque`` = mean effort [N m], both None unless
        every finger joint reports an effort; None when no finger joint is in the message.
    """
    indices = [i for i, name in enumerate(names) if name in joint_names and i < len(positions)]
    if not indices:
        return None
    theta = float(sum(positions[i] for i in indices) / len(indices))
    torques = [float(efforts[i]) for i in indices if i < len(efforts)]
    if len(torques) != len(indices):
        return JointInput(stamp=stamp, theta=theta)
    current = effort_to_current(sum(abs(torque) for torque in torques) / len(torques))
    return JointInput(stamp=stamp, theta=theta, effort=current,
                      torque=sum(torques) / len(torques))


@dataclass(frozen=True)
class WrenchInput:
    """Latest wrist force/torque reading the controller uses (optional input)."""

    stamp: float      # sample time [s]
    force_z: float    # vertical load the wrist carries, + = pulling the gripper down [N]


@dataclass(frozen=True)
class ControlInputs:
    """Everything :meth:`GraspStateMachine.step` reads (``None`` = never received)."""

    perception: PerceptionInput | None = None
    joint: JointInput | None = None
    wrench: WrenchInput | None = None   # wrist load, used only with LiftCheckParams.use_wrench


@dataclass(frozen=True)
class ServoOutput:
    """Servo command (mirror of ``forte_msgs/msg/ServoCommand`` without header)."""

    position: float          # [rad]
    max_current: float       # [A]
    profile_velocity: float  # [rad/s]


@dataclass(frozen=True)
class ControlOutputs:
    """What the controller commands after a step, and its state for reporting."""

    servo: ServoOutput | None      # None: nothing commanded yet (leave the gripper alone)
    servo_changed: bool            # the servo command differs from the previous step
    arm_velocity: float            # vertical arm velocity [m/s], + is up
    state: GraspState
    controller: Controller
    outcome: Outcome               # outcome of the current/last grasp (NONE while running)
    fault_flags: FaultFlag
    slip_events: int               # slip events acted on in this grasp [count]
    slip_reacted: bool             # a tightening was commanded in this step
    tightening: float              # total slip tightening [rad]
    lift_height: float             # integrated commanded lift [m]
    target_force: float            # force the controller loads to [N]
    estimated_force: float         # latest estimated force [N] (NaN if none)
    force_valid: bool
    finished: bool                 # the grasp reached its outcome in this step
    message: str
    gross_slip_events: int = 0     # tightenings on gross-slip evidence in this grasp [count]
    slip_duration: float = 0.0     # time perception reported slipping in this grasp [s]

