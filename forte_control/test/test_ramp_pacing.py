"""The closing and loading ramps are paced by the perception's sample time (``ramp_lead``).

A perception that trails the servo (a loaded computer, a slow link) reports contact late;
a ramp run on the wall clock closes on blind for that delay. Known answers: closing speed
0.25 rad/s (the default), ``ramp_lead`` 0.05 s, steps of :data:`DT`.
"""
from __future__ import annotations

import math
from dataclasses import replace

import pytest
from test_state_machine import DT, Rig

from forte_control.state_machine import Controller, ControllerParams, GraspState

#: Freshness bound large enough that a 0.6 s old perception is still accepted [s].
LENIENT = replace(ControllerParams(), perception_timeout=1.0, joint_state_timeout=1.0)
SPEED = LENIENT.closing_speed
LEAD = LENIENT.ramp_lead


@pytest.mark.parametrize('age', [0.0, 0.03, 0.3, 0.6])
def test_closing_command_runs_at_most_ramp_lead_ahead_of_perception(age):
    rig = Rig(LENIENT)
    rig.perception_age = age
    assert rig.start(controller=Controller.FORTE)[0]
    out = rig.run_until(lambda o: rig.now >= 101.0 - 1e-9)
    assert out.state == GraspState.CLOSING
    # an age under the lead costs nothing; an older perception lets the ramp run LEAD
    # beyond the command it has seen, once per age: ramp time LEAD * ceil(1 s / age)
    ramp_time = 1.0 if age <= LEAD else LEAD * math.ceil(1.0 / age)
    assert out.servo.position == pytest.approx(1.0 - SPEED * ramp_time, abs=SPEED * DT)


def test_trailing_perception_does_not_close_past_contact_blind():
    """The world: the object touches at 0.6 rad; the perception reports what the joint
    was ``age`` earlier. Unpaced, the command would be 0.6 - 0.25 * 0.5 = 0.475 rad when
    the late contact arrives; paced, at most (lead + 2 steps) of ramp past contact."""
    age, contact_angle = 0.5, 0.6
    rig = Rig(LENIENT)
    rig.perception_age = age
    assert rig.start(controller=Controller.FORTE)[0]
    history: list[tuple[float, float]] = [(rig.now, rig.theta)]

    def world(out) -> bool:
        history.append((rig.now, rig.theta))
        seen = [theta for time, theta in history if time <= rig.now - age + 1e-9]
        if seen and seen[-1] <= contact_angle:
            rig.contact = (True, True)
        return out.state == GraspState.LOADING
    out = rig.run_until(world, limit=30.0)  # 0.4 rad at LEAD per age: 16 s
    assert out.servo.position >= contact_angle - SPEED * (LEAD + 2 * DT)
    assert out.servo.position < contact_angle  # it did reach the object


def test_loading_ramp_is_paced_too():
    rig = Rig(LENIENT)
    assert rig.start(controller=Controller.FORTE)[0]
    rig.run_until(lambda o: rig.theta <= 0.6)
    rig.contact, rig.force = (True, True), 0.1
    out = rig.tick()
    assert out.state == GraspState.LOADING
    at_contact = out.servo.position
    rig.perception_age = 0.5  # perception falls behind while loading
    loading_start = rig.now
    out = rig.run_until(lambda o: rig.now >= loading_start + 1.0 - 1e-9)
    assert out.state == GraspState.LOADING
    # 1 s of loading at 0.05 rad/s would be 0.05 rad; paced, LEAD per 0.5 s of age
    moved = at_contact - out.servo.position
    assert LENIENT.loading_speed * LEAD <= moved <= LENIENT.loading_speed * 3 * LEAD + 1e-12


def test_on_off_is_not_paced():
    """ON_OFF closes without sensing: a trailing (or absent) perception does not slow it."""
    rig = Rig(LENIENT)
    rig.perception_age = 0.6
    assert rig.start(controller=Controller.ON_OFF)[0]
    out = rig.run_until(lambda o: rig.now >= 101.0 - 1e-9)
    assert out.servo.position == pytest.approx(1.0 - LENIENT.on_off_closing_speed, abs=1e-9)
