"""FORTE's reaction to smooth gross slip while lifting (no stick-slip for the detector).

Synthetic inputs with the physics of docs/control.md: fingers that slide up an object the
table still holds stay unequally loaded (the table's friction pins the object against one
finger); fingers that slide off a round object lose their deformation while the grip command
is unchanged. A tighter grip that overcomes the table's friction centres the object (equal
levels). Numbers: levels are sums of three tared channels (normalised units).
"""
from __future__ import annotations

from dataclasses import replace

import pytest
from grasp_world import ACTIVE, DT, GraspWorld, squeeze_force

from forte_control import state_machine
from forte_control.state_machine import Controller, GraspState, Outcome
from forte_control.state_machine.lift_check import LiftCheckParams, LiftMonitor

EQUAL = (0.10, 0.06, 0.03, 0.10, 0.06, 0.03)       # levels 0.19 / 0.19
ONE_SIDED = (0.10, 0.06, 0.03, 0.05, 0.03, 0.015)  # levels 0.19 / 0.095


def feed(monitor: LiftMonitor, pattern, seconds: float, t0: float = 0.0) -> float:
    """Feed ``pattern`` for ``seconds`` at 100 Hz while lifting; returns the end time."""
    steps = int(round(seconds / DT))
    for k in range(steps):
        monitor.update(t0 + k * DT, pattern, False, False)
    return t0 + steps * DT


def scaled(pattern, factor: float) -> tuple[float, ...]:
    return tuple(factor * v for v in pattern)


def test_equal_steady_levels_are_no_gross_slip():
    monitor = LiftMonitor(LiftCheckParams())
    feed(monitor, EQUAL, 1.0)
    assert monitor.unequal_while_lifting(0.02) == ''
    assert monitor.deformation_decay() == ''


def test_unequal_levels_after_the_minimum_lift_mean_the_table_holds_the_object():
    params = LiftCheckParams()
    monitor = LiftMonitor(params)
    feed(monitor, ONE_SIDED, 1.0)
    assert monitor.unequal_while_lifting(0.9 * params.gross_slip_min_lift) == ''  # not yet
    evidence = monitor.unequal_while_lifting(params.gross_slip_min_lift)
    assert 'table still holds' in evidence and '0.1900 / 0.0950' in evidence


def test_an_unloaded_finger_is_not_evidence_of_sliding():
    """One finger not touching is a missing contact, not a table holding the object."""
    monitor = LiftMonitor(LiftCheckParams())
    feed(monitor, (0.1, 0.06, 0.03, 0.002, 0.001, 0.0), 1.0)
    assert monitor.unequal_while_lifting(0.02) == ''


@pytest.mark.parametrize('fraction, slides', [(0.85, False), (0.75, True)])
def test_deformation_falling_below_its_lift_peak_means_the_contact_slides_off(fraction,
                                                                              slides):
    """Decay threshold 0.2: 15 % below the peak is not evidence, 25 % is."""
    monitor = LiftMonitor(LiftCheckParams())
    t = feed(monitor, EQUAL, 0.5)
    feed(monitor, scaled(EQUAL, fraction), 0.5, t)
    evidence = monitor.deformation_decay()
    assert ('slides off' in evidence) is slides, evidence


def test_a_barely_loaded_gripper_has_no_decay_evidence():
    """Below twice the loaded level a fall is noise, not an object sliding away."""
    monitor = LiftMonitor(LiftCheckParams())
    t = feed(monitor, scaled(EQUAL, 0.04), 0.5)  # levels 0.0076 each
    feed(monitor, scaled(EQUAL, 0.01), 0.5, t)
    assert monitor.deformation_decay() == ''


class TableWorld(GraspWorld):
    """An object on the table pinned against the left finger until the grip exceeds
    ``free_after`` tightenings: from then on it is centred (equal levels). In contact from
    the start; the grip force grows 5 N/rad as the servo closes."""

    def __init__(self, controller: Controller, free_after: int | None,
                 lift_check: LiftCheckParams | None = None) -> None:
        super().__init__(lift_check=lift_check)
        self.controller = controller
        self.free_after = free_after
        self.loaded_at: float | None = None

    def pattern(self) -> tuple[float, ...]:
        if self.loaded_at is None:
            return (0.0,) * 6
        tightenings = round((self.loaded_at - self.theta) / state_machine.PAPER_SLIP_INCREMENT)
        if self.free_after is not None and tightenings >= self.free_after:
            return EQUAL
        return ONE_SIDED

    def perception(self) -> state_machine.PerceptionInput:
        return state_machine.PerceptionInput(
            stamp=self.now, force=squeeze_force(self.theta), force_valid=True,
            contact=(True, True), slip_active=True, filtered=self.pattern())

    def run(self) -> tuple[state_machine.ControlOutputs, list[float]]:
        """Run to the end; returns the last outputs and the lift heights of tightenings."""
        self.start(self.controller)
        tightened_at = []
        while True:
            out, closed = self.step()
            if closed and self.loaded_at is not None:
                tightened_at.append(out.lift_height)
            if out.state == GraspState.LIFTING and self.loaded_at is None:
                self.loaded_at = self.theta  # the grip the loading ended with
            if out.state not in ACTIVE:
                return out, tightened_at


