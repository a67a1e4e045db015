"""Gripper driver node with real rclpy (DDS on loopback), driven through its lifecycle
services like a lifecycle manager, talking through the real dynamixel-sdk to the simulated
XM430-W350 pair in its own process on a pty."""
import gc
import math
import threading
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import Log
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto
from forte_driver.emulators.simulated_servo import SimulatedServoProcess
from forte_driver.ros.gripper_driver_node import GripperDriverNode
from forte_msgs.msg import GraspState, ServoCommand
from forte_ros.contract import SERVO_TORQUE_CONSTANT
from forte_ros.qos import COMMANDS, DIAGNOSTICS, GRASP_STATE
from forte_ros.testing import wait_until

PULSE = 2.0 * math.pi / 4096.0
#: /rosout as ros2 topic echo reads it: the node's log lines, also those before matching.
ROSOUT = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.TRANSIENT_LOCAL)


def wait_for(predicate, timeout=10.0):
    """``predicate``'s first true value within ``timeout`` [s], polled every 20 ms."""
    return wait_until(predicate, timeout, period=0.02)


class Harness:
    """Driver node + probe node on one executor thread; lifecycle via the services."""

    def __init__(self, bus, **parameters):
        self.bus = bus
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        overrides = [Parameter('port', value=bus.device_path if bus else '/dev/forte-missing')]
        overrides += [Parameter(name, value=value) for name, value in parameters.items()]
        self.driver = GripperDriverNode(context=self.context, parameter_overrides=overrides)
        self.probe = rclpy.create_node('gripper_probe', context=self.context)
        self.joint_states: list[JointState] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.probe.create_subscription(JointState, 'joint_states', self.joint_states.append,
                                       COMMANDS)
        self.probe.create_subscription(DiagnosticArray, '/diagnostics',
                                       self.diagnostics.append, DIAGNOSTICS)
        self.commands = self.probe.create_publisher(ServoCommand, 'gripper/command', COMMANDS)
        # the bridge of ros2_control's TopicBasedSystem, and the grasp controller's state
        self.joint_commands = self.probe.create_publisher(JointState, 'gripper/joint_commands',
                                                          COMMANDS)
        self.grasp_states = self.probe.create_publisher(GraspState, 'grasp/state', GRASP_STATE)
        self.log: list[str] = []
        self.probe.create_subscription(
            Log, '/rosout', lambda m: self.log.append(m.msg)
            if m.name.endswith('gripper_driver') else None, ROSOUT)
        self.change_state = self.probe.create_client(ChangeState, 'gripper_driver/change_state')
        self.get_state = self.probe.create_client(GetState, 'gripper_driver/get_state')
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.driver)
        self.executor.add_node(self.probe)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        assert self.change_state.wait_for_service(timeout_sec=10.0)

    def _call(self, client, request):
        future = client.call_async(request)
        assert wait_for(future.done, timeout=20.0), 'lifecycle service did not answer'
        return future.result()

    def transition(self, transition_id: int) -> bool:
        request = ChangeState.Request()
        request.transition.id = transition_id
        return self._call(self.change_state, request).success

    def state(self) -> int:
        return self._call(self.get_state, GetState.Request()).current_state.id

    def send(self, position, max_current=0.0, profile_velocity=0.0):
        assert wait_for(lambda: self.commands.get_subscription_count() >= 1)
        message = ServoCommand(position=position, max_current=max_current,
                               profile_velocity=profile_velocity)
        message.header.stamp = self.probe.get_clock().now().to_msg()
        self.commands.publish(message)

    def joint_state_where(self, predicate, timeout=10.0):
        def find():
            return next((m for m in reversed(self.joint_states[-50:]) if predicate(m)), None)
        return wait_for(find, timeout)

    def servo_status(self, servo_id, predicate, timeout=10.0):
        def find():
            for array in reversed(self.diagnostics[-10:]):
                for status in array.status:
                    if status.name.endswith(f'(id {servo_id})') and predicate(status):
                        return status
            return None
        return wait_for(find, timeout)

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(timeout=5.0)
        self.driver.stop_hardware('test end')
        self.driver.destroy_node()
        self.probe.destroy_node()
        rclpy.shutdown(context=self.context)
        # rcl finalises a destroyed node when its handle is collected, and then drops the
        # /rosout publisher registered under its logger name: if that happened during the
        # next test, it would take the next 'gripper_driver' node's /rosout away (its log
        # lines stop reaching /rosout mid-test). Collect now.
        self.driver = self.probe = self.executor = None
        gc.collect()


