"""The grasp state machine: configuration, commands (start, cancel, fault reset), the step.

Every step first runs the safety checks (:mod:`.safety`); when they let the grasp go on, the
handler of the current state (:mod:`.phases`) advances it. The procedure is described in
:mod:`forte_control.state_machine`. Pure Python, no rclpy.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from forte_control.state_machine.controller_params import ControllerParams, grasp_params
from forte_control.state_machine.lift_check import LiftCheckParams, OpenGripperLevels
from forte_control.state_machine.phases import GraspPhases
from forte_control.state_machine.progress import GraspProgress, LatestInputs
from forte_control.state_machine.safety import (
    SafetyStop,
    SafetyVerdict,
    check_step,
    check_time,
    flag_names,
    persisting_conditions,
    stale_flags,
)
from forte_control.state_machine.types import (
    ACTIVE_STATES,
    ControlInputs,
    Controller,
    ControlOutputs,
    FaultFlag,
    GraspGoal,
    GraspState,
    Outcome,
    ServoOutput,
)

__all__ = ['GraspStateMachine']


class GraspStateMachine(GraspPhases):
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
        self._grasp: GraspProgress | None = None
        self._fault_flags = FaultFlag.NONE
        self._last_outcome = Outcome.NONE
        self._servo: ServoOutput | None = None
        self._arm_velocity = 0.0
        self._last_step: float | None = None
        self._latest = LatestInputs()
        self._message = 'idle'
        self._finished_pending = False

    # -- configuration (a grasp in progress keeps what it started with) ---------------
    @property
    def params(self) -> ControllerParams:
        """Node-level parameters (applied to the next grasp)."""
        return self._params

    @property
    def lift_check(self) -> LiftCheckParams:
        """Thresholds of the lift verification (applied to the next grasp)."""
        return self._lift_check

    def set_params(self, params: ControllerParams) -> tuple[bool, str]:
        """Replace the parameters; refused with a reason when unsafe."""
        return self._configure('_params', params)

    def set_lift_check(self, lift_check: LiftCheckParams) -> tuple[bool, str]:
        """Replace the lift verification's thresholds; refused with a reason when unusable."""
        return self._configure('_lift_check', lift_check)

    def _configure(self, attribute: str, config: ControllerParams | LiftCheckParams
                   ) -> tuple[bool, str]:
        """Keep ``config`` as ``attribute`` when it has no problems: ``(True, 'ok')``, else
        ``(False, the problems)``."""
        problems = config.problems()
        if problems:
            return False, '; '.join(problems)
        setattr(self, attribute, config)
        return True, 'ok'

    # -- state ---------------------------------------------------------------------------
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
        goal is refused (see :func:`.controller_params.grasp_params`).
        """
        return grasp_params(self._params, goal)

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
        check_time(now)
        if inputs is not None:
            self._latest.remember(inputs, now)
        if self._state == GraspState.FAULT:
            return False, f'fault latched ({flag_names(self._fault_flags)}); reset it first'
        if self._state in ACTIVE_STATES:
            return False, f'busy: grasp in progress ({self._state.name})'
        params, reason = self.effective_params(goal)
        if params is None:
            return False, reason
        controller = Controller(int(goal.controller))
        stale = stale_flags(self._latest, now, params, controller)
        if stale:
            return False, f'refused before any motion: {flag_names(stale)}'
        joint = self._latest.joint
        assert joint is not None  # checked by stale_flags
        if joint.servo_error:
            return False, 'refused: servo reports a hardware error'
        if controller != Controller.ON_OFF:
            perception = self._latest.perception
            assert perception is not None
            if not perception.data_valid:
                return False, 'refused: perception reports invalid data'
        start_angle = joint.theta
        self._controller = controller
        self._grasp = GraspProgress(goal=goal, params=params, lift_check=self._lift_check,
                                    start_time=now, phase_start=now,
                                    ramp_start_angle=max(start_angle, params.min_angle),
                                    target_force=params.initial_force,
                                    open_levels=OpenGripperLevels(
                                        self._lift_check.balance_window,
                                        2 * self._lift_check.min_finger_level))
        self._state = GraspState.CLOSING
        # the command starts where the gripper is: every active state has a command to hold
        self._command(self._grasp.ramp_start_angle, params.closing_speed)
        self._grasp.ramp_commands.record(now, self._grasp.ramp_start_angle)
        self._arm_velocity = 0.0
        self._last_step = now
        self._message = f'{controller.name}: closing from {start_angle:.3f} rad'
        return True, 'accepted'

    def cancel(self, now: float) -> ControlOutputs:
        """Stop motion immediately: arm velocity 0, gripper held at its current command."""
        check_time(now)
        return self._move_to(now, self._cancel_active)

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
        check_time(now)
        if inputs is not None:
            self._latest.remember(inputs, now)
        if self._state != GraspState.FAULT:
            return False, f'no fault latched (state {self._state.name})', FaultFlag.NONE
        force_params = self._grasp.params if self._grasp is not None else self._params
        persisting = persisting_conditions(self._latest, now, self._params, force_params,
                                           self._controller)
        if persisting:
            return (False, f'refused: condition persists ({flag_names(persisting)})',
                    FaultFlag.NONE)
        cleared = self._fault_flags
        self._fault_flags = FaultFlag.NONE
        self._state = GraspState.IDLE
        self._grasp = None
        self._arm_velocity = 0.0
        self._message = f'fault reset ({flag_names(cleared)} cleared)'
        return True, self._message, cleared

    # -- the step --------------------------------------------------------------------------
    def step(self, inputs: ControlInputs, now: float) -> ControlOutputs:
        """Advance the machine to time ``now`` with the latest inputs; return the commands."""
        check_time(now)
        self._latest.remember(inputs, now)
        return self._move_to(now, lambda: self._advance(now))

    def _move_to(self, now: float, active: Callable[[], bool]) -> ControlOutputs:
        """Bring the machine to ``now``: the lift integrates the last arm velocity and
        ``active`` (True if it tightened on slip) acts on a grasp in progress; else the arm
        stays still. Returns the outputs."""
        servo_before = self._servo
        slip_reacted = False
        if self._state in ACTIVE_STATES and self._grasp is not None:
            self._integrate(now)
            slip_reacted = active()
        else:
            self._arm_velocity = 0.0
        self._last_step = now
        return self._outputs(servo_changed=self._servo != servo_before,
                             slip_reacted=slip_reacted)

    def _integrate(self, now: float) -> None:
        """The lift height integrates the arm velocity commanded at the previous step."""
        grasp = self._grasp
        if self._last_step is not None and grasp is not None:
            dt = max(0.0, now - self._last_step)
            grasp.lift_height += self._arm_velocity * dt

    def _cancel_active(self) -> bool:
        self._finish(Outcome.CANCELED, 'canceled: motion stopped, grip held')
        return False

    def _advance(self, now: float) -> bool:
        """Safety checks, then the handler of the state; True if a slip tightening was
        commanded."""
        assert self._grasp is not None
        verdict = check_step(self._grasp, self._latest, self._state, self._controller, now)
        if verdict.stop is not None:
            self._stop(verdict, now)
            return False
        handler = self._PHASES[self._state]
        return handler(self, now, self._latest.perception, verdict.perception_valid)

    def _stop(self, verdict: SafetyVerdict, now: float) -> None:
        """Act on a safety check that stops the phase: fault, timeout or hold."""
        if verdict.stop is SafetyStop.FAULT:
            self._fault(verdict.flags, verdict.message, verdict.outcome)
        elif verdict.stop is SafetyStop.TIMEOUT:
            self._finish(Outcome.TIMEOUT, verdict.message)
        else:  # force above the cap, not confirmed yet: never tighten meanwhile
            if self._state in (GraspState.CLOSING, GraspState.LOADING):
                self._hold_ramp(now)
            self._message = verdict.message

    # -- outputs ----------------------------------------------------------------------------
    def _outputs(self, servo_changed: bool, slip_reacted: bool) -> ControlOutputs:
        """The commands and the state to report after a step."""
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
            gross_slip_events=grasp.gross_slip_events if grasp is not None else 0,
            slip_duration=grasp.slip_duration if grasp is not None else 0.0,
        )
