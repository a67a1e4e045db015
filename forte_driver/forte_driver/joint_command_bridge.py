"""The JointState command bridge of the gripper driver and its ownership rule (pure, no rclpy).

``topic_based_ros2_control/TopicBasedSystem`` (ros2_control's hardware interface over topics)
publishes the commands of its joints as a sensor_msgs/JointState and reads the joints back
from another JointState topic. The gripper driver serves both ends for the FORTE gripper:
it reads ``joint_states`` (as always) and takes commands on ``gripper/joint_commands``. This
module turns such a message into one servo command (:func:`bridge_command`) and decides
whether it may move the servos (:class:`BridgeGate`); the node
(:mod:`forte_driver.ros.joint_command_bridge`) only converts messages.

The message (:func:`bridge_command`)
------------------------------------
- ``name``: ``<prefix>forte_left_finger_joint``, ``<prefix>forte_right_finger_joint`` (the
  right finger is the URDF mimic of the left), or both. Other joints in the same message
  (a TopicBasedSystem that also holds an arm) are ignored; a message naming no finger joint
  is refused.
- ``position`` [rad]: the gripper angle theta of the paper (0 = fully closed). Both finger
  joints, when named, must agree within :data:`POSITION_MATCH`. A position beyond the
  joint limits (the driver's ``theta_min`` .. ``theta_max`` as read back from the servos,
  the URDF's 0 .. 1.0 rad by default) by more than :data:`LIMIT_TOLERANCE` is refused,
  with the limits in the reason; within that tolerance it is clipped to the limit (a
  trajectory that ends at the limit plus rounding).
- ``velocity`` [rad/s] (optional: empty, or one per name; 0 = not given): its magnitude is
  the servo's Profile Velocity for the move; 0 = the driver's ``default_profile_velocity``.
  A non-zero value below one register unit (:data:`MIN_PROFILE_VELOCITY`) is raised to it
  (the register's 0 would mean "no speed limit").
- ``effort`` [N m] (optional, same shape; 0 = not given): its magnitude caps the joint
  torque: converted to the Goal Current cap [A] with the servo's torque constant
  (:func:`forte_ros.contract.effort_to_current`; 1.0 N m -> 0.561 A); 0 = the driver's
  ``default_current``. A non-zero value below one current unit (:data:`MIN_CURRENT`) is
  raised to it (a cap of 0 A would hold nothing).
Of the finger joints named, the left one's velocity and effort are used (the right one
mirrors it). Values beyond the servos' Current / Velocity Limit are clipped by the driver's
command check, as for ``gripper/command``.

The ownership rule (:class:`BridgeGate`)
----------------------------------------
The grasp controller (forte_control, the ``grasp`` action) owns the servos while a Grasp
runs: from ``grasp/state`` (forte_msgs/GraspState) CLOSING, LOADING, LIFTING, HOLDING,
RELEASING, and while its fault is latched (FAULT: it holds the grip until
``grasp/reset_fault``). Then:

1. a bridge command is refused, not queued (a warning once per grasp, a counter);
2. every command seen is remembered, refused or not; a command acts only when it differs
   from the last one seen (:data:`REPEAT_TOLERANCE`). The controller manager republishes
   its last command: after the grasp that stale command (from before the grasp, or sent
   while it ran) must not open the gripper and drop the held object, and repeats cost
   nothing (no bus traffic). A new command acts at once;
3. a ``grasp/state`` older than ``grasp_state_timeout`` (receive time) no longer owns: the
   controller publishes it at least once a second, so silence means it is gone. Rule 2
   still keeps its stale command from acting.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

from forte_ros.contract import effort_to_current

__all__ = ['GRASP_STATE_NAMES', 'LIMIT_TOLERANCE', 'MIN_CURRENT', 'MIN_PROFILE_VELOCITY',
           'OWNING_STATES', 'POSITION_MATCH', 'REPEAT_TOLERANCE', 'BridgeCommand',
           'BridgeGate', 'Verdict', 'bridge_command']

#: Largest difference between the two finger joints' positions in one command [rad].
POSITION_MATCH = 1e-4
#: A position at most this far beyond a joint limit is clipped to it, further is refused
#: [rad] (below one servo pulse, 1.534e-3 rad).
LIMIT_TOLERANCE = 1e-3
#: Two commands whose position, speed and current cap differ by no more than this are the
#: same command [rad, rad/s, A].
REPEAT_TOLERANCE = 1e-9
#: Smallest non-zero profile velocity: one Profile Velocity unit, 0.229 rev/min [rad/s].
MIN_PROFILE_VELOCITY = 0.229 * 2.0 * math.pi / 60.0
#: Smallest non-zero current cap: one Goal Current unit [A].
MIN_CURRENT = 2.69e-3

#: forte_msgs/GraspState ``state`` constants by value (mirrored: this module imports no
#: messages; a test checks them against forte_msgs).
GRASP_STATE_NAMES = {0: 'IDLE', 1: 'CLOSING', 2: 'LOADING', 3: 'LIFTING', 4: 'HOLDING',
                     5: 'RELEASING', 6: 'DONE', 7: 'FAULT'}
#: Grasp states in which the grasp controller owns the servos (a Grasp runs, or its fault
#: holds the grip).
OWNING_STATES = frozenset({1, 2, 3, 4, 5, 7})


@dataclass(frozen=True)
class BridgeCommand:
    """One servo command from the bridge.

    Attributes
    ----------
    theta : float
        Gripper angle [rad], within the joint limits.
    max_current : float
        Goal Current cap [A]; 0 = the driver's default.
    profile_velocity : float
        Profile Velocity [rad/s]; 0 = the driver's default.
    clipped : str
        Why ``theta`` differs from the message's position ('' if it does not).
    """

    theta: float
    max_current: float = 0.0
    profile_velocity: float = 0.0
    clipped: str = ''

    def same_as(self, other: BridgeCommand | None) -> bool:
        """True if ``other`` commands the same (within :data:`REPEAT_TOLERANCE`)."""
        return other is not None and all(
            abs(a - b) <= REPEAT_TOLERANCE for a, b in (
                (self.theta, other.theta), (self.max_current, other.max_current),
                (self.profile_velocity, other.profile_velocity)))


def _optional(values: Sequence[float], index: int, names: int, what: str
              ) -> tuple[float, str]:
    """The magnitude of an optional per-joint field at ``index`` (0 when not given)."""
    if len(values) == 0:
        return 0.0, ''
    if len(values) != names:
        return 0.0, f'{len(values)} {what} values for {names} names (give none or one per name)'
    value = float(values[index])
    if not math.isfinite(value):
        return 0.0, f'{what} {value} is not a finite number'
    return abs(value), ''


def bridge_command(names: Sequence[str], positions: Sequence[float],
                   velocities: Sequence[float], efforts: Sequence[float],
                   joint_names: Sequence[str], theta_min: float,
                   theta_max: float) -> tuple[BridgeCommand | None, str]:
    """A JointState command as one servo command (see the module docstring).

    Parameters
    ----------
    names, positions, velocities, efforts : sequence
        The message's ``name``, ``position`` [rad], ``velocity`` [rad/s], ``effort`` [N m].
    joint_names : sequence of str
        The gripper's finger joints (left, right), with the driver's prefix.
    theta_min, theta_max : float
        Joint limits [rad] (the servos' position limits as read back).

    Returns
    -------
    command : BridgeCommand or None
        None if refused.
    reason : str
        Why it was refused ('' if not).
    """
    found = [(joint, index) for joint in joint_names
             for index, name in enumerate(names) if name == joint]
    if not found:
        return None, (f'names none of the finger joints {", ".join(joint_names)} '
                      f'(got {", ".join(names) or "no names"})')
    if len({joint for joint, _ in found}) != len(found):
        return None, f'names {found[0][0]} more than once'
    if len(positions) != len(names):
        return None, f'{len(positions)} positions for {len(names)} names'
    values = [float(positions[index]) for _, index in found]
    if not all(math.isfinite(value) for value in values):
        return None, f'position {values} is not finite'
    if max(values) - min(values) > POSITION_MATCH:
        return None, (f'finger positions differ ({", ".join(f"{v:.4f}" for v in values)} '
                      f'rad): the fingers move together (the right one mimics the left)')
    theta = values[0]
    if not theta_min - LIMIT_TOLERANCE <= theta <= theta_max + LIMIT_TOLERANCE:
        return None, (f'position {theta:.4f} rad outside the joint limits [{theta_min:.4f}, '
                      f'{theta_max:.4f}] rad (theta_min .. theta_max, read back from the '
                      "servos' position limit registers)")
    clipped = min(max(theta, theta_min), theta_max)
    index = found[0][1]
    speed, problem = _optional(velocities, index, len(names), 'velocity')
    if problem:
        return None, problem
    torque, problem = _optional(efforts, index, len(names), 'effort')
    if problem:
        return None, problem
    current = max(effort_to_current(torque), MIN_CURRENT) if torque > 0.0 else 0.0
    speed = max(speed, MIN_PROFILE_VELOCITY) if speed > 0.0 else 0.0
    note = f'position {theta:.6f} rad clipped to the limit {clipped:.4f} rad' \
        if clipped != theta else ''
    return BridgeCommand(clipped, current, speed, note), ''


class Verdict(Enum):
    """What :meth:`BridgeGate.judge` decided about a command."""

    ACT = 'act'            #: send it to the servos
    REPEAT = 'repeat'      #: the same as the last command seen: nothing to do
    OWNED = 'owned'        #: refused: the grasp controller owns the servos


class BridgeGate:
    """The ownership rule between the bridge and the grasp controller (module docstring).

    Parameters
    ----------
    grasp_state_timeout : float
        A ``grasp/state`` older than this no longer owns the servos [s].

    Attributes
    ----------
    last_seen : BridgeCommand or None
        The last command judged (refused or not).
    grasps : int
        Ownership periods begun so far (a Grasp started, or a fault latched) [count].
    """

    def __init__(self, grasp_state_timeout: float = 3.0) -> None:
        self.grasp_state_timeout = float(grasp_state_timeout)
        self.grasp_state: int | None = None
        self._received = -math.inf
        self.last_seen: BridgeCommand | None = None
        self.grasps = 0
        self._warned = 0  # the ownership period whose first refusal was warned about

    def on_grasp_state(self, state: int, now: float) -> None:
        """A ``grasp/state`` message with ``state`` arrived at ``now`` [s, monotonic]."""
        owned_before = bool(self.owner(now))
        self.grasp_state, self._received = int(state), float(now)
        if not owned_before and self.owner(now):
            self.grasps += 1

    def owner(self, now: float) -> str:
        """Why the grasp controller owns the servos at ``now`` ('' if it does not)."""
        state = self.grasp_state
        if state not in OWNING_STATES or now - self._received > self.grasp_state_timeout:
            return ''
        name = GRASP_STATE_NAMES[state]
        if state == 7:
            return (f'the grasp controller holds the grip with a latched fault (grasp/state '
                    f'{name}; call grasp/reset_fault)')
        return f'a Grasp is running (grasp/state {name}): the grasp controller owns the servos'

    def judge(self, command: BridgeCommand, now: float) -> tuple[Verdict, bool]:
        """Decide on ``command`` at ``now`` [s] and remember it as the last one seen.

        Returns
        -------
        verdict : Verdict
            REPEAT if it is the last command seen; else OWNED while the grasp controller
            owns the servos; else ACT.
        warn : bool
            True for the first refusal of an ownership period (warn once per grasp).
        """
        repeat = command.same_as(self.last_seen)
        self.last_seen = command
        if repeat:
            return Verdict.REPEAT, False
        if self.owner(now):
            warn = self._warned != self.grasps
            self._warned = self.grasps
            return Verdict.OWNED, warn
        return Verdict.ACT, False
