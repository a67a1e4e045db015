"""Step-by-step tests of the grasp state machine with synthetic perception and joint inputs."""
from __future__ import annotations

import math
from dataclasses import replace

import pytest
from grasp_world import DT

from forte_control.state_machine import (
    PAPER_SLIP_INCREMENT,
    ControlInputs,
    Controller,
    ControllerParams,
    FaultFlag,
    GraspGoal,
    GraspState,
    GraspStateMachine,
    JointInput,
    Outcome,
    PerceptionInput,
)

#: Tared filtered channels of an object held by both fingers alike (a carried object).
CARRIED = (0.05, 0.03, 0.015) * 2


class Rig:
    """Synthetic world: the joint follows the servo command at once (or stays blocked at
    ``block_angle`` by an object), perception fields are set by the test. Once the fingers
    touch (``to_lifting``), the tactile pattern is that of a carried object (:data:`CARRIED`)
    unless the test set its own."""

    def __init__(self, params: ControllerParams | None = None, theta: float = 1.0) -> None:
        self.machine = GraspStateMachine(params or ControllerParams())
        self.now = 100.0
        self.theta = theta
        self.block_angle = -1.0
        self.force = 0.0
        self.force_valid = True
        self.contact = (False, False)
        self.slip = False
        self.slip_active = True
        self.slipping = False
        self.data_valid = True
        self.filtered: tuple[float, ...] | None = None
        self.perception_age = 0.0
        self.joint_age = 0.0
        self.send_perception = True
        self.send_joint = True
        self.servo_error = False
        self.history = []

    def inputs(self) -> ControlInputs:
        perception = None
        if self.send_perception:
            perception = PerceptionInput(
                stamp=self.now - self.perception_age, force=self.force,
                force_valid=self.force_valid, contact=self.contact, slip=self.slip,
                slip_active=self.slip_active, slipping=self.slipping,
                data_valid=self.data_valid, filtered=self.filtered)
        joint = None
        if self.send_joint:
            joint = JointInput(stamp=self.now - self.joint_age, theta=self.theta,
                               servo_error=self.servo_error)
        return ControlInputs(perception=perception, joint=joint)

    def start(self, **goal):
        return self.machine.start(GraspGoal(**goal), self.now, self.inputs())

    def tick(self, dt: float = DT):
        self.now += dt
        out = self.machine.step(self.inputs(), self.now)
        if out.servo is not None:
            self.theta = max(out.servo.position, self.block_angle)
        self.slip = False  # consumed
        self.history.append(out)
        return out

    def run_until(self, predicate, limit: float = 30.0, dt: float = DT):
        end = self.now + limit
        while self.now < end:
            out = self.tick(dt)
            if predicate(out):
                return out
        raise AssertionError(f'condition not reached in {limit} s; last state '
                             f'{self.history[-1].state.name}: {self.history[-1].message}')

    def to_lifting(self, contact_angle: float = 0.6, **goal):
        """Close onto an object at ``contact_angle`` and load it; force follows the squeeze."""
        assert self.start(**goal)[0]
        self.block_angle = -1.0

        def world(out):
            # contact and a force that grows 10 N/rad beyond the contact angle
            if self.theta <= contact_angle:
                self.contact = (True, True)
                self.force = 10.0 * (contact_angle - self.theta)
                if self.filtered is None:
                    self.filtered = CARRIED
            return out.state == GraspState.LIFTING
        self.run_until(world)
        return self.history[-1]

    def assert_reset_refused_until(self, refusal: str = '', **fixed) -> None:
        """The latched fault's reset is refused (its reason containing ``refusal``) while
        the condition persists, and accepted once the attributes ``fixed`` are set and a
        step saw them."""
        ok, message, _ = self.machine.reset_fault(self.now)
        assert not ok and refusal in message
        for name, value in fixed.items():
            setattr(self, name, value)
        self.tick()
        assert self.machine.reset_fault(self.now)[0]


