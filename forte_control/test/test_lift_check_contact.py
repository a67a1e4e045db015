"""The lift check on fingers that slide along an object the table holds (issue 38).

Synthetic inputs with the physics of docs/control.md, "Lift verification", rule 4: the
fingers point down, and each one's three channels sit on its distal, middle and root legs
(0.15, 0.5 and 0.85 of a 72 mm sensing span from the tip). A contact's normal load reaches a
channel through the pad with a gain that is largest with the contact over its leg and never
below 55 % of that. When the fingers slide up an object the table holds, the contact moves
toward the fingertips by the arm's travel; a carried object stays where the fingers hold it
once its weight is taken. A tightening changes the grip: every channel of a finger by the
same factor.

And the lift past a late tightening: the object slid along the fingers, possibly onto the
table, and hangs only as high as the lift since.
"""
from __future__ import annotations

import math
import random

import pytest
from grasp_world import DT, GraspWorld, squeeze_force

from forte_control import state_machine
from forte_control.state_machine import Controller, GraspState, Outcome
from forte_control.state_machine.lift_check import LiftCheckParams, LiftMonitor, middle_shift

SPAN = 0.072                       # finger length that the contact location 0..1 covers [m]
CENTRES = (0.15, 0.5, 0.85)        # legs of the distal, middle and root channel [-]
BASE = (0.026, 0.016, 0.010)       # channel gain with the contact over its leg [1/mm]
FLOOR = 0.55                       # share of that gain anywhere on the pad [-]
WIDTH = 0.38                       # reach of a leg along the finger [-]
LIFT_SPEED = 0.005                 # [m/s]


def finger(location: float, deflection: float) -> tuple[float, float, float]:
    """A finger's (distal, middle, root) channels for a contact at ``location`` (0 = tip)
    pressing ``deflection`` [mm]."""
    return tuple(deflection * base * (FLOOR + (1.0 - FLOOR)
                                      * math.exp(-((location - centre) / WIDTH) ** 2))
                 for base, centre in zip(BASE, CENTRES, strict=True))


def grasp(location: float, deflection: float = 2.0) -> tuple[float, ...]:
    """Both fingers alike (levels about 0.09 each: a light grip, the Pocky box's)."""
    return finger(location, deflection) * 2


def lift(monitor: LiftMonitor, location, *, seconds: float = 6.0, hold: float = 1.0,
         tighten_at: float | None = None, noise: float = 0.0, drift=None) -> None:
    """Feed a lift of ``seconds`` and a hold at 100 Hz: ``location(t)`` of the contact,
    optionally a tightening (x 1.5) at ``tighten_at`` [s], white ``noise`` per channel and
    ``drift(t)`` added to every finger's three channels."""
    rng = random.Random(7)
    for k in range(int(round((seconds + hold) / DT))):
        t = k * DT
        holding = t >= seconds
        deflection = 2.0 if tighten_at is None or t < tighten_at else 3.0
        pattern = grasp(location(min(t, seconds)), deflection)
        if drift is not None:
            pattern = tuple(value + extra for value, extra in zip(pattern, drift(t) * 2,
                                                                   strict=True))
        pattern = tuple(value + rng.gauss(0.0, noise) for value in pattern)
        monitor.update(10.0 + t, pattern, False, holding)
        if tighten_at is not None and abs(t - tighten_at) < DT / 2:
            monitor.grip_changed()


def sliding_up(start: float, since: float = 0.0):
    """Contact location of fingers sliding up a resting object from ``since`` [s] on."""
    return lambda t: max(0.0, start - LIFT_SPEED * max(0.0, t - since) / SPAN)


