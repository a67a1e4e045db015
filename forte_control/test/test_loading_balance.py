"""FORTE loads on while a heavy object is pinned against one finger (docs/control.md,
"Loading until both fingers hold").

Synthetic physics: the fingers close symmetrically; the left one touches the object at
``LEFT_TOUCH`` and presses it with STIFFNESS x its travel. The object rests on the table,
whose friction (``TABLE_FRICTION``) holds it where it is until the push exceeds it; the right
finger touches at ``right_touch``. Once both touch, a static object is squeezed by both
fingers' travel. A finger's three channels read its force through one gain per leg, and
the force estimate is the sum of both fingers' forces.
"""
from __future__ import annotations

from dataclasses import replace

import pytest
from grasp_world import DT, GraspWorld

from forte_control import state_machine
from forte_control.state_machine import Controller, GraspState
from forte_control.state_machine.lift_check import pinned_against_one_finger

STIFFNESS = 5.0                 # finger force per rad of travel past its touch [N/rad]
LEFT_TOUCH = 0.5                # command at which the left finger touches [rad]
TABLE_FRICTION = 1.2            # force the table's friction holds the object with [N]
LEG_GAINS = (0.10, 0.06, 0.03)  # (distal, middle, root) channel per N of finger force


class PinnedWorld(GraspWorld):
    """An object on the table, touched first by the left finger."""

    def __init__(self, right_touch: float, params: state_machine.ControllerParams,
                 controller: Controller = Controller.FORTE) -> None:
        super().__init__(params)
        self.controller = controller
        self.right_touch = right_touch
        self.messages: list[str] = []

    def forces(self) -> tuple[float, float]:
        """(left, right) finger forces at the current command [N]."""
        left = max(0.0, STIFFNESS * (LEFT_TOUCH - self.theta))
        right = max(0.0, STIFFNESS * (self.right_touch - self.theta))
        if right == 0.0:
            left = min(left, TABLE_FRICTION)  # the object slides on the table, pushed
        return left, right

    def perception(self) -> state_machine.PerceptionInput:
        left, right = self.forces()
        filtered = tuple(gain * left for gain in LEG_GAINS) + \
            tuple(gain * right for gain in LEG_GAINS)
        return state_machine.PerceptionInput(
            stamp=self.now, force=left + right, force_valid=True,
            contact=(left > 0.0, right > 0.0), slip_active=True, filtered=filtered)

    def run_to_lift(self) -> tuple[float, float, float]:
        """Step until LIFTING begins: (command, left force, right force) then."""
        self.start(self.controller)
        while self.now < 40.0:
            out, _ = self.step()
            self.messages.append(out.message)
            if out.state == GraspState.LIFTING:
                return (self.theta, *self.forces())
            assert out.state in (GraspState.CLOSING, GraspState.LOADING), out.message
        raise AssertionError('never lifted')


#: The contact is flagged a few ramp steps after the touch (closing at 0.25 rad/s), and the
#: force target is initial_force above the force then: the target command comes that much
#: earlier than the touch alone says [rad].
CONTACT_OVERSHOOT = 0.005


def target_command(params: state_machine.ControllerParams, fingers: int = 1) -> float:
    """The command at which ``fingers`` touching at LEFT_TOUCH reach the force target [rad]."""
    return LEFT_TOUCH - params.initial_force / (fingers * STIFFNESS)


def test_forte_loads_on_until_both_fingers_hold_then_lifts():
    params = state_machine.ControllerParams()
    world = PinnedWorld(right_touch=0.42, params=params)
    theta, left, right = world.run_to_lift()
    assert right >= params.min_finger_share * left > 0.0
    # it stopped as soon as the share was reached (within one 10 ms ramp step)
    needed = (0.42 - params.min_finger_share * LEFT_TOUCH) / (1.0 - params.min_finger_share)
    assert theta == pytest.approx(needed, abs=params.loading_speed * DT * 2 + 1e-9)
    assert target_command(params) - theta < params.max_balancing_closing
    assert any('pinned against one finger' in message for message in world.messages)


@pytest.mark.parametrize('params, controller', [
    (replace(state_machine.ControllerParams(), min_finger_share=0.0), Controller.FORTE),
    (state_machine.ControllerParams(), Controller.NO_SLIP),
])
def test_the_papers_loading_lifts_at_the_target_on_one_finger(params, controller):
    """min_finger_share 0 (the paper's loading) and the other controllers lift at the force
    target although the right finger has not touched: the pinned grip the rule avoids."""
    world = PinnedWorld(right_touch=0.42, params=params, controller=controller)
    theta, left, right = world.run_to_lift()
    assert right == 0.0 and left >= params.initial_force
    assert theta == pytest.approx(target_command(params), abs=CONTACT_OVERSHOOT)


def test_the_extra_closing_stops_at_its_cap():
    """A right finger out of reach: at most max_balancing_closing past the target, then
    the lift (the lift monitor judges what follows)."""
    params = state_machine.ControllerParams()
    world = PinnedWorld(right_touch=0.1, params=params)
    theta, left, right = world.run_to_lift()
    assert right == 0.0 and left > params.initial_force
    closed_past = target_command(params) - theta
    assert closed_past == pytest.approx(params.max_balancing_closing, abs=CONTACT_OVERSHOOT)


def test_a_centred_object_lifts_at_the_target():
    """Both fingers touch together: nothing changes against the paper's loading."""
    params = state_machine.ControllerParams()
    world = PinnedWorld(right_touch=LEFT_TOUCH, params=params)
    theta, left, right = world.run_to_lift()
    assert left == right
    assert theta == pytest.approx(target_command(params, fingers=2), abs=CONTACT_OVERSHOOT)
    assert not any('pinned' in message for message in world.messages)


@pytest.mark.parametrize('filtered, zero, pinned', [
    ((0.1, 0.06, 0.03, 0.03, 0.018, 0.009), (0.0, 0.0), True),    # share 0.30 < 0.33
    ((0.1, 0.06, 0.03, 0.034, 0.0204, 0.0102), (0.0, 0.0), False),  # share 0.34
    ((0.03, 0.018, 0.009, 0.1, 0.06, 0.03), (0.0, 0.0), True),    # either finger
    ((0.003, 0.002, 0.0, 0.0, 0.0, 0.0), (0.0, 0.0), False),      # below the floor: unloaded
    ((0.1, 0.06, 0.03, 0.05, 0.03, 0.015), (0.0, 0.05), True),    # after the open zero
    ((0.1, 0.06, float('nan'), 0.0, 0.0, 0.0), (0.0, 0.0), False),  # no evidence from NaN
    (None, (0.0, 0.0), False),
])
def test_pinned_evidence_known_answers(filtered, zero, pinned):
    evidence = pinned_against_one_finger(filtered, zero, 0.33, 0.006)
    assert bool(evidence) == pinned
    if pinned:
        assert 'pinned against one finger' in evidence


def test_pinned_evidence_is_off_at_share_zero():
    assert pinned_against_one_finger((0.1, 0.06, 0.03, 0.0, 0.0, 0.0), (0.0, 0.0), 0.0,
                                     0.006) == ''
