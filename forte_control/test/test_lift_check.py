"""The controller's claim about the object: lift verification and the closed-on-object check.

Synthetic inputs with the physics of docs/control.md: a carried object hangs between two
fingers that press it equally (its only horizontal forces), an object still on the table can
be held against one finger by the table's friction, and fingers that still slip at the end
of the lift are sliding along the object, not carrying it.
"""
from __future__ import annotations

from dataclasses import replace

import pytest
from grasp_world import ACTIVE, DT, GraspWorld

from forte_control import state_machine
from forte_control.state_machine import GraspState, GraspStateMachine, Outcome
from forte_control.state_machine.lift_check import (
    LiftCheckParams,
    LiftMonitor,
    OpenGripperLevels,
    closed_on_object_evidence,
    finger_levels,
    shear_index,
)
from forte_control.state_machine.phases import MAX_PROBES
from forte_control.state_machine.types import WrenchInput

EQUAL = (0.10, 0.06, 0.03, 0.10, 0.06, 0.03)       # both fingers pressed alike
ONE_SIDED = (0.10, 0.06, 0.03, 0.05, 0.03, 0.015)  # right finger at half the left's load


def lift(monitor: LiftMonitor, pattern, *, lift_time=6.0, hold_time=1.0, flags=(),
         hold_flags=(), wrench=None, t0=10.0):
    """Feed a lift of ``lift_time`` then a hold of ``hold_time`` at 100 Hz.

    ``flags`` / ``hold_flags``: times (s after the start of the lift / of the hold) of slip
    flags; ``wrench``: function time-since-lift-start -> vertical wrist load [N] or None.
    """
    steps = int(round((lift_time + hold_time) / DT))
    for k in range(steps):
        t = k * DT
        holding = t >= lift_time
        flag = any(abs(t - f) < DT / 2 for f in flags) or any(
            abs(t - lift_time - f) < DT / 2 for f in hold_flags)
        reading = None if wrench is None else WrenchInput(t0 + t, wrench(t))
        monitor.update(t0 + t, pattern, flag, holding, reading, t0 + t)
    return monitor.verdict()


#: Sensor drift since the tare (minutes at 0.00026 per square-root second per channel): the
#: left finger's level +0.009, the right's -0.003, with no load on the pads.
DRIFT = (0.003, 0.003, 0.003, -0.001, -0.001, -0.001)
DRIFTED_EQUAL = tuple(a + b for a, b in zip(EQUAL, DRIFT, strict=True))


def test_finger_levels_sum_each_fingers_channels():
    assert finger_levels(EQUAL) == pytest.approx((0.19, 0.19))
    assert finger_levels(None) is None
    assert finger_levels((0.1,) * 5) is None
    assert finger_levels((float('nan'),) + (0.1,) * 5) is None


def test_equal_fingers_and_a_quiet_lift_mean_carried():
    verdict = lift(LiftMonitor(LiftCheckParams()), EQUAL, flags=(1.0, 2.5, 4.9))
    assert verdict.carried, verdict.reason
    assert '0.1900 / 0.1900' in verdict.reason


def test_one_finger_pressing_harder_means_the_table_still_holds_the_object():
    verdict = lift(LiftMonitor(LiftCheckParams()), ONE_SIDED)
    assert not verdict.carried and 'unequal' in verdict.reason


def test_a_finger_without_load_is_not_a_grasp():
    verdict = lift(LiftMonitor(LiftCheckParams()), (0.1, 0.06, 0.03, 0.002, 0.001, 0.0))
    assert not verdict.carried and 'not loaded' in verdict.reason


def test_balance_tolerance_grows_with_the_load():
    """Unit trims make equal forces read a few per cent apart; heavier grips more so."""
    params = LiftCheckParams()
    light = (0.03, 0.02, 0.01, 0.031, 0.021, 0.0105)          # 4 % apart, 0.06 each
    heavy = (0.30, 0.20, 0.10, 0.306, 0.204, 0.102)            # 2 % apart, 0.6 each
    assert lift(LiftMonitor(params), light).carried
    assert lift(LiftMonitor(params), heavy).carried
    lopsided = (0.30, 0.20, 0.10, 0.27, 0.18, 0.09)            # 10 % apart
    assert not lift(LiftMonitor(params), lopsided).carried


