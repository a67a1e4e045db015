"""rclpy tests of the grasp controller node: real nodes exchanging real messages over DDS.

A fake gripper world node behaves like the simulator + perception node + gripper driver +
arm: every tick it advances simulated time by 10 ms and publishes it on ``/clock``, moves its
servo towards the commanded angle, integrates the arm velocity, senses contact / force once
the fingers close on an object and publishes TactileState, JointState (position and servo
current) and a wrist WrenchStamped stamped with the simulated time; it can inject slip, drop
the object, leave it on the table while the fingers slide up it, or stop publishing (stale
data). The tactile pattern follows the physics the lift verification relies on: a carried
object loads both fingers equally and its weight shears the pads the same way however high
the arm is; an object the table holds against one finger loads that finger more. The
controller runs on that clock (``use_sim_time``) with its default freshness bounds, so a
slow or loaded machine slows the test instead of making its data look stale. An action
client node sends Grasp goals.

The three nodes share one SingleThreadedExecutor, spun by the test itself between its
checks (``Harness.spin_until``): one thread runs every callback, as in the controller's
``main``, and waits are measured in simulated time.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable

import pytest
import rclpy
import rclpy.time
from geometry_msgs.msg import TwistStamped, WrenchStamped
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from forte_control.ros.grasp_controller_node import GraspControllerNode
from forte_control.state_machine import PAPER_SLIP_INCREMENT, FaultFlag, GraspState, Outcome
from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState as GraspStateMsg
from forte_msgs.msg import ServoCommand, TactileState
from forte_msgs.srv import ResetFault
from forte_ros.contract import current_to_effort
from forte_ros.qos import COMMANDS, DIAGNOSTICS, GRASP_STATE, TACTILE_STATE, reliable
from forte_ros.testing import gripper_goal

STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6  # action_msgs/msg/GoalStatus

#: Fast grasps for tests: close at 1 rad/s from 0.7 rad to contact at 0.5 rad, lift 5 mm.
#: The freshness bounds are the controller's defaults (0.1 / 0.2 s, in simulated time).
FAST = {
    'closing_speed': 1.0, 'loading_speed': 0.5, 'lift_speed': 0.02, 'max_lift_speed': 0.02,
    'lift_distance': 0.005, 'hold_duration': 0.3, 'arm_frame_id': 'panda_link0',
    'use_sim_time': True,
}
TICK = 0.01          # simulated time per world tick (one perception update) [s]
GAIN = 0.5           # tactile response of each channel to the squeeze [normalised / rad]
FREE_CURRENT = 0.05  # servo current while moving freely [A]
FREE_EFFORT = -current_to_effort(FREE_CURRENT)  # its joint effort along theta [N m]
CURRENT_GAIN = 2.0   # current rise per rad of squeeze [A/rad]
WALL_LIMIT = 120.0   # a wait that lasts this long in wall time means a hang [s]


class FakeWorld(Node):
    """Stands in for the simulator, perception, gripper driver and arm."""

    def __init__(self) -> None:
        super().__init__('fake_world')
        self.sim_time = 100.0          # simulated time [s], published on /clock
        self.theta = 0.7               # servo angle [rad]
        self.command = None            # latest commanded angle [rad]
        self.servo_speed = 2.0         # [rad/s]
        self.contact_angle = 0.5       # fingers touch the object here [rad]
        self.stiffness = 10.0          # [N/rad]
        self.object_present = True
        self.table_holds = False       # object stays on the table, pressed against one finger
        self.tactile_contact = True    # False: a very soft object, no contact flag / pattern
        self.weight = 2.0              # object weight carried at the wrist once lifted [N]
        self.lift = 0.0                # [m]
        self.arm_velocity = 0.0
        self.publish_perception = True
        self.publish_joints = True
        self.slip_next = False
        self.slipping_until = -1.0  # sim time [s] until which perception reports slipping
        self.invalid_until = -math.inf  # tactile data_valid false before this time [s]
        self.servo_log: list[tuple[float, ServoCommand]] = []   # (simulated time, command)
        self.arm_log: list[tuple[float, TwistStamped]] = []
        self.states: list[GraspStateMsg] = []
        self.sample_index = 0
        self.stamp_offset = 0.0        # shift of the header stamps [s] (recorded data)
        self.clock_every = 1           # ticks per /clock message (the sim's clock_rate)
        self.ticks = 0
        # /clock and arm/wrench are no contract topics: reliable, keep last 10 (the
        # controller's best-effort wrench subscription accepts a reliable publisher)
        self.clock_pub = self.create_publisher(Clock, '/clock', reliable(10))
        self.tactile_pub = self.create_publisher(TactileState, 'tactile/state', TACTILE_STATE)
        self.joint_pub = self.create_publisher(JointState, 'joint_states', COMMANDS)
        self.wrench_pub = self.create_publisher(WrenchStamped, 'arm/wrench', reliable(10))
        self.create_subscription(ServoCommand, 'gripper/command', self.on_servo, COMMANDS)
        self.create_subscription(TwistStamped, 'arm/cmd_vel', self.on_arm, COMMANDS)
        self.create_subscription(GraspStateMsg, 'grasp/state', self.states.append, GRASP_STATE)
        self.create_timer(TICK, self.tick)  # wall-clock timer: simulated time = ticks

    @property
    def state(self) -> int | None:
        """The controller's latest published grasp state (None before the first)."""
        return self.states[-1].state if self.states else None

    def on_servo(self, msg: ServoCommand) -> None:
        self.command = msg.position
        self.servo_log.append((self.sim_time, msg))

    def on_arm(self, msg: TwistStamped) -> None:
        self.arm_velocity = msg.twist.linear.z
        self.arm_log.append((self.sim_time, msg))

    def tick(self) -> None:
        self.sim_time += TICK
        self.ticks += 1
        if self.ticks % self.clock_every == 0:
            self.clock_pub.publish(Clock(clock=to_time(self.sim_time)))
        if self.command is not None:
            step = max(-self.servo_speed * TICK, min(self.servo_speed * TICK,
                                                     self.command - self.theta))
            self.theta += step
        if self.object_present:  # the object blocks the fingers a little beyond contact
            self.theta = max(self.theta, self.contact_angle - 0.2)
        self.lift += self.arm_velocity * TICK
        squeeze = self.contact_angle - self.theta
        in_contact = self.object_present and squeeze > 0.0
        carried = in_contact and not self.table_holds and self.lift > 0.0
        stamp = to_time(self.sim_time - self.stamp_offset)
        self.sample_index += 20
        if self.publish_perception:
            self.tactile_pub.publish(self.tactile(stamp, squeeze, in_contact))
        if self.publish_joints:
            joints = JointState()
            joints.header.stamp = stamp
            joints.name = ['forte_left_finger_joint', 'forte_right_finger_joint']
            joints.position = [self.theta, self.theta]
            current = FREE_CURRENT + (CURRENT_GAIN * squeeze if in_contact else 0.0)
            # joint_states effort: joint torque [N m] along theta, as the driver reports it
            # (the servo pushes toward closing: negative)
            joints.effort = [-current_to_effort(current)] * 2
            self.joint_pub.publish(joints)
        wrench = WrenchStamped()
        wrench.header.stamp = stamp
        wrench.wrench.force.z = -self.weight if carried else 0.0  # z up: a weight pulls down
        self.wrench_pub.publish(wrench)

    def tactile(self, stamp, squeeze: float, in_contact: bool) -> TactileState:
        """The perception of the current squeeze (both fingers alike unless the table holds
        the object against the left finger once the arm moved)."""
        sensed = in_contact and self.tactile_contact
        msg = TactileState()
        msg.header.stamp = stamp
        msg.header.frame_id = 'forte_base_link'
        msg.sample_index = self.sample_index
        msg.force = self.stiffness * squeeze if sensed else 0.0
        msg.force_valid = True
        msg.contact = [sensed, sensed]
        msg.slip = self.slip_next
        self.slip_next = False
        msg.slipping = self.sim_time < self.slipping_until
        msg.finger_slipping = [msg.slipping, msg.slipping]
        msg.slip_active = True
        msg.data_valid = self.sim_time >= self.invalid_until  # false: the chunks after a gap
        msg.tared = True
        level = GAIN * squeeze if sensed else 0.0
        left = 2.0 * level if self.table_holds and self.lift > 0.0 else level
        msg.filtered = [left] * 3 + [level] * 3
        return msg