def test_middle_shift_ignores_the_grip_and_sees_the_contact_move():
    params = LiftCheckParams()
    assert middle_shift(grasp(0.3), grasp(0.3, 3.0), 0.01) == pytest.approx(0.0, abs=1e-12)
    # 10 mm toward the tip from 0.3 of the span: the middle leg loses load share
    moved = middle_shift(grasp(0.3), grasp(0.3 - 0.010 / SPAN), 0.01)
    assert moved > params.contact_shift
    # toward the root it gains: no evidence of fingers sliding up the object
    assert middle_shift(grasp(0.3), grasp(0.3 + 0.010 / SPAN), 0.01) < 0.0
    assert middle_shift(grasp(0.3), (0.0,) * 3 + grasp(0.3)[3:], 0.01) is None


def test_fingers_sliding_up_a_resting_object_are_refused():
    """The Pocky box of the closed loop (seed 0, trials 0-2): equal levels, no slip flag, a
    probe fall under probe_unload; the contact moved 16-22 mm toward the tips, the middle
    channels lost 0.0046-0.0083 of load share."""
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, sliding_up(0.3))
    verdict = monitor.verdict()
    assert not verdict.carried and 'contact moved toward the fingertips' in verdict.reason
    assert 'equal' not in verdict.reason.split(';')[0]  # rules 1 and 2 did not refuse it


def test_a_carried_object_stays_where_the_fingers_hold_it():
    """Same grip, the contact still: accepted with sensor noise (0.001 per sample and
    channel, the 11-bit quantum)."""
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, lambda t: 0.3, noise=0.001)
    assert monitor.contact_moved() == ''
    assert monitor.verdict().carried


def test_the_contact_is_placed_again_after_each_tightening():
    """The fingers slid up the object until a tightening 2 s into the lift took its weight
    (the contact then stays): the judged grip is the tightened one. Without the grip change
    the slide before it counts."""
    caught = lambda t: max(0.3 - LIFT_SPEED * min(t, 2.0) / SPAN, 0.0)  # noqa: E731
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, caught, tighten_at=2.0)
    assert monitor.verdict().carried
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, caught)
    assert not monitor.verdict().carried


@pytest.mark.parametrize('shift, carried', [(0.0025, True), (0.0045, False)])
def test_a_pattern_drift_within_contact_shift_is_accepted(shift, carried):
    """A contact cooling toward a cold object lowers every channel by its heated share
    (here 1, 0.6, 0.3) and shifts the middle channels' share too: on carried objects of the
    closed loop (seed 0, 834 trials) by at most 0.0025 (a light grip on a cold meringue);
    the resting Pocky boxes shifted it by 0.0046 or more. contact_shift (0.0035) lies
    between."""
    share = finger(0.3, 2.0)[1] / sum(finger(0.3, 2.0))
    cooling = shift / (2 * (0.6 - 1.9 * share))  # per finger, at the end of the lift

    def drift(t: float) -> tuple[float, ...]:
        ramp = (min(t, 6.0) - 0.55) / (6.0 - 0.55)  # 0 in the first pattern's window
        return tuple(-cooling * ramp * heated for heated in (1.0, 0.6, 0.3))

    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, lambda t: 0.3, drift=drift)
    assert monitor.verdict().carried is carried


def test_no_evidence_without_time_to_move():
    """A lift that ends before the first pattern is complete and over judges nothing here
    (the machine lifts on past a late tightening, so this is a hold without a lift)."""
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, sliding_up(0.3), seconds=0.6)
    assert monitor.contact_moved() == ''


def test_tightenings_in_the_hold_do_not_move_the_first_pattern():
    monitor = LiftMonitor(LiftCheckParams())
    lift(monitor, sliding_up(0.3))
    monitor.grip_changed()
    assert 'contact moved' in monitor.contact_moved()