@pytest.fixture
def bus():
    with SimulatedServoProcess(ids=(1, 2), positions=(2048, 2048)) as simulated:
        yield simulated


@pytest.fixture
def harness(bus):
    started = Harness(bus)
    yield started
    started.close()


def configure_and_activate(harness):
    assert harness.transition(Transition.TRANSITION_CONFIGURE)
    assert harness.transition(Transition.TRANSITION_ACTIVATE)
    assert harness.state() == State.PRIMARY_STATE_ACTIVE


def values_of(status: DiagnosticStatus) -> dict:
    return {pair.key: pair.value for pair in status.values}


def test_command_moves_the_servos_and_joint_states_report_radians(bus, harness):
    configure_and_activate(harness)
    # configure wrote mode 5 and the limits into the servos' own registers.
    assert bus.register_value(1, 'Operating Mode') == 5
    assert bus.register_value(1, 'Max Position Limit') == 2700
    assert bus.register_value(2, 'Min Position Limit') == 1396
    assert bus.register_value(2, 'Current Limit') == 371
    assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(2, 'Torque Enable')
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    harness.send(0.4, max_current=0.3, profile_velocity=2.0)
    moving = harness.joint_state_where(lambda m: m.velocity[0] > 0.0)
    assert moving is not None, 'no joint_states sample while moving'
    # 2 rad/s -> 83 units of 0.229 rpm = 1.99041 rad/s, on both (mirrored) joints.
    assert list(moving.velocity) == pytest.approx([83 * 0.0239809] * 2, rel=1e-5)
    # Free motion current 15 units = 0.04035 A, positive along theta (opening); effort is
    # the joint torque: 0.04035 A x 4.1 / 2.3 N m/A = 0.071929 N m.
    assert list(moving.effort) == pytest.approx([0.071929] * 2, abs=1e-6)
    arrived = harness.joint_state_where(
        lambda m: m.position[0] == m.position[1] and abs(m.position[0] - 0.4) < 1e-3
        and m.velocity[0] == 0.0)
    assert arrived is not None, 'joint_states never reported theta = 0.4 rad'
    assert list(arrived.name) == ['forte_left_finger_joint', 'forte_right_finger_joint']
    assert arrived.position[0] == pytest.approx(261 * PULSE, abs=1e-12)  # 0.4 rad = 261 pulses
    assert arrived.header.stamp.sec > 0
    assert bus.register_value(1, 'Present Position') == 2048 + 261
    assert bus.register_value(2, 'Present Position') == 2048 - 261
    assert bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1  # one packet, both servos


def test_effort_is_the_joint_torque_of_the_squeezing_current(bus, harness):
    """joint_states effort [N m] = k x the servo's Present Current [A], k = 4.1 / 2.3 N m/A
    (forte_ros.contract), along theta: squeezing (pushing closed) is negative."""
    configure_and_activate(harness)
    harness.send(0.3, max_current=0.5, profile_velocity=4.0)
    assert harness.joint_state_where(lambda m: abs(m.position[0] - 0.3) < 1e-3)
    bus.set_servo(1, obstacle=2048 + 100, obstacle_blocks_increasing=False)
    bus.set_servo(2, obstacle=2048 - 100, obstacle_blocks_increasing=True)
    harness.send(0.0, max_current=0.4)
    # 0.4 A -> 148 units (rounded toward zero) = 0.39812 A -> 0.709692 N m
    expected = -0.709692
    squeezing = harness.joint_state_where(
        lambda m: list(m.effort) == pytest.approx([expected] * 2, abs=1e-6))
    assert squeezing is not None, harness.joint_states[-1]
    assert list(squeezing.position) == pytest.approx([100 * PULSE] * 2, abs=1e-12)
    # the servos' own Present Current registers (the right horn is mirrored: +148 raw on
    # the left servo is -148 along theta)
    assert bus.register_value(1, 'Present Current') == -148
    assert bus.register_value(2, 'Present Current') == 148
    assert expected == pytest.approx(-148 * 0.00269 * SERVO_TORQUE_CONSTANT, abs=1e-6)
    right = harness.servo_status(1, lambda s: values_of(s).get('current_A') == '-0.3981')
    assert right is not None and values_of(right)['effort_Nm'] == '-0.7097'


