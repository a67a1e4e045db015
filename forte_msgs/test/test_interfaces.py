"""forte_msgs over real DDS: every type round-trips across two processes; action and services work.

The peer (``echo_peer.py``) runs in a separate process. Each message is filled with a distinct
non-default value in every field (found by introspection, so a new field is covered
automatically), published here, echoed by the peer and compared field by field on return.
"""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from forte_msgs.action import Grasp
from forte_msgs.msg import (
    GraspState,
    SensorInfo,
    ServoCommand,
    SimGroundTruth,
    TactileFrames,
    TactileState,
)
from forte_msgs.srv import ResetFault, Tare
from forte_ros.sensor_identity import SensorIdentity

MESSAGE_TYPES = (TactileFrames, TactileState, ServoCommand, GraspState, SimGroundTruth,
                 SensorInfo)
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
PEER = Path(__file__).with_name('echo_peer.py')

SCALAR_VALUES = {
    'boolean': lambda i: True,
    'string': lambda i: f'value_{i}',
    'double': lambda i: 0.5 + i,
    'float': lambda i: 0.25 + i,
    'uint8': lambda i: 3 + i % 250,
    'int32': lambda i: -7 - i,
    'uint16': lambda i: 60_000 + i,
    'uint32': lambda i: 4_000_000_000 - i,
    'int64': lambda i: -(2**40) - i,
    'uint64': lambda i: 2**63 + i,
}


def filled(message_type: type, seed: int = 1):
    """Return a message of ``message_type`` with every field set to a non-default value."""
    message = message_type()
    for index, (name, type_name) in enumerate(message_type.get_fields_and_field_types().items()):
        value_of = SCALAR_VALUES.get(type_name.split('[')[0].removeprefix('sequence<').rstrip('>'))
        i = seed * 100 + index
        if type_name.startswith('sequence<'):
            setattr(message, name, [value_of(i + k) for k in range(5)])
        elif '[' in type_name:
            size = int(type_name.split('[')[1].rstrip(']'))
            setattr(message, name, [value_of(i + k) for k in range(size)])
        elif value_of is not None:
            setattr(message, name, value_of(i))
        elif type_name == 'std_msgs/Header':
            message.header.stamp.sec = 1_700_000_000 + i
            message.header.stamp.nanosec = 123_456_789
            message.header.frame_id = 'forte_base_link'
        else:
            raise AssertionError(f'no test value for field {name}: {type_name}')
    return message


