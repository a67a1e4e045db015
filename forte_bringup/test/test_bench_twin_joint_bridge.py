"""ros2_control's TopicBasedSystem path on the bench twin: the real gripper driver, the real
grasp controller, real rclpy, a simulated scene behind the servo bus.

One graph per test in this process (:class:`forte_ros.testing.SpinningGraph`, one
SingleThreadedExecutor): the bench twin node (its servo pair in a process of its own on a
pty, the scene advancing in real time), the gripper driver node on the twin's servo link
(``autostart``), the grasp controller node, and the test's node, which publishes what
``topic_based_ros2_control/TopicBasedSystem`` publishes on ``gripper/joint_commands``
(sensor_msgs/JointState: every joint of its system, position, velocity and effort, 0 where a
joint has no such command interface, the mimic joint at the mimicked joint's value) and sends
Grasp goals. Every claim about motion is judged on the scene's ground truth (the twin's
finger angle), never on the driver's belief.

The scene is ``empty`` (no object: the fingers close freely, the servo current is the
scene's no-load current). The Grasp is ON_OFF (it needs no perception, so no sensor driver,
perception node or force model is needed to run a real Grasp through the real controller):
close to theta = 0, settle, lift 5 mm, hold, then NOT_CARRIED (no tactile data to verify the
lift), the grip kept.
"""
from __future__ import annotations

import time

import pytest
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from forte_control.ros.grasp_controller_node import GraspControllerNode
from forte_driver.dynamixel.units import AMPERES_PER_CURRENT_UNIT
from forte_driver.joint_command_bridge import OWNING_STATES
from forte_driver.ros.gripper_driver_node import GripperDriverNode
from forte_msgs.action import Grasp
from forte_msgs.msg import GraspState
from forte_ros import call_in_executor
from forte_ros.contract import SERVO_TORQUE_CONSTANT
from forte_ros.qos import COMMANDS, reliable
from forte_ros.testing import SpinningGraph, wait_until
from forte_sim.ros.bench_twin_node import BenchTwinNode

LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'
#: The scene's finger angle must come this close to a commanded one [rad] (the servo
#: quantisation is 1.5e-3 rad; the twin's scene follows the servos' goal).
REACHED = 0.01
UP = 30.0       # longest wait for the graph to come up [s]
MOVE = 10.0     # longest wait for a move of the scene [s] (default profile 1 rad/s)
#: The ON_OFF grasp, fast: close at 2 rad/s, settle 0.3 s, lift 5 mm at 20 mm/s, hold
#: 0.3 s, no set-down probe. Freshness 1 s: the twin, the servo process and three nodes
#: share two cores.
CONTROLLER = {
    'on_off_closing_speed': 2.0, 'on_off_settle': 0.3, 'lift_speed': 0.02,
    'max_lift_speed': 0.02, 'lift_distance': 0.005, 'hold_duration': 0.3,
    'lift_check.probe_distance': 0.0, 'joint_state_timeout': 1.0,
}


class Graph:
    """The bench twin, the gripper driver, the grasp controller and the test's node."""

    def __init__(self, folder) -> None:
        self.ros = SpinningGraph('topic_based_system')
        context = self.ros.context
        self.twin_node = self.ros.add(BenchTwinNode(context=context, parameter_overrides=[
            Parameter('sensor_link', value=str(folder / 'sensor')),
            Parameter('servo_link', value=str(folder / 'gripper')),
            Parameter('scene', value='empty'), Parameter('seed', value=1)]))
        self.driver = self.ros.add(GripperDriverNode(context=context, parameter_overrides=[
            Parameter('port', value=str(folder / 'gripper')),
            Parameter('autostart', value=True)]))
        self.controller = self.ros.add(GraspControllerNode(context=context, parameter_overrides=[
            Parameter(name, value=value) for name, value in CONTROLLER.items()]))
        node = self.ros.node
        self.joint_states = self.ros.collect(JointState, 'joint_states', reliable(1000))
        # deeper than the contract's depth 1, so that no state is overwritten unread
        self.grasp_states = self.ros.collect(GraspState, 'grasp/state',
                                             reliable(100, transient_local=True))
        self.commands = node.create_publisher(JointState, 'gripper/joint_commands', COMMANDS)
        self.grasp = ActionClient(node, Grasp, 'grasp')
        self.ros.start()

    @property
    def theta(self) -> float:
        """The scene's finger angle: the ground truth [rad]."""
        return self.twin_node.twin.scene.joint_position

    def command(self, position: float, velocity: float = 0.0, effort: float = 0.0) -> None:
        """One TopicBasedSystem message: both finger joints (the right one the mimic)."""
        self.commands.publish(JointState(name=[LEFT, RIGHT], position=[position] * 2,
                                         velocity=[velocity] * 2, effort=[effort] * 2))

    def close(self) -> None:
        self.ros.stop()
        self.grasp.destroy()
        self.controller.prepare_shutdown()
        self.driver.stop_hardware('test end')
        self.twin_node.prepare_shutdown()
        self.ros.close()


@pytest.fixture
def graph(tmp_path):
    started = Graph(tmp_path / 'bench')
    try:
        assert wait_until(lambda: len(started.joint_states) >= 5, UP), 'no joint_states'
        assert wait_until(lambda: started.commands.get_subscription_count() >= 1, UP)
        assert wait_until(started.grasp.server_is_ready, UP)
        yield started
    finally:
        started.close()


