"""The parameter YAML files match the nodes: every key is declared, every value applies.

Each graph's nodes are started as the real executables with the graph's YAML (exactly the
command line ``forte_bringup`` uses); the test then asks every node over its parameter
services which parameters it declares and what values they hold. A misspelt key (which
rclpy would silently ignore), a value of the wrong type (the node refuses to start) or a
node block with no matching node fails here. A YAML lists only what differs from the node's
defaults (read from the nodes' parameter tables): a key that repeats a default fails too.
"""
from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from rcl_interfaces.srv import GetParameters, ListParameters
from rclpy.parameter import parameter_value_to_python

from forte_bringup.bringup import node_command
from forte_bringup.graph import GRAPHS, config_folder, params_file
from forte_bringup.graph_nodes import started_nodes
from forte_bringup.visualization import VisualizationConfig
from forte_bringup.visualization_node import PARAMETERS as VISUALIZATION_PARAMETERS
from forte_control import parameters as control
from forte_control.state_machine import ControllerParams
from forte_control.state_machine.lift_check import LiftCheckParams
from forte_driver.dynamixel.gripper_config import GripperConfig
from forte_driver.ros import bag_replay_node, gripper_driver_parameters, serial_sensor_parameters
from forte_perception.pipeline import PipelineConfig
from forte_perception.ros import perception_node
from forte_sim.ros import sim_node


def load(graph: str) -> dict:
    return yaml.safe_load(params_file(graph).read_text())


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_yaml_blocks_are_the_graph_nodes(graph):
    data = load(graph)
    assert set(data) == {spec.name for spec in GRAPHS[graph].nodes}
    for name, block in data.items():
        assert set(block) == {'ros__parameters'}, name
        assert isinstance(block['ros__parameters'], dict)


def test_every_graph_has_its_own_file():
    files = {GRAPHS[g].params_file for g in GRAPHS}
    assert files == {'hardware.yaml', 'sim.yaml', 'replay.yaml'}
    assert all((config_folder() / f).is_file() for f in files)


def flatten(block: dict, prefix: str = '') -> dict:
    """Nested YAML parameter blocks as ROS names them: ``{'a': {'b': 1}}`` -> ``{'a.b': 1}``."""
    flat = {}
    for key, value in block.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f'{prefix}{key}.'))
        else:
            flat[prefix + key] = value
    return flat


#: robot_state_publisher's parameters and defaults (Jazzy, robot_state_publisher.cpp; it
#: has no wheel, so no running node here to ask; where it is installed the slow test below
#: checks the YAML against the running node).
ROBOT_STATE_PUBLISHER_DEFAULTS = {'robot_description': '', 'publish_frequency': 20.0,
                                  'ignore_timestamp': False, 'frame_prefix': ''}


def table_defaults() -> dict[str, dict[str, object]]:
    """node name -> parameter -> default, from each node's parameter table (and the core
    dataclass holding the defaults of its entries with a field)."""
    tables = {
        'serial_sensor': [(serial_sensor_parameters.PARAMETERS, None)],
        'gripper_driver': [(gripper_driver_parameters.PARAMETERS, GripperConfig())],
        'bag_replay': [(bag_replay_node.PARAMETERS, None)],
        'sim': [(sim_node.PARAMETERS, None)],
        'perception': [(perception_node.PARAMETERS, PipelineConfig())],
        'grasp_controller': [(control.CONTROLLER_PARAMETERS, ControllerParams()),
                             (control.LIFT_CHECK_PARAMETERS, LiftCheckParams()),
                             (control.NODE_PARAMETERS, None)],
        'visualization': [(VISUALIZATION_PARAMETERS, VisualizationConfig())],
    }
    return {node: {'use_sim_time': False} | {
        name: spec.default_from(defaults) for table, defaults in groups
        for name, spec in table.items()} for node, groups in tables.items()} | {
        'robot_state_publisher': {'use_sim_time': False} | ROBOT_STATE_PUBLISHER_DEFAULTS,
        'rviz2': {'use_sim_time': False}}


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_robot_state_publisher_keeps_the_time_of_the_joint_states(graph):
    """robot_state_publisher stamps TF in the time of the graph (simulated time in the sim
    graph, as the nodes reading joint_states); its URDF is never in the YAML (the front ends
    set it for the graph's prefix)."""
    data = load(graph)
    publisher = data['robot_state_publisher']['ros__parameters']
    controller = data['grasp_controller']['ros__parameters']
    assert publisher.get('use_sim_time', False) == controller.get('use_sim_time', False)
    assert publisher.get('use_sim_time', False) == (graph == 'sim')
    assert 'robot_description' not in publisher


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_yaml_lists_only_what_differs_from_the_node_defaults(graph):
    """A key whose value is the node's default repeats it (and goes stale when the default
    changes): the YAML gives only what this graph changes."""
    defaults = table_defaults()
    for name, block in load(graph).items():
        for key, value in flatten(block['ros__parameters']).items():
            assert key in defaults[name], f'{graph}.yaml: {name} has no parameter {key}'
            default = defaults[name][key]
            same = value == pytest.approx(default) if isinstance(value, float) else \
                value == default
            assert not same, f'{graph}.yaml {name}.{key}: {value!r} is the node default'