def test_open_gripper_levels_average_the_first_window_only():
    levels = OpenGripperLevels(window=0.2, limit=0.02)
    assert levels.zero() == (0.0, 0.0)  # no sample: nothing to subtract
    for k in range(21):  # 0 .. 0.2 s: the open gripper
        levels.update(1.0 + k * DT, DRIFT)
    levels.update(1.0 + 0.2 + 0.5 * DT, (float('nan'),) * 6)  # an invalid sample is skipped
    for k in range(22, 100):  # later: the fingers close on the object
        levels.update(1.0 + k * DT, EQUAL)
    assert levels.zero() == pytest.approx((0.009, -0.003), abs=1e-12)


def test_a_loaded_start_is_not_taken_for_drift():
    levels = OpenGripperLevels(window=0.2, limit=0.02)
    for k in range(30):
        levels.update(k * DT, EQUAL)  # 0.19 on each finger: touching something already
    assert levels.zero() == (0.0, 0.0)


def test_levels_are_measured_from_the_open_gripper():
    """Drift since the tare unbalances a carried object's fingers (0.199 / 0.187, 0.012 apart
    against 0.0118 allowed); measured from the open gripper's levels they are equal."""
    assert not lift(LiftMonitor(LiftCheckParams()), DRIFTED_EQUAL).carried
    verdict = lift(LiftMonitor(LiftCheckParams(), zero=(0.009, -0.003)), DRIFTED_EQUAL)
    assert verdict.carried, verdict.reason
    assert '0.1900 / 0.1900' in verdict.reason


def test_slip_at_the_end_of_the_lift_means_still_sliding():
    verdict = lift(LiftMonitor(LiftCheckParams()), EQUAL, flags=(5.5,))
    assert not verdict.carried and 'sliding' in verdict.reason
    # quiet_time before the hold is enough
    assert lift(LiftMonitor(LiftCheckParams()), EQUAL, flags=(4.95,)).carried


def test_shear_index_is_distal_minus_root_of_both_fingers():
    assert shear_index(EQUAL) == pytest.approx(0.14)
    assert shear_index(None) is None


def set_down(unload: float, params: LiftCheckParams | None = None, grip: float = 1.0):
    """A quiet, balanced lift, then the set-down probe: the fingers' shear pattern
    (distal up, root down per newton of tangential load) drops by ``unload`` per finger, and
    every channel is scaled by ``grip`` (a tightening during the probe)."""
    monitor = LiftMonitor(params or LiftCheckParams())
    t = 10.0
    for _ in range(600):
        monitor.update(t, EQUAL, False, False)
        t += DT
    monitor.begin_probe()
    d, r = 0.6 * unload, 0.4 * unload  # distal falls, root rises: the difference by unload
    unloaded = tuple(grip * value for value in (EQUAL[0] - d, EQUAL[1], EQUAL[2] + r,
                                                EQUAL[3] - d, EQUAL[4], EQUAL[5] + r))
    for k in range(80):
        pattern = EQUAL if k < 10 else unloaded
        monitor.update(t, pattern, False, True)
        t += DT
    return monitor.verdict()


def test_set_down_probe_that_leaves_the_shear_pattern_means_carried():
    verdict = set_down(0.0005)
    assert verdict.carried and 'when set down' in verdict.reason


def test_set_down_probe_that_unloads_the_fingers_means_the_table_holds_the_object():
    verdict = set_down(0.003)
    assert not verdict.carried and 'table took load' in verdict.reason
    assert '-0.0060' in verdict.reason  # both fingers, distal - root


def test_a_tightening_during_the_probe_does_not_deny_the_lift():
    """A slip tightening while the probe lowers raises the whole pattern (by 60 % here: the
    shear index by +0.084, 19x probe_unload); only a fall means the table took load. A 2 %
    tightening over an unload of 0.012 still leaves a fall of 0.0094 > 0.0045."""
    verdict = set_down(0.0, grip=1.6)
    assert verdict.carried and '+0.0840 when set down' in verdict.reason
    verdict = set_down(0.006, grip=1.02)
    assert not verdict.carried and '-0.0094' in verdict.reason


def test_slip_while_holding_does_not_deny_the_lift():
    """With the arm still only gravity can make the object slip: it hangs from the fingers."""
    verdict = lift(LiftMonitor(LiftCheckParams()), EQUAL, hold_flags=(0.5,))
    assert verdict.carried, verdict.reason


def test_only_the_last_balance_window_counts():
    monitor = LiftMonitor(LiftCheckParams())
    for k in range(100):  # one-sided while the object is still on the table ...
        monitor.update(10.0 + k * DT, ONE_SIDED, False, False)
    for k in range(100, 250):  # ... equal once it hangs from the fingers
        monitor.update(10.0 + k * DT, EQUAL, False, k >= 200)
    assert monitor.verdict().carried