def to_time(seconds: float):
    """Float seconds -> builtin_interfaces/Time."""
    return rclpy.time.Time(nanoseconds=round(seconds * 1e9)).to_msg()


class Harness:
    """Controller node + fake world + client node on one SingleThreadedExecutor."""

    def __init__(self, **overrides: object) -> None:
        params = dict(FAST, **overrides)
        self.controller = GraspControllerNode(parameter_overrides=[
            Parameter(name, value=value) for name, value in params.items()])
        self.world = FakeWorld()
        self.client_node = Node('grasp_test_client')
        self.client = ActionClient(self.client_node, Grasp, 'grasp')
        self.reset_client = self.client_node.create_client(ResetFault, 'grasp/reset_fault')
        self.executor = SingleThreadedExecutor()
        for node in (self.controller, self.world, self.client_node):
            self.executor.add_node(node)
        assert self.spin_until(lambda: self.client.server_is_ready()
                               and self.reset_client.service_is_ready()
                               and self.world.count_subscribers('/clock') > 0
                               and self.world.states, 30.0)
        # the controller has the clock and fresh data once it accepts to report them
        self.spin_for(0.3)

    @property
    def now(self) -> float:
        """Simulated time [s]."""
        return self.world.sim_time

    def spin_until(self, condition: Callable[[], object], timeout: float = 10.0) -> bool:
        """Run callbacks until ``condition()`` is true or ``timeout`` simulated seconds."""
        end = self.now + timeout
        wall_end = time.monotonic() + WALL_LIMIT
        while not condition():
            if self.now >= end or time.monotonic() >= wall_end:
                return bool(condition())
            self.executor.spin_once(timeout_sec=0.05)
        return True

    def spin_for(self, duration: float) -> None:
        """Run callbacks for ``duration`` simulated seconds."""
        self.spin_until(lambda: False, duration)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.client.destroy()
        for node in (self.controller, self.world, self.client_node):
            node.destroy_node()

    def send(self, feedback: list | None = None, **goal_fields: object):
        goal = Grasp.Goal()
        for name, value in goal_fields.items():
            setattr(goal, name, value)
        future = self.client.send_goal_async(
            goal, feedback_callback=(lambda msg: feedback.append(msg.feedback))
            if feedback is not None else None)
        assert self.spin_until(future.done)
        return future.result()

    def result(self, handle, timeout: float = 15.0):
        future = handle.get_result_async()
        assert self.spin_until(future.done, timeout)
        return future.result()

    def reset(self):
        future = self.reset_client.call_async(ResetFault.Request())
        assert self.spin_until(future.done)
        return future.result()

    def lifting(self, **goal_fields: object):
        """Send a goal and run until the controller reports LIFTING."""
        handle = self.send(**goal_fields)
        assert handle.accepted
        assert self.spin_until(lambda: self.world.state == GraspState.LIFTING)
        return handle