def test_forte_tightens_until_the_object_is_centred_and_then_carries_it():
    world = TableWorld(Controller.FORTE, free_after=3)
    out, tightened_at = world.run()
    params = LiftCheckParams()
    assert len(tightened_at) == 3
    assert min(tightened_at) >= params.gross_slip_min_lift - 1e-9
    assert out.outcome == Outcome.LIFTED, out.message
    assert (out.slip_events, out.gross_slip_events) == (0, 3)  # no slip flag at all


def test_gross_slip_tightenings_are_spaced_and_stop_at_the_cap_without_a_fault():
    """Never freed: tightening every gross_slip_interval of lift up to max_tightening, then
    the lift verification reports the object not carried (no TIGHTENING_LIMIT fault)."""
    world = TableWorld(Controller.FORTE, free_after=None)
    out, tightened_at = world.run()
    params = state_machine.ControllerParams()
    cap = round(params.max_tightening / params.slip_increment)
    assert len(tightened_at) == cap == out.gross_slip_events
    spacing = LiftCheckParams().gross_slip_interval * params.lift_speed  # [m] of lift
    gaps = [b - a for a, b in zip(tightened_at, tightened_at[1:])]
    assert min(gaps) >= spacing - 1e-6
    assert out.outcome == Outcome.NOT_CARRIED and 'unequal' in out.message
    assert out.fault_flags == 0


@pytest.mark.parametrize('controller, lift_check', [
    (Controller.NO_SLIP, None),
    (Controller.FORTE, replace(LiftCheckParams(), gross_slip_reaction=False)),
])
def test_no_gross_slip_reaction_without_forte_or_when_switched_off(controller, lift_check):
    world = TableWorld(controller, free_after=1, lift_check=lift_check)
    out, tightened_at = world.run()
    assert tightened_at == []
    assert out.outcome == Outcome.NOT_CARRIED


class SlidingOffWorld(GraspWorld):
    """Fingers sliding off a round object: while the arm lifts, the deformation decays
    5 % per mm of lift; each tightening restores 15 % (up to the start level); with the arm
    still it holds."""

    def __init__(self, lift_check: LiftCheckParams | None = None) -> None:
        super().__init__(lift_check=lift_check)
        self.scale = 1.0
        self.tightened_at: list[float] = []  # commanded lift of each tightening [m]

    def perception(self) -> state_machine.PerceptionInput:
        return state_machine.PerceptionInput(
            stamp=self.now, force=squeeze_force(self.theta), force_valid=True,
            contact=(True, True), slip_active=True, filtered=scaled(EQUAL, self.scale))

    def run(self) -> tuple[state_machine.ControlOutputs, int, int]:
        """Run to the end: last outputs, tightenings and control steps with the arm
        stopped while LIFTING."""
        self.start(Controller.FORTE)
        paused = tightened = 0
        lifting = False
        while True:
            out, closed = self.step()
            if closed and lifting:
                tightened += 1
                self.tightened_at.append(out.lift_height)
                self.scale = min(1.0, self.scale + 0.15)
            lifting = out.state == GraspState.LIFTING
            if lifting:
                paused += out.arm_velocity == 0.0
                self.scale *= 1.0 - 0.05 * out.arm_velocity * DT * 1000.0
            if out.state not in ACTIVE:
                return out, tightened, paused


def test_forte_stops_the_lift_while_the_contact_slides_off_and_tightens():
    """The contact keeps sliding while the arm lifts, so FORTE tightens on beyond the lift
    height: each tightening means the object slid, and it hangs only as high as the lift
    since. The lift goes on quiet_time (1 s = 5 mm) and probe_distance (2 mm) past the last
    one, and the set-down probe lowers the 2 mm from there: 5 mm of lift since, within a
    control step."""
    world = SlidingOffWorld()
    out, tightened, paused = world.run()
    assert tightened >= 2 and paused >= tightened
    assert out.outcome == Outcome.LIFTED, out.message
    check, params = LiftCheckParams(), state_machine.ControllerParams()
    since = check.quiet_time * params.lift_speed
    assert world.tightened_at[-1] > 0.03
    assert out.lift_height - world.tightened_at[-1] == pytest.approx(since, abs=1e-4)


def test_without_the_reaction_the_contact_slides_off_and_the_drop_is_reported():
    world = SlidingOffWorld(replace(LiftCheckParams(), gross_slip_reaction=False))
    out, tightened, paused = world.run()
    assert (tightened, paused) == (0, 0)
    assert out.outcome == Outcome.DROPPED, out.message
