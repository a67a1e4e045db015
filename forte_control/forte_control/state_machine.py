"""The FORTE grasp state machine: a pure function of its inputs and time (no rclpy).

The procedure follows the results section of the FORTE paper:

1. CLOSING: the servo command ramps towards closed (theta decreases) at ``closing_speed``
   until the perception reports contact (``contact_mode``: either finger, the paper's "any
   channel", or both fingers).
2. LOADING: the command keeps ramping, at ``loading_speed``, until the estimated grip force
   is ``initial_force`` above the force at contact (``initial_force_mode='relative'``) or
   reaches ``initial_force`` (``'absolute'``).
3. LIFTING: the arm moves up at ``lift_speed``; with the FORTE controller every slip flag
   (outside a refractory period) tightens the servo by ``slip_increment``; the lift ends
   with success when the commanded lift height reaches ``lift_distance``.
4. HOLDING: the arm stops, the grip is held (and still tightened on slip) for
   ``hold_duration``; then DONE with outcome LIFTED, or RELEASING (gripper opens) when the
   goal asked for it.

Drops are detected from the sensors during LIFTING and HOLDING (see :class:`DropDetector`).
The commanded lift proves nothing about the object: at the end of the hold the evidence of
the lift (:mod:`.lift_check`: both fingers loaded equally, as only a free object can be, and
no slip in the last part of the lift) decides between LIFTED and NOT_CARRIED. Closing fully
without a contact flag ends in NO_CONTACT only if nothing was squeezed (joint not blocked,
no deformation, force or current rise); else CLOSED_ON_OBJECT.
NO_SLIP runs the same procedure without the slip reaction; ON_OFF closes fully at constant
speed without sensing and lifts (its sensors only decide the recorded outcome).

Safety is checked on every step before anything moves: freshness of perception and joint
state, validity of the perception data, force cap, tightening cap, lift cap. A safety fault
stops the arm, holds the gripper at its current command and latches until
:meth:`GraspStateMachine.reset_fault`, which is refused while the condition persists.

Time is a float in seconds on one clock shared by ``now`` and the input stamps (ROS time in
the node, simulation time in the closed loop).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from enum import IntEnum, IntFlag
from typing import Any

from forte_control.lift_check import (
    DropDetector,
    LiftCheckParams,
    LiftMonitor,
    WrenchInput,
    closed_on_object_evidence,
)
from forte_control.parameters import (  # noqa: F401 - HARD_MAX_* re-exported
    HARD_MAX_ANGLE,
    HARD_MAX_CURRENT,
    HARD_MAX_FORCE,
    HARD_MAX_FRESHNESS,
    HARD_MAX_LIFT_DISTANCE,
    HARD_MAX_LIFT_SPEED,
    HARD_MAX_SERVO_SPEED,
    HARD_MAX_SLIP_INCREMENT,
    HARD_MAX_TIGHTENING,
    range_problems,
)

# ---------------------------------------------------------------------------------------
# Constants mirrored from forte_msgs (tests check they equal the message constants).


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

#: Set-down probe: time constant of the approach to the end point [s], and the distance
#: from it at which the probe counts as arrived [m].
_PROBE_APPROACH = 0.2
_PROBE_END = 1e-5

#: The paper's slip response, 0.88 degree [rad].
PAPER_SLIP_INCREMENT = math.radians(0.88)

# Hard limits no parameter may exceed (HARD_MAX_*): defined with the parameter table in
# forte_control.parameters and imported above, so they stay importable from here.


# ---------------------------------------------------------------------------------------
# Parameters


@dataclass(frozen=True)
class ControllerParams:
    """Configuration of the grasp controller (node parameters; a goal may override some).

    Angles in rad (paper convention: 0 = fully closed, closing decreases theta), forces in
    N, distances in m, speeds in rad/s or m/s, times in s, current in A.
    """

    # closing and contact
    closing_speed: float = 0.25             # servo command ramp while closing [rad/s]
    contact_mode: str = 'either'            # 'either' finger (paper: any channel) or 'both'
    min_angle: float = 0.0                  # most closed command allowed [rad]
    no_contact_settle: float = 0.3          # wait at min_angle before NO_CONTACT [s]
    # loading
    loading_speed: float = 0.05             # servo command ramp while loading [rad/s]
    initial_force: float = 0.25             # f_init [N]
    initial_force_mode: str = 'relative'    # 'relative' (above force at contact) | 'absolute'
    invalid_force_timeout: float = 0.5      # longest wait for a valid force in LOADING [s]
    # lifting
    lift_speed: float = 0.005               # arm lift speed [m/s]
    lift_distance: float = 0.03             # lift height that counts as success [m]
    hold_duration: float = 1.0              # HOLDING time before the outcome LIFTED [s]
    # slip reaction (FORTE controller)
    slip_increment: float = PAPER_SLIP_INCREMENT   # tightening per slip event [rad]
    slip_refractory: float = 0.05           # min time between two tightenings [s]
    slip_speed: float = 1.0                 # servo profile velocity for tightening [rad/s]
    # drop detection (LIFTING / HOLDING)
    drop_force_fraction: float = 0.3        # drop when force < fraction * reference force
    drop_min_reference_force: float = 0.1   # force detector armed only above this [N]
    drop_level_fraction: float = 0.3        # drop when deformation level < fraction * ref
    drop_min_reference_level: float = 0.01  # level detector armed only above this [-1..1]
    drop_on_contact_loss: bool = False      # also drop when both contact flags are false
    drop_confirm_time: float = 0.1          # condition must persist this long [s]
    # on-off controller
    on_off_closing_speed: float = 0.25      # constant closing speed of ON_OFF [rad/s]
    on_off_settle: float = 0.5              # wait at theta=0 before lifting [s]
    # release
    open_angle: float = 1.0                 # command when releasing [rad]
    release_speed: float = 0.5              # servo speed when releasing [rad/s]
    release_tolerance: float = 0.02         # joint angle tolerance to finish releasing [rad]
    release_timeout: float = 3.0            # longest RELEASING [s]
    # safety
    max_force: float = 8.0                  # force cap [N] (top of the force model range)
    force_limit_confirm: float = 0.03       # force above the cap this long -> fault [s]
    max_tightening: float = 20 * PAPER_SLIP_INCREMENT  # cap on total slip tightening [rad]
    max_lift_distance: float = 0.2          # lift cap [m]
    max_lift_speed: float = 0.02            # largest lift speed a goal may ask [m/s]
    perception_timeout: float = 0.1         # perception freshness bound [s]
    joint_state_timeout: float = 0.2        # joint state freshness bound [s]
    invalid_input_timeout: float = 0.2     # data_valid false this long -> fault [s]
    timeout: float = 60.0                   # whole-grasp timeout [s]
    max_current: float = 1.0                # servo current limit sent with commands [A]

    def problems(self) -> list[str]:
        """Reasons why these parameters are unsafe or inconsistent (empty when valid).

        Ranges and choices come from :data:`forte_control.parameters.CONTROLLER_PARAMETERS`
        (inclusive bounds, the same as the node's parameter descriptors); a value outside
        is reported as ``'<name>=<value> outside [<low>, <high>] <unit>'``. Relations
        between parameters are checked only when every value is in its range.
        """
        out: list[str] = []
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, float) and not math.isfinite(value):
                out.append(f'{item.name} must be finite, got {value}')
        if out:
            return out

        # ranges and choices: the table of forte_control.parameters (the node's descriptors)
        out.extend(range_problems({item.name: getattr(self, item.name) for item in fields(self)}))
        if out:
            return out
        if self.initial_force >= self.max_force:
            out.append(f'initial_force={self.initial_force} N must be below '
                       f'max_force={self.max_force} N')
        if self.lift_speed > self.max_lift_speed:
            out.append(f'lift_speed={self.lift_speed} m/s above max_lift_speed='
                       f'{self.max_lift_speed} m/s')
        if self.lift_distance > self.max_lift_distance:
            out.append(f'lift_distance={self.lift_distance} m above max_lift_distance='
                       f'{self.max_lift_distance} m')
        if self.slip_increment > self.max_tightening and self.max_tightening > 0.0:
            out.append(f'slip_increment={self.slip_increment} rad above max_tightening='
                       f'{self.max_tightening} rad')
        if self.min_angle >= self.open_angle:
            out.append(f'min_angle={self.min_angle} rad must be below open_angle='
                       f'{self.open_angle} rad')
        return out

    def validated(self) -> ControllerParams:
        """Return ``self`` if valid, else raise ``ValueError`` listing every problem."""
        problems = self.problems()
        if problems:
            raise ValueError('unsafe controller parameters: ' + '; '.join(problems))
        return self


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
    data_valid: bool = True
    filtered: tuple[float, ...] | None = None   # (6,) tared filtered channels, optional
    finger_variance: tuple[float, float] = (0.0, 0.0)  # [dB^2], reported in feedback


def perception_input(state: Any, stamp: float, slip: bool | None = None) -> PerceptionInput:
    """The controller's view of one perception state.

    Parameters
    ----------
    state : forte_msgs.msg.TactileState or forte_perception.pipeline.PerceptionOutput
        Anything with TactileState's field names (``force``, ``force_valid``, ``contact``,
        ``slip``, ``slip_active``, ``data_valid``, ``filtered``, ``finger_variance``).
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
        slip_active=bool(state.slip_active), data_valid=bool(state.data_valid),
        filtered=tuple(float(value) for value in state.filtered),
        finger_variance=(float(state.finger_variance[0]), float(state.finger_variance[1])))


