"""The simulated scene node with real rclpy: frames, joint states, ground truth, commands."""
from __future__ import annotations

import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import ParameterType
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from forte_msgs.msg import SensorInfo, ServoCommand, SimGroundTruth, TactileFrames
from forte_ros import call_in_executor
from forte_ros.contract import SERVO_TORQUE_CONSTANT
from forte_ros.qos import COMMANDS, SENSOR_INFO, reliable
from forte_ros.sensor_identity import SIMULATED_SENSOR, SensorIdentity
from forte_ros.testing import SpinningGraph, wait_until
from forte_sim.ros.sim_node import LEFT_JOINT, RIGHT_JOINT, SimNode


class Harness:
    """Sim node + a listener/commander node, spun by one executor in a thread."""

    def __init__(self, **parameters) -> None:
        self.ros = SpinningGraph('sim_peer')
        overrides = [Parameter(name, value=value) for name, value in parameters.items()]
        self.node = self.ros.add(SimNode(context=self.ros.context, parameter_overrides=overrides))
        self.peer = self.ros.node
        # a deeper reliable queue than the contract's: the test must see every message
        deep = reliable(1000)
        self.frames: list[tuple[float, TactileFrames]] = self.ros.collect(
            TactileFrames, 'tactile/frames', deep, arrival_times=True)
        self.joints: list[JointState] = self.ros.collect(JointState, 'joint_states', deep)
        self.truth: list[SimGroundTruth] = self.ros.collect(SimGroundTruth, 'sim/ground_truth',
                                                            deep)
        self.clock: list[Clock] = self.ros.collect(Clock, '/clock', deep)
        self.diagnostics: list[DiagnosticArray] = self.ros.collect(DiagnosticArray,
                                                                   '/diagnostics', deep)
        self.servo = self.peer.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        self.arm = self.peer.create_publisher(TwistStamped, 'arm/cmd_vel', COMMANDS)
        self.ros.start()

    def wait(self, condition, timeout: float = 30.0) -> bool:
        """Poll ``condition`` until true; generous timeout for loaded CI machines."""
        return bool(wait_until(condition, timeout, period=0.02))

    def transition(self, name: str) -> TransitionCallbackReturn:
        """Run lifecycle transition ``name`` ('configure', 'cleanup', ...) in the executor's
        thread, as the node's change_state service would: from the test's thread, a cleanup
        destroys timers and publishers under a spin in progress (InvalidHandle)."""
        return call_in_executor(self.ros.executor, getattr(self.node, f'trigger_{name}'))

    def close(self) -> None:
        self.ros.close()


@pytest.fixture
def harness_factory():
    made = []

    def make(**parameters):
        harness = Harness(**parameters)
        made.append(harness)
        return harness

    yield make
    for harness in made:
        harness.close()


def test_real_time_frames_have_the_contract_layout_rate_and_sequence(harness_factory):
    harness = harness_factory(scene='grasp', object='apple', seed=1, reliable=True)
    assert harness.wait(lambda: len(harness.frames) >= 5)
    start_wall, start = harness.frames[-1]
    time.sleep(1.5)
    end_wall, end = harness.frames[-1]
    samples = end.first_sequence - start.first_sequence
    rate = samples / (end_wall - start_wall)
    assert 1000 < rate < 3000                       # 2 kHz of samples in real time
    messages = [message for _, message in harness.frames]
    sequences = np.array([message.first_sequence for message in messages])
    np.testing.assert_array_equal(np.diff(sequences), 20)
    first = messages[0]
    assert first.sample_count == 20 and first.sample_period == pytest.approx(0.0005)
    assert list(first.channel_names) == ['left_distal', 'left_middle', 'left_root',
                                         'right_distal', 'right_middle', 'right_root']
    assert len(first.data) == 120 and first.header.frame_id == 'forte_base_link'
    data = np.asarray(first.data).reshape(20, 6)
    assert np.all(np.abs(data) < 1.0)
    np.testing.assert_allclose(data * 1024, np.rint(data * 1024))   # 11-bit quantised
    # stamps: sample time of the first row, 10 ms apart
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in messages])
    np.testing.assert_allclose(np.diff(stamps), 0.01, atol=1e-6)
    assert first.device_time_us == first.first_sequence * 500
    # diagnostics report the simulation's progress once per second
    assert harness.wait(lambda: any(status.name.endswith('simulated scene')
                                    for array in harness.diagnostics
                                    for status in array.status))
    values = {item.key: item.value for item in harness.diagnostics[-1].status[0].values}
    assert values['scene'] == 'grasp' and values['object'] == 'apple'
    assert float(values['simulated_seconds']) > 0.0
    assert values['rejected_commands'] == '0'


