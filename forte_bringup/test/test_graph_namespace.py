"""The ``namespace`` / ``prefix`` arguments and the sim graph's default force model, as both
front ends build them (issue 27; nothing is started).

- :func:`forte_ros.contract.graph_namespace` / :func:`forte_ros.contract.check_prefix`
  accept ROS names and refuse the rest with the reason;
- a namespaced parameter file keys every node block by the namespaced node name (rcl matches
  a ``sim:`` block to ``/sim`` only);
- ``forte_bringup``'s command lines: ``__ns``, the copied YAML, ``prefix``, ``/clock`` ->
  ``<namespace>/clock`` in the sim graph only, the recorder in the namespace recording its
  topics; no change without the arguments;
- the launch files' nodes (launch_ros, when installed) get the same namespace, remappings,
  parameter files and parameters;
- perception's force model: the argument, else the YAML, else (sim graph only) the
  simulated rig's cached model (:func:`forte_evaluation.sim_force_model.force_model_path`).
"""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from forte_bringup.bringup import Bringup, BringupError
from forte_bringup.graph import (
    GRAPHS,
    namespaced_parameter_file,
    params_file,
)
from forte_bringup.graph_nodes import force_model_source
from forte_bringup.robot_model import robot_state_publisher_available
from forte_evaluation.sim_force_model import force_model_path
from forte_ros.contract import (
    BASE_FRAME,
    JOINT_NAMES,
    check_prefix,
    graph_namespace,
    joint_names,
    prefixed,
)
from forte_ros.testing import launch_file_actions, wait_until

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'


def launch_actions(launch_file: str, **arguments: str) -> tuple[object, list]:
    """What ``launch/<launch_file>`` amounts to for ``arguments``; nothing is executed."""
    return launch_file_actions(LAUNCH / launch_file, **arguments)


def option_values(command: list[str], option: str) -> list[str]:
    """Every value following ``option`` in a command line."""
    return [command[i + 1] for i, item in enumerate(command[:-1]) if item == option]


def test_contract_names_and_prefix():
    assert prefixed(BASE_FRAME, 'right_') == 'right_forte_base_link'
    assert prefixed('', 'right_') == ''  # no frame stays no frame
    assert joint_names() == JOINT_NAMES == ('forte_left_finger_joint',
                                            'forte_right_finger_joint')
    assert joint_names('r_') == ('r_forte_left_finger_joint', 'r_forte_right_finger_joint')
    # the gripper driver's joints come from its configuration, with its prefix parameter
    from forte_driver.ros.gripper_driver_parameters import gripper_config

    assert [f.joint_name for f in gripper_config({}).fingers] == list(JOINT_NAMES)
    assert [f.joint_name for f in gripper_config({'prefix': 'r_'}).fingers] == list(
        joint_names('r_'))


def test_namespace_and_prefix_are_checked():
    assert graph_namespace('') == graph_namespace(' / ') == ''
    assert graph_namespace('right') == graph_namespace('/right/') == '/right'
    assert graph_namespace('lab/left_arm') == '/lab/left_arm'
    for bad in ('1st', 'a b', 'a//b', 'right-hand'):
        with pytest.raises(ValueError, match='not a valid ROS name'):
            graph_namespace(bad)
    assert check_prefix('') == '' and check_prefix('right_') == 'right_'
    for bad in ('/right_', 'a b', 'r-'):
        with pytest.raises(ValueError, match='prefix'):
            check_prefix(bad)
    with pytest.raises(BringupError, match='not a valid ROS name'):
        Bringup('sim', {'namespace': '9'}, echo=None)
    with pytest.raises(BringupError, match='prefix'):
        Bringup('sim', {'prefix': '/x'}, echo=None).commands()


def test_namespaced_parameter_file_keys_the_namespaced_nodes(tmp_path: Path):
    source = tmp_path / 'p.yaml'
    source.write_text('sim:\n  ros__parameters: {object: apple}\n'
                      '/**:\n  ros__parameters: {use_sim_time: true}\n')
    assert namespaced_parameter_file(source, '') == source
    copy = namespaced_parameter_file(source, '/lab/right')
    assert copy != source
    assert yaml.safe_load(copy.read_text()) == {
        '/lab/right/sim': {'ros__parameters': {'object': 'apple'}},
        '/**': {'ros__parameters': {'use_sim_time': True}}}


def test_forte_bringup_commands_under_a_namespace(tmp_path: Path):
    bringup = Bringup('sim', {'namespace': 'right', 'prefix': 'right_', 'record': 'true',
                              'bag_output': str(tmp_path / 'bag')}, echo=None)
    assert bringup.node_path('sim') == '/right/sim'
    commands = bringup.commands()
    for name in ('sim', 'perception', 'grasp_controller'):
        command = commands[name]
        assert option_values(command, '-r')[:2] == [f'__node:={name}', '__ns:=/right']
        assert '/clock:=/right/clock' in option_values(command, '-r')  # its own clock
        assert 'prefix:=right_' in option_values(command, '-p')
        (parameters,) = option_values(command, '--params-file')
        assert set(yaml.safe_load(Path(parameters).read_text())) == {
            '/right/sim', '/right/perception', '/right/grasp_controller',
            '/right/visualization', '/right/robot_state_publisher', '/right/rviz2'}
    recorder = commands['recorder']
    assert '__ns:=/right' in option_values(recorder, '-r')
    assert '/clock:=/right/clock' in option_values(recorder, '-r')
    topics = recorder[recorder.index('--topics') + 1:recorder.index('-o')]
    assert '/right/tactile/frames' in topics and '/diagnostics' in topics
    assert all(t.startswith('/right/') or t == '/diagnostics' for t in topics)
    # without the arguments nothing changes
    plain = Bringup('sim', echo=None).commands()['sim']
    assert not [r for r in option_values(plain, '-r') if r.startswith(('__ns', '/clock'))]
    assert option_values(plain, '--params-file') == [str(params_file('sim'))]
    # a graph without its own clock keeps /clock (the hardware graph runs on wall time)
    hardware = Bringup('hardware', {'namespace': 'right', 'prefix': 'right_'}, echo=None)
    for name, command in hardware.commands().items():
        assert not [r for r in option_values(command, '-r') if r.startswith('/clock')]
        if name != 'robot_state_publisher':  # it gets the prefixed URDF, not a prefix
            assert 'prefix:=right_' in option_values(command, '-p'), name


