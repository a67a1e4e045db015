"""Position goals of the standard gripper actions as FORTE servo moves (pure, no rclpy).

The grasp controller serves two control_msgs actions that open or close the gripper to a
position, for MoveIt and other action clients: ``GripperCommand`` (``gripper_cmd``) and
``ParallelGripperCommand`` (``parallel_gripper_cmd``). Both become the same
:class:`GripperGoal` and run the same move (:class:`GripperMove`); this module holds the
conversion, the checks and the bookkeeping of a move, so they are tested without ROS.

The mapping (docs/control.md, "Gripper position actions and MoveIt"):

- **position**: the gripper angle theta [rad] of the paper (0 = fully closed, larger
  opens), the position of each finger joint in ``joint_states`` (both fingers move
  together: one servo command drives both). ``GripperCommand.command.position`` is theta.
  A ``ParallelGripperCommand`` goal (a sensor_msgs/JointState) names one finger joint or
  both; both must then ask for the same angle (within :data:`POSITION_MATCH`). Allowed:
  ``min_angle`` (the controller's most closed command) to ``max_angle`` (the joint's upper
  limit, 1.0 rad: the URDF's and the gripper driver's); a goal beyond is rejected at once,
  the reason naming the limit.
- **effort**: the most joint torque the move may use [N m] (the finger joint is the servo
  horn, 1:1), like ``GripperCommand.command.max_effort``; converted to the servo current
  cap with the servo torque constant (:func:`forte_ros.contract.effort_to_current`, 4.1 N m
  / 2.3 A: 1.0 N m -> 0.561 A). 0 (or none given) = the controller's ``max_current``; a
  larger value is capped at ``max_current``.
- **velocity** (ParallelGripperCommand only): the servo profile velocity [rad/s]; 0 (or
  none given) = the controller's ``release_speed``; capped at :data:`MAX_VELOCITY`.
- ``velocity`` and ``effort`` hold no value, one value, or one per named joint (all
  equal): MoveIt's ParallelGripperCommand handle sends one per joint.

A goal naming a joint the controller does not know, giving unequal values, a value that is
not a finite number, a negative effort or velocity, or a position outside the range is
refused with a reason that names the problem.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from forte_control.parameters import HARD_MAX_SERVO_SPEED
from forte_control.state_machine import ControllerParams, ServoOutput
from forte_ros.contract import effort_to_current

__all__ = ['MAX_VELOCITY', 'POSITION_MATCH', 'STALL_MOTION', 'GripperGoal', 'GripperMove',
           'gripper_command_goal', 'parallel_gripper_goal', 'position_problem']
#: Fastest profile velocity a goal gets [rad/s] (a faster request is capped).
MAX_VELOCITY = HARD_MAX_SERVO_SPEED
#: Largest difference between the positions a ParallelGripperCommand goal gives its two
#: finger joints [rad]: the fingers move together, so they must ask for one angle.
POSITION_MATCH = 1e-4
#: A joint that moved less than this between two checks of a move has stalled [rad].
STALL_MOTION = 1e-4


@dataclass(frozen=True)
class GripperGoal:
    """A gripper position goal in FORTE's terms.

    Attributes
    ----------
    position : float
        Gripper angle theta to reach [rad], 0 = fully closed.
    max_effort : float
        Most joint torque the move may use [N m]; 0 = the controller's ``max_current``.
    max_velocity : float
        Servo profile velocity [rad/s]; 0 = the controller's ``release_speed``.
    """

    position: float
    max_effort: float = 0.0
    max_velocity: float = 0.0

    def servo(self, params: ControllerParams) -> ServoOutput:
        """The servo command of this goal under the controller's ``params``.

        Parameters
        ----------
        params : ControllerParams
            The controller's parameters (``max_current``, ``release_speed``).

        Returns
        -------
        ServoOutput
            ``position``; current ``min(max_effort / k, max_current)`` [A] with k the
            servo torque constant [N m/A] (``max_current`` when ``max_effort`` is 0);
            profile velocity ``min(max_velocity, MAX_VELOCITY)`` (``release_speed`` when
            ``max_velocity`` is 0).
        """
        current = min(effort_to_current(self.max_effort), params.max_current) \
            if self.max_effort > 0.0 else params.max_current
        speed = min(self.max_velocity, MAX_VELOCITY) if self.max_velocity > 0.0 \
            else params.release_speed
        return ServoOutput(position=self.position, max_current=current, profile_velocity=speed)


def position_problem(position: float, params: ControllerParams) -> str:
    """Why ``position`` [rad] cannot be a gripper goal ('' if it can)."""
    if not math.isfinite(position):
        return f'position {position} rad is not a finite number'
    if not params.min_angle <= position <= params.max_angle:
        return (f'position {position:.4f} rad outside [{params.min_angle:.4f}, '
                f'{params.max_angle:.4f}] rad (min_angle .. max_angle, the joint limit)')
    return ''


def _limit_problem(value: float, what: str, unit: str) -> str:
    if not math.isfinite(value):
        return f'{what} {value} {unit} is not a finite number'
    if value < 0.0:
        return f'{what} {value} {unit} is negative'
    return ''


def gripper_command_goal(position: float, max_effort: float,
                         params: ControllerParams) -> tuple[GripperGoal | None, str]:
    """A ``GripperCommand`` goal (``command.position``, ``command.max_effort``) as a goal.

    Parameters
    ----------
    position : float
        Gripper angle theta [rad].
    max_effort : float
        Joint torque cap [N m], 0 = the controller's ``max_current``.
    params : ControllerParams
        The controller's parameters (``min_angle``, ``max_angle``).

    Returns
    -------
    goal : GripperGoal or None
        None if refused.
    reason : str
        Why it was refused ('' if not).
    """
    problem = position_problem(float(position), params) or \
        _limit_problem(float(max_effort), 'max_effort', 'N m')
    if problem:
        return None, problem
    return GripperGoal(float(position), max_effort=float(max_effort)), ''


def _common_value(values: Sequence[float], names: Sequence[str], what: str,
                  unit: str) -> tuple[float, str]:
    """The one value of an optional per-joint field (``velocity`` / ``effort``): none (0),
    one for all joints, or one per joint, all equal."""
    if len(values) == 0:
        return 0.0, ''
    if len(values) not in (1, len(names)):
        return 0.0, (f'{len(values)} {what} values for {len(names)} joint(s): give none, one, '
                     'or one per joint')
    for value in values:
        problem = _limit_problem(float(value), what, unit)
        if problem:
            return 0.0, problem
    if max(values) - min(values) > 0.0:
        return 0.0, (f'unequal {what} values {", ".join(f"{v:g}" for v in values)} {unit}: '
                     'one servo command drives both fingers')
    return float(values[0]), ''


def _joint_problem(names: Sequence[str], joint_names: Sequence[str]) -> str:
    known = ', '.join(joint_names)
    if not names:
        return f'no joint named: name one of {known}, or both'
    unknown = [name for name in names if name not in joint_names]
    if unknown:
        return f'unknown joint(s) {", ".join(map(repr, unknown))}: this gripper has {known}'
    repeated = sorted({name for name in names if list(names).count(name) > 1})
    if repeated:
        return f'joint(s) {", ".join(map(repr, repeated))} named more than once'
    return ''


def parallel_gripper_goal(names: Sequence[str], positions: Sequence[float],
                          velocities: Sequence[float], efforts: Sequence[float],
                          joint_names: Sequence[str],
                          params: ControllerParams) -> tuple[GripperGoal | None, str]:
    """A ``ParallelGripperCommand`` goal (its JointState ``command``) as a goal.

    Parameters
    ----------
    names, positions, velocities, efforts : sequence
        The ``name``, ``position`` [rad], ``velocity`` [rad/s] and ``effort`` [N m] of the
        goal's ``command``.
    joint_names : sequence of str
        The controller's finger joints (its ``joint_names`` with its ``prefix``).
    params : ControllerParams
        The controller's parameters (``min_angle``, ``max_angle``).

    Returns
    -------
    goal : GripperGoal or None
        None if refused.
    reason : str
        Why it was refused ('' if not).
    """
    problem = _joint_problem(names, joint_names)
    if problem:
        return None, problem
    if len(positions) != len(names):
        return None, f'{len(positions)} position(s) for {len(names)} joint name(s)'
    for name, position in zip(names, positions):
        problem = position_problem(float(position), params)
        if problem:
            return None, f'{name}: {problem}'
    if max(positions) - min(positions) > POSITION_MATCH:
        given = ', '.join(f'{name} {float(p):.4f}' for name, p in zip(names, positions))
        return None, (f'positions differ ({given} rad): the fingers move together, give '
                      f'both the same gripper angle (within {POSITION_MATCH:g} rad)')
    velocity, problem = _common_value(velocities, names, 'velocity', 'rad/s')
    if problem:
        return None, problem
    effort, problem = _common_value(efforts, names, 'effort', 'N m')
    if problem:
        return None, problem
    return GripperGoal(float(positions[0]), max_effort=effort, max_velocity=velocity), ''


@dataclass
class GripperMove:
    """A gripper move in progress, checked at the controller's control rate.

    It ends when the joint is within ``tolerance`` of the goal, or at ``deadline``; it has
    stalled when the joint moved less than :data:`STALL_MOTION` between two checks.

    Attributes
    ----------
    goal : GripperGoal
        What the move asked for.
    tolerance : float
        Joint angle tolerance that ends the move [rad] (``release_tolerance``).
    deadline : float
        Time at which the move ends unreached [s] (now + ``release_timeout``).
    theta : float
        Joint angle at the latest check [rad]; NaN before the first joint state.
    effort : float
        Joint effort at the latest check [N m] (mean of the finger joints, along theta:
        negative while squeezing); NaN when not reported.
    stalled : bool
        The joint did not move between the last two checks.
    finished : bool
        The move has ended.
    """

    goal: GripperGoal
    tolerance: float
    deadline: float
    theta: float = math.nan
    effort: float = math.nan
    stalled: bool = False
    finished: bool = False

    @property
    def reached(self) -> bool:
        """The joint is within ``tolerance`` of the goal's position."""
        return math.isfinite(self.theta) and \
            abs(self.theta - self.goal.position) <= self.tolerance

    @property
    def stalled_short(self) -> bool:
        """The move stopped short of its goal: stalled and not reached (a result's
        ``stalled``)."""
        return self.stalled and not self.reached

    @property
    def position(self) -> float:
        """The joint angle to report [rad]: the latest measured, or the goal before any."""
        return self.theta if math.isfinite(self.theta) else self.goal.position

    def observe(self, theta: float | None, effort: float | None, now: float) -> bool:
        """Check the move with the latest joint state; True once it has ended.

        Parameters
        ----------
        theta : float or None
            Latest joint angle [rad] (None: no joint state yet).
        effort : float or None
            Latest joint effort [N m] (None: not reported).
        now : float
            Current time [s], on the clock of ``deadline``.

        Returns
        -------
        bool
            ``finished``: reached, or ``now`` at or past the deadline.
        """
        if self.finished:
            return True
        if theta is not None:
            self.stalled = abs(theta - self.theta) < STALL_MOTION
            self.theta = float(theta)
            self.effort = float(effort) if effort is not None else math.nan
        self.finished = self.reached or now >= self.deadline
        return self.finished
