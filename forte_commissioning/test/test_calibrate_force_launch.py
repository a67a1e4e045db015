"""calibrate_force.launch.py read by ``launch`` itself (nothing is started): every argument
described, a bad value refused by name, each mode starts what it says."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

REASON = ('launch / launch_ros need a ROS 2 install (or the launch kit, '
          '../shared/ros2-launch-kit)')
launch = pytest.importorskip('launch', reason=REASON)
launch_ros = pytest.importorskip('launch_ros', reason=REASON)

from launch_ros.actions import Node  # noqa: E402

from forte_ros.testing import launch_file_actions, launch_file_description  # noqa: E402

LAUNCH_FILE = Path(__file__).resolve().parents[1] / 'launch' / 'calibrate_force.launch.py'


def started(**arguments: str) -> list:
    """The actions the launch file amounts to for ``arguments`` (others at their default)."""
    return launch_file_actions(LAUNCH_FILE, **arguments)[1]


def nodes(actions: list) -> dict[str, Node]:
    found = {}
    for action in actions:
        if isinstance(action, Node):
            found[action.node_executable] = action
    return found


def test_every_argument_is_declared_with_a_description():
    arguments = launch_file_description(LAUNCH_FILE).get_launch_arguments()
    names = [argument.name for argument in arguments]
    assert {'mode', 'session_dir', 'quick', 'load_cell_topic', 'load_cell_axis',
            'load_cell_sign', 'auto_continue', 'real_time_factor'} <= set(names)
    for argument in arguments:
        assert len(argument.description) > 20, argument.name


def test_sim_mode_starts_the_calibration_scene_and_the_procedure():
    found = nodes(started(mode='sim', quick='true', load_cell_sign='-1'))
    assert set(found) == {'sim_node', 'forte_calibrate_force'}
    assert 'perception_node' not in found and 'grasp_controller_node' not in found


def test_hardware_mode_starts_the_drivers_and_the_procedure_only():
    actions = started(mode='hardware', sensor_port='/dev/null')
    executables = {getattr(action, 'node_executable', None) for action in actions}
    assert {'serial_sensor_node', 'gripper_driver_node', 'forte_calibrate_force'} <= executables
    assert 'grasp_controller_node' not in executables and 'sim_node' not in executables


@pytest.mark.parametrize('arguments, problem', [
    ({'mode': 'robot'}, 'expected sim or hardware'),
    ({'quick': 'yes'}, 'expected true or false'),
    ({'load_cell_sign': 'minus'}, 'load_cell_sign'),
])
def test_a_bad_argument_stops_the_launch_with_its_name(arguments, problem):
    with pytest.raises(ValueError, match=problem):
        started(**arguments)


@pytest.mark.parametrize('mode', ['sim', 'hardware'])
def test_force_calibration_launch_runs_in_a_namespace(mode: str):
    """calibrate_force.launch.py builds on the graph: namespace and prefix reach every node."""
    context, actions = launch_file_actions(LAUNCH_FILE, mode=mode, namespace='right',
                                           prefix='right_', sensor_port='/dev/null')
    nodes = {action.node_executable: action for action in actions if isinstance(action, Node)}
    expected = {'sim_node'} if mode == 'sim' else {'serial_sensor_node', 'gripper_driver_node'}
    assert set(nodes) == expected | {'forte_calibrate_force'}
    for executable, node in nodes.items():
        node._perform_substitutions(context)
        assert node.expanded_node_namespace == '/right', executable
        if executable != 'forte_calibrate_force':
            documents = [yaml.safe_load(Path(path).read_text())
                         for path, _ in node._Node__expanded_parameter_arguments]
            assert documents[-1][node.node_name]['ros__parameters']['prefix'] == 'right_'
