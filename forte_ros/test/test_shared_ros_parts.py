"""forte_ros.qos against docs/contracts.md's table; descriptors, diagnostics and the test
graph for real.

The QoS test reads the contract's table itself (the topic rows and their QoS column), so a
profile that drifts from the document fails here, whichever side changed.
"""
from __future__ import annotations

import re
from pathlib import Path

import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import ParameterType
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from std_msgs.msg import String

from forte_ros import diagnostics, qos
from forte_ros.parameter_table import ParameterSpec
from forte_ros.parameters import spec_descriptor
from forte_ros.testing import SpinningGraph, wait_until

CONTRACTS = Path(__file__).resolve().parents[2] / 'docs' / 'contracts.md'


def contract_qos() -> dict[str, str]:
    """``{topic: QoS text}`` from the topics table of docs/contracts.md."""
    rows = {}
    for line in CONTRACTS.read_text().splitlines():
        cells = [cell.strip() for cell in line.strip().strip('|').split('|')]
        if len(cells) == 4 and cells[0].startswith('`') and 'keep last' in cells[2]:
            rows[cells[0].strip('`')] = cells[2]
    return rows


PROFILE_OF_TOPIC = {
    'tactile/frames': qos.SENSOR_FRAMES, 'tactile/state': qos.TACTILE_STATE,
    'tactile/sensor_info': qos.SENSOR_INFO, 'load_cell/wrench': qos.LOAD_CELL,
    'gripper/command': qos.COMMANDS, 'joint_states': qos.COMMANDS,
    'gripper/joint_commands': qos.COMMANDS,
    'arm/cmd_vel': qos.COMMANDS, 'grasp/state': qos.GRASP_STATE,
    'sim/ground_truth': qos.GROUND_TRUTH, '/diagnostics': qos.DIAGNOSTICS,
}


def test_every_contract_topic_has_its_documented_profile():
    table = contract_qos()
    assert set(table) == set(PROFILE_OF_TOPIC)
    for topic, text in table.items():
        profile = PROFILE_OF_TOPIC[topic]
        depth = int(re.search(r'keep last (\d+)', text).group(1))
        assert profile.depth == depth, topic
        best_effort = 'best effort' in text
        assert (profile.reliability == ReliabilityPolicy.BEST_EFFORT) == best_effort, topic
        transient = 'transient local' in text
        assert (profile.durability == DurabilityPolicy.TRANSIENT_LOCAL) == transient, topic
    assert 'reliable:=true' in table['tactile/frames']
    assert qos.frames_profile(True).reliability == ReliabilityPolicy.RELIABLE
    assert qos.frames_profile(True).depth == qos.SENSOR_FRAMES.depth
    assert qos.frames_profile(False) is qos.SENSOR_FRAMES


def test_diagnostics_builder_keeps_order_and_converts_values():
    status = diagnostics.diagnostic_status('node: part', diagnostics.WARN, 'slow',
                                           {'rate_hz': 1999.5, 'dropped': 3, 'port': '/dev/x'},
                                           hardware_id='forte')
    assert status.level == DiagnosticStatus.WARN and status.hardware_id == 'forte'
    assert [(kv.key, kv.value) for kv in status.values] == [
        ('rate_hz', '1999.5'), ('dropped', '3'), ('port', '/dev/x')]
    array = diagnostics.diagnostic_array(Time(sec=12, nanosec=5), [status])
    assert isinstance(array, DiagnosticArray)
    assert (array.header.stamp.sec, array.header.stamp.nanosec) == (12, 5)
    assert array.status == [status]


def test_status_names_carry_the_namespace_only_when_there_is_one():
    graph = SpinningGraph('forte_test_node_path')
    try:
        plain = graph.add(rclpy.create_node('perception', context=graph.context))
        right = graph.add(rclpy.create_node('perception', namespace='right',
                                            context=graph.context))
        nested = graph.add(rclpy.create_node('perception', namespace='/cell_2/right',
                                             context=graph.context))
        assert diagnostics.node_path(plain) == 'perception'
        assert diagnostics.node_path(right) == 'right/perception'
        assert diagnostics.node_path(nested) == 'cell_2/right/perception'
    finally:
        graph.close()


def test_spinning_graph_delivers_real_messages_and_closes():
    graph = SpinningGraph('forte_test_talker_listener')
    talker = graph.add(rclpy.create_node('forte_test_talker', context=graph.context))
    publisher = talker.create_publisher(String, 'forte_test/chatter', qos.reliable(10))
    received = graph.collect(String, 'forte_test/chatter', qos.reliable(10))
    stamped = graph.collect(String, 'forte_test/chatter', qos.reliable(10), arrival_times=True)
    graph.start()
    assert wait_until(lambda: publisher.get_subscription_count() == 2, 10.0)
    for index in range(5):
        publisher.publish(String(data=f'message {index}'))
    assert wait_until(lambda: len(received) == 5 and len(stamped) == 5, 10.0)
    assert [message.data for message in received] == [f'message {i}' for i in range(5)]
    assert all(isinstance(arrival, float) for arrival, _ in stamped)
    graph.close()
    assert not graph.context.ok()


def test_descriptor_range_follows_the_kind():
    integer = spec_descriptor(ParameterSpec('batch_size', int, 'samples per message', low=1,
                                            high=2000, default=20, read_only=True))
    assert integer.read_only and integer.description == 'samples per message'
    assert integer.type == ParameterType.PARAMETER_INTEGER and integer.name == 'batch_size'
    assert [(r.from_value, r.to_value, r.step) for r in integer.integer_range] == [(1, 2000, 1)]
    assert not integer.floating_point_range
    real = spec_descriptor(ParameterSpec('period', float, 'period', 's', 0.05, 60, default=0.5))
    assert real.description == 'period [s]' and real.type == ParameterType.PARAMETER_DOUBLE
    assert [(r.from_value, r.to_value, r.step) for r in real.floating_point_range] == [
        (0.05, 60.0, 0.0)]
    assert not real.integer_range and not real.read_only
    any_step = spec_descriptor(ParameterSpec('rate', int, 'rate', low=1, high=4000,
                                             integer_step=0, default=2000))
    assert [(r.from_value, r.to_value, r.step) for r in any_step.integer_range] == [(1, 4000, 0)]
    for kind, default in ((bool, True), (str, 'forte_base_link')):  # no range: flag, text
        plain = spec_descriptor(ParameterSpec('x', kind, 'x', low=0, high=1, default=default))
        assert not plain.integer_range and not plain.floating_point_range
        assert not plain.additional_constraints
    unbounded = spec_descriptor(ParameterSpec('x', int, 'x', default=3))
    assert not unbounded.integer_range and not unbounded.floating_point_range
    names = spec_descriptor(ParameterSpec('joints', list, 'joint names', default=('a',)))
    assert names.type == ParameterType.PARAMETER_STRING_ARRAY