def test_bad_commands_are_refused_or_clipped_with_a_reason(bus, harness):
    assert harness.transition(Transition.TRANSITION_CONFIGURE)
    harness.send(0.5)  # inactive: ignored
    assert wait_for(lambda: harness.driver.counters['commands_ignored_inactive'] == 1)
    assert harness.transition(Transition.TRANSITION_ACTIVATE)
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    harness.send(math.nan)
    harness.send(0.5, max_current=-1.0)
    assert wait_for(lambda: harness.driver.counters['commands_refused'] == 2)
    harness.send(5.0, max_current=9.0)  # clipped to theta_max and current_limit
    assert wait_for(lambda: harness.driver.counters['commands_clipped'] == 1)
    assert wait_for(lambda: bus.register_value(1, 'Goal Position') == 2700)
    assert bus.register_value(2, 'Goal Position') == 1396
    assert bus.register_value(1, 'Goal Current') == 371
    assert bus.count(proto.INSTRUCTION_SYNC_WRITE) - before == 1  # refused ones sent nothing
    assert harness.driver.counters['commands_sent'] == 1


def test_hardware_error_status_and_temperature_in_diagnostics(bus, harness):
    configure_and_activate(harness)
    ok = harness.servo_status(1, lambda s: s.level == DiagnosticStatus.OK)
    assert ok is not None and values_of(ok)['temperature_C'] == '30'
    bus.inject_hardware_error(2, ct.HW_ERROR_OVERLOAD)
    status = harness.servo_status(2, lambda s: s.level == DiagnosticStatus.ERROR)
    assert status is not None, 'overload never surfaced in /diagnostics'
    assert 'overload error' in status.message
    values = values_of(status)
    assert values['hardware_error_status'] == '0x20'
    assert values['torque_enabled'] == 'False'  # overload is in the Shutdown mask
    right = harness.servo_status(1, lambda s: True)
    assert right.level == DiagnosticStatus.OK
    bus.set_servo(1, temperature=67.0)  # within 5 degC of the 70 degC limit
    warm = harness.servo_status(1, lambda s: s.level == DiagnosticStatus.WARN)
    assert warm is not None and 'near limit 70' in warm.message


def state_sync_reads(bus):
    """Sync reads of the state block (Present Current 126 ..) the servos received."""
    return sum(1 for instruction, _, parameters in bus.packet_log()
               if instruction == proto.INSTRUCTION_SYNC_READ and parameters[0] == 126)


def test_state_replies_with_an_error_number_are_not_published(bus, harness):
    configure_and_activate(harness)
    driver = harness.driver
    assert harness.joint_state_where(lambda m: True)
    bus.inject_status_error(2, ct.STATUS_ERROR_DATA_RANGE, 'sync read', count=30, address=126)
    assert wait_for(lambda: driver.counters['state_samples_skipped_status_error'] == 30)
    # /diagnostics is published on its own timer: the array in hand may predate the 30th
    # reply (a loaded machine once read '29' there), so wait for one that counts all 30
    status = harness.servo_status(2, lambda s: s.level == DiagnosticStatus.ERROR
                                  and 'data range error' in s.message
                                  and values_of(s).get('status_errors.data range error') == '30')
    assert status is not None, 'the 30 error replies never surfaced in /diagnostics'
    assert 'not used as state' in status.message
    assert harness.servo_status(1, lambda s: s.level == DiagnosticStatus.OK)
    assert driver.gripper.status_errors.of(2) == {'data range error': 30}
    assert harness.transition(Transition.TRANSITION_DEACTIVATE)  # stop sampling, then count
    counters = driver.counters
    # Every state sync read the servos received (but the one of activate, which commands
    # "hold here") is a used sample, a skipped error reply or a lost reply; joint_states
    # come only from used samples, none repeated.
    assert wait_for(lambda: state_sync_reads(bus) == 1 + counters['state_reads']
                    + counters['state_samples_skipped_status_error']
                    + counters['state_read_failures']), (state_sync_reads(bus), counters)
    assert wait_for(lambda: len(harness.joint_states) == counters['joint_states_published'])
    assert counters['joint_states_published'] <= counters['state_reads']
    assert len(harness.joint_states) <= state_sync_reads(bus) - 30
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in harness.joint_states]
    assert all(later > earlier for earlier, later in zip(stamps, stamps[1:], strict=False))