class LateSlipWorld(GraspWorld):
    """FORTE lifting an object; one slip flag when the lift reaches ``slip_at``: the object
    slid down onto the table there and the tightening holds it (it rises with the fingers
    from then on). Equal, constant tactile pattern: only the arm's path is judged."""

    def __init__(self, slip_at: float, controller: Controller = Controller.FORTE) -> None:
        super().__init__(now=50.0)
        self.controller = controller
        self.slip_at = slip_at
        self.flagged_at = math.nan  # commanded lift when the flag was sent [m]
        self.slip = False

    def perception(self) -> state_machine.PerceptionInput:
        return state_machine.PerceptionInput(
            stamp=self.now, force=squeeze_force(self.theta), force_valid=True,
            contact=(True, True), slip=self.slip, slip_active=True, filtered=grasp(0.3))

    def run(self) -> tuple[state_machine.ControlOutputs, float, list[float]]:
        """Last outputs, the lift of the tightening and the object's height at every step
        after it [m]."""
        self.start(self.controller)
        tightened_at, heights, slipped, lifted = math.nan, [], False, 0.0
        while self.now < 120.0:
            self.slip = not slipped and lifted >= self.slip_at
            if self.slip:
                slipped, self.flagged_at = True, lifted
            out, closed = self.step()
            lifted = out.lift_height
            if closed and out.state in (GraspState.LIFTING, GraspState.HOLDING):
                tightened_at = out.lift_height
            if math.isfinite(tightened_at):
                heights.append(out.lift_height - tightened_at)
            if out.state == GraspState.DONE:
                return out, tightened_at, heights
        raise AssertionError('grasp did not finish')


@pytest.mark.parametrize('slip_at', [0.0296, 0.0316])
def test_a_late_tightening_lifts_on_so_the_probe_cannot_set_the_object_down(slip_at):
    """Closed loop, seed 0: a Pringles can and a metal bottle slid onto the table near the
    lift height, were tightened on there and lifted 1.6-1.9 mm to the top; the 2 mm set-down
    probe then lowered them back onto the table and LIFTED was claimed. Now the arm goes on
    quiet_time of lift (5 mm) and the probe's 2 mm past the tightening: the probe leaves the
    whole 5 mm under the object (within a control step), and the slip is over 1 s before the
    end of the lift (rule 2)."""
    out, tightened_at, heights = LateSlipWorld(slip_at).run()
    check = LiftCheckParams()
    clearance = check.quiet_time * LIFT_SPEED
    assert tightened_at >= slip_at
    assert out.outcome == Outcome.LIFTED, out.message
    top = heights.index(max(heights))
    assert heights[top] == pytest.approx(clearance + check.probe_distance, abs=1e-4)
    assert min(heights[top:]) == pytest.approx(clearance, abs=1e-4)
    assert out.lift_height == pytest.approx(tightened_at + clearance, abs=1e-4)


def test_a_late_slip_flag_lifts_on_until_the_lift_ends_quiet():
    """W/o Slip does not tighten; its slip flag 0.4 mm before the lift height would fall
    into the lift's last quiet_time (rule 2: the fingers still slide). The lift goes on
    until quiet_time of lift has passed since the flag: the object is judged by a lift that
    ends quiet (LIFTED), 5 mm and the probe's 2 mm past the flag, and the probe brings it
    back to 5 mm past the flag."""
    world = LateSlipWorld(0.0316, Controller.NO_SLIP)
    out, tightened_at, _ = world.run()
    check = LiftCheckParams()
    assert math.isnan(tightened_at) and out.slip_events == 0
    assert out.outcome == Outcome.LIFTED, out.message
    assert out.lift_height == pytest.approx(
        world.flagged_at + check.quiet_time * LIFT_SPEED, abs=1e-4)


