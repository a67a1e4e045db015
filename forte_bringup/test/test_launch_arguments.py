"""The launch files' arguments, read by ``launch`` itself (nothing is started).

Every argument of the three launch files is declared with a real description and matches
the graph description (forte_bringup/graph.py); the sim graph has ``real_time_factor``
(a double parameter of the sim node); ``record:=true`` adds the recorder as a launch_ros node
of forte_bringup whose executable is found through the package (as ``ros2 run`` finds it);
every graph has the visualization node (``visualization:=false``: not) and, where it is
installed (a made-up ament prefix here), robot_state_publisher with the gripper's URDF
(``robot_state_publisher:=false``: not); where it is not, one log line instead.
Needs ``launch`` / ``launch_ros`` (a ROS 2 install, or the launch kit on a bare machine).
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REASON = ('launch / launch_ros need a ROS 2 install (or the launch kit, '
          '../shared/ros2-launch-kit); forte_bringup starts the same graphs (test_bringup.py)')
launch = pytest.importorskip('launch', reason=REASON)
launch_ros = pytest.importorskip('launch_ros', reason=REASON)

import yaml  # noqa: E402
from launch.actions import LogInfo  # noqa: E402
from launch_ros.actions import Node  # noqa: E402
from launch_ros.substitutions import ExecutableInPackage  # noqa: E402
from robot_model_probe import (  # noqa: E402
    fake_robot_state_publisher,
    without_robot_state_publisher,
)

from forte_bringup.graph import GRAPHS  # noqa: E402
from forte_bringup.robot_model import ROBOT_STATE_PUBLISHER_MISSING, expand_gripper  # noqa: E402
from forte_ros.testing import launch_file_actions, launch_file_description  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'


def description(graph: str) -> launch.LaunchDescription:
    """The launch description of ``launch/<graph>.launch.py``."""
    return launch_file_description(LAUNCH / f'{graph}.launch.py')


def started_actions(graph: str, **arguments: str) -> tuple[launch.LaunchContext, list]:
    """What ``launch/<graph>.launch.py`` amounts to for ``arguments``; nothing is executed."""
    return launch_file_actions(LAUNCH / f'{graph}.launch.py', **arguments)


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_every_argument_has_a_description(graph: str):
    arguments = description(graph).get_launch_arguments()
    assert [a.name for a in arguments] == [a.name for a in GRAPHS[graph].arguments]
    for argument in arguments:
        assert argument.description and argument.description != 'no description given', (
            graph, argument.name)
        assert len(argument.description) > 20, (graph, argument.name, argument.description)


def test_sim_has_a_real_time_factor_argument():
    (argument,) = [a for a in description('sim').get_launch_arguments()
                   if a.name == 'real_time_factor']
    assert argument.default_value[0].perform(launch.LaunchContext()) == ''  # YAML value
    assert 'real time' in argument.description and 'YAML' in argument.description
    graph = GRAPHS['sim']
    assert ('real_time_factor', 'real_time_factor') in graph.node('sim').argument_parameters
    assert graph.argument('real_time_factor').typed('2') == 2.0  # the double parameter
    # the value reaching the running node: test_launch_graphs.py (sim graph)


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_record_adds_the_recorder_node_of_the_package(graph: str, tmp_path):
    extra = {'bag': str(tmp_path / 'bag')} if graph == 'replay' else {}
    _, without = started_actions(graph, **extra)
    assert not [a for a in without if isinstance(a, Node) and a.node_executable == 'forte_record']
    context, actions = started_actions(graph, record='true',
                                       bag_output=str(tmp_path / 'out'), **extra)
    (recorder,) = [a for a in actions
                   if isinstance(a, Node) and a.node_executable == 'forte_record']
    assert type(recorder) is Node and recorder.node_package == 'forte_bringup'
    # launch_ros finds it under lib/forte_bringup/ of the package's prefix, as ros2 run does
    path = Path(ExecutableInPackage('forte_record', 'forte_bringup').perform(context))
    assert path.parent.name == 'forte_bringup' and path.parent.parent.name == 'lib'
    assert path.is_file()


def launched(context: launch.LaunchContext, actions: list) -> tuple[dict, list[str]]:
    """The launch_ros nodes by executable, and the lines of the LogInfo actions."""
    nodes = {a.node_executable: a for a in actions if isinstance(a, Node)}
    lines = [''.join(part.perform(context) for part in a.msg) for a in actions
             if isinstance(a, LogInfo)]
    return nodes, lines


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_visualization_and_robot_state_publisher(graph: str, tmp_path, monkeypatch):
    extra = {'bag': str(tmp_path / 'bag')} if graph == 'replay' else {}
    monkeypatch.setenv('AMENT_PREFIX_PATH', os.pathsep.join(
        [str(tmp_path / 'ros'), without_robot_state_publisher()]))
    fake_robot_state_publisher(tmp_path / 'ros')
    context, actions = started_actions(graph, namespace='right', prefix='right_', **extra)
    nodes, lines = launched(context, actions)
    # the hardware graph, which a robot's launch includes, leaves the model to the robot
    assert ('robot_state_publisher' in nodes) == (graph != 'hardware')
    context, actions = started_actions(graph, namespace='right', prefix='right_',
                                       robot_state_publisher='true', **extra)
    nodes, lines = launched(context, actions)
    assert ROBOT_STATE_PUBLISHER_MISSING not in lines
    for executable, package in (('forte_visualization', 'forte_bringup'),
                                ('robot_state_publisher', 'robot_state_publisher')):
        node = nodes[executable]
        assert node.node_package == package
        node._perform_substitutions(context)  # what launch_ros does when it starts it
        assert node.expanded_node_namespace == '/right'
        assert (node.expanded_remapping_rules or []) == (
            [('/clock', '/right/clock')] if graph == 'sim' else [])
        documents = [yaml.safe_load(Path(path).read_text())
                     for path, _ in node._Node__expanded_parameter_arguments]
        assert node.node_name in documents[0]  # the graph's YAML, keyed for the namespace
        block = documents[0][node.node_name]['ros__parameters']
        assert block.get('use_sim_time', False) == (
            graph == 'sim' and executable == 'robot_state_publisher')
        given = documents[-1][node.node_name]['ros__parameters']
        if executable == 'robot_state_publisher':
            assert given == {'robot_description': expand_gripper('right_')}
        else:
            assert given == {'prefix': 'right_'}
    context, actions = started_actions(graph, visualization='false',
                                       robot_state_publisher='false', **extra)
    nodes, lines = launched(context, actions)
    assert not {'forte_visualization', 'robot_state_publisher'} & set(nodes)
    assert ROBOT_STATE_PUBLISHER_MISSING not in lines

    monkeypatch.setenv('AMENT_PREFIX_PATH', without_robot_state_publisher())
    context, actions = started_actions(graph, **extra)
    nodes, lines = launched(context, actions)
    assert 'robot_state_publisher' not in nodes and 'forte_visualization' in nodes
    assert lines.count(ROBOT_STATE_PUBLISHER_MISSING) == (graph != 'hardware')
    context, actions = started_actions(graph, robot_state_publisher='true', **extra)
    nodes, lines = launched(context, actions)
    assert lines.count(ROBOT_STATE_PUBLISHER_MISSING) == 1