def test_no_tactile_data_means_not_shown_carried():
    monitor = LiftMonitor(LiftCheckParams())
    monitor.update(10.0, None, False, False)
    verdict = monitor.verdict()
    assert not verdict.carried and 'no tactile data' in verdict.reason


def test_verification_can_be_switched_off():
    assert lift(LiftMonitor(LiftCheckParams(verify_lift=False)), ONE_SIDED).carried


def test_optional_wrench_needs_the_wrist_to_take_the_load():
    params = LiftCheckParams(use_wrench=True, min_wrench_load=1.0)
    assert lift(LiftMonitor(params), EQUAL, wrench=lambda t: 0.2 + min(t, 2.0)).carried
    drag = lift(LiftMonitor(params), EQUAL, wrench=lambda t: 0.2 + min(t, 0.3))
    assert not drag.carried and 'wrist load' in drag.reason
    missing = lift(LiftMonitor(params), EQUAL)
    assert not missing.carried and 'wrench' in missing.reason
    # off by default: a wrench input changes nothing
    assert lift(LiftMonitor(LiftCheckParams()), EQUAL, wrench=lambda t: 0.0).carried


def test_stale_wrench_is_ignored():
    params = LiftCheckParams(use_wrench=True, min_wrench_load=1.0)
    monitor = LiftMonitor(params)
    for k in range(700):
        t = 10.0 + k * DT
        monitor.update(t, EQUAL, False, k >= 600, WrenchInput(10.0, 5.0), t)
    verdict = monitor.verdict()
    assert not verdict.carried and 'no fresh wrist wrench' in verdict.reason


def test_bad_thresholds_refused():
    assert LiftCheckParams().problems() == []
    assert LiftCheckParams(balance_floor=-1.0).problems()
    assert LiftCheckParams(quiet_time=float('nan')).problems()
    assert LiftCheckParams(balance_window=0.0).problems()
    with pytest.raises(ValueError, match='lift check'):
        GraspStateMachine(lift_check=LiftCheckParams(loaded_level=-0.1))


@pytest.mark.parametrize('kwargs, fragment', [
    ({'theta': 0.08}, 'joint stopped'),                        # blocked by a rigid object
    ({'filtered': (0.06, 0.03, 0.015) * 2}, 'deformation'),    # a soft object squeezed
    ({'force': 0.6}, 'force'),
    ({'current': 0.25}, 'servo current'),
])
def test_closing_on_something_is_seen(kwargs, fragment):
    values = {'command': 0.0, 'theta': 0.0, 'filtered': (0.001, -0.001, 0.0) * 2,
              'force': 0.02, 'current': 0.06, 'free_current': 0.05}
    values.update(kwargs)
    assert fragment in closed_on_object_evidence(LiftCheckParams(), **values)


def test_an_empty_gripper_closes_on_nothing():
    assert closed_on_object_evidence(LiftCheckParams(), 0.0, 0.005, (0.002, 0.0, -0.001) * 2,
                                     0.05, 0.07, 0.05) == ''
    assert closed_on_object_evidence(LiftCheckParams(), 0.0, 0.0, None, None, None,
                                     None) == ''


class World(GraspWorld):
    """The joint follows the command unless an object blocks it at ``block``; the tactile
    pattern and force are set by the test."""

    def __init__(self, lift_check: LiftCheckParams | None = None) -> None:
        super().__init__(lift_check=lift_check, now=50.0)
        self.block = -1.0
        self.filtered = (0.0,) * 6
        self.force = 0.0
        self.contact = (False, False)
        self.slip = False

    def perception(self) -> state_machine.PerceptionInput:
        return state_machine.PerceptionInput(
            stamp=self.now, force=self.force, force_valid=True, contact=self.contact,
            slip=self.slip, slip_active=True, filtered=self.filtered)

    def follow(self, command: float) -> float:
        return max(command, self.block)

    def run(self, limit: float = 20.0):
        self.start(state_machine.Controller.NO_SLIP)
        end = self.now + limit
        while self.now < end:
            out, _ = self.step()
            if out.state not in ACTIVE:
                return out
        raise AssertionError('grasp did not finish')


def test_machine_reports_no_contact_for_an_empty_gripper():
    out = World().run()
    assert out.outcome == Outcome.NO_CONTACT and out.message == 'closed fully without contact'