def test_joint_commands_move_the_twins_fingers_and_effort_is_newton_metres(graph):
    start = time.monotonic()
    graph.command(0.3)                  # no velocity / effort: the driver's defaults
    assert wait_until(lambda: abs(graph.theta - 0.3) < REACHED, MOVE), graph.theta
    closed = time.monotonic() - start
    graph.command(0.7, velocity=0.5, effort=1.0)   # 0.5 rad/s, 1 N m -> 0.561 A cap
    assert wait_until(lambda: abs(graph.theta - 0.7) < REACHED, MOVE), graph.theta
    opened = time.monotonic() - start - closed
    assert opened > 0.4 / 0.5 - 0.1, opened  # 0.4 rad at the commanded 0.5 rad/s
    servos = graph.twin_node.twin.servos
    assert servos.register_value(1, 'Goal Current') == 208 == servos.register_value(
        2, 'Goal Current')
    # joint_states come back with both joint names at the scene's angle
    assert wait_until(lambda: abs(graph.joint_states[-1].position[0] - graph.theta) < 0.003
                      and graph.joint_states[-1].velocity[0] == 0.0, MOVE)
    state = graph.joint_states[-1]
    assert list(state.name) == [LEFT, RIGHT]
    assert state.position[0] == pytest.approx(0.7, abs=REACHED)
    assert state.position[0] == pytest.approx(state.position[1], abs=2e-3)
    # effort [N m] = k x the servos' Present Current, along theta (sign: the servo pushes
    # toward its goal; at rest on it the twin reports the holding side, closing, negative);
    # at rest its magnitude is the scene's no-load current, 0.05 A
    def present_currents() -> tuple[float, float]:
        left = -servos.register_value(2, 'Present Current') * AMPERES_PER_CURRENT_UNIT
        right = servos.register_value(1, 'Present Current') * AMPERES_PER_CURRENT_UNIT
        return left, right

    currents = present_currents()
    time.sleep(0.2)
    assert present_currents() == currents  # at rest: a known, steady current
    assert wait_until(lambda: len(graph.joint_states) > 20, MOVE)
    effort = list(graph.joint_states[-1].effort)
    assert effort == pytest.approx([SERVO_TORQUE_CONSTANT * c for c in currents], abs=1e-9)
    assert abs(effort[0]) == pytest.approx(0.05 * 4.1 / 2.3, abs=SERVO_TORQUE_CONSTANT * 0.0027)
    print(f'\nbridge moves: to 0.3 rad in {closed:.2f} s, 0.3 -> 0.7 rad in {opened:.2f} s; '
          f'at rest Present Current {currents} A -> effort {effort} N m')


def test_a_running_grasp_owns_the_servos_and_its_stale_command_never_acts(graph):
    counters = graph.driver.counters
    graph.command(0.7)                  # MoveIt opened the gripper before the grasp
    assert wait_until(lambda: abs(graph.theta - 0.7) < REACHED, MOVE), graph.theta
    sent = call_in_executor(graph.ros.executor, graph.grasp.send_goal_async,
                            Grasp.Goal(controller=Grasp.Goal.ON_OFF, timeout=30.0))
    assert wait_until(sent.done, 10.0) and sent.result().accepted
    result = call_in_executor(graph.ros.executor, sent.result().get_result_async)
    assert wait_until(lambda: graph.driver._bridge_gate.owner(time.monotonic()), 10.0)
    # while it runs: the controller manager republishes its last command (0.7) every cycle,
    # and MoveIt sends a new one (0.95, open), republished too: none moves the fingers
    refused_at = graph.theta
    for _ in range(5):
        graph.command(0.7)
        time.sleep(0.01)
    graph.command(0.95)
    while not result.done():
        graph.command(0.95)
        assert graph.theta <= refused_at + 1e-6  # closing (ON_OFF), never opening
        time.sleep(0.01)
    outcome = result.result().result
    assert outcome.outcome == Grasp.Result.NOT_CARRIED, outcome.message
    assert counters['bridge_commands_refused_grasp_running'] == 1, counters
    assert counters['bridge_commands_repeated'] > 10, counters
    # the states the controller published, on which the driver keyed
    states = [message.state for message in graph.grasp_states]
    running = states[states.index(GraspState.CLOSING):states.index(GraspState.DONE)]
    assert set(running) <= OWNING_STATES and {GraspState.CLOSING, GraspState.LIFTING,
                                              GraspState.HOLDING} <= set(running), states
    assert wait_until(lambda: graph.driver._bridge_gate.grasp_state == GraspState.DONE, 5.0)
    # after the grasp, the stale command keeps coming and must not open the held grip
    held = graph.theta
    assert held < 0.05, held           # ON_OFF closed the empty gripper
    writes = counters['bridge_commands_sent']
    for _ in range(50):
        graph.command(0.95)
        time.sleep(0.01)
    time.sleep(0.3)
    assert graph.theta == pytest.approx(held, abs=2e-3), graph.theta
    assert counters['bridge_commands_sent'] == writes
    # a new command acts at once
    graph.command(0.4)
    assert wait_until(lambda: abs(graph.theta - 0.4) < REACHED, MOVE), graph.theta
    assert counters['bridge_commands_sent'] == writes + 1
    print(f'\ngrasp states seen: {sorted(set(running))}; counters {counters}')