def test_constants_equal_messages():
    from forte_msgs.action import Grasp
    from forte_msgs.msg import GraspState as GraspStateMsg
    for member in GraspState:
        assert getattr(GraspStateMsg, member.name) == member.value
    for name, member in FaultFlag.__members__.items():
        assert getattr(GraspStateMsg, f'FAULT_{name}') == member.value
    for member in Outcome:
        assert getattr(Grasp.Result, member.name) == member.value
        assert getattr(GraspStateMsg, f'OUTCOME_{member.name}') == member.value
    for member in Controller:
        assert getattr(Grasp.Goal, member.name) == member.value
    # and no message constant is missing from the mirror
    msg_states = {n for n in dir(GraspStateMsg) if n.isupper()
                  and not n.startswith(('FAULT_', 'OUTCOME_'))
                  and isinstance(getattr(GraspStateMsg, n), int)}
    assert msg_states == {m.name for m in GraspState}
    msg_faults = {n[6:] for n in dir(GraspStateMsg) if n.startswith('FAULT_')}
    assert msg_faults == set(FaultFlag.__members__)
    msg_outcomes = {n[8:] for n in dir(GraspStateMsg) if n.startswith('OUTCOME_')}
    result_outcomes = {n for n in dir(Grasp.Result) if n.isupper()
                       and isinstance(getattr(Grasp.Result, n), int)}
    assert msg_outcomes == result_outcomes == set(Outcome.__members__)


def test_paper_defaults():
    p = ControllerParams()
    assert p.initial_force == 0.25
    assert p.lift_speed == 0.005
    assert math.isclose(p.slip_increment, 0.015359, abs_tol=1e-6)
    assert p.problems() == []


@pytest.mark.parametrize('change, fragment', [
    ({'max_force': 50.0}, 'max_force'),
    ({'max_force': float('nan')}, 'finite'),
    ({'initial_force': 7.0, 'max_force': 6.0}, 'initial_force'),
    ({'lift_speed': 0.03}, 'max_lift_speed'),
    ({'lift_distance': 0.3}, 'max_lift_distance'),
    ({'slip_increment': 0.5}, 'slip_increment'),
    ({'perception_timeout': 0.0}, 'perception_timeout'),
    ({'perception_timeout': 5.0}, 'perception_timeout'),
    ({'max_current': 10.0}, 'max_current'),
    ({'contact_mode': 'any'}, 'contact_mode'),
    ({'initial_force_mode': 'x'}, 'initial_force_mode'),
    ({'min_angle': 1.5, 'open_angle': 1.0}, 'min_angle'),
    ({'closing_speed': -0.1}, 'closing_speed'),
])
def test_unsafe_params_refused_with_reason(change, fragment):
    params = replace(ControllerParams(), **change)
    problems = params.problems()
    assert problems and any(fragment in p for p in problems)
    with pytest.raises(ValueError, match='unsafe'):
        GraspStateMachine(params)
    machine = GraspStateMachine()
    ok, reason = machine.set_params(params)
    assert not ok and fragment in reason
    assert machine.params == ControllerParams()  # unchanged
    ok, _ = machine.set_params(replace(ControllerParams(), max_force=4.0))
    assert ok and machine.params.max_force == 4.0