class SlideUpWorld(GraspWorld):
    """FORTE lifting a smooth object the table holds (the Pocky box): equal levels, no slip
    flag, the contact moving toward the fingertips by the arm's travel, until the grip has
    been tightened ``caught_after`` times (None: never); from then on the object rises with
    the fingers and the contact stays. Each tightening presses the pads 10 % deeper."""

    def __init__(self, caught_after: int | None, lift_check: LiftCheckParams | None = None
                 ) -> None:
        super().__init__(lift_check=lift_check, now=50.0)
        self.caught_after = caught_after
        self.loaded_at: float | None = None
        self.location = 0.4        # contact place along the fingers [-] (0 = tip)
        self.lifted = 0.0          # commanded lift of the previous step [m]
        self.tightened_at: list[float] = []  # commanded lift of each tightening [m]

    def tightenings(self) -> int:
        if self.loaded_at is None:
            return 0
        return round((self.loaded_at - self.theta) / state_machine.PAPER_SLIP_INCREMENT)

    def perception(self) -> state_machine.PerceptionInput:
        return state_machine.PerceptionInput(
            stamp=self.now, force=squeeze_force(self.theta), force_valid=True,
            contact=(True, True), slip_active=True,
            filtered=grasp(self.location, 2.0 * (1.0 + 0.1 * self.tightenings())))

    def run(self) -> state_machine.ControlOutputs:
        self.start(Controller.FORTE)
        while self.now < 120.0:
            out, closed = self.step()
            if closed and self.loaded_at is not None:
                self.tightened_at.append(out.lift_height)
            if out.state == GraspState.LIFTING and self.loaded_at is None:
                self.loaded_at = self.theta
            caught = self.caught_after is not None and self.tightenings() >= self.caught_after
            if not caught:  # the fingers slide up the object by the arm's travel
                travel = out.lift_height - self.lifted
                self.location = max(0.0, self.location - travel / SPAN)
            self.lifted = out.lift_height
            if out.state == GraspState.DONE:
                return out
        raise AssertionError('grasp did not finish')


def test_forte_tightens_when_the_contact_moves_along_the_fingers_and_carries_the_object():
    """No slip flag and equal levels (rules 1 and 2 of the gross-slip reaction see nothing):
    the contact moving toward the fingertips is the evidence. One tightening of two
    increments catches the object, which then rises with the fingers: LIFTED, and the
    contact judged since the tightening stayed put."""
    world = SlideUpWorld(caught_after=2)
    out = world.run()
    assert out.outcome == Outcome.LIFTED, out.message
    assert (out.slip_events, out.gross_slip_events) == (0, 1)
    assert len(world.tightened_at) == 1
    assert world.tightenings() == 2  # one tightening of two increments
    # the evidence needs the first pattern (contact_settle + probe_window) and then the
    # contact to move: never before 5 mm of lift, and well before the lift height
    assert 0.005 < world.tightened_at[0] < 0.02


def test_without_the_reaction_the_sliding_contact_is_refused():
    world = SlideUpWorld(caught_after=2, lift_check=LiftCheckParams(gross_slip_reaction=False))
    out = world.run()
    assert world.tightened_at == []
    assert out.outcome == Outcome.NOT_CARRIED and 'contact moved' in out.message


@pytest.mark.parametrize('caught_after', [None, 3])
def test_an_object_the_tightening_does_not_catch_is_not_claimed_lifted(caught_after):
    """The fingers slide on after the tightening (until the contact reaches the end of the
    sensing span, where a pattern can no longer move): the contact evidence tightens once
    per lift, so the verdict judges the grip since that tightening and sees it move. An
    object that a further increment would have caught is reported NOT_CARRIED: it was not
    caught."""
    world = SlideUpWorld(caught_after=caught_after)
    out = world.run()
    assert len(world.tightened_at) == 1
    assert world.location < 0.05  # the contact ran to the tip
    assert out.outcome == Outcome.NOT_CARRIED and 'contact moved' in out.message


def test_after_the_contact_tightening_the_lift_goes_on_twice_the_travel_of_its_evidence():
    """The object is caught 23 mm up (a contact starting 50 mm from the tip): the lift goes
    on to twice that travel past the tightening, so rule 4 judges the tightened grip over
    46 mm, and the set-down probe leaves it there."""
    world = SlideUpWorld(caught_after=2)
    world.location = 0.7
    out = world.run()
    assert out.outcome == Outcome.LIFTED, out.message
    (tightened_at,) = world.tightened_at
    assert tightened_at > 0.02
    assert out.lift_height == pytest.approx(3.0 * tightened_at, abs=1e-4)