def test_machine_reports_a_squeezed_soft_object_that_never_tripped_contact():
    """Below contact_level (mean 0.0035 < 0.005) the closing goes on; the force estimate
    then shows the gripper closed on something."""
    world = World()
    world.filtered = (0.006, 0.003, 0.0015) * 2  # deformed, too slowly for the contact flag
    world.force = 0.6
    out = world.run()
    assert out.outcome == Outcome.CLOSED_ON_OBJECT
    assert 'force' in out.message and 'deformation' not in out.message


@pytest.mark.parametrize('contact_level, loads', [(0.005, True), (0.0, False)])
def test_a_deformation_level_is_contact_while_closing(contact_level, loads):
    """A soft object deforms the fingers (mean |filtered| 0.012) without tripping the
    rate-based contact flag: at contact_level 0.005 the machine loads from there, at 0
    (flags only) it closes fully and reports what it closed on."""
    params = replace(state_machine.ControllerParams(), contact_level=contact_level)
    world = World()
    world.machine = GraspStateMachine(params)
    world.filtered = (0.018, 0.012, 0.006) * 2
    world.force = 0.1
    world.start(state_machine.Controller.NO_SLIP)
    states = set()
    for _ in range(2000):
        out, _ = world.step()
        states.add(out.state)
        if out.state not in (GraspState.CLOSING, GraspState.LOADING):
            break
    assert (GraspState.LOADING in states) is loads
    if not loads:
        assert out.outcome == Outcome.CLOSED_ON_OBJECT and 'deformation' in out.message


def test_machine_reports_a_blocked_joint():
    world = World()
    world.block = 0.1  # a rigid object stalls the servo short of closed
    out = world.run()
    assert out.outcome == Outcome.CLOSED_ON_OBJECT and 'joint stopped' in out.message


def test_machine_ends_a_one_sided_lift_in_not_carried():
    world = World(replace(LiftCheckParams(), quiet_time=0.5))
    world.contact = (True, True)  # contact at once; the force reaches the target at once
    world.force = 0.4
    world.filtered = ONE_SIDED
    out = world.run(limit=30.0)
    assert out.outcome == Outcome.NOT_CARRIED and 'unequal' in out.message
    assert out.lift_height == pytest.approx(0.03, abs=1e-3)
    world = World()
    world.contact = (True, True)
    world.force = 0.4
    world.filtered = EQUAL
    out = world.run(limit=30.0)
    assert out.outcome == Outcome.LIFTED


@pytest.mark.parametrize('table_holds', [False, True])
def test_machine_probes_by_setting_down_and_judges_the_shear_change(table_holds):
    """Lift 2 mm beyond the lift height, hold, lower back: a resting object unloads the
    fingers while they go down (shear pattern falls), a carried one goes down with them."""
    world = World()
    world.contact = (True, True)
    world.force = 0.4
    world.filtered = EQUAL
    world.start(state_machine.Controller.FORTE)
    top = 0.0
    while True:
        out, _ = world.step()
        top = max(top, out.lift_height)
        if out.arm_velocity < 0.0 and table_holds:  # lowering onto the table's support
            world.filtered = (0.097, 0.06, 0.032, 0.097, 0.06, 0.032)
        if out.state == GraspState.DONE:
            break
    assert top == pytest.approx(0.032, abs=1e-4)
    assert out.lift_height == pytest.approx(0.03, abs=2e-5)
    if table_holds:
        assert out.outcome == Outcome.NOT_CARRIED and 'table took load' in out.message
    else:
        assert out.outcome == Outcome.LIFTED and 'when set down' in out.message


#: EQUAL with the table taking load: distal 0.003 lower, root 0.002 higher per finger
#: (shear index 0.010 lower)
ON_TABLE = (0.097, 0.06, 0.032, 0.097, 0.06, 0.032)


def probe_run(world: World, controller, during_hold, during_lowering, limit: float = 30.0):
    """Run a grasp with ``world``'s contact, force and pattern; ``during_hold(world, t)`` is
    called at each step of HOLDING with the time since it began [s] and
    ``during_lowering(world, k)`` at each step the arm goes down, k counting from 0 at each
    descent. Returns the last outputs and the arm's direction changes ('+', '-')."""
    world.start(controller)
    hold_start = None
    descent_steps = 0
    moves: list[str] = []
    end = world.now + limit
    while world.now < end:
        out, _ = world.step()
        world.slip = False
        direction = '+' if out.arm_velocity > 0 else '-' if out.arm_velocity < 0 else ''
        if direction and (not moves or moves[-1] != direction):
            moves.append(direction)
            descent_steps = 0
        if out.state == GraspState.HOLDING:
            hold_start = world.now if hold_start is None else hold_start
            if direction == '-':
                during_lowering(world, descent_steps)
                descent_steps += 1
            else:
                during_hold(world, world.now - hold_start)
        if out.state == GraspState.DONE:
            return out, moves
    raise AssertionError('grasp did not finish')


