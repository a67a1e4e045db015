"""FORTE keeps tightening while the slipping state persists after a tightening (issue 26).

The synthetic rig of test_state_machine: perception updates every 10 ms (DT), the slip event
and the slipping state set by the test. Defaults: slipping_interval 0.2 s, slip_refractory
0.05 s, slip_increment 0.88 deg, max_tightening 20 increments.
"""
from __future__ import annotations

from dataclasses import replace

import pytest
from grasp_world import DT
from test_state_machine import Rig

from forte_control.state_machine import (
    PAPER_SLIP_INCREMENT,
    Controller,
    ControllerParams,
    GraspState,
)


def tighten_times(rig: Rig, seconds: float) -> list[float]:
    """Times [s, from now] at which the machine tightened during ``seconds`` (a
    re-tightening while slipping is no flag's reaction: slip_reacted stays false)."""
    start, times = rig.now, []
    while rig.now < start + seconds - 1e-9:
        before = rig.history[-1].servo.position
        out = rig.tick()
        if out.servo.position < before - 1e-12:
            assert not out.slip_reacted
            times.append(round(rig.now - start, 6))
    return times


def test_a_slide_that_outlasts_the_tightening_is_tightened_again_at_the_interval():
    rig = Rig()
    held = rig.to_lifting().servo.position
    rig.slip, rig.slipping = True, True
    assert rig.tick().slip_reacted  # the event: first tightening
    times = tighten_times(rig, 0.65)  # still slipping
    assert times == pytest.approx([0.2, 0.4, 0.6], abs=DT / 2)
    rig.slipping = False  # the slide stopped
    assert tighten_times(rig, 1.0) == []
    out = rig.history[-1]
    assert out.slip_events == 4
    assert out.servo.position == pytest.approx(held - 4 * PAPER_SLIP_INCREMENT)


def test_slipping_without_a_tightening_first_does_nothing():
    # the state is raised by an event; alone (e.g. a late message) it does not start tightening
    rig = Rig()
    rig.to_lifting()
    rig.slipping = True
    assert tighten_times(rig, 1.0) == []


def test_persisting_slip_stops_at_the_cap_without_a_fault():
    params = replace(ControllerParams(), max_tightening=3 * PAPER_SLIP_INCREMENT)
    rig = Rig(params)
    rig.to_lifting()
    rig.slip, rig.slipping = True, True
    rig.tick()
    tighten_times(rig, 2.0)
    out = rig.history[-1]
    assert out.slip_events == 3 and out.tightening == pytest.approx(3 * PAPER_SLIP_INCREMENT)
    assert out.state != GraspState.FAULT


def test_interval_zero_turns_it_off_and_no_slip_never_reacts():
    rig = Rig(replace(ControllerParams(), slipping_interval=0.0))
    rig.to_lifting()
    rig.slip, rig.slipping = True, True
    rig.tick()
    assert tighten_times(rig, 1.0) == []
    rig = Rig()
    rig.to_lifting(controller=Controller.NO_SLIP)
    rig.slip, rig.slipping = True, True
    assert tighten_times(rig, 1.0) == []


def test_the_papers_reaction_tightens_once_per_event_whatever_the_state_says():
    # slip_reaction 'events' (slip_mode paper): a persisting slipping state adds nothing,
    # each new event tightens once (the paper's controller)
    rig = Rig(replace(ControllerParams(), slip_reaction='events'))
    held = rig.to_lifting().servo.position
    rig.slip, rig.slipping = True, True
    assert rig.tick().slip_reacted
    assert tighten_times(rig, 1.0) == []
    rig.slip = True  # a second event, long after the refractory time
    out = rig.tick()
    assert out.slip_reacted and out.slip_events == 2
    assert out.servo.position == pytest.approx(held - 2 * PAPER_SLIP_INCREMENT)


def test_an_unknown_slip_reaction_is_refused():
    problems = replace(ControllerParams(), slip_reaction='always').problems()
    assert any('slip_reaction' in problem for problem in problems)


def test_slip_duration_counts_sample_time_while_slipping():
    rig = Rig()
    rig.to_lifting()
    rig.slipping = True
    for _ in range(50):  # 0.5 s slipping
        rig.tick()
    rig.slipping = False
    for _ in range(30):
        rig.tick()
    # the time from the first slipping state to the first state that is not: 50 updates
    assert rig.history[-1].slip_duration == pytest.approx(50 * DT, abs=1e-9)


def tighten_times_with(rig: Rig, seconds: float, slipping) -> list[float]:
    """As :func:`tighten_times`, with the slipping state set before each update from
    ``slipping(time since the last tightening [s])``."""
    start, times, last = rig.now, [], rig.now
    while rig.now < start + seconds - 1e-9:
        before = rig.history[-1].servo.position
        rig.slipping = slipping(rig.now + DT - last)
        out = rig.tick()
        if out.servo.position < before - 1e-12:
            times.append(round(rig.now - start, 6))
            last = rig.now
    return times


def test_a_dip_of_the_state_at_the_interval_does_not_skip_the_tightening():
    """A gross slide rings between its stick-slip bursts only: the state goes down for the
    30 ms before each interval's end. Seen in the last half interval (0.1 s), it still
    persists."""
    rig = Rig()
    rig.to_lifting()
    rig.slip, rig.slipping = True, True
    assert rig.tick().slip_reacted
    rig.slip = False
    times = tighten_times_with(rig, 0.65, lambda since: since < 0.17 - 1e-9)
    assert times == pytest.approx([0.2, 0.4, 0.6], abs=DT / 2)


def test_a_state_down_for_half_an_interval_is_a_slide_that_stopped():
    rig = Rig()
    rig.to_lifting()
    rig.slip, rig.slipping = True, True
    rig.tick()
    rig.slip = False
    # up for 0.05 s after the tightening (the stopped slide's ringing), then down
    assert tighten_times_with(rig, 1.0, lambda since: since < 0.05 + 1e-9) == []