def test_latched_hardware_error_refuses_commands_while_readings_flow(bus, harness):
    configure_and_activate(harness)
    driver = harness.driver
    bus.inject_hardware_error(1, ct.HW_ERROR_INPUT_VOLTAGE)  # torque stays on: WARN
    warned = harness.servo_status(1, lambda s: s.level == DiagnosticStatus.WARN)
    assert warned is not None and 'input voltage error' in warned.message
    assert values_of(warned)['alert_bit'] == 'True'
    before = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    harness.send(0.3, max_current=0.4)  # still obeyed
    assert wait_for(lambda: bus.count(proto.INSTRUCTION_SYNC_WRITE) == before + 1)
    bus.inject_hardware_error(2, ct.HW_ERROR_ELECTRICAL_SHOCK)  # shutdown: torque off
    status = harness.servo_status(2, lambda s: s.level == DiagnosticStatus.ERROR)
    assert status is not None and 'electrical shock error' in status.message
    assert 'commands refused' in status.message
    assert values_of(status)['torque_enabled'] == 'False'
    assert wait_for(lambda: 2 in driver.gripper.alerts)
    count = len(harness.joint_states)
    harness.send(0.5)
    assert wait_for(lambda: driver.counters['commands_refused_hardware_error'] == 1)
    assert wait_for(lambda: len(harness.joint_states) > count + 20)  # readings still flow
    assert bus.count(proto.INSTRUCTION_SYNC_WRITE) == before + 1  # nothing sent
    assert driver.counters['state_samples_skipped_status_error'] == 0


def test_silent_servos_give_no_joint_states_and_an_error_until_they_answer_again(bus, harness):
    configure_and_activate(harness)
    assert harness.joint_state_where(lambda m: True)
    bus.set_servo(1, responding=False)
    bus.set_servo(2, responding=False)
    assert wait_for(lambda: harness.driver.counters['consecutive_read_failures'] >= 3)
    count = len(harness.joint_states)
    time.sleep(0.5)
    assert len(harness.joint_states) <= count + 2  # in flight at most; nothing invented

    def driver_status(level):
        def find():
            for array in reversed(harness.diagnostics[-5:]):
                for status in array.status:
                    if status.name.endswith(': driver') and status.level == level:
                        return status
            return None
        return wait_for(find)

    failing = driver_status(DiagnosticStatus.ERROR)
    assert failing is not None and 'state reads failing' in failing.message
    bus.set_servo(2, responding=True)  # only the left servo comes back
    silent = harness.servo_status(1, lambda s: 'no answer' in s.message)
    assert silent is not None and silent.level == DiagnosticStatus.ERROR
    assert harness.servo_status(2, lambda s: values_of(s)['hardware_error_status'] == '0x00')
    bus.set_servo(1, responding=True)
    assert wait_for(lambda: len(harness.joint_states) > count + 20)
    assert driver_status(DiagnosticStatus.OK) is not None