def test_full_forte_grasp_step_by_step():
    rig = Rig()
    out = rig.tick()
    assert out.state == GraspState.IDLE and out.servo is None and out.arm_velocity == 0.0
    ok, reason = rig.start(controller=Controller.FORTE)
    assert ok, reason
    # CLOSING: ramp at closing_speed from the measured angle, arm still
    out = rig.tick()
    assert out.state == GraspState.CLOSING
    assert out.servo.position == pytest.approx(1.0 - 0.25 * DT)
    assert out.servo.profile_velocity == 0.25 and out.servo.max_current == 1.0
    assert out.arm_velocity == 0.0
    rig.run_until(lambda o: rig.theta <= 0.6)
    # contact on one finger is enough in 'either' mode; force at contact is 0.1 N
    rig.contact = (True, False)
    rig.force = 0.1
    rig.filtered = CARRIED
    out = rig.tick()
    assert out.state == GraspState.LOADING
    assert out.target_force == pytest.approx(0.35)
    angle_at_contact = out.servo.position
    out = rig.tick()
    assert out.servo.position == pytest.approx(angle_at_contact - 0.05 * DT)
    assert out.servo.profile_velocity == 0.05
    rig.force = 0.34
    assert rig.tick().state == GraspState.LOADING
    rig.force = 0.35
    out = rig.tick()
    assert out.state == GraspState.LIFTING and out.arm_velocity == 0.005
    held = out.servo.position
    # LIFTING: lift height integrates the commanded velocity
    out = rig.tick()
    assert out.lift_height == pytest.approx(0.005 * DT)
    assert out.servo.position == held
    # slip -> tighten by 0.88 deg in the same step
    rig.slip = True
    out = rig.tick()
    assert out.slip_reacted and out.slip_events == 1
    assert out.servo.position == pytest.approx(held - PAPER_SLIP_INCREMENT)
    assert out.servo_changed
    assert out.tightening == pytest.approx(PAPER_SLIP_INCREMENT)
    # lift to 3 cm + the 2 mm of the set-down probe -> HOLDING (arm stops) -> after
    # hold_duration down to 3 cm -> DONE with LIFTED (the shear pattern did not change)
    out = rig.run_until(lambda o: o.state == GraspState.HOLDING)
    assert out.arm_velocity == 0.0
    assert out.lift_height == pytest.approx(0.032, abs=0.005 * DT + 1e-9)
    out = rig.run_until(lambda o: o.arm_velocity < 0.0)
    assert out.state == GraspState.HOLDING and 'set-down probe' in out.message
    out = rig.run_until(lambda o: o.state == GraspState.DONE)
    assert out.lift_height == pytest.approx(0.03, abs=2e-5)
    assert out.outcome == Outcome.LIFTED and out.finished
    assert rig.machine.last_outcome == Outcome.LIFTED
    assert 'equal' in out.message  # the evidence that the object was carried
    out = rig.tick()
    assert out.state == GraspState.DONE and not out.finished and out.arm_velocity == 0.0
    # a new goal is accepted after DONE
    assert rig.start()[0]


def test_contact_mode_both_waits_for_second_finger():
    rig = Rig(replace(ControllerParams(), contact_mode='both'))
    assert rig.start()[0]
    rig.tick()
    rig.contact = (False, True)
    assert rig.tick().state == GraspState.CLOSING
    rig.contact = (True, True)
    assert rig.tick().state == GraspState.LOADING


def test_absolute_initial_force_mode():
    rig = Rig(replace(ControllerParams(), initial_force_mode='absolute', initial_force=0.5))
    assert rig.start()[0]
    rig.contact = (True, True)
    rig.force = 0.3
    out = rig.tick()
    assert out.state == GraspState.LOADING and out.target_force == 0.5
    rig.force = 0.5
    assert rig.tick().state == GraspState.LIFTING


def test_slip_refractory_and_same_sample_not_counted_twice():
    rig = Rig()
    start = rig.to_lifting()
    held = start.servo.position
    rig.slip = True
    assert rig.tick().slip_reacted
    rig.slip = True  # 10 ms later: inside the 50 ms refractory period, same event
    out = rig.tick()
    assert not out.slip_reacted and out.slip_events == 1
    # the same perception sample (same stamp) presented twice acts once
    rig.tick(0.05)
    inputs = replace(rig.inputs(), perception=replace(rig.inputs().perception, slip=True))
    rig.now += DT
    first = rig.machine.step(inputs, rig.now)
    rig.now += DT
    second = rig.machine.step(inputs, rig.now)
    assert first.slip_reacted and not second.slip_reacted
    assert second.slip_events == 2
    assert second.servo.position == pytest.approx(held - 2 * PAPER_SLIP_INCREMENT)


def test_slip_ignored_when_detector_not_active_or_data_invalid():
    rig = Rig()
    rig.to_lifting()
    rig.slip, rig.slip_active = True, False
    assert not rig.tick().slip_reacted
    rig.slip_active = True
    rig.slip, rig.data_valid = True, False
    assert not rig.tick().slip_reacted
    rig.data_valid = True
    rig.slip = True
    assert rig.tick().slip_reacted


def test_no_slip_controller_never_tightens():
    rig = Rig()
    start = rig.to_lifting(controller=Controller.NO_SLIP)
    for _ in range(20):
        rig.slip = True
        out = rig.tick(0.1)
        assert not out.slip_reacted
        if out.state != GraspState.LIFTING:
            break
    assert out.servo.position == start.servo.position and out.slip_events == 0