@pytest.fixture(scope='module')
def ros_context():
    rclpy.init()
    yield
    rclpy.try_shutdown()


@pytest.fixture
def harness(ros_context, request):
    overrides = getattr(request, 'param', {})
    rig = Harness(**overrides)
    yield rig
    rig.close()


def test_forte_grasp_lifts_with_feedback_and_latched_state(harness):
    feedback = []
    handle = harness.send(feedback)
    assert handle.accepted
    response = harness.result(handle)
    result = response.result
    assert result.outcome == Outcome.LIFTED, result.message
    assert response.status == STATUS_SUCCEEDED
    assert result.lift_height == pytest.approx(0.005, abs=0.002)
    assert result.final_force > 0.0
    assert len(feedback) >= 3
    assert {GraspState.CLOSING, GraspState.LIFTING} <= {f.state for f in feedback}
    # the servo closed from the open angle towards the object, the arm moved up then stopped
    commands = [msg.position for _, msg in harness.world.servo_log]
    assert commands[0] < 0.7 and min(commands) < 0.5
    harness.spin_for(0.1)
    velocities = [msg.twist.linear.z for _, msg in harness.world.arm_log]
    assert max(velocities) == pytest.approx(0.02)
    assert velocities[-1] == 0.0
    assert all(msg.header.frame_id == 'panda_link0' for _, msg in harness.world.arm_log)
    assert harness.world.lift == pytest.approx(0.005, abs=0.003)
    # a late joiner receives the latest grasp state (transient local)
    late = []
    harness.client_node.create_subscription(GraspStateMsg, 'grasp/state', late.append,
                                            GRASP_STATE)
    assert harness.spin_until(lambda: late)
    assert late[-1].state == GraspState.DONE and late[-1].last_outcome == Outcome.LIFTED
    assert late[-1].header.frame_id == 'forte_base_link'