def test_servo_command_moves_the_joint_and_the_arm_lifts(harness_factory):
    harness = harness_factory(scene='grasp', object='jam_jar', seed=2, real_time_factor=2.0)
    assert harness.wait(lambda: len(harness.joints) >= 3)
    start = harness.joints[-1].position[0]
    assert list(harness.joints[-1].name) == [LEFT_JOINT, RIGHT_JOINT]
    target = 0.30

    def closed():
        harness.servo.publish(ServoCommand(position=target))
        return harness.joints[-1].position[0] < start - 0.1

    assert harness.wait(closed)
    # the servo stalls at the jar, which is wider than the commanded gap
    assert harness.wait(lambda: harness.truth[-1].finger_force[0] > 1.0)
    # effort = joint torque along theta [N m]: squeezing the jar pushes closed (negative),
    # k x the scene's servo current (both fingers)
    current = harness.joints[-1].effort[0] / SERVO_TORQUE_CONSTANT
    assert current < -0.05
    lift = TwistStamped()
    lift.twist.linear.z = 0.02

    def lifted():
        harness.arm.publish(lift)
        return harness.truth[-1].lift_height > 0.01

    assert harness.wait(lifted)
    truth = harness.truth[-1]
    assert truth.scene == 'grasp' and truth.object_name == 'jam_jar' and truth.trial == 0
    assert truth.object_height > 0.0
    # without commands the arm stops after cmd_vel_timeout (0.5 s simulated)
    heights = []

    def stopped():
        time.sleep(0.3)
        latest = harness.truth[-1]
        heights.append((latest.header.stamp.sec + 1e-9 * latest.header.stamp.nanosec,
                        latest.lift_height))
        return (len(heights) >= 2 and heights[-1][0] > heights[-2][0]
                and heights[-1][1] == heights[-2][1])

    assert harness.wait(stopped)


def test_as_fast_as_possible_with_clock(harness_factory):
    harness = harness_factory(scene='calibration', object='sphere', seed=3,
                              real_time_factor=0.0, publish_clock=True, reliable=True)
    assert harness.wait(lambda: len(harness.clock) >= 2)

    def seconds(clock):
        return clock.clock.sec + 1e-9 * clock.clock.nanosec

    # the simulation clock runs (its speed is measured in bench_sim.py)
    assert harness.wait(lambda: seconds(harness.clock[-1]) - seconds(harness.clock[0]) > 0.5)
    clocks = [seconds(clock) for clock in harness.clock]
    assert np.all(np.diff(clocks) > 0)
    truth = harness.truth[-1]
    assert truth.scene == 'calibration' and truth.object_state == 0
    # one batch per executor turn: a reader in the same executor keeps up
    sequences = np.array([m.first_sequence for _, m in harness.frames])
    np.testing.assert_array_equal(np.diff(sequences), 20)
    assert len(sequences) > 10


@pytest.mark.parametrize('clock_rate', [20.0, 100.0])
def test_clock_comes_at_its_rate_and_never_ahead_of_the_data(harness_factory, clock_rate):
    harness = harness_factory(scene='calibration', object='sphere', seed=3, clock_rate=clock_rate,
                              real_time_factor=0.0, publish_clock=True, reliable=True)
    assert harness.wait(lambda: len(harness.frames) >= 200)  # 2 simulated seconds

    def nanoseconds(stamp) -> int:
        return stamp.sec * 10**9 + stamp.nanosec

    frames = [nanoseconds(m.header.stamp) for _, m in list(harness.frames)]
    clocks = np.array([nanoseconds(c.clock) for c in list(harness.clock)])
    inside = clocks[(clocks > frames[0] + 10**8) & (clocks < frames[-1] - 10**8)]
    period = round(1e9 / clock_rate)  # [ns]
    span = frames[-1] - frames[0] - 2 * 10**8
    # 1 / clock_rate apart, on batch boundaries (10 ms): an open interval of the span holds
    # span // period of them, one fewer when both ends fall on the grid, one more at most
    assert span // period - 1 <= len(inside) <= span // period + 1, (len(inside), span / period)
    np.testing.assert_array_equal(np.diff(inside), period)
    # each /clock is the end of a batch already published: the time of data that exists
    ends = {stamp + 20 * 500_000 for stamp in frames}  # first sample + 20 x 0.5 ms
    assert set(inside.tolist()) <= ends