def test_tightening_cap_faults_before_exceeding():
    params = replace(ControllerParams(), max_tightening=2.5 * PAPER_SLIP_INCREMENT)
    rig = Rig(params)
    rig.to_lifting()
    for expected in (1, 2):
        rig.slip = True
        assert rig.tick(0.06).slip_events == expected
    rig.slip = True
    out = rig.tick(0.06)
    assert out.state == GraspState.FAULT
    assert out.fault_flags == FaultFlag.TIGHTENING_LIMIT
    assert out.outcome == Outcome.FAULT and out.finished
    assert out.tightening == pytest.approx(2 * PAPER_SLIP_INCREMENT)
    assert out.arm_velocity == 0.0


def test_drop_by_force_during_lifting():
    rig = Rig()
    rig.to_lifting()
    rig.force = 0.6
    rig.tick()
    rig.force = 0.1  # below 0.3 x 0.6 N
    out = rig.tick()
    assert out.state == GraspState.LIFTING  # not yet confirmed (0.1 s)
    out = rig.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.5)
    assert out.state == GraspState.DONE and out.outcome == Outcome.DROPPED
    assert 'force' in out.message and out.arm_velocity == 0.0


def test_short_force_dip_is_not_a_drop():
    rig = Rig()
    rig.to_lifting()
    rig.force = 0.6
    rig.tick()
    rig.force = 0.05
    for _ in range(5):  # 50 ms < drop_confirm_time
        assert rig.tick().state == GraspState.LIFTING
    rig.force = 0.6
    for _ in range(20):
        assert rig.tick().state == GraspState.LIFTING


def test_drop_by_deformation_level_and_contact_loss():
    rig = Rig(replace(ControllerParams(), drop_on_contact_loss=True))
    rig.filtered = (0.1,) * 6
    rig.to_lifting()
    rig.filtered = (0.01,) * 6  # 10 % of the held level
    out = rig.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.5)
    assert out.outcome == Outcome.DROPPED and 'deformation' in out.message
    rig2 = Rig(replace(ControllerParams(), drop_on_contact_loss=True))
    rig2.to_lifting()
    rig2.contact = (False, False)
    out = rig2.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.5)
    assert out.outcome == Outcome.DROPPED and 'contact' in out.message


def test_drop_during_holding():
    rig = Rig()
    rig.to_lifting()
    rig.run_until(lambda o: o.state == GraspState.HOLDING)
    rig.force = 0.0
    out = rig.run_until(lambda o: o.state != GraspState.HOLDING, limit=0.5)
    assert out.outcome == Outcome.DROPPED and 'HOLDING' in out.message


def test_release_after_hold():
    rig = Rig()
    rig.to_lifting(release_after=True)
    out = rig.run_until(lambda o: o.state == GraspState.RELEASING)
    assert out.servo.position == 1.0 and out.outcome == Outcome.LIFTED
    assert not out.finished
    out = rig.tick()  # joint reaches the open angle
    assert out.state == GraspState.DONE and out.finished and out.outcome == Outcome.LIFTED


def test_no_contact_when_fully_closed():
    rig = Rig()
    assert rig.start()[0]
    out = rig.run_until(lambda o: o.state != GraspState.CLOSING)
    assert out.state == GraspState.DONE and out.outcome == Outcome.NO_CONTACT
    assert out.servo.position == 0.0
    # it waited no_contact_settle at the closed angle: 1.0 rad / 0.25 rad/s + 0.3 s
    assert rig.now - 100.0 == pytest.approx(4.3, abs=2 * DT)


def test_loading_closes_fully_without_reaching_force_then_lifts():
    rig = Rig()
    assert rig.start()[0]
    rig.contact = (True, True)
    rig.force = 0.0
    out = rig.run_until(lambda o: o.state != GraspState.LOADING and o.state
                        != GraspState.CLOSING, limit=30)
    assert out.state == GraspState.LIFTING and 'closed fully' in out.message


def test_loading_waits_for_valid_force_then_faults():
    rig = Rig()
    assert rig.start()[0]
    rig.tick()
    rig.contact = (True, True)
    rig.force_valid = False
    out = rig.tick()
    assert out.state == GraspState.LOADING
    held = out.servo.position
    out = rig.tick()
    assert out.servo.position == held  # never ramps on an invalid force
    rig.force_valid = True
    rig.force = 0.2
    out = rig.tick()
    assert out.state == GraspState.LOADING and out.target_force == pytest.approx(0.45)
    rig.force_valid = False
    out = rig.run_until(lambda o: o.state != GraspState.LOADING, limit=1.0)
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.INVALID_INPUT


