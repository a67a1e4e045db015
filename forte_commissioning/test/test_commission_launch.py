"""commission.launch.py read by ``launch`` itself (nothing is started): every argument
described; ``namespace`` and ``prefix`` (issue 27) reach every node it starts — the hardware
graph's (through hardware.launch.py, as the main graphs apply them), ``forte_commission``
and the bench twin — and a bad value stops the launch with the argument's name.

``forte_commission`` itself in a namespace with a prefix: its topics resolved inside the
namespace, the prefixed joints, only its own namespace's serial driver status (one rclpy node
in this process). The same run live, in a namespace: test_commission_graph.py.
"""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

REASON = ('launch / launch_ros need a ROS 2 install (or the launch kit, '
          '../shared/ros2-launch-kit)')
launch = pytest.importorskip('launch', reason=REASON)
launch_ros = pytest.importorskip('launch_ros', reason=REASON)

from launch.actions import ExecuteProcess  # noqa: E402
from launch_ros.actions import Node  # noqa: E402

from forte_ros.testing import launch_file_actions, launch_file_description  # noqa: E402

LAUNCH_FILE = Path(__file__).resolve().parents[1] / 'launch' / 'commission.launch.py'
HARDWARE_NODES = ['serial_sensor_node', 'gripper_driver_node', 'perception_node',
                  'grasp_controller_node']


def started(**arguments: str) -> tuple[launch.LaunchContext, list]:
    """The actions of commission.launch.py for ``arguments`` (others at their default)."""
    return launch_file_actions(LAUNCH_FILE, **arguments)


def parameters(node: Node, context: launch.LaunchContext) -> dict:
    """The parameters a launch_ros node gets, the later files winning."""
    node._perform_substitutions(context)  # what launch_ros does when it starts it
    values = {}
    for path, _ in node._Node__expanded_parameter_arguments:
        for block in yaml.safe_load(Path(path).read_text()).values():
            values.update(block['ros__parameters'])
    return values


def test_namespace_and_prefix_are_declared_with_a_description():
    arguments = {argument.name: argument
                 for argument in launch_file_description(LAUNCH_FILE).get_launch_arguments()}
    assert {'target', 'namespace', 'prefix', 'sensor_fault'} <= set(arguments)
    for argument in arguments.values():
        assert len(argument.description) > 20, argument.name
    assert 'namespace' in arguments['namespace'].description
    assert 'joint' in arguments['prefix'].description


def test_every_node_of_the_hardware_target_is_in_the_namespace_with_the_prefix():
    context, actions = started(namespace='right', prefix='right_',
                               sensor_port='/dev/null', gripper_port='/dev/null')
    nodes = {action.node_executable: action for action in actions if isinstance(action, Node)}
    assert set(HARDWARE_NODES) | {'forte_commission'} <= set(nodes)
    for executable, node in nodes.items():  # the hardware graph's (all of them) and ours
        values = parameters(node, context)
        assert node.expanded_node_namespace == '/right', executable
        if executable in HARDWARE_NODES + ['forte_commission']:
            assert values['prefix'] == 'right_', executable
    assert parameters(nodes['serial_sensor_node'], context)['port'] == '/dev/null'


def test_the_bench_twin_is_in_the_namespace_on_its_own_links():
    context, actions = started(target='bench_twin', namespace='/lab/right/', prefix='right_')
    (bench,) = [action for action in actions if isinstance(action, Node)]
    values = parameters(bench, context)
    assert bench.expanded_node_namespace == '/lab/right'
    assert values['prefix'] == 'right_'
    links = ['/tmp/forte_bench/lab/right/sensor', '/tmp/forte_bench/lab/right/gripper']
    assert [values['sensor_link'], values['servo_link']] == links
    (wait,) = [action for action in actions if isinstance(action, ExecuteProcess)
               and not isinstance(action, Node)]
    assert [part[0].perform(context) for part in wait.cmd[-2:]] == links


def test_without_the_arguments_nothing_moves():
    context, actions = started(target='bench_twin')
    (bench,) = [action for action in actions if isinstance(action, Node)]
    values = parameters(bench, context)
    assert bench.expanded_node_namespace == '/'
    assert values['prefix'] == ''
    assert values['sensor_link'] == '/tmp/forte_bench/sensor'
    context, actions = started(sensor_port='/dev/null')
    (commission,) = [action for action in actions if isinstance(action, Node)
                     and action.node_executable == 'forte_commission']
    assert parameters(commission, context)['prefix'] == ''
    assert commission.expanded_node_namespace == '/'


@pytest.mark.parametrize('arguments, problem', [
    ({'namespace': '2nd'}, "'2nd' is not a valid ROS name"),
    ({'prefix': '/right_'}, 'not starting with a slash'),
    ({'target': 'robot'}, 'expected one of'),
])
def test_a_bad_argument_stops_the_launch_with_its_name(arguments, problem):
    with pytest.raises(ValueError, match=problem):
        started(**arguments)


def test_forte_commission_follows_its_namespace_and_prefix():
    rclpy = pytest.importorskip('rclpy')
    from rclpy.parameter import Parameter

    from forte_commissioning.ros.commission_node import CommissionNode
    from forte_commissioning.simulated_commissioning import protocol

    rclpy.init()
    try:
        node = CommissionNode(protocol(), headless=True, namespace='right',
                              parameter_overrides=[Parameter('prefix', value='right_')])
        topics = {sub.topic_name for sub in node.subscriptions} | {
            pub.topic_name for pub in node.publishers}
        assert {'/right/tactile/frames', '/right/joint_states', '/right/gripper/command',
                '/right/sim/operator_press', '/diagnostics'} <= topics, topics
        assert node.joints == ('right_forte_left_finger_joint', 'right_forte_right_finger_joint')
        assert node._own_serial_status('right/serial_sensor: tactile sensor')
        assert not node._own_serial_status('serial_sensor: tactile sensor')  # the root's
        assert not node._own_serial_status('left/serial_sensor: tactile sensor')
        assert not node._own_serial_status('right/perception: force')
        node.destroy_node()
        root = CommissionNode(protocol(), headless=True)
        assert root.joints == ('forte_left_finger_joint', 'forte_right_finger_joint')
        assert root._own_serial_status('serial_sensor: tactile sensor')
        assert not root._own_serial_status('right/serial_sensor: tactile sensor')
        root.destroy_node()
    finally:
        rclpy.try_shutdown()