def test_slip_tightens_from_the_tactile_callback(harness):
    # 2 s of lift: the slip early in it leaves the last lift_check.quiet_time (1 s) quiet, so
    # the lift verification can call the object carried
    harness.controller.set_parameters([Parameter('lift_distance', value=0.04)])
    handle = harness.lifting()
    harness.spin_for(0.1)
    before = harness.world.servo_log[-1][1].position
    count = len(harness.world.servo_log)
    harness.world.slip_next = True
    assert harness.spin_until(lambda: len(harness.world.servo_log) > count, 1.0)
    tightening = harness.world.servo_log[count][1]
    assert tightening.position == pytest.approx(before - PAPER_SLIP_INCREMENT, abs=1e-9)
    # sent from the callback of the perception update that carried the flag (the controller
    # records the latency of those reactions only), not by the 20 Hz control step
    assert len(harness.controller.slip_reaction_latency) == 1
    result = harness.result(handle).result
    assert result.outcome == Outcome.LIFTED and result.slip_events == 1
    assert result.tightening == pytest.approx(PAPER_SLIP_INCREMENT)


def test_a_slide_that_persists_is_tightened_again_and_its_duration_reported(harness):
    # slip, then 0.5 s of slipping state: the first tightening on the event, one more per
    # slipping_interval (0.2 s) while it lasts; the result's slip_duration is the 0.5 s
    harness.controller.set_parameters([Parameter('lift_distance', value=0.04)])
    feedback = []
    handle = harness.send(feedback)
    assert handle.accepted
    assert harness.spin_until(lambda: harness.world.state == GraspState.LIFTING)
    harness.spin_for(0.1)
    before = harness.world.servo_log[-1][1].position
    harness.world.slip_next = True
    harness.world.slipping_until = harness.world.sim_time + 0.5
    result = harness.result(handle).result
    assert result.outcome == Outcome.LIFTED, result.message
    assert result.slip_events == 3  # the event, then at 0.2 s and 0.4 s of slipping
    assert result.tightening == pytest.approx(3 * PAPER_SLIP_INCREMENT)
    assert min(msg.position for _, msg in harness.world.servo_log) == pytest.approx(
        before - 3 * PAPER_SLIP_INCREMENT, abs=1e-9)
    assert result.slip_duration == pytest.approx(0.5, abs=0.011)  # one update: 10 ms
    assert any(f.slipping for f in feedback)


def test_cancel_stops_the_arm_immediately(harness):
    harness.controller.set_parameters([Parameter('lift_distance', value=0.02)])
    handle = harness.lifting()
    harness.spin_for(0.2)
    assert harness.world.arm_velocity > 0.0
    cancel = handle.cancel_goal_async()
    assert harness.spin_until(cancel.done)
    canceled_at = harness.now
    response = harness.result(handle)
    assert response.result.outcome == Outcome.CANCELED
    assert response.status == STATUS_CANCELED
    assert harness.spin_until(lambda: harness.world.arm_velocity == 0.0, 0.1)
    harness.spin_for(0.3)
    late_motion = [msg.twist.linear.z for t, msg in harness.world.arm_log
                   if t > canceled_at + 0.05]
    assert all(v == 0.0 for v in late_motion)
    assert response.result.lift_height < 0.02
    assert harness.world.state == GraspState.DONE
    assert harness.world.states[-1].last_outcome == Outcome.CANCELED


