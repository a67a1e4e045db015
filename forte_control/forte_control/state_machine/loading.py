"""LOADING: the grip loaded to the force target before the lift (a base of the phases).

:class:`LoadingPhase` holds the LOADING handler of :class:`~.phases.GraspPhases` and the
target it loads to. FORTE loads on past the target while the object is pinned against one
finger (:func:`~.lift_check.pinned_against_one_finger`): a heavy object that the first
finger pushed against the table's friction reaches the force target on that finger alone,
and a lift from there slides the fingers on it before anything rings (docs/control.md,
"Loading until both fingers hold"). Pure Python, no rclpy.
"""
from __future__ import annotations

import math

from forte_control.state_machine.lift_check import pinned_against_one_finger
from forte_control.state_machine.types import Controller, FaultFlag, PerceptionInput

__all__ = ['LoadingPhase']


class LoadingPhase:
    """LOADING handler and force target; the attributes are the machine's (see
    :class:`~.phases.GraspPhases`)."""

    def _loading(self, now: float, perception: PerceptionInput | None, valid: bool) -> bool:
        """LOADING: ramp on at loading_speed until the force target, then LIFTING."""
        grasp = self._grasp
        assert grasp is not None
        if not valid:
            self._hold_ramp(now)
            return False
        assert perception is not None
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
        if perception.force >= grasp.target_force and not self._pinned(perception):
            self._enter_lifting(now, f'loaded {perception.force:.3f} N (target '
                                f'{grasp.target_force:.3f} N), lifting')
            return False
        command = self._ramp(now, p.loading_speed, p.min_angle)
        self._command(command, p.loading_speed)
        if command <= p.min_angle:
            self._enter_lifting(now, f'closed fully at {perception.force:.3f} N before the '
                                f'target {grasp.target_force:.3f} N, lifting')
        return False

    def _pinned(self, perception: PerceptionInput) -> bool:
        """FORTE at the force target: True while the object is pinned against one finger and
        the loading may still close for it (``max_balancing_closing`` past the command that
        first reached the target); the message names the evidence once."""
        grasp = self._grasp
        assert grasp is not None and self._servo is not None
        p = grasp.params
        if self._controller != Controller.FORTE:
            return False
        evidence = pinned_against_one_finger(perception.filtered, grasp.levels_zero(),
                                             p.min_finger_share, grasp.lift_check.balance_floor)
        if not evidence:
            return False
        if grasp.balancing_from is None:
            grasp.balancing_from = self._servo.position
            self._message = f'loaded {perception.force:.3f} N but {evidence}: loading on'
        return grasp.balancing_from - self._servo.position < p.max_balancing_closing - 1e-12

    def _update_target(self, perception: PerceptionInput) -> None:
        """The force target: ``initial_force``, above the force at contact if 'relative'."""
        grasp = self._grasp
        assert grasp is not None
        p = grasp.params
        if p.initial_force_mode == 'absolute':
            grasp.target_force = p.initial_force
        elif grasp.contact_force is not None:
            grasp.target_force = grasp.contact_force + p.initial_force
        else:
            grasp.target_force = math.nan  # unknown until a valid force arrives