@dataclass(frozen=True)
class JointInput:
    """Latest gripper joint state."""

    stamp: float                 # sample time [s]
    theta: float                 # servo angle [rad], 0 = fully closed
    servo_error: bool = False    # hardware error reported by the driver
    effort: float | None = None  # servo current [A] (mean of the servos), None = not reported


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


# ---------------------------------------------------------------------------------------
# The state machine


@dataclass
class _Grasp:
    """Bookkeeping of the grasp in progress."""

    goal: GraspGoal
    params: ControllerParams           # effective parameters (node params + goal overrides)
    lift_check: LiftCheckParams        # lift verification thresholds when the goal started
    start_time: float
    phase_start: float
    ramp_start_angle: float = 0.0      # command at the start of the current ramp [rad]
    contact_force: float | None = None
    target_force: float = 0.0
    force_invalid_since: float | None = None
    over_force_since: float | None = None
    at_min_since: float | None = None
    last_tightening_time: float = -math.inf
    last_slip_stamp: float = -math.inf
    drop: DropDetector | None = None
    lift: LiftMonitor | None = None
    lift_target: float = 0.0           # lift_distance, plus the set-down probe if any [m]
    probe_phase: str = ''              # '', 'down' (lowering), 'settle'
    probe_since: float = 0.0           # start of the probe's settle [s]
    free_current: float | None = None  # lowest servo current while closing [A]
    slip_events: int = 0
    tightening: float = 0.0
    lift_height: float = 0.0
    outcome: Outcome = Outcome.NONE