@pytest.fixture(scope='module')
def peer(leak_guard):
    """Start the echo peer in its own process; it inherits this test's isolated ROS domain.

    Asks for ``leak_guard`` so that it is stopped before the guard looks for what the module
    left running: pytest 7 (Ubuntu 24.04's, under ``colcon test``) tears module fixtures of
    equal rank down in setup order, pytest 8 in reverse; a dependency orders both."""
    process = subprocess.Popen(
        [sys.executable, str(PEER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == 'ready'
    yield process
    process.stdin.close()
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()  # reaped: a killed child left unwaited is still this test's child


@pytest.fixture
def node():
    rclpy.init()
    node = Node('forte_msgs_test_client')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    node.executor_for_test = executor
    yield node
    node.destroy_node()
    rclpy.try_shutdown()


def spin_until(node: Node, condition, timeout: float = 15.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        node.executor_for_test.spin_once(timeout_sec=0.05)
    return condition()


def test_filled_messages_differ_from_defaults():
    for message_type in MESSAGE_TYPES:
        assert filled(message_type) != message_type(), message_type.__name__


@pytest.mark.parametrize('message_type', MESSAGE_TYPES, ids=lambda t: t.__name__)
def test_message_round_trips_through_another_process(peer, node, message_type):
    name = message_type.__name__
    received = []
    node.create_subscription(message_type, f'echo_out/{name}', received.append, RELIABLE)
    publisher = node.create_publisher(message_type, f'echo_in/{name}', RELIABLE)
    sent = filled(message_type, seed=3)
    assert spin_until(node, lambda: publisher.get_subscription_count() > 0), 'peer not discovered'
    assert spin_until(node, lambda: node.count_publishers(f'echo_out/{name}') > 0)
    deadline = time.monotonic() + 15.0
    while not received and time.monotonic() < deadline:  # discovery may lag the first sample
        publisher.publish(sent)
        spin_until(node, lambda: bool(received), timeout=0.5)
    assert received, f'{name} did not come back'
    assert received[0] == sent


def test_large_frame_batch_keeps_every_sample(peer, node):
    """A 2000-sample batch (1 s at 2 kHz) survives the trip bit for bit."""
    received = []
    node.create_subscription(TactileFrames, 'echo_out/TactileFrames', received.append, RELIABLE)
    publisher = node.create_publisher(TactileFrames, 'echo_in/TactileFrames', RELIABLE)
    data = np.random.default_rng(0).uniform(-1, 1, size=(2000, 6))
    message = TactileFrames(sample_count=2000, sample_period=0.0005, data=data.ravel().tolist())
    assert spin_until(node, lambda: publisher.get_subscription_count() > 0)
    deadline = time.monotonic() + 15.0
    while not received and time.monotonic() < deadline:
        publisher.publish(message)
        spin_until(node, lambda: bool(received), timeout=0.5)
    assert received
    np.testing.assert_array_equal(np.asarray(received[0].data).reshape(-1, 6), data)


def call(node: Node, client, request):
    assert client.wait_for_service(timeout_sec=15.0), f'{client.srv_name} not available'
    future = client.call_async(request)
    assert spin_until(node, future.done)
    return future.result()


def test_services_answer_across_processes(peer, node):
    tare = call(node, node.create_client(Tare, 'perception/tare'), Tare.Request(duration=0.5))
    assert tare.success and list(tare.baseline) == [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    refused = call(node, node.create_client(Tare, 'perception/tare'), Tare.Request(duration=0.0))
    assert not refused.success and 'positive' in refused.message
    reset = call(node, node.create_client(ResetFault, 'grasp/reset_fault'), ResetFault.Request())
    assert reset.success
    assert reset.cleared_flags == GraspState.FAULT_STALE_PERCEPTION | GraspState.FAULT_FORCE_LIMIT


def send_goal(node: Node, client: ActionClient, goal: Grasp.Goal, feedback: list):
    assert client.wait_for_server(timeout_sec=15.0)
    future = client.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m.feedback))
    assert spin_until(node, future.done)
    return future.result()


def test_grasp_action_feedback_and_result(peer, node):
    client = ActionClient(node, Grasp, 'grasp')
    feedback = []
    goal = Grasp.Goal(controller=Grasp.Goal.FORTE, initial_force=0.25, lift_distance=0.05,
                      timeout=0.5)
    handle = send_goal(node, client, goal, feedback)
    assert handle.accepted
    result_future = handle.get_result_async()
    assert spin_until(node, result_future.done)
    result = result_future.result().result
    assert result.outcome == Grasp.Result.LIFTED
    assert result.final_force == pytest.approx(0.5)
    assert result.lift_height == pytest.approx(0.05)
    assert [f.slip_events for f in feedback] == [0, 1]
    assert all(f.state == GraspState.LIFTING for f in feedback)


def test_grasp_action_rejects_unknown_controller_and_cancels(peer, node):
    client = ActionClient(node, Grasp, 'grasp')
    assert not send_goal(node, client, Grasp.Goal(controller=9), []).accepted
    handle = send_goal(node, client, Grasp.Goal(controller=Grasp.Goal.ON_OFF, timeout=10.0), [])
    assert handle.accepted
    cancel = handle.cancel_goal_async()
    assert spin_until(node, cancel.done)
    result_future = handle.get_result_async()
    assert spin_until(node, result_future.done)
    assert result_future.result().result.outcome == Grasp.Result.CANCELED


def test_sensor_info_carries_exactly_the_sensor_identity_fields():
    """SensorInfo(**identity.to_dict()) and SensorIdentity.from_message stay in step."""
    identity = SensorIdentity(source='serial', device_id='00000000c0ffee01', firmware='1.2.3',
                              protocol_version=1, sample_rate=1000.0, adc_bits=12)
    message = SensorInfo(**identity.to_dict())
    assert set(SensorInfo.get_fields_and_field_types()) == {'header', *identity.to_dict()}
    assert SensorIdentity.from_message(message) == identity
