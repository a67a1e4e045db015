"""Bare-machine bringup: command lines, and whole graphs started for real.

The graph tests start the real node executables as child processes (what ``forte_bringup``
does), then watch their topics and drive them from this process over DDS: the hardware
graph against an emulated sensor and simulated Dynamixel servos on pseudo-terminals
(lifecycle nodes configured and activated through their change_state services), the
simulation graph through a Grasp goal, and the ``forte_bringup`` command stopped by SIGINT.
The probe node, the bag and the emulated devices come from :mod:`forte_bringup.testing`, shared with
the launch tests (``test_launch_graphs.py``).
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
import yaml
from robot_model_probe import fake_robot_state_publisher, without_robot_state_publisher

from forte_bringup.bringup import (
    Bringup,
    BringupError,
    find_executable,
    node_command,
    parse_graph_arguments,
)
from forte_bringup.graph import GRAPHS, parameter_text, params_file
from forte_bringup.robot_model import (
    ROBOT_STATE_PUBLISHER_MISSING,
    expand_gripper,
    robot_state_publisher_available,
)
from forte_bringup.testing import (
    emulated_devices,
    force_model_file,
    interrupt,
    python_module,
    watching,
    write_quiet_bag,
)
from forte_ros.testing import wait_until


def option_values(command: list[str], option: str) -> list[str]:
    """Every value that follows ``option`` in a command line."""
    return [command[i + 1] for i, item in enumerate(command[:-1]) if item == option]


# --- command lines (pure) ------------------------------------------------------------------
def test_node_command_matches_the_launch_description():
    graph = GRAPHS['hardware']
    arguments = parse_graph_arguments(graph, ['sensor_port:=/tmp/s',
                                              'arm_cmd_vel_topic:=/servo/delta_twist_cmds'])
    yaml = params_file('hardware')
    sensor = node_command(graph.node('serial_sensor'), yaml, arguments, executable='x')
    assert sensor == ['x', '--ros-args', '-r', '__node:=serial_sensor', '--params-file',
                      str(yaml), '-p', 'port:=/tmp/s']
    gripper = node_command(graph.node('gripper_driver'), yaml, arguments, executable='x')
    assert '-p' not in gripper  # empty argument: the YAML value stays
    control = node_command(graph.node('grasp_controller'), yaml, arguments, executable='x')
    assert control[-2:] == ['-r', 'arm/cmd_vel:=/servo/delta_twist_cmds']
    replay = GRAPHS['replay']
    control = node_command(replay.node('grasp_controller'), params_file('replay'),
                           parse_graph_arguments(replay, ['bag:=b']), executable='x')
    assert control[-2:] == ['-p', 'dry_run:=true']  # replay never moves anything
    source = node_command(replay.node('bag_replay'), params_file('replay'),
                          parse_graph_arguments(replay, ['bag:=/data/b', 'rate:=0']),
                          executable='x', graph=replay)
    # rate is a double parameter: the integer-looking 0 must go out as 0.0
    assert source[-4:] == ['-p', 'bag_path:=/data/b', '-p', 'rate:=0.0']
    with pytest.raises(BringupError, match='rate:=fast'):
        node_command(replay.node('bag_replay'), params_file('replay'),
                     parse_graph_arguments(replay, ['bag:=b', 'rate:=fast']), executable='x',
                     graph=replay)


def test_the_overlay_goes_after_the_yaml_of_the_nodes_it_names(tmp_path):
    """params_overlay: a second --params-file after the graph's YAML, for the nodes the
    overlay names only (as the launch files do); a bad overlay refuses to start."""
    overlay = tmp_path / 'slip.yaml'
    overlay.write_text('perception:\n  ros__parameters:\n    slip_threshold: 1.5\n')
    bringup = Bringup('sim', {'params_overlay': str(overlay)}, log_dir=tmp_path, echo=None)
    commands = bringup.commands()
    perception = commands['perception']
    files = [perception[i + 1] for i, item in enumerate(perception) if item == '--params-file']
    assert files == [str(params_file('sim')), str(overlay)]
    assert commands['sim'].count('--params-file') == 1
    overlay.write_text('planner:\n  ros__parameters:\n    speed: 1\n')
    with pytest.raises(BringupError, match="no node 'planner'"):
        Bringup('sim', {'params_overlay': str(overlay)}, log_dir=tmp_path, echo=None)
    with pytest.raises(BringupError, match='cannot read'):
        Bringup('sim', {'params_overlay': str(tmp_path / 'absent.yaml')}, log_dir=tmp_path,
                echo=None)


def test_argument_values_keep_their_parameter_type():
    sim = GRAPHS['sim']
    assert sim.argument('seed').typed('7') == 7
    assert parameter_text(GRAPHS['replay'].argument('rate').typed('2')) == '2.0'
    assert parameter_text('raspberry') == 'raspberry'
    assert parameter_text('yes') == "'yes'"  # YAML would read a bare yes as a boolean
    assert parameter_text('123') == "'123'"  # a string parameter that looks like a number
    assert parameter_text(True) == 'true'
    with pytest.raises(ValueError):
        sim.argument('seed').typed('1.5')


def test_arguments_are_checked():
    with pytest.raises(BringupError, match='no argument'):
        parse_graph_arguments(GRAPHS['sim'], ['sensor_port:=/dev/x'])
    with pytest.raises(BringupError, match='name:=value'):
        parse_graph_arguments(GRAPHS['sim'], ['object=raspberry'])
    with pytest.raises(BringupError, match='needs bag'):
        Bringup('replay')
    with pytest.raises(BringupError, match='unknown graph'):
        Bringup('moon')
    with pytest.raises(BringupError, match='does not exist'):
        Bringup('sim', {'params_file': '/no/such.yaml'})


def test_record_argument_adds_the_recorder(tmp_path):
    bringup = Bringup('sim', {'record': 'true', 'bag_output': str(tmp_path / 'b')}, echo=None)
    commands = bringup.commands()
    assert list(commands) == ['sim', 'perception', 'grasp_controller', 'visualization'] + (
        ['robot_state_publisher'] if robot_state_publisher_available() else []) + ['recorder']
    # the installed console script, found like the nodes (as the launch files' Node does)
    assert commands['recorder'] == [find_executable('forte_bringup', 'forte_record'),
                                    '-o', str(tmp_path / 'b'),
                                    '--ros-args', '-r', '__node:=forte_recorder']
    assert 'recorder' not in Bringup('sim', echo=None).commands()


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_visualization_runs_in_every_graph_unless_turned_off(graph: str, tmp_path):
    extra = {'bag': str(tmp_path / 'bag')} if graph == 'replay' else {}
    command = Bringup(graph, {'namespace': 'right', 'prefix': 'right_', **extra},
                      echo=None).commands()['visualization']
    assert command[0] == find_executable('forte_bringup', 'forte_visualization')
    assert option_values(command, '-r')[:2] == ['__node:=visualization', '__ns:=/right']
    assert option_values(command, '-p') == ['prefix:=right_']
    assert ('/clock:=/right/clock' in option_values(command, '-r')) == (graph == 'sim')
    (parameters,) = option_values(command, '--params-file')
    assert '/right/visualization' in yaml.safe_load(Path(parameters).read_text())
    off = Bringup(graph, {'visualization': 'false', **extra}, echo=None)
    assert 'visualization' not in off.commands()
    assert 'visualization' not in [spec.name for spec in off.nodes]
    with pytest.raises(BringupError, match='visualization:=maybe'):
        Bringup(graph, {'visualization': 'maybe', **extra}, echo=None)


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_robot_state_publisher_where_installed(graph: str, tmp_path, monkeypatch):
    """Installed (an ament prefix that registers it): started in the graph's namespace with
    the gripper's URDF for the prefix, the graph's YAML and the sim graph's clock; not
    installed: left out with the one line; ``robot_state_publisher:=false``: left out, no
    line."""
    extra = {'bag': str(tmp_path / 'bag')} if graph == 'replay' else {}
    # explicit: the hardware graph's default is false (a robot's launch includes it)
    arguments = {'namespace': 'right', 'prefix': 'right_', 'robot_state_publisher': 'true',
                 **extra}
    executable = fake_robot_state_publisher(tmp_path / 'ros')
    monkeypatch.setenv('AMENT_PREFIX_PATH',
                       f'{tmp_path / "ros"}{os.pathsep}{without_robot_state_publisher()}')
    bringup = Bringup(graph, arguments, echo=None)
    assert bringup.notes == []
    command = bringup.commands()['robot_state_publisher']
    assert command[0] == str(executable)
    remaps = option_values(command, '-r')
    assert remaps[:2] == ['__node:=robot_state_publisher', '__ns:=/right']
    assert remaps[2:] == (['/clock:=/right/clock'] if graph == 'sim' else [])
    assert option_values(command, '-p') == [
        'robot_description:=' + parameter_text(expand_gripper('right_'))]
    (parameters,) = option_values(command, '--params-file')
    block = yaml.safe_load(Path(parameters).read_text())['/right/robot_state_publisher']
    assert block['ros__parameters'].get('use_sim_time', False) == (graph == 'sim')
    off = Bringup(graph, {**arguments, 'robot_state_publisher': 'false'}, echo=None)
    assert 'robot_state_publisher' not in off.commands() and off.notes == []

    monkeypatch.setenv('AMENT_PREFIX_PATH', without_robot_state_publisher())
    absent = Bringup(graph, arguments, echo=None)
    assert absent.notes == [ROBOT_STATE_PUBLISHER_MISSING]
    assert 'robot_state_publisher' not in absent.commands()
    assert 'visualization' in absent.commands()


def test_a_urdf_reaches_the_node_unchanged_through_the_command_line():
    """``-p robot_description:=<URDF>`` (several lines, quotes, ``<?xml``) as rcl parses it:
    a node declaring its overrides reads back exactly the expanded URDF."""
    import rclpy
    from rclpy.context import Context

    urdf = expand_gripper('right_')
    assert '\n' in urdf and '"' in urdf
    context = Context()
    rclpy.init(args=['--ros-args', '-p', f'robot_description:={parameter_text(urdf)}'],
               context=context)
    try:
        node = rclpy.create_node('urdf_reader', context=context,
                                 automatically_declare_parameters_from_overrides=True)
        assert node.get_parameter('robot_description').value == urdf
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_executables_resolve_like_ros2_run():
    path = find_executable('forte_driver', 'bag_replay_node')
    assert Path(path).name == 'bag_replay_node' and os.access(path, os.X_OK)
    with pytest.raises(BringupError, match='not found'):
        find_executable('forte_driver', 'no_such_node')


# --- live graphs ---------------------------------------------------------------------------
@pytest.fixture
def watcher():
    with watching() as node:
        yield node


@pytest.mark.slow
def test_hardware_graph_on_emulated_devices(watcher, tmp_path):
    with emulated_devices(tmp_path) as (sensor_link, servo_link):
        bringup = Bringup('hardware', {'sensor_port': str(sensor_link),
                                       'gripper_port': str(servo_link)},
                          log_dir=tmp_path / 'logs', echo=None)
        bringup.start(timeout=60.0)
        try:
            # lifecycle nodes only publish once activated through change_state
            assert wait_until(lambda: watcher.counts['tactile/frames'] > 50, 30.0), (
                watcher.counts, (tmp_path / 'logs' / 'serial_sensor.log').read_text()[-2000:])
            assert wait_until(lambda: watcher.counts['joint_states'] > 10, 30.0), watcher.counts
            assert wait_until(lambda: watcher.counts['tactile/state'] > 10, 30.0), watcher.counts
            assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, 30.0)
            bringup.check_children()
        finally:
            codes = bringup.stop()
        assert set(codes) == {'serial_sensor', 'gripper_driver', 'perception',
                              'grasp_controller', 'visualization'} | (
            {'robot_state_publisher'} if robot_state_publisher_available() else set())
        assert all(code is not None for code in codes.values())


@pytest.mark.slow
def test_sim_graph_serves_a_grasp(watcher, tmp_path):
    from forte_msgs.action import Grasp
    from forte_msgs.msg import GraspState, SimGroundTruth

    model = force_model_file(tmp_path / 'force_model.npz')
    # real time, sim.yaml's default, given here as the argument (the graph takes ~45 % of one
    # core; 30 grasps at 1.0 beside two CPU-bound processes ended without a STALE fault:
    # benchmarks/bench_graph.py); a raspberry: 0.25 N lifts it whatever the DDS timing
    # (FORTE on the soda can, seed 0, races its stick-slip, and the race goes either way
    # over DDS: demo_scenes.py)
    bringup = Bringup('sim', {'object': 'raspberry', 'force_model': str(model),
                              'real_time_factor': '1.0'},
                      log_dir=tmp_path / 'logs', echo=None)
    assert bringup.commands()['sim'][-2:] == ['-p', 'real_time_factor:=1.0']
    bringup.start(timeout=60.0)
    try:
        # the controller refuses a goal before perception is tared and joint states flow
        assert wait_until(lambda: watcher.counts['tared'] > 20, 30.0), watcher.counts
        assert wait_until(lambda: watcher.counts['joint_states'] > 10, 30.0), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, 30.0)
        assert watcher.parameter('sim', 'real_time_factor') == 1.0
        time.sleep(0.5)
        assert watcher.truth is not None and watcher.truth.object_name == 'raspberry'
        assert watcher.truth.object_state == SimGroundTruth.OBJECT_RESTING
        goal = Grasp.Goal(controller=Grasp.Goal.FORTE, lift_distance=0.01, timeout=60.0)
        accepted, result, feedback = watcher.grasp_once_inputs_flow(goal, timeout=120.0)
        assert accepted
        assert result is not None, watcher.last_grasp_state
        # the claim against the simulator's ground truth (which the controller never sees)
        truth = watcher.truth
        assert (result.outcome, truth.object_state) == (
            Grasp.Result.LIFTED, SimGroundTruth.OBJECT_HELD), (result.message, truth)
        assert truth.object_height == pytest.approx(0.01, abs=0.002)
        assert 'equal' in result.message and 'when set down' in result.message
        assert watcher.last_grasp_state.last_outcome == GraspState.OUTCOME_LIFTED
        assert feedback, 'no action feedback'
        assert result.lift_height == pytest.approx(0.01, abs=0.002)
        assert result.duration > 0.0
        bringup.check_children()
    finally:
        bringup.stop()


@pytest.mark.slow
def test_forte_bringup_command_stops_cleanly_on_sigint(tmp_path):
    lines = []
    with python_module('forte_bringup.bringup', 'sim', '--quiet',
                       '--log-dir', str(tmp_path / 'logs')) as process:
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline:
            line = process.stdout.readline()
            if not line:
                break
            lines.append(line)
            if 'graph up' in line:
                break
        assert any('graph up' in line for line in lines), ''.join(lines)
        time.sleep(1.0)
        output = interrupt(process, timeout=60)
    assert process.returncode == 0, ''.join(lines) + output
    assert 'stopped: ' in output
    # without robot_state_publisher: its one line, and the graph came up all the same
    missing = [line for line in lines if ROBOT_STATE_PUBLISHER_MISSING in line]
    assert len(missing) == (0 if robot_state_publisher_available() else 1), ''.join(lines)
    for name in ('sim', 'perception', 'grasp_controller', 'visualization'):
        assert (tmp_path / 'logs' / f'{name}.log').is_file()


@pytest.mark.slow
def test_replay_graph_drives_perception_from_a_bag(watcher, tmp_path):
    bag = write_quiet_bag(tmp_path / 'bag')  # 6 s of quiet sensor at 2 kHz
    bringup = Bringup('replay', {'bag': str(bag), 'rate': '2'}, log_dir=tmp_path / 'logs',
                      echo=None)
    bringup.start(timeout=60.0)
    try:
        assert wait_until(lambda: watcher.counts['tactile/state'] > 20, 30.0), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, 30.0)
        bringup.check_children()
    finally:
        bringup.stop()
    replay_log = (tmp_path / 'logs' / 'bag_replay.log').read_text()
    assert 'replaying' in replay_log