@dataclass
class _Latest:
    perception: PerceptionInput | None = None
    joint: JointInput | None = None
    wrench: WrenchInput | None = None
    invalid_since: float | None = None


class GraspStateMachine:
    """The grasp controller as a pure state machine.

    Parameters
    ----------
    params : ControllerParams
        Node-level configuration and safety caps; validated (``ValueError`` if unsafe).
    lift_check : LiftCheckParams, optional
        Thresholds of the lift verification and of the closed-on-object check.

    Notes
    -----
    Call :meth:`step` periodically (the node does it at 20 Hz and on every perception
    message that carries slip) with the latest inputs. Nothing happens between calls: the
    outputs of a step hold until the next one, and the commanded lift height integrates the
    arm velocity commanded at the previous step over the elapsed time.
    """

    def __init__(self, params: ControllerParams | None = None,
                 lift_check: LiftCheckParams | None = None) -> None:
        self._params = (params or ControllerParams()).validated()
        ok, reason = self.set_lift_check(lift_check or LiftCheckParams())
        if not ok:
            raise ValueError(f'unusable lift check parameters: {reason}')
        self._state = GraspState.IDLE
        self._controller = Controller.FORTE
        self._grasp: _Grasp | None = None
        self._fault_flags = FaultFlag.NONE
        self._last_outcome = Outcome.NONE
        self._servo: ServoOutput | None = None
        self._arm_velocity = 0.0
        self._last_step: float | None = None
        self._latest = _Latest()
        self._message = 'idle'
        self._finished_pending = False

    # -- configuration -----------------------------------------------------------------
    @property
    def params(self) -> ControllerParams:
        """Node-level parameters (applied to the next grasp)."""
        return self._params

    def set_params(self, params: ControllerParams) -> tuple[bool, str]:
        """Replace the parameters; refused with a reason when unsafe.

        A grasp in progress keeps the parameters it started with.
        """
        problems = params.problems()
        if problems:
            return False, '; '.join(problems)
        self._params = params
        return True, 'ok'

    @property
    def lift_check(self) -> LiftCheckParams:
        """Thresholds of the lift verification (applied to the next grasp)."""
        return self._lift_check

    def set_lift_check(self, lift_check: LiftCheckParams) -> tuple[bool, str]:
        """Replace the lift verification's thresholds; refused with a reason when unusable.

        A grasp in progress keeps the thresholds it started with.
        """
        problems = lift_check.problems()
        if problems:
            return False, '; '.join(problems)
        self._lift_check = lift_check
        return True, 'ok'

    @property
    def state(self) -> GraspState:
        return self._state

    @property
    def fault_flags(self) -> FaultFlag:
        return self._fault_flags

    @property
    def last_outcome(self) -> Outcome:
        return self._last_outcome

    def effective_params(self, goal: GraspGoal) -> tuple[ControllerParams | None, str]:
        """Parameters of a grasp: node parameters with the goal's non-zero overrides.

        Goal caps may only be tighter than the node caps. Returns ``(None, reason)`` if the
        goal is refused.
        """
        p = self._params
        problems = []
        for name in ('initial_force', 'lift_speed', 'lift_distance', 'slip_increment',
                     'max_tightening', 'max_force', 'timeout'):
            value = getattr(goal, name)
            if not math.isfinite(value) or value < 0.0:
                problems.append(f'goal {name}={value} must be finite and >= 0 (0 = default)')
        if problems:
            return None, '; '.join(problems)
        try:
            Controller(int(goal.controller))
        except ValueError:
            return None, f'unknown controller {goal.controller}'
        if goal.max_force > p.max_force:
            problems.append(f'goal max_force={goal.max_force} N above the node cap '
                            f'{p.max_force} N')
        if goal.max_tightening > p.max_tightening:
            problems.append(f'goal max_tightening={goal.max_tightening} rad above the node cap '
                            f'{p.max_tightening} rad')
        if goal.lift_distance > p.max_lift_distance:
            problems.append(f'goal lift_distance={goal.lift_distance} m above the lift cap '
                            f'{p.max_lift_distance} m')
        if goal.lift_speed > p.max_lift_speed:
            problems.append(f'goal lift_speed={goal.lift_speed} m/s above max_lift_speed '
                            f'{p.max_lift_speed} m/s')
        if problems:
            return None, '; '.join(problems)
        overrides = {name: getattr(goal, name) for name in
                     ('initial_force', 'lift_speed', 'lift_distance', 'slip_increment',
                      'max_tightening', 'max_force', 'timeout') if getattr(goal, name) > 0.0}
        params = replace(p, **overrides)
        problems = params.problems()
        if problems:
            return None, 'goal refused: ' + '; '.join(problems)
        return params, 'ok'

    # -- commands ------------------------------------------------------------------------
    def start(self, goal: GraspGoal, now: float, inputs: ControlInputs | None = None
              ) -> tuple[bool, str]:
        """Begin a grasp; refused (``False``, reason) when busy, faulted or data is stale.

        Parameters
        ----------
        goal : GraspGoal
        now : float
            Current time [s].
        inputs : ControlInputs, optional
            Latest inputs (else those of the last step).
        """
        _check_time(now)
        if inputs is not None:
            self._remember(inputs, now)
        if self._state == GraspState.FAULT:
            return False, f'fault latched ({_flag_names(self._fault_flags)}); reset it first'
        if self._state in ACTIVE_STATES:
            return False, f'busy: grasp in progress ({self._state.name})'
        params, reason = self.effective_params(goal)
        if params is None:
            return False, reason
        controller = Controller(int(goal.controller))
        stale = self._stale_flags(now, params, controller)
        if stale:
            return False, f'refused before any motion: {_flag_names(stale)}'
        joint = self._latest.joint
        assert joint is not None  # checked by _stale_flags
        if joint.servo_error:
            return False, 'refused: servo reports a hardware error'
        if controller != Controller.ON_OFF:
            perception = self._latest.perception
            assert perception is not None
            if not perception.data_valid:
                return False, 'refused: perception reports invalid data'
        start_angle = joint.theta
        self._controller = controller
        self._grasp = _Grasp(goal=goal, params=params, lift_check=self._lift_check,
                             start_time=now, phase_start=now,
                             ramp_start_angle=max(start_angle, params.min_angle),
                             target_force=params.initial_force)
        self._state = GraspState.CLOSING
        # the command starts where the gripper is: every active state has a command to hold
        self._command(self._grasp.ramp_start_angle, params.closing_speed)
        self._arm_velocity = 0.0
        self._last_step = now
        self._message = f'{controller.name}: closing from {start_angle:.3f} rad'
        return True, 'accepted'

    def cancel(self, now: float) -> ControlOutputs:
        """Stop motion immediately: arm velocity 0, gripper held at its current command."""
        _check_time(now)
        servo_before = self._servo
        if self._state in ACTIVE_STATES and self._grasp is not None:
            self._integrate(now)
            self._finish(Outcome.CANCELED, 'canceled: motion stopped, grip held')
        else:
            self._arm_velocity = 0.0
        self._last_step = now
        return self._outputs(servo_changed=self._servo != servo_before, slip_reacted=False)

    def reset_fault(self, now: float, inputs: ControlInputs | None = None
                    ) -> tuple[bool, str, FaultFlag]:
        """Leave FAULT (to IDLE); refused while a fault condition persists.

        Parameters
        ----------
        now : float
            Current time [s].
        inputs : ControlInputs, optional
            Latest inputs, judged for the persisting conditions (else those of the last
            step), as in :meth:`start`.

        Returns
        -------
        tuple
            ``(success, message, cleared_flags)``.
        """
        _check_time(now)
        if inputs is not None:
            self._remember(inputs, now)
        if self._state != GraspState.FAULT:
            return False, f'no fault latched (state {self._state.name})', FaultFlag.NONE
        persisting = self._persisting_conditions(now)
        if persisting:
            return (False, f'refused: condition persists ({_flag_names(persisting)})',
                    FaultFlag.NONE)
        cleared = self._fault_flags
        self._fault_flags = FaultFlag.NONE
        self._state = GraspState.IDLE
        self._grasp = None
        self._arm_velocity = 0.0
        self._message = f'fault reset ({_flag_names(cleared)} cleared)'
        return True, self._message, cleared

    # -- the step --------------------------------------------------------------------------
    def step(self, inputs: ControlInputs, now: float) -> ControlOutputs:
        """Advance the machine to time ``now`` with the latest inputs; return the commands."""
        _check_time(now)
        servo_before = self._servo
        self._remember(inputs, now)
        slip_reacted = False
        if self._state in ACTIVE_STATES and self._grasp is not None:
            self._integrate(now)
            slip_reacted = self._advance(now)
        else:
            self._arm_velocity = 0.0
        self._last_step = now
        return self._outputs(servo_changed=self._servo != servo_before,
                             slip_reacted=slip_reacted)

    # -- internals -------------------------------------------------------------------------
    def _remember(self, inputs: ControlInputs, now: float) -> None:
        latest = self._latest
        if inputs.perception is not None:
            latest.perception = inputs.perception
            if inputs.perception.data_valid:
                latest.invalid_since = None
            elif latest.invalid_since is None:
                latest.invalid_since = now
        if inputs.joint is not None:
            latest.joint = inputs.joint
        if inputs.wrench is not None:
            latest.wrench = inputs.wrench

    def _integrate(self, now: float) -> None:
        grasp = self._grasp
        if self._last_step is not None and grasp is not None:
            dt = max(0.0, now - self._last_step)
            grasp.lift_height += self._arm_velocity * dt

    def _stale_flags(self, now: float, params: ControllerParams, controller: Controller
                     ) -> FaultFlag:
        flags = FaultFlag.NONE
        joint = self._latest.joint
        if joint is None or not _fresh(joint.stamp, now, params.joint_state_timeout) \
                or not math.isfinite(joint.theta):
            flags |= FaultFlag.STALE_JOINT_STATE
        if controller != Controller.ON_OFF:
            perception = self._latest.perception
            if perception is None or not _fresh(perception.stamp, now,
                                                params.perception_timeout):
                flags |= FaultFlag.STALE_PERCEPTION
        return flags

    def _persisting_conditions(self, now: float) -> FaultFlag:
        params = self._grasp.params if self._grasp is not None else self._params
        flags = self._stale_flags(now, self._params, self._controller)
        perception = self._latest.perception
        if perception is not None and perception.force_valid \
                and perception.force > params.max_force and self._controller != Controller.ON_OFF:
            flags |= FaultFlag.FORCE_LIMIT
        if (self._controller != Controller.ON_OFF and perception is not None
                and not perception.data_valid):
            flags |= FaultFlag.INVALID_INPUT
        joint = self._latest.joint
        if joint is not None and joint.servo_error:
            flags |= FaultFlag.SERVO
        return flags

    def _fault(self, flags: FaultFlag, message: str, outcome: Outcome = Outcome.FAULT) -> None:
        grasp = self._grasp
        self._fault_flags |= flags
        self._arm_velocity = 0.0
        self._state = GraspState.FAULT
        self._message = f'FAULT {_flag_names(flags)}: {message}'
        if grasp is not None and grasp.outcome == Outcome.NONE:
            grasp.outcome = outcome
            self._last_outcome = outcome
            self._finished_pending = True

    def _finish(self, outcome: Outcome, message: str) -> None:
        grasp = self._grasp
        assert grasp is not None
        grasp.outcome = outcome
        self._last_outcome = outcome
        self._arm_velocity = 0.0
        self._message = message
        self._state = GraspState.DONE
        self._finished_pending = True

    def _enter(self, state: GraspState, now: float) -> None:
        grasp = self._grasp
        assert grasp is not None
        self._state = state
        grasp.phase_start = now
        if self._servo is not None:
            grasp.ramp_start_angle = self._servo.position

    def _command(self, position: float, speed: float) -> None:
        params = self._grasp.params if self._grasp is not None else self._params
        self._servo = ServoOutput(position=float(position), max_current=params.max_current,
                                  profile_velocity=float(speed))

    def _ramp(self, now: float, speed: float, floor: float) -> float:
        grasp = self._grasp
        assert grasp is not None
        return max(floor, grasp.ramp_start_angle - speed * (now - grasp.phase_start))

    def _advance(self, now: float) -> bool:
        """One step of the active grasp; returns True if a slip tightening was commanded."""
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        controller = self._controller
        uses_perception = controller != Controller.ON_OFF
        perception = self._latest.perception
        joint = self._latest.joint
        state = self._state

        # -- safety first -------------------------------------------------------------------
        stale = self._stale_flags(now, p, controller)
        if stale:
            self._fault(stale, 'data older than the freshness bound: arm stopped, gripper held')
            return False
        assert joint is not None
        if joint.servo_error:
            self._fault(FaultFlag.SERVO, 'servo hardware error')
            return False
        if grasp.lift_height > p.max_lift_distance + 1e-9:
            self._fault(FaultFlag.LIFT_LIMIT, f'lift {grasp.lift_height:.4f} m above the cap '
                        f'{p.max_lift_distance} m')
            return False
        if state != GraspState.RELEASING and now - grasp.start_time > p.timeout:
            self._finish(Outcome.TIMEOUT, f'timeout after {p.timeout:g} s in {state.name}')
            return False
        # ON_OFF does not need perception; it uses it (when fresh) only for the outcome
        valid = (perception is not None and perception.data_valid
                 and _fresh(perception.stamp, now, p.perception_timeout))
        if uses_perception:
            assert perception is not None
            valid = perception.data_valid
            if not valid and self._latest.invalid_since is not None \
                    and now - self._latest.invalid_since > p.invalid_input_timeout:
                self._fault(FaultFlag.INVALID_INPUT, 'perception data invalid for more than '
                            f'{p.invalid_input_timeout:g} s')
                return False
            if valid and perception.force_valid and perception.force > p.max_force:
                if grasp.over_force_since is None:
                    grasp.over_force_since = now
                if now - grasp.over_force_since >= p.force_limit_confirm:
                    self._fault(FaultFlag.FORCE_LIMIT, f'force {perception.force:.3f} N above '
                                f'the cap {p.max_force:g} N for {p.force_limit_confirm:g} s',
                                outcome=Outcome.FORCE_LIMIT)
                    return False
                # not confirmed yet (a single estimate can spike): never tighten meanwhile
                if state in (GraspState.CLOSING, GraspState.LOADING):
                    self._hold_ramp(now)
                self._message = f'force {perception.force:.3f} N above the cap, holding'
                return False
            grasp.over_force_since = None

        # -- the phases ------------------------------------------------------------------
        if state == GraspState.CLOSING:
            if controller == Controller.ON_OFF:
                command = self._ramp(now, p.on_off_closing_speed, 0.0)
                self._command(command, p.on_off_closing_speed)
                if command <= 0.0:
                    if grasp.at_min_since is None:
                        grasp.at_min_since = now
                    if now - grasp.at_min_since >= p.on_off_settle:
                        self._enter_lifting(now, 'ON_OFF: closed fully, lifting')
                return False
            if valid and self._contact(perception):
                grasp.contact_force = perception.force if perception.force_valid else None
                self._enter(GraspState.LOADING, now)
                self._update_target(perception)
                self._message = (f'contact at {grasp.ramp_start_angle:.3f} rad, loading to '
                                 f'{grasp.target_force:.3f} N')
                return self._loading(now, perception)
            if not valid:
                # hold the command until the data is valid again (never act on bad data)
                self._hold_ramp(now)
                return False
            command = self._ramp(now, p.closing_speed, p.min_angle)
            self._command(command, p.closing_speed)
            if joint.effort is not None and math.isfinite(joint.effort):
                grasp.free_current = joint.effort if grasp.free_current is None \
                    else min(grasp.free_current, joint.effort)
            if command <= p.min_angle:
                if grasp.at_min_since is None:
                    grasp.at_min_since = now
                if now - grasp.at_min_since >= p.no_contact_settle:
                    self._finish_closed(command, perception)
            return False

        if state == GraspState.LOADING:
            if not valid:
                self._hold_ramp(now)
                return False
            return self._loading(now, perception)

        if state in (GraspState.LIFTING, GraspState.HOLDING):
            return self._lift_or_hold(now, state, perception, valid)

        if state == GraspState.RELEASING:
            self._arm_velocity = 0.0
            self._command(p.open_angle, p.release_speed)
            if joint.theta >= p.open_angle - p.release_tolerance \
                    or now - grasp.phase_start >= p.release_timeout:
                self._state = GraspState.DONE
                self._finished_pending = True
                self._message = 'released'
            return False
        return False

    def _lift_or_hold(self, now: float, state: GraspState,
                      perception: PerceptionInput | None, valid: bool) -> bool:
        """LIFTING / HOLDING: slip reaction, drop detection, lift evidence, arm, verdict."""
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        reacted = False
        if self._controller == Controller.FORTE and valid and perception.slip \
                and perception.slip_active and perception.stamp > grasp.last_slip_stamp:
            grasp.last_slip_stamp = perception.stamp
            if now - grasp.last_tightening_time >= p.slip_refractory:
                if grasp.tightening + p.slip_increment > p.max_tightening + 1e-12:
                    self._fault(FaultFlag.TIGHTENING_LIMIT, 'slip tightening would exceed the '
                                f'cap {p.max_tightening:.4f} rad')
                    return False
                assert self._servo is not None
                position = max(p.min_angle, self._servo.position - p.slip_increment)
                grasp.tightening += self._servo.position - position
                grasp.slip_events += 1
                grasp.last_tightening_time = now
                self._command(position, p.slip_speed)
                self._message = f'slip {grasp.slip_events}: tightened to {position:.4f} rad'
                reacted = True
        if valid and grasp.drop is not None and grasp.drop.update(perception, now):
            self._finish(Outcome.DROPPED, f'dropped in {state.name}: {grasp.drop.reason}')
            return reacted
        if valid and grasp.lift is not None:
            grasp.lift.update(perception.stamp, perception.filtered,
                              perception.slip and perception.slip_active,
                              state == GraspState.HOLDING, self._latest.wrench, now)
        if state == GraspState.LIFTING:
            self._lift_arm(now)
        else:
            self._hold(now)
        return reacted

    def _hold(self, now: float) -> None:
        """HOLDING: arm still for hold_duration, then the set-down probe, then the verdict."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        p = grasp.params
        probe = grasp.lift_target - p.lift_distance
        if not grasp.probe_phase:
            self._arm_velocity = 0.0
            if now - grasp.phase_start < p.hold_duration:
                return
            if probe <= 0.0:
                self._judge_lift(now)
                return
            grasp.probe_phase = 'down'
            grasp.lift.begin_probe()
            self._message = f'set-down probe: lowering {probe * 1000:.1f} mm'
        if grasp.probe_phase == 'down':
            remaining = grasp.lift_height - p.lift_distance
            if remaining > _PROBE_END:
                # slow down exponentially into the end point: stopping a downward motion
                # accelerates the object upward, and a carried object's friction must carry
                # m x that acceleration on top of its weight
                self._arm_velocity = -min(p.lift_speed, remaining / _PROBE_APPROACH)
                return
            grasp.probe_phase = 'settle'
            grasp.probe_since = now
        self._arm_velocity = 0.0
        if now - grasp.probe_since >= grasp.lift_check.probe_settle:
            self._judge_lift(now)

    def _lift_arm(self, now: float) -> None:
        """Arm command while LIFTING: on up to the lift height, then HOLDING."""
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        if grasp.lift_height >= grasp.lift_target - 1e-12:
            self._arm_velocity = 0.0
            self._enter(GraspState.HOLDING, now)
            self._message = f'lifted {grasp.lift_height:.4f} m, holding'
        else:
            self._arm_velocity = p.lift_speed

    def _judge_lift(self, now: float) -> None:
        """End of the hold: LIFTED (or RELEASING) if the object is carried, else NOT_CARRIED."""
        grasp = self._grasp
        assert grasp is not None and grasp.lift is not None
        p = grasp.params
        verdict = grasp.lift.verdict()
        evidence = f': {verdict.reason}'
        if not verdict.carried:
            self._finish(Outcome.NOT_CARRIED, f'lift of {grasp.lift_height:.4f} m commanded, '
                         f'object not carried: {verdict.reason}')
        elif grasp.goal.release_after:
            grasp.outcome = Outcome.LIFTED
            self._last_outcome = Outcome.LIFTED
            self._arm_velocity = 0.0
            self._enter(GraspState.RELEASING, now)
            self._command(p.open_angle, p.release_speed)
            self._message = 'lifted and held; releasing' + evidence
        else:
            self._finish(Outcome.LIFTED, f'lifted {grasp.lift_height:.4f} m and held '
                         f'{p.hold_duration:g} s{evidence}')

    def _hold_ramp(self, now: float) -> None:
        """Freeze the ramp at the current command (restarts from there later)."""
        grasp = self._grasp
        assert grasp is not None
        if self._servo is not None:
            grasp.ramp_start_angle = self._servo.position
        grasp.phase_start = now

    def _contact(self, perception: PerceptionInput | None) -> bool:
        if perception is None:
            return False
        left, right = perception.contact
        if self._grasp is not None and self._grasp.params.contact_mode == 'both':
            return bool(left and right)
        return bool(left or right)

    def _update_target(self, perception: PerceptionInput) -> None:
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        if p.initial_force_mode == 'absolute':
            grasp.target_force = p.initial_force
        elif grasp.contact_force is not None:
            grasp.target_force = grasp.contact_force + p.initial_force
        else:
            grasp.target_force = math.nan  # unknown until a valid force arrives

    def _loading(self, now: float, perception: PerceptionInput) -> bool:
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        if not perception.force_valid or not math.isfinite(perception.force):
            if grasp.force_invalid_since is None:
                grasp.force_invalid_since = now
            if now - grasp.force_invalid_since > p.invalid_force_timeout:
                self._fault(FaultFlag.INVALID_INPUT, 'no valid force estimate for '
                            f'{p.invalid_force_timeout:g} s while loading')
            else:
                self._hold_ramp(now)
            return False
        grasp.force_invalid_since = None
        if grasp.contact_force is None and p.initial_force_mode == 'relative':
            grasp.contact_force = perception.force
            self._update_target(perception)
        if perception.force >= grasp.target_force:
            self._enter_lifting(now, f'loaded {perception.force:.3f} N (target '
                                f'{grasp.target_force:.3f} N), lifting')
            return False
        command = self._ramp(now, p.loading_speed, p.min_angle)
        self._command(command, p.loading_speed)
        if command <= p.min_angle:
            self._enter_lifting(now, f'closed fully at {perception.force:.3f} N before the '
                                f'target {grasp.target_force:.3f} N, lifting')
        return False

    def _enter_lifting(self, now: float, message: str) -> None:
        grasp = self._grasp
        assert grasp is not None
        self._enter(GraspState.LIFTING, now)
        grasp.drop = DropDetector(grasp.params)
        grasp.lift = LiftMonitor(grasp.lift_check)
        probe = grasp.lift_check.probe_distance if grasp.lift_check.verify_lift else 0.0
        if grasp.params.lift_distance + probe > grasp.params.max_lift_distance:
            probe = 0.0  # no room under the lift cap: judged without the probe
        grasp.lift_target = grasp.params.lift_distance + probe
        perception = self._latest.perception
        if perception is not None and perception.data_valid \
                and _fresh(perception.stamp, now, grasp.params.perception_timeout):
            grasp.drop.update(perception, now)  # references from the grip at lift start
        self._arm_velocity = grasp.params.lift_speed
        self._message = message

    def _finish_closed(self, command: float, perception: PerceptionInput | None) -> None:
        """Closed fully without a contact flag: NO_CONTACT, or CLOSED_ON_OBJECT on evidence."""
        grasp = self._grasp
        joint = self._latest.joint
        assert grasp is not None and joint is not None
        filtered = force = None
        if perception is not None and perception.data_valid:
            filtered = perception.filtered
            if perception.force_valid:
                force = perception.force
        evidence = closed_on_object_evidence(grasp.lift_check, command, joint.theta, filtered,
                                             force, joint.effort, grasp.free_current)
        if evidence:
            self._finish(Outcome.CLOSED_ON_OBJECT, 'closed fully without a contact flag, '
                         f'but on something (possibly squeezed): {evidence}')
        else:
            self._finish(Outcome.NO_CONTACT, 'closed fully without contact')

    def _outputs(self, servo_changed: bool, slip_reacted: bool) -> ControlOutputs:
        grasp = self._grasp
        perception = self._latest.perception
        finished = self._finished_pending
        self._finished_pending = False
        force = math.nan
        force_valid = False
        if perception is not None:
            force = perception.force
            force_valid = perception.force_valid
        return ControlOutputs(
            servo=self._servo,
            servo_changed=servo_changed,
            arm_velocity=self._arm_velocity,
            state=self._state,
            controller=self._controller,
            outcome=grasp.outcome if grasp is not None else self._last_outcome,
            fault_flags=self._fault_flags,
            slip_events=grasp.slip_events if grasp is not None else 0,
            slip_reacted=slip_reacted,
            tightening=grasp.tightening if grasp is not None else 0.0,
            lift_height=grasp.lift_height if grasp is not None else 0.0,
            target_force=grasp.target_force if grasp is not None else 0.0,
            estimated_force=force,
            force_valid=force_valid,
            finished=finished,
            message=self._message,
        )


def _fresh(stamp: float, now: float, bound: float) -> bool:
    """True when ``stamp`` is finite and no older than ``bound`` seconds at ``now``."""
    return math.isfinite(stamp) and now - stamp <= bound


def _check_time(now: float) -> None:
    if not isinstance(now, (int, float)) or not math.isfinite(now):
        raise ValueError(f'now must be a finite time in seconds, got {now!r}')


def _flag_names(flags: FaultFlag) -> str:
    names = [flag.name for flag in FaultFlag if flag and flag in flags]
    return '|'.join(names) if names else 'NONE'


__all__ = [
    'ACTIVE_STATES', 'PAPER_SLIP_INCREMENT', 'ControlInputs', 'ControlOutputs', 'Controller',
    'ControllerParams', 'DropDetector', 'FaultFlag', 'GraspGoal', 'GraspState',
    'GraspStateMachine', 'JointInput', 'LiftCheckParams', 'Outcome', 'PerceptionInput',
    'ServoOutput', 'WrenchInput', 'perception_input',
]