def test_bad_parameters_and_commands_are_refused(harness_factory):
    harness = harness_factory(scene='grasp', object='apple', seed=4)
    result = harness.node.set_parameters([Parameter('real_time_factor', value=-1.0)])[0]
    assert not result.successful
    result = harness.node.set_parameters([Parameter('real_time_factor', value=2.0)])[0]
    assert result.successful
    result = harness.node.set_parameters([Parameter('object', value='soda_can')])[0]
    assert not result.successful and 'clean up' in result.reason  # the scene is built
    descriptor = harness.node.describe_parameter('real_time_factor')
    assert descriptor.type == ParameterType.PARAMETER_DOUBLE
    assert harness.wait(lambda: len(harness.joints) >= 2)
    harness.servo.publish(ServoCommand(position=float('nan')))
    assert harness.wait(lambda: harness.node._rejected_commands == 1)
    assert harness.joints[-1].position[0] == pytest.approx(harness.node._scene.initial_angle)


def test_deactivate_pauses_and_activate_resumes_the_stream(harness_factory):
    harness = harness_factory(scene='empty', seed=5, reliable=True)
    assert harness.wait(lambda: len(harness.frames) >= 10)
    assert harness.transition('deactivate') == TransitionCallbackReturn.SUCCESS
    # frames published before the deactivation may still be in flight on a busy machine:
    # wait until the count settles (no frame for 0.5 s), then it must stay put
    paused = -1
    deadline = time.monotonic() + 10.0
    while len(harness.frames) != paused and time.monotonic() < deadline:
        paused = len(harness.frames)
        time.sleep(0.5)
    assert len(harness.frames) == paused, 'frames kept arriving after the deactivation'
    time.sleep(1.0)
    assert len(harness.frames) == paused
    assert harness.transition('activate') == TransitionCallbackReturn.SUCCESS
    assert harness.wait(lambda: len(harness.frames) >= paused + 10)
    messages = [message for _, message in harness.frames]
    np.testing.assert_array_equal(np.diff([m.first_sequence for m in messages]), 20)
    # resumed on the wall clock: the stamps jump over the pause, never go back
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in messages])
    assert np.all(np.diff(stamps) > 0)
    assert np.diff(stamps)[paused - 1] > 0.4


def _quiet_for(harness: Harness, seconds: float) -> bool:
    """True when no frame and no truth message arrived for ``seconds``."""
    counts = (len(harness.frames), len(harness.truth))
    time.sleep(seconds)
    return counts == (len(harness.frames), len(harness.truth))


def test_a_new_scene_after_cleanup_takes_the_new_object(harness_factory):
    harness = harness_factory(scene='grasp', object='apple', seed=4, reliable=True)
    assert harness.wait(lambda: harness.truth)
    assert harness.truth[-1].object_name == 'apple'
    assert harness.transition('deactivate') == TransitionCallbackReturn.SUCCESS
    assert harness.transition('cleanup') == TransitionCallbackReturn.SUCCESS
    results = harness.node.set_parameters([Parameter('object', value='soda_can'),
                                           Parameter('seed', value=13)])
    assert all(result.successful for result in results)
    # messages the old scene published before deactivate may still be in flight on a loaded
    # machine: count from when none has arrived for 0.5 s
    assert harness.wait(lambda: _quiet_for(harness, 0.5))
    truths, frames = len(harness.truth), len(harness.frames)
    assert harness.transition('configure') == TransitionCallbackReturn.SUCCESS
    assert harness.transition('activate') == TransitionCallbackReturn.SUCCESS
    assert harness.wait(lambda: len(harness.truth) > truths + 5)
    truth = harness.truth[-1]
    assert truth.object_name == 'soda_can' and truth.object_state == 1  # RESTING, a new scene
    assert harness.frames[frames][1].first_sequence == 0  # the new scene's first sample


def test_unknown_object_fails_configure():
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = SimNode(context=context,
                       parameter_overrides=[Parameter('object', value='unobtainium')])
        assert node._scene is None and node._timer is None
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_the_simulated_sensor_identity_is_latched(harness_factory):
    """A subscriber that joins after the node started still receives the simulator's
    SensorInfo (transient local), which perception checks a force model against."""
    harness = harness_factory(scene='empty', reliable=True)
    assert harness.wait(lambda: len(harness.frames) >= 2)
    received = harness.ros.collect(SensorInfo, 'tactile/sensor_info', SENSOR_INFO)
    assert harness.wait(lambda: len(received) >= 1, 10.0), 'no latched sensor info'
    assert SensorIdentity.from_message(received[0]) == SIMULATED_SENSOR
    assert received[0].header.frame_id == 'forte_base_link'