def test_stale_perception_faults_latches_and_reset_service(harness):
    harness.controller.set_parameters([Parameter('lift_distance', value=0.02)])
    handle = harness.lifting()
    harness.world.publish_perception = False
    response = harness.result(handle)
    assert response.result.outcome == Outcome.FAULT
    assert 'STALE_PERCEPTION' in response.result.message
    assert response.status == STATUS_ABORTED
    assert harness.spin_until(lambda: harness.world.arm_velocity == 0.0, 0.1)
    assert harness.spin_until(lambda: harness.world.state == GraspState.FAULT)
    assert harness.world.states[-1].fault_flags == FaultFlag.STALE_PERCEPTION
    # latched: a new goal is refused, and reset is refused while the data is stale
    assert not harness.send().accepted
    reset = harness.reset()
    assert not reset.success and 'STALE_PERCEPTION' in reset.message
    harness.world.publish_perception = True
    harness.spin_for(0.1)
    reset = harness.reset()
    assert reset.success and reset.cleared_flags == FaultFlag.STALE_PERCEPTION
    # back to normal: the gripper is now holding the object, open it for the next grasp
    harness.world.theta = 0.7
    harness.world.command = None
    handle = harness.send()
    assert handle.accepted
    assert harness.result(handle).result.outcome == Outcome.LIFTED


def test_idle_controller_listens_to_no_input(harness):
    """Idle, the controller has no subscription on its 100 Hz inputs (it costs nothing per
    message); a goal subscribes them, and they are dropped again once it has ended."""
    world = harness.world
    inputs = ('tactile/state', 'joint_states', 'arm/wrench')

    def subscribers() -> list[int]:
        return [world.count_subscribers(topic) for topic in inputs]

    assert harness.spin_until(lambda: subscribers() == [0, 0, 0], 2.0), subscribers()
    handle = harness.send()
    assert handle.accepted
    assert harness.spin_until(lambda: subscribers() == [1, 1, 1], 2.0), subscribers()
    assert harness.result(handle).result.outcome == Outcome.LIFTED
    assert harness.spin_until(lambda: subscribers() == [0, 0, 0], 2.0), subscribers()
    assert harness.world.states[-1].state == GraspState.DONE


def test_coarse_clock_the_data_time_keeps_freshness_exact(harness):
    """/clock at 10 Hz (the sim's clock_rate), data every 10 ms: the machine's time is the
    newest input stamp, so the grasp runs as on a fine clock, and stale perception is
    still caught within its 0.1 s bound plus one tick."""
    harness.world.clock_every = 10
    harness.controller.set_parameters([Parameter('lift_distance', value=0.02)])
    handle = harness.lifting()
    harness.spin_for(0.2)
    assert harness.world.state == GraspState.LIFTING
    stopped = harness.now
    harness.world.publish_perception = False
    assert harness.spin_until(lambda: harness.world.state == GraspState.FAULT, 1.0)
    assert harness.now - stopped <= 0.1 + 0.1 + 2 * TICK, harness.now - stopped
    result = harness.result(handle).result
    assert result.outcome == Outcome.FAULT and 'STALE_PERCEPTION' in result.message


def test_no_joint_states_refuses_goal_before_motion(harness):
    harness.world.publish_joints = False
    harness.spin_for(0.4)  # twice the default joint_state_timeout (0.2 s)
    handle = harness.send()
    if handle.accepted:  # accepted by the goal callback, refused by the machine
        result = harness.result(handle).result
        assert result.outcome == Outcome.FAULT and 'STALE_JOINT_STATE' in result.message
    harness.spin_for(0.1)
    assert harness.world.servo_log == []
    assert all(msg.twist.linear.z == 0.0 for _, msg in harness.world.arm_log)


def test_a_goal_waits_past_invalid_tactile_data(harness):
    """A goal that meets tactile states marked invalid (the chunks after a gap of lost
    samples) waits for a valid one, at most input_wait (1 s), instead of being refused."""
    valid_from = harness.now + 0.3
    harness.world.invalid_until = valid_from
    handle = harness.send(controller=Grasp.Goal.FORTE)
    assert handle.accepted
    result = harness.result(handle).result
    assert result.outcome == Outcome.LIFTED, result.message
    assert harness.world.servo_log[0][0] >= valid_from  # no motion on invalid data


