"""The launch files' arguments, read by ``launch`` itself (nothing is started).

Every argument of the three launch files is declared with a real description and matches
the graph description (forte_bringup/graph.py); the sim graph has ``real_time_factor``
(a double parameter of the sim node); ``record:=true`` adds the recorder as a launch_ros node
of forte_bringup whose executable is found through the package (as ``ros2 run`` finds it).
Needs ``launch`` / ``launch_ros`` (a ROS 2 install, or the launch kit on a bare machine).
"""
from __future__ import annotations

from pathlib import Path

import pytest

REASON = ('launch / launch_ros need a ROS 2 install (or the launch kit, '
          '../shared/ros2-launch-kit); forte_bringup starts the same graphs (test_bringup.py)')
launch = pytest.importorskip('launch', reason=REASON)
launch_ros = pytest.importorskip('launch_ros', reason=REASON)

from launch.actions import DeclareLaunchArgument, OpaqueFunction  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402
from launch_ros.actions import Node  # noqa: E402
from launch_ros.substitutions import ExecutableInPackage  # noqa: E402

from forte_bringup.graph import GRAPHS  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'


def description(graph: str) -> launch.LaunchDescription:
    """The launch description of ``launch/<graph>.launch.py``."""
    source = PythonLaunchDescriptionSource(str(LAUNCH / f'{graph}.launch.py'))
    return source.get_launch_description(launch.LaunchContext())


def started_actions(graph: str, **arguments: str) -> tuple[launch.LaunchContext, list]:
    """The actions the launch file's node-creating OpaqueFunction returns for ``arguments``.

    The declared arguments are evaluated as ``ros2 launch`` would (given values first,
    defaults for the rest), then the OpaqueFunction runs; nothing is executed.
    """
    context = launch.LaunchContext()
    context.launch_configurations.update(arguments)
    actions = []
    for entity in description(graph).entities:
        if isinstance(entity, DeclareLaunchArgument):
            entity.execute(context)
        elif isinstance(entity, OpaqueFunction):
            actions += entity.execute(context) or []
    return context, actions


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
