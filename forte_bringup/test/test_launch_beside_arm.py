"""FORTE's hardware launch included beside an arm's bringup (launch_pytest, real DDS).

A robot's launch file includes ``hardware.launch.py`` next to what its arm's bringup starts
(stand_in_arm.py: ``/robot_state_publisher`` with ``/robot_description`` of an arm whose
``tool0`` carries FORTE, and ``/joint_state_broadcaster`` on ``/joint_states``). The gripper
(emulated sensor and servos on pseudo-terminals) is included with ``namespace:=right
prefix:=right_`` and otherwise its defaults. Checked on the live graph:

- no two nodes share a fully qualified name;
- the arm's topics (``/robot_description``, ``/joint_states``) have no publisher but the
  arm's nodes, and ``/tf``, ``/tf_static`` and ``/clock`` none of FORTE's (the hardware
  graph's default is ``robot_state_publisher:=false``; no clock outside the simulator);
- every topic the RViz view written for these arguments names (:mod:`forte_bringup.rviz_view`)
  exists with the type RViz subscribes with.

robot_state_publisher counts as installed (an ament prefix of the test's own registers a
stand-in, stand_in_arm.py ``--as-robot-state-publisher``), so the defaults are what keeps
it out; and the same checks find the clash when the gripper is included in the root
namespace with ``robot_state_publisher:=true`` (a second ``/robot_state_publisher``, a second
publisher of ``/robot_description``).

Needs launch_pytest and launch_ros (a ROS 2 install, or the launch kit on a bare machine);
skipped with that reason otherwise.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

REASON = ('launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest) or the '
          'launch kit (../shared/ros2-launch-kit)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)

import launch  # noqa: E402
from launch.actions import ExecuteProcess, IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_bringup.graph import GRAPHS, node_arguments  # noqa: E402
from forte_bringup.rviz_view import view_topics  # noqa: E402
from forte_bringup.testing import emulated_devices, watching  # noqa: E402
from forte_ros.testing import wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'
STAND_IN_ARM = Path(__file__).resolve().parent / 'stand_in_arm.py'
ARGUMENTS = {'namespace': 'right', 'prefix': 'right_'}
#: The arm bringup's topics and the nodes that may publish them (fully qualified).
ARM_TOPICS = {'/robot_description': {'/robot_state_publisher'},
              '/tf': set(),          # the stand-in publishes no TF (no tf2_msgs wheel)
              '/tf_static': set(),
              '/joint_states': {'/joint_state_broadcaster'},
              '/clock': set()}
#: Longest wait for the graph and for each expectation [s] (2 shared cores).
UP = 90.0
WAIT = 60.0


@pytest.fixture
def devices(tmp_path: Path, monkeypatch):
    """The emulated devices, and robot_state_publisher 'installed' (the stand-in)."""
    prefix = tmp_path / 'ros'
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'robot_state_publisher').write_text('')
    executable = prefix / 'lib' / 'robot_state_publisher' / 'robot_state_publisher'
    executable.parent.mkdir(parents=True)
    executable.write_text(f'#!/bin/sh\nexec {sys.executable} {STAND_IN_ARM} '
                          '--as-robot-state-publisher "$@"\n')
    executable.chmod(0o755)
    monkeypatch.setenv('AMENT_PREFIX_PATH', f'{prefix}:{os.environ["AMENT_PREFIX_PATH"]}')
    with emulated_devices(tmp_path) as links:
        yield links


def arm_and_gripper(devices: tuple[Path, Path], **arguments: str) -> launch.LaunchDescription:
    sensor, gripper = devices
    return launch.LaunchDescription([
        ExecuteProcess(cmd=[sys.executable, str(STAND_IN_ARM), arguments.get('prefix', '')],
                       output='screen'),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(LAUNCH / 'hardware.launch.py')),
            launch_arguments={**arguments, 'sensor_port': str(sensor),
                              'gripper_port': str(gripper)}.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


@launch_pytest.fixture
def with_defaults(devices: tuple[Path, Path]) -> launch.LaunchDescription:
    return arm_and_gripper(devices, **ARGUMENTS)


@launch_pytest.fixture
def with_its_own_model_in_the_root(devices: tuple[Path, Path]) -> launch.LaunchDescription:
    return arm_and_gripper(devices, robot_state_publisher='true')


def qualified(namespace: str, name: str) -> str:
    return f'{namespace.rstrip("/")}/{name}'


def names(watcher) -> list[str]:
    """Fully qualified names of every node on the graph (a name twice: two nodes)."""
    return [qualified(namespace, name)
            for name, namespace in watcher.get_node_names_and_namespaces()]


def publishers(watcher, topic: str) -> set[str]:
    return {qualified(info.node_namespace, info.node_name)
            for info in watcher.get_publishers_info_by_topic(topic)}


@pytest.mark.launch(fixture=with_defaults)
def test_the_gripper_launch_adds_nothing_the_arm_owns_and_its_view_finds_every_topic():
    graph = GRAPHS['hardware']
    view_file = node_arguments(graph.node('rviz2'), ARGUMENTS, graph)[1]
    import yaml

    wanted = view_topics(yaml.safe_load(Path(view_file).read_text(encoding='utf-8')))
    with watching('right') as watcher:
        states = watcher.wait_for_graph_active('hardware', UP)
        assert set(states.values()) == {'active'}, states
        assert wait_until(lambda: watcher.counts['joint_states'] > 5, WAIT), watcher.counts

        def topics() -> dict[str, list[str]]:
            return dict(watcher.get_topic_names_and_types())

        # every topic of the view, of RViz's type (the visualization node's arrive last)
        assert wait_until(lambda: all(kind in topics().get(topic, ())
                                      for topic, kind in wanted.items()), WAIT), \
            {topic: topics().get(topic) for topic in wanted}
        assert '/robot_description' in wanted and '/right/visualization/markers' in wanted
        # every node discovered (the graph's last ones come up after the drivers)
        assert wait_until(lambda: {'/robot_state_publisher', '/joint_state_broadcaster',
                                   '/right/gripper_driver', '/right/serial_sensor',
                                   '/right/perception', '/right/grasp_controller',
                                   '/right/visualization'} <= set(names(watcher)), WAIT), \
            sorted(names(watcher))
        assert len(names(watcher)) == len(set(names(watcher))), sorted(names(watcher))
        for topic, owners in ARM_TOPICS.items():  # (the arm's, once discovered)
            assert wait_until(lambda t=topic, o=owners: publishers(watcher, t) == o, 10.0), \
                (topic, publishers(watcher, topic))
        # the gripper's joints are in its namespace, prefixed
        assert set(watcher.joint_names) == {'right_forte_left_finger_joint',
                                            'right_forte_right_finger_joint'}


@pytest.mark.launch(fixture=with_its_own_model_in_the_root)
def test_the_checks_find_a_gripper_model_that_clashes_with_the_arms():
    with watching() as watcher:
        # every lifecycle node: a transition still under way at the end fails the launch
        states = watcher.wait_for_graph_active('hardware', UP)
        assert set(states.values()) == {'active'}, states

        assert wait_until(lambda: names(watcher).count('/robot_state_publisher') == 2, WAIT), \
            sorted(names(watcher))
        assert len(publishers(watcher, '/robot_description')) == 1   # one name, two nodes
        assert len(watcher.get_publishers_info_by_topic('/robot_description')) == 2