def test_force_model_defaults_to_the_simulated_rig_in_the_sim_graph_only(tmp_path: Path):
    sim, hardware = GRAPHS['sim'], GRAPHS['hardware']
    assert force_model_source(sim, {}, params_file('sim')) == 'sim'
    assert force_model_source(sim, {'force_model': '/m.npz'}, params_file('sim')) == 'argument'
    overlay = tmp_path / 'model.yaml'
    overlay.write_text('perception:\n  ros__parameters:\n    model_path: /cal.npz\n')
    assert force_model_source(sim, {}, params_file('sim'), overlay) == 'yaml'
    assert force_model_source(hardware, {}, params_file('hardware')) == 'none'
    assert force_model_source(GRAPHS['replay'], {}, params_file('replay')) == 'none'
    command = Bringup('sim', echo=None).commands()['perception']
    assert f'model_path:={force_model_path()}' in option_values(command, '-p')
    command = Bringup('hardware', echo=None).commands()['perception']
    assert not [p for p in option_values(command, '-p') if p.startswith('model_path')]


def test_launch_files_build_the_same_namespaced_nodes():
    pytest.importorskip('launch', reason='launch / launch_ros need a ROS 2 install or the '
                        'launch kit (../shared/ros2-launch-kit)')
    pytest.importorskip('launch_ros', reason='launch_ros needs a ROS 2 install or the kit')
    from launch_ros.actions import Node

    context, actions = launch_actions('sim.launch.py', namespace='right', prefix='right_',
                                      force_model='/m.npz')
    nodes = [action for action in actions if isinstance(action, Node)]
    assert [node.node_executable for node in nodes] == [
        'sim_node', 'perception_node', 'grasp_controller_node', 'forte_visualization'] + (
        ['robot_state_publisher'] if robot_state_publisher_available() else [])
    for node in nodes:
        node._perform_substitutions(context)  # what launch_ros does when it starts it
        assert node.expanded_node_namespace == '/right'
        assert node.expanded_remapping_rules == [('/clock', '/right/clock')]
        files = [Path(path) for path, _ in node._Node__expanded_parameter_arguments]
        documents = [yaml.safe_load(path.read_text()) for path in files]
        assert '/right/sim' in documents[0]  # the copy keyed by the namespaced names
        if node.node_executable != 'robot_state_publisher':  # the prefixed URDF instead
            assert documents[-1][node.node_name]['ros__parameters']['prefix'] == 'right_'


@pytest.mark.slow
def test_forte_bringup_runs_a_namespaced_sim_graph(tmp_path: Path):
    """The bare-machine runner: the sim graph in ``/right`` with ``prefix:=right_``; nothing
    of it in the root namespace, its own clock, prefixed joints and frames."""
    from forte_bringup.testing import watching

    bringup = Bringup('sim', {'namespace': 'right', 'prefix': 'right_',
                              'object': 'raspberry'}, log_dir=tmp_path, echo=None)
    with watching() as root, watching('right') as probe:
        bringup.start(timeout=90.0)
        try:
            assert probe.lifecycle_state('sim') == 'active'
            assert wait_until(lambda: probe.counts['tactile/frames'] > 20, 60.0), probe.counts
            assert wait_until(lambda: probe.counts['tared'] > 5, 60.0), probe.counts
            assert wait_until(lambda: probe.counts['grasp/state'] >= 1, 30.0), probe.counts
            assert probe.joint_names == list(joint_names('right_'))
            assert probe.frame_ids['tactile/frames'] == 'right_forte_base_link'
            assert probe.frame_ids['tactile/state'] == 'right_forte_base_link'
            assert probe.frame_ids['grasp/state'] == 'right_forte_base_link'
            assert probe.parameter('perception', 'model_path') == str(force_model_path())
            topics = {name for name, _ in root.get_topic_names_and_types()}
            assert '/right/clock' in topics and '/clock' not in topics, sorted(topics)
            for topic in ('/tactile/frames', '/joint_states', '/grasp/state', '/clock'):
                assert not root.get_publishers_info_by_topic(topic), topic  # none at the root
            assert root.counts['tactile/frames'] == root.counts['joint_states'] == 0
            bringup.check_children()
        finally:
            codes = bringup.stop()
    assert set(codes) == {'sim', 'perception', 'grasp_controller', 'visualization'} | (
        {'robot_state_publisher'} if robot_state_publisher_available() else set())