def call(node, client, request, timeout=10.0, attempt_timeout=5.0):
    """Call an idempotent service, asking again every ``attempt_timeout`` s until
    ``timeout`` s: a server can take a request before its response writer has matched the
    client's reader, and then the response is lost (ros2/rmw_fastrtps#390); seen once in CI
    on a cold start, as a parameter service that was discovered but never answered."""
    deadline = time.monotonic() + timeout
    assert client.wait_for_service(timeout_sec=timeout), client.srv_name
    attempts = 0
    while time.monotonic() < deadline:
        attempts += 1
        future = client.call_async(request)
        rclpy.spin_until_future_complete(
            node, future, timeout_sec=min(attempt_timeout, deadline - time.monotonic()))
        if future.done():
            return future.result()
        client.remove_pending_request(future)
    raise AssertionError(f'{client.srv_name}: no answer to {attempts} requests in {timeout} s')


@pytest.mark.slow
@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_yaml_keys_are_declared_parameters_with_those_values(graph, tmp_path):
    # every node this machine has (robot_state_publisher only where installed)
    nodes, _ = started_nodes(GRAPHS[graph], {})
    data = load(graph)
    arguments = {'bag': str(tmp_path / 'no_bag_needed.mcap')}
    if graph == 'replay':  # the replay node checks its bag at start: give it a real one
        from forte_driver.replay.bags import BagWriter, TopicSpec
        bag = tmp_path / 'bag'
        with BagWriter(bag) as writer:
            writer.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
        arguments['bag'] = str(bag)
    processes = {}
    rclpy.init()
    node = rclpy.create_node('config_checker')
    try:
        for spec in nodes:
            command = node_command(spec, params_file(graph), arguments)
            processes[spec.name] = subprocess.Popen(
                command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        for spec in nodes:
            expected = flatten(data[spec.name]['ros__parameters'])
            listed = call(node, node.create_client(ListParameters,
                                                   f'/{spec.name}/list_parameters'),
                          ListParameters.Request(), timeout=30.0)
            declared = set(listed.result.names)
            unknown = set(expected) - declared
            assert not unknown, f'{graph}.yaml: {spec.name} does not declare {sorted(unknown)}'
            if not expected:
                continue
            got = call(node, node.create_client(GetParameters, f'/{spec.name}/get_parameters'),
                       GetParameters.Request(names=list(expected)))
            values = dict(zip(expected, (parameter_value_to_python(v) for v in got.values)))
            fixed = dict(spec.fixed_parameters)
            for key, value in expected.items():
                value = fixed.get(key, value)
                actual = values[key]
                where = f'{graph}.yaml {spec.name}.{key}: node has {actual!r}, file {value!r}'
                if isinstance(value, float):
                    assert actual == pytest.approx(value), where
                elif isinstance(value, list):
                    assert list(actual) == value, where
                else:
                    assert actual == value, where
            assert processes[spec.name].poll() is None, f'{spec.name} exited'
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        for process in processes.values():
            process.terminate()
        for process in processes.values():
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        time.sleep(0.1)


def test_launch_files_build_their_graph_from_the_shared_description():
    launch_folder = Path(__file__).resolve().parents[1] / 'launch'
    for graph in GRAPHS:
        text = (launch_folder / f'{graph}.launch.py').read_text()
        compile(text, f'{graph}.launch.py', 'exec')
        assert 'def generate_launch_description' in text
        assert f"graph_launch_description('{graph}')" in text
    for graph in GRAPHS.values():
        for argument in graph.arguments:
            assert argument.description.strip(), f'{graph.name}: {argument.name} undocumented'