def test_stream_of_commands_each_sent_once_while_joint_states_flow(bus, harness):
    configure_and_activate(harness)
    before = len(bus.packet_log())
    first_sample = len(harness.joint_states)
    goal = round(0.398 * 4096 / (2 * math.pi))  # the last command [pulse from the centre]
    for index in range(100):  # 50 Hz, like a controller
        harness.send(0.2 + 0.002 * index, max_current=0.4, profile_velocity=4.0)
        time.sleep(0.02)

    def goal_of_servo_1(parameters: bytes) -> int:
        """Goal Position of servo 1 in a sync write: address and length (2 bytes each), then
        (id, data) per servo."""
        assert int.from_bytes(parameters[0:2], 'little') == ct.COMMAND_BLOCK_START
        chunk = 1 + int.from_bytes(parameters[2:4], 'little')
        start = 1 + ct.GOAL_POSITION.address - ct.COMMAND_BLOCK_START
        for offset in range(4, len(parameters), chunk):
            if parameters[offset] == 1:
                return ct.decode_value(ct.GOAL_POSITION, parameters[offset + start:])
        raise AssertionError(f'servo 1 is not in the sync write {parameters.hex()}')

    def goals_written():  # [pulse from the centre] in each sync write since the stream began
        return [goal_of_servo_1(parameters) - 2048
                for instruction, _, parameters in bus.packet_log()[before:]
                if instruction == proto.INSTRUCTION_SYNC_WRITE]

    assert wait_for(lambda: goals_written()[-1:] == [goal])
    # The commands topic keeps the last 10 (the contract): a stalled machine may drop some of
    # the 100, never repeat or reorder one. Each command taken is written once, in order
    # (0.002 rad = 1.3 pulses apart), and the last one always arrives.
    written = goals_written()
    assert len(written) == harness.driver.counters['commands_sent'] >= 50
    assert all(later > earlier for earlier, later in zip(written, written[1:], strict=False))
    assert len(harness.joint_states) - first_sample >= 100  # 100 Hz for 2 s, minus losses
    final = harness.joint_state_where(
        lambda m: list(m.position) == pytest.approx([0.398] * 2, abs=PULSE)
        and m.velocity[0] == 0.0)
    assert final is not None
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
              for m in harness.joint_states[first_sample:]]
    assert all(later > earlier for earlier, later in zip(stamps, stamps[1:], strict=False))


def test_deactivate_and_shutdown_hold_the_grip(bus, harness):
    configure_and_activate(harness)
    assert harness.transition(Transition.TRANSITION_DEACTIVATE)
    assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(2, 'Torque Enable')
    assert harness.transition(Transition.TRANSITION_INACTIVE_SHUTDOWN)
    assert harness.state() == State.PRIMARY_STATE_FINALIZED
    assert bus.register_value(1, 'Torque Enable') == 1 == bus.register_value(2, 'Torque Enable')


def test_release_on_shutdown_switches_torque_off(bus):
    harness = Harness(bus, release_on_shutdown=True)
    try:
        configure_and_activate(harness)
        assert harness.transition(Transition.TRANSITION_DEACTIVATE)
        assert bus.register_value(1, 'Torque Enable') == 0 == bus.register_value(
            2, 'Torque Enable')
    finally:
        harness.close()


def test_parameters_are_validated(harness):
    driver = harness.driver
    result = driver.set_parameters([Parameter('default_current', value=1.5)])[0]
    assert not result.successful and 'default_current' in result.reason
    result = driver.set_parameters([Parameter('theta_min', value=1.2)])[0]
    assert not result.successful and 'is empty' in result.reason
    result = driver.set_parameters([Parameter('current_limit', value=5.0)])[0]
    assert not result.successful  # outside the descriptor range
    assert harness.transition(Transition.TRANSITION_CONFIGURE)
    result = driver.set_parameters([Parameter('theta_max', value=0.8)])[0]
    assert not result.successful and 'unconfigured' in result.reason
    assert driver.set_parameters([Parameter('default_current', value=0.7)])[0].successful
    assert harness.transition(Transition.TRANSITION_CLEANUP)
    assert driver.set_parameters([Parameter('theta_max', value=0.8)])[0].successful
    assert harness.transition(Transition.TRANSITION_CONFIGURE)
    assert harness.bus.register_value(1, 'Max Position Limit') == 2048 + 522


def test_configure_fails_cleanly_without_a_device():
    harness = Harness(None)
    try:
        assert not harness.transition(Transition.TRANSITION_CONFIGURE)
        assert harness.state() == State.PRIMARY_STATE_UNCONFIGURED
    finally:
        harness.close()