def test_reset_judges_the_inputs_it_is_given():
    """A reset with inputs judges those (as start does), not those of the last step."""
    rig = Rig()
    rig.to_lifting()
    rig.force = 8.5
    out = rig.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.1)
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.FORCE_LIMIT
    rig.force = 1.0
    ok, message, _ = rig.machine.reset_fault(rig.now)  # last step saw 8.5 N
    assert not ok and 'FORCE_LIMIT' in message
    ok, _, cleared = rig.machine.reset_fault(rig.now, rig.inputs())  # 1.0 N, no step
    assert ok and cleared == FaultFlag.FORCE_LIMIT


def test_force_limit_fault_and_reset_refused_while_above():
    rig = Rig()
    rig.to_lifting()
    rig.force = 8.5
    out = rig.tick()
    assert out.state == GraspState.LIFTING  # 30 ms confirmation
    out = rig.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.1)
    assert out.state == GraspState.FAULT and out.outcome == Outcome.FORCE_LIMIT
    assert out.fault_flags == FaultFlag.FORCE_LIMIT and out.arm_velocity == 0.0
    held = out.servo.position
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.servo.position == held  # latched, held
    ok, message, cleared = rig.machine.reset_fault(rig.now)
    assert not ok and 'FORCE_LIMIT' in message and cleared == FaultFlag.NONE
    rig.force = 1.0
    rig.tick()
    ok, message, cleared = rig.machine.reset_fault(rig.now)
    assert ok and cleared == FaultFlag.FORCE_LIMIT
    assert rig.tick().state == GraspState.IDLE


def test_goal_caps_can_only_tighten():
    rig = Rig()
    assert not rig.start(max_force=9.0)[0]
    assert not rig.start(lift_distance=0.5)[0]
    assert not rig.start(lift_speed=0.05)[0]
    assert not rig.start(max_tightening=1.0)[0]
    ok, reason = rig.start(initial_force=float('nan'))
    assert not ok and 'finite' in reason
    ok, reason = rig.start(initial_force=3.0, max_force=2.0)
    assert not ok and 'initial_force' in reason
    assert not rig.start(controller=7)[0]
    assert rig.machine.state == GraspState.IDLE
    ok, _ = rig.start(max_force=3.0, lift_distance=0.01, lift_speed=0.01, timeout=5.0)
    assert ok


def test_goal_overrides_apply():
    rig = Rig()
    rig.to_lifting(lift_distance=0.01, lift_speed=0.01, initial_force=0.5)
    out = rig.run_until(lambda o: o.state == GraspState.HOLDING)
    assert out.lift_height == pytest.approx(0.012, abs=0.01 * DT + 1e-9)  # + probe
    assert out.target_force == pytest.approx(0.5, abs=0.2)
    out = rig.run_until(lambda o: o.state == GraspState.DONE)
    assert out.lift_height == pytest.approx(0.01, abs=2e-5)


@pytest.mark.parametrize('state', [GraspState.CLOSING, GraspState.LOADING,
                                   GraspState.LIFTING, GraspState.HOLDING])
@pytest.mark.parametrize('which', ['perception', 'joint'])
def test_stale_data_faults_in_every_phase(state, which):
    rig = Rig()
    rig.to_lifting() if state in (GraspState.LIFTING, GraspState.HOLDING) else rig.start()
    if state == GraspState.LOADING:
        rig.contact = (True, True)
        rig.tick()
    if state == GraspState.HOLDING:
        rig.run_until(lambda o: o.state == GraspState.HOLDING)
    rig.tick()
    assert rig.machine.state == state
    held = rig.history[-1].servo.position
    if which == 'perception':
        rig.perception_age = 0.15
        rig.slip = True  # a stale slip must not be acted on
        rig.force = 9.0  # nor a stale force
        flag = FaultFlag.STALE_PERCEPTION
    else:
        rig.joint_age = 0.25
        flag = FaultFlag.STALE_JOINT_STATE
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.fault_flags == flag
    assert out.outcome == Outcome.FAULT and out.finished
    assert out.arm_velocity == 0.0 and out.servo.position == held and not out.slip_reacted
    # latched: fresh data alone does not leave FAULT
    rig.perception_age = rig.joint_age = 0.0
    rig.force = 0.3
    assert rig.tick().state == GraspState.FAULT
    assert not rig.start()[0]
    ok, _, cleared = rig.machine.reset_fault(rig.now)
    assert ok and cleared == flag
    assert rig.start()[0]