def test_a_goal_on_lasting_invalid_tactile_data_is_refused(harness):
    harness.world.invalid_until = harness.now + 5.0
    handle = harness.send(controller=Grasp.Goal.FORTE)
    if handle.accepted:  # accepted by the goal callback, refused by the machine
        result = harness.result(handle).result
        assert result.outcome == Outcome.FAULT and 'invalid data' in result.message
    assert harness.now < harness.world.invalid_until
    assert harness.world.servo_log == []


def test_object_left_on_the_table_is_not_carried(harness):
    """The fingers slide up an object the table holds against one finger: the lift is
    commanded to the end, but the result says NOT_CARRIED (aborted), with the evidence."""
    harness.world.table_holds = True
    handle = harness.send(controller=Grasp.Goal.NO_SLIP)
    response = harness.result(handle)
    assert response.result.outcome == Outcome.NOT_CARRIED, response.result.message
    assert response.status == STATUS_ABORTED
    assert 'unequal' in response.result.message
    assert response.result.lift_height == pytest.approx(0.005, abs=0.001)
    assert harness.spin_until(lambda: harness.world.states[-1].last_outcome
                              == Outcome.NOT_CARRIED, 1.0)


@pytest.mark.parametrize('harness', [{'lift_check.use_wrench': True}], indirect=True)
def test_wrist_wrench_confirms_the_load(harness):
    """With ``lift_check.use_wrench``, LIFTED needs the wrist to carry more once lifted; a
    wrist that feels no load makes the same tactile evidence NOT_CARRIED."""
    response = harness.result(harness.send())
    assert response.result.outcome == Outcome.LIFTED, response.result.message
    assert 'wrist load +2.000 N' in response.result.message
    harness.world.theta = 0.7  # open again, and lift an object of no weight
    harness.world.command = None
    harness.world.lift = 0.0
    harness.world.weight = 0.0
    response = harness.result(harness.send())
    assert response.result.outcome == Outcome.NOT_CARRIED, response.result.message
    assert 'wrist load grew 0.000 N' in response.result.message


def test_closed_on_a_soft_object_without_contact_flag(harness):
    """An object too soft to trip the contact flag still blocks the joint and raises the
    servo current (JointState effort): CLOSED_ON_OBJECT, not a benign NO_CONTACT."""
    harness.world.tactile_contact = False
    response = harness.result(harness.send())
    assert response.result.outcome == Outcome.CLOSED_ON_OBJECT, response.result.message
    assert 'joint stopped' in response.result.message
    assert 'servo current' in response.result.message  # effort reached the machine
    assert response.status == STATUS_ABORTED


def test_drop_detected_from_sensors(harness):
    harness.controller.set_parameters([Parameter('lift_distance', value=0.03)])
    handle = harness.lifting(controller=Grasp.Goal.NO_SLIP)
    harness.spin_for(0.2)
    harness.world.object_present = False
    result = harness.result(handle).result
    assert result.outcome == Outcome.DROPPED, result.message


def test_invalid_goal_and_unsafe_parameters_refused(harness):
    assert not harness.send(max_force=9.9).accepted  # above the node cap of 8 N
    assert not harness.send(controller=9).accepted
    results = harness.controller.set_parameters([Parameter('max_force', value=50.0)])
    assert not results[0].successful
    result = harness.controller.set_parameters_atomically([
        Parameter('initial_force', value=5.0), Parameter('max_force', value=4.0)])
    assert not result.successful and 'initial_force' in result.reason
    assert harness.controller.get_parameter('initial_force').value == 0.25
    results = harness.controller.set_parameters([Parameter('contact_mode', value='any')])
    assert not results[0].successful and 'contact_mode' in results[0].reason
    assert harness.controller.get_parameter('max_force').value == 8.0
    results = harness.controller.set_parameters([Parameter('max_force', value=3.0)])
    assert results[0].successful
    # the new cap applies to the next goal: a goal above it is refused
    assert not harness.send(max_force=5.0).accepted