def test_the_probe_waits_for_a_grip_that_slid_onto_the_table_in_the_hold():
    """Closed loop, soda can seed 16: 0.9 s into the hold the can slid 18 mm down onto the
    table (one slip flag), FORTE tightened (every channel x 1.3), the probe lowered, the table
    took load. Judged against the hanging grip before the slide, the index rose (+0.06 there,
    LIFTED claimed for a can on the table); the probe waits for the quiet grip instead."""
    world = World()
    world.contact, world.force, world.filtered = (True, True), 0.4, EQUAL

    def slide_onto_table(world: World, held: float) -> None:
        if 0.9 <= held < 0.9 + DT / 2:
            world.slip = True
            world.filtered = tuple(1.3 * value for value in EQUAL)

    def lower(world: World, _step: int) -> None:
        world.filtered = tuple(1.3 * value for value in ON_TABLE)

    out, moves = probe_run(world, state_machine.Controller.FORTE, slide_onto_table, lower)
    assert out.slip_events == 1
    assert out.outcome == Outcome.NOT_CARRIED and 'table took load' in out.message
    assert '-0.0130' in out.message  # 1.3 x (0.010 per finger): the grip as it now is


def test_a_slip_during_the_probe_sends_the_arm_back_up_to_probe_again():
    """A carried object slips once as the probe lowers (FORTE tightens: x 1.1). The probe's
    reference is void; up again, a quiet probe finds the shear pattern unchanged. The slip
    came 0.25 mm into the descent (at 31.75 mm): the object hangs only as high as the lift
    since, so the arm goes up quiet_time of lift (5 mm) and the probe's 2 mm past it and the
    probe lowers 2 mm from there (36.75 mm, within a control step)."""
    world = World()
    world.contact, world.force, world.filtered = (True, True), 0.4, EQUAL
    descents = []

    def slip_once(world: World, step: int) -> None:
        if step == 0:
            descents.append(world.now)
        if len(descents) == 1 and step == 5:
            world.slip = True
            world.filtered = tuple(1.1 * value for value in EQUAL)

    out, moves = probe_run(world, state_machine.Controller.FORTE, lambda *_: None, slip_once)
    assert moves == ['+', '-', '+', '-']  # lift, probe, back up, probe again
    assert len(descents) == 2 and out.slip_events == 1
    assert out.outcome == Outcome.LIFTED and '+0.0000 when set down' in out.message
    assert out.lift_height == pytest.approx(0.03175 + 0.005, abs=1e-4)


def test_a_grip_that_slips_in_every_probe_is_not_claimed():
    world = World()
    world.contact, world.force, world.filtered = (True, True), 0.4, EQUAL

    def slip(world: World, step: int) -> None:
        world.slip = step == 3

    out, moves = probe_run(world, state_machine.Controller.NO_SLIP, lambda *_: None, slip,
                           limit=60.0)
    assert moves.count('-') == MAX_PROBES
    assert out.outcome == Outcome.NOT_CARRIED and 'never settled' in out.message


def test_no_probe_without_room_under_the_lift_cap():
    world = World()
    world.machine = GraspStateMachine(replace(state_machine.ControllerParams(),
                                              max_lift_distance=0.03))
    world.contact = (True, True)
    world.force = 0.4
    world.filtered = EQUAL
    out = world.run(limit=30.0)
    assert out.outcome == Outcome.LIFTED and 'set down' not in out.message


@pytest.mark.parametrize('open_time, outcome', [(0.5, Outcome.LIFTED),
                                                (0.0, Outcome.NOT_CARRIED)])
def test_machine_judges_the_lift_from_the_open_gripper_levels(open_time, outcome):
    """The tare is old: every sample carries DRIFT. With half a second of open gripper at the
    start (as every grasp from open has), the carried object's equal fingers are seen; a
    grasp that starts in contact has no such zero and the drift reads as unequal fingers."""
    world = World()
    world.filtered = DRIFT
    world.start(state_machine.Controller.NO_SLIP)
    end = world.now + 30.0
    opened = world.now + open_time
    while world.now < end:
        if world.now + DT >= opened:
            world.contact, world.force, world.filtered = (True, True), 0.4, DRIFTED_EQUAL
        out, _ = world.step()
        if out.state == GraspState.DONE:
            break
    assert out.outcome == outcome, out.message