def test_missing_data_refuses_start_and_reset_refused_while_stale():
    rig = Rig()
    rig.send_perception = False
    rig.machine = GraspStateMachine()
    ok, reason = rig.start()
    assert not ok and 'STALE_PERCEPTION' in reason
    rig.send_perception = True
    rig.joint_age = 1.0
    ok, reason = rig.start()
    assert not ok and 'STALE_JOINT_STATE' in reason
    rig.joint_age = 0.0
    assert rig.start()[0]
    rig.tick()
    rig.send_perception = False  # perception stops arriving
    rig.tick(0.05)
    assert rig.machine.state == GraspState.CLOSING  # 50 ms old: still fresh
    out = rig.tick(0.06)
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.STALE_PERCEPTION
    rig.assert_reset_refused_until('STALE_PERCEPTION', send_perception=True)


def test_nan_stamp_is_stale():
    rig = Rig()
    assert rig.start()[0]
    rig.perception_age = float('nan')
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.STALE_PERCEPTION


def test_invalid_data_holds_then_faults():
    rig = Rig()
    assert rig.start()[0]
    rig.tick()
    rig.data_valid = False
    rig.contact = (True, True)  # contact on invalid data is ignored
    out = rig.tick()
    assert out.state == GraspState.CLOSING
    held = out.servo.position
    out = rig.tick()
    assert out.servo.position == held
    out = rig.run_until(lambda o: o.state != GraspState.CLOSING, limit=1.0)
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.INVALID_INPUT
    rig.assert_reset_refused_until(data_valid=True)


def test_servo_error_faults():
    rig = Rig()
    rig.to_lifting()
    rig.servo_error = True
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.SERVO
    rig.assert_reset_refused_until(servo_error=False)


def test_lift_cap_fault_when_steps_are_too_far_apart():
    rig = Rig(replace(ControllerParams(), max_lift_distance=0.05, lift_distance=0.04,
                      perception_timeout=1.0, joint_state_timeout=1.0))
    rig.to_lifting()
    out = rig.tick(0.9)  # 4.5 mm
    assert out.state == GraspState.LIFTING
    rig.now += 11.0  # controller starved for 11 s while the arm moved (55 mm)
    rig.perception_age = rig.joint_age = 0.0
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.fault_flags == FaultFlag.LIFT_LIMIT
    assert out.arm_velocity == 0.0


def test_timeout():
    rig = Rig(replace(ControllerParams(), timeout=2.0))
    assert rig.start()[0]
    rig.block_angle = 0.5  # object blocks the fingers but no contact is ever sensed
    out = rig.run_until(lambda o: o.state != GraspState.CLOSING, limit=5.0)
    assert out.state == GraspState.DONE and out.outcome == Outcome.TIMEOUT
    assert rig.now - 100.0 == pytest.approx(2.0, abs=2 * DT)


@pytest.mark.parametrize('phase', ['closing', 'lifting'])
def test_cancel_stops_motion_immediately(phase):
    rig = Rig()
    if phase == 'closing':
        assert rig.start()[0]
        rig.tick()
    else:
        rig.to_lifting()
        rig.tick()
    before = rig.history[-1]
    out = rig.machine.cancel(rig.now)
    assert out.state == GraspState.DONE and out.outcome == Outcome.CANCELED and out.finished
    assert out.arm_velocity == 0.0 and out.servo == before.servo
    out = rig.tick(0.5)
    assert out.servo == before.servo and out.arm_velocity == 0.0
    assert out.lift_height == before.lift_height  # no lift after cancel
    assert rig.start()[0]


def test_cancel_when_idle_and_busy_start_refused():
    rig = Rig()
    out = rig.machine.cancel(rig.now)
    assert out.state == GraspState.IDLE and out.outcome == Outcome.NONE
    assert rig.start()[0]
    ok, reason = rig.start()
    assert not ok and 'busy' in reason
    assert not rig.machine.reset_fault(rig.now)[0]