@pytest.mark.parametrize('harness', [{'dry_run': True}], indirect=True)
def test_dry_run_computes_but_publishes_no_motion(harness):
    feedback = []
    handle = harness.send(feedback)
    result = harness.result(handle).result
    # nothing moved the joint, so the machine closed its command on a joint that stayed open:
    # from its inputs, the gripper is blocked on something
    assert result.outcome == Outcome.CLOSED_ON_OBJECT, result.message
    assert 'joint stopped at 0.700 rad' in result.message
    assert harness.world.servo_log == []
    assert harness.world.arm_log and all(msg.twist.linear.z == 0.0
                                         for _, msg in harness.world.arm_log)
    # the state machine did run: it ramped the command although nothing was published
    commands = [f.servo_command for f in feedback]
    assert commands and min(commands) < 0.7


def test_gripper_command_action(harness):
    control_msgs = pytest.importorskip(
        'control_msgs.action', reason='control_msgs is not installed here (the launch kit '
        'builds it); the GripperCommand server is only created where it is')
    client = ActionClient(harness.client_node, control_msgs.GripperCommand, 'gripper_cmd')
    assert harness.spin_until(client.server_is_ready)
    harness.world.object_present = False
    sent = client.send_goal_async(gripper_goal(0.3, max_effort=0.5))
    assert harness.spin_until(sent.done)
    handle = sent.result()
    assert handle.accepted
    future = handle.get_result_async()
    assert harness.spin_until(future.done, 5.0)
    result = future.result().result
    assert result.reached_goal and not result.stalled
    assert result.position == pytest.approx(0.3, abs=0.03)
    command = harness.world.servo_log[-1][1]
    # max_effort is joint torque: 0.5 N m / 1.7826 N m/A = 0.2805 A of current cap
    assert command.position == pytest.approx(0.3)
    assert command.max_current == pytest.approx(0.280488, abs=1e-6)
    # refused while a grasp runs
    harness.world.object_present = True
    harness.world.theta = 0.7
    harness.world.command = None
    harness.lifting()
    sent = client.send_goal_async(gripper_goal(0.3, max_effort=0.5))
    assert harness.spin_until(sent.done)
    assert not sent.result().accepted
    client.destroy()


def test_diagnostics_report_state_and_fault(harness):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    received = []
    harness.client_node.create_subscription(DiagnosticArray, '/diagnostics', received.append,
                                            DIAGNOSTICS)
    assert harness.spin_until(lambda: received, 3.0)
    status = received[-1].status[0]
    assert 'grasp_controller' in status.name and status.level == DiagnosticStatus.OK
    values = {item.key: item.value for item in status.values}
    assert values['state'] == 'IDLE' and values['inputs'] == 'idle: not subscribed'
    harness.controller.set_parameters([Parameter('lift_distance', value=0.02)])
    harness.lifting()
    received.clear()
    assert harness.spin_until(lambda: received, 3.0)
    values = {item.key: item.value for item in received[-1].status[0].values}
    assert values['inputs'] == 'subscribed' and float(values['perception_age_s']) < 0.1
    harness.world.publish_joints = False
    assert harness.spin_until(lambda: harness.world.state == GraspState.FAULT, 2.0)
    received.clear()
    assert harness.spin_until(lambda: received, 3.0)
    status = received[-1].status[0]
    assert status.level == DiagnosticStatus.ERROR
    values = {item.key: item.value for item in status.values}
    assert int(values['fault_flags']) == FaultFlag.STALE_JOINT_STATE


@pytest.mark.parametrize('harness', [{'use_receive_time': True}], indirect=True)
def test_recorded_stamps_with_receive_time(harness):
    """Replayed data carry old stamps: by header stamp they are stale, by receive time not."""
    harness.world.stamp_offset = 30.0
    harness.spin_for(0.3)
    handle = harness.send()
    assert handle.accepted
    assert harness.result(handle).result.outcome == Outcome.LIFTED


def test_recorded_stamps_are_stale_by_default(harness):
    harness.world.stamp_offset = 30.0
    harness.spin_for(0.3)
    handle = harness.send()
    if handle.accepted:
        result = harness.result(handle).result
        assert result.outcome == Outcome.FAULT and 'STALE' in result.message
    assert harness.world.servo_log == []