@pytest.mark.parametrize('sensing', [False, True])
def test_on_off_closes_fully_without_sensing_then_lifts(sensing):
    rig = Rig()
    rig.send_perception = sensing  # ON_OFF needs no perception to move
    assert rig.start(controller=Controller.ON_OFF)[0]
    rig.block_angle = 0.4
    rig.contact = (True, True)
    rig.force = 7.0  # above the force cap: ON_OFF does not sense, so no FORCE_LIMIT
    rig.filtered = CARRIED
    out = rig.run_until(lambda o: o.state == GraspState.LIFTING)
    assert out.servo.position == 0.0
    # 1.0 rad at 0.25 rad/s, then on_off_settle 0.5 s
    assert rig.now - 100.0 == pytest.approx(4.5, abs=2 * DT)
    out = rig.run_until(lambda o: o.state == GraspState.HOLDING)
    assert out.outcome == Outcome.NONE
    out = rig.run_until(lambda o: o.state == GraspState.DONE)
    assert out.slip_events == 0
    if sensing:  # the tactile pattern shows the object carried
        assert out.outcome == Outcome.LIFTED
    else:  # nothing shows that the object left the table: not claimed
        assert out.outcome == Outcome.NOT_CARRIED and 'no tactile data' in out.message


def test_on_off_drop_detected_from_sensors_for_outcome():
    rig = Rig()
    assert rig.start(controller=Controller.ON_OFF)[0]
    rig.force = 2.0
    rig.run_until(lambda o: o.state == GraspState.LIFTING)
    rig.slip = True
    out = rig.tick()
    assert not out.slip_reacted
    rig.force = 0.1
    out = rig.run_until(lambda o: o.state != GraspState.LIFTING, limit=0.5)
    assert out.outcome == Outcome.DROPPED


def test_time_must_be_finite():
    machine = GraspStateMachine()
    with pytest.raises(ValueError):
        machine.step(ControlInputs(), float('nan'))


def test_long_run_is_stable():
    """An hour of 10 ms steps in HOLDING-free idle and repeated grasps keeps state bounded."""
    rig = Rig(replace(ControllerParams(), lift_distance=0.005, hold_duration=0.1))
    for _ in range(20):
        rig.contact = (False, False)
        rig.force = 0.0
        rig.theta = 1.0
        rig.to_lifting()
        out = rig.run_until(lambda o: o.state == GraspState.DONE)
        assert out.outcome == Outcome.LIFTED
        assert out.lift_height == pytest.approx(0.005, abs=0.005 * DT + 1e-9)


def test_contact_and_force_at_the_first_step_then_slip():
    """CLOSING -> LOADING -> LIFTING within one step still has a command to tighten from."""
    rig = Rig(replace(ControllerParams(), initial_force_mode='absolute'))
    rig.theta = 0.5
    rig.contact = (True, True)
    rig.force = 0.5
    assert rig.start()[0]
    out = rig.tick()
    assert out.state == GraspState.LIFTING
    assert out.servo.position == pytest.approx(0.5)
    rig.slip = True
    out = rig.tick()
    assert out.slip_reacted
    assert out.servo.position == pytest.approx(0.5 - PAPER_SLIP_INCREMENT)


def test_force_spike_above_cap_holds_without_fault_and_without_tightening():
    rig = Rig()
    start = rig.to_lifting()
    rig.force = 8.5
    rig.slip = True  # a slip during the spike must not tighten beyond the cap
    out = rig.tick()
    assert out.state == GraspState.LIFTING and not out.slip_reacted
    assert out.servo.position == start.servo.position and 'above the cap' in out.message
    rig.force = 1.0
    out = rig.tick()
    assert out.state == GraspState.LIFTING and out.fault_flags == FaultFlag.NONE


def test_force_limit_immediate_when_confirmation_is_zero():
    rig = Rig(replace(ControllerParams(), force_limit_confirm=0.0))
    assert rig.start()[0]
    rig.tick()
    rig.force = 8.5
    rig.contact = (True, True)
    out = rig.tick()
    assert out.state == GraspState.FAULT and out.outcome == Outcome.FORCE_LIMIT
