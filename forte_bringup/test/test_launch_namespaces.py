"""Two simulated grippers on one ROS domain (issue 27), under launch_pytest.

``sim.launch.py`` twice in one launch: a plain one and one with ``namespace:=right
prefix:=right_``, neither with a ``force_model`` nor an ``object`` argument (so each
perception runs on the sim graph's default, the simulated rig's cached model, and each scene
is sim.yaml's raspberry). The test

- lists every name the two graphs use (node names; each node's publishers, subscriptions,
  services, clients, action servers and clients, read from the ROS graph before and during
  the grasps, since the controller subscribes to its inputs only during a goal) and asserts
  that the graphs share none but the ROS-wide topics (``/rosout``, ``/parameter_events``,
  ``/tf``, ``/tf_static``, ``/diagnostics``); in particular each simulation has its own
  clock (``/clock``, ``/right/clock``);
- sends a Grasp goal (FORTE, lift 1 cm) to each graph's ``grasp`` action at the
  same time and asserts that each ends LIFTED with its own ground truth
  (``sim/ground_truth`` of its namespace) HELD at the lift height: the claim is checked
  against the simulator, not the controller's belief;
- asserts the joint names of each ``joint_states`` and the frame ids of each graph's
  messages (``forte_base_link`` / ``right_forte_base_link``, arm commands in ``base_link`` /
  ``right_base_link``), the statuses on the shared ``/diagnostics`` named by node path
  (``perception: ...``, ``right/perception: ...``), and that perception was given the
  default model.

Needs launch_pytest and launch_ros (a ROS 2 install, or the launch kit on a bare machine);
skipped with that reason otherwise.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

REASON = ('launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest) or the '
          'launch kit (../shared/ros2-launch-kit); on a bare machine forte_bringup starts '
          'the same graphs (test_bringup.py)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)

import launch  # noqa: E402
from launch.actions import GroupAction, IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_bringup.testing import Watcher, watching  # noqa: E402
from forte_ros.contract import BASE_FRAME, JOINT_NAMES  # noqa: E402
from forte_ros.testing import wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'
#: Longest wait for the graphs to come up and for each expectation [s] (2 shared cores).
UP = 120.0
WAIT = 60.0
#: The only names two graphs may share.
ROS_WIDE = {'/rosout', '/parameter_events', '/tf', '/tf_static', '/diagnostics'}
NODES = ('sim', 'perception', 'grasp_controller')
#: (namespace, prefix) of the two graphs.
GRAPHS = (('', ''), ('/right', 'right_'))
#: Half real time: two simulations, two perceptions and two controllers share 2 cores.
REAL_TIME_FACTOR = '0.5'


def scoped_include(**arguments: str) -> GroupAction:
    """``launch/sim.launch.py`` with ``arguments``, its launch configurations kept apart."""
    return GroupAction([IncludeLaunchDescription(
        PythonLaunchDescriptionSource(str(LAUNCH / 'sim.launch.py')),
        launch_arguments=arguments.items())], scoped=True)


@launch_pytest.fixture
def two_grippers() -> launch.LaunchDescription:
    return launch.LaunchDescription([
        # sim.yaml's scene (the raspberry), as a user launches it
        scoped_include(real_time_factor=REAL_TIME_FACTOR),
        scoped_include(seed='1', real_time_factor=REAL_TIME_FACTOR, namespace='right',
                       prefix='right_'),
        launch_pytest.actions.ReadyToTest(),
    ])


def graph_names(probe: Watcher, namespace: str) -> set[str]:
    """Every name the graph's nodes in ``namespace`` use now (empty set: not all visible).

    Node names (fully qualified), each node's publishers, subscriptions, services, clients,
    action servers and action clients.
    """
    from rclpy.action.graph import (
        get_action_client_names_and_types_by_node,
        get_action_server_names_and_types_by_node,
    )

    node_namespace = namespace or '/'
    names: set[str] = set()
    try:
        for node in NODES:
            names.add(f'{namespace}/{node}')
            for query in (probe.get_publisher_names_and_types_by_node,
                          probe.get_subscriber_names_and_types_by_node,
                          probe.get_service_names_and_types_by_node,
                          probe.get_client_names_and_types_by_node):
                names.update(name for name, _ in query(node, node_namespace))
            for query in (get_action_server_names_and_types_by_node,
                          get_action_client_names_and_types_by_node):
                names.update(name for name, _ in query(probe, node, node_namespace))
    except Exception:  # noqa: BLE001  a node not discovered yet (NodeNameNonExistentError)
        return set()
    return names


def watch_frames(probe: Watcher) -> dict[str, str]:
    """Also record the frame ids of ``gripper/command`` and ``arm/cmd_vel`` on ``probe``."""
    from geometry_msgs.msg import TwistStamped

    from forte_msgs.msg import ServoCommand
    from forte_ros import qos

    frames: dict[str, str] = {}
    for topic, kind in (('gripper/command', ServoCommand), ('arm/cmd_vel', TwistStamped)):
        probe.create_subscription(
            kind, topic, lambda message, topic=topic: frames.__setitem__(
                topic, message.header.frame_id), qos.COMMANDS)
    return frames


def grasp_in_thread(probe: Watcher, results: dict[str, Any], key: str) -> threading.Thread:
    """Send a FORTE Grasp goal (lift 1 cm) from a thread; the answer lands in results[key]."""
    from forte_msgs.action import Grasp

    def run() -> None:
        goal = Grasp.Goal(controller=Grasp.Goal.FORTE, lift_distance=0.01, timeout=90.0)
        try:
            results[key] = probe.grasp_once_inputs_flow(goal, timeout=240.0)
        except Exception as error:  # noqa: BLE001  reported by the test, not lost in the thread
            results[key] = error

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.launch(fixture=two_grippers)
def test_two_namespaced_sim_grippers_share_only_ros_wide_names_and_both_lift():
    from forte_evaluation.sim_force_model import force_model_path
    from forte_msgs.action import Grasp
    from forte_msgs.msg import SimGroundTruth

    with watching() as left, watching('right') as right:
        probes = (left, right)
        for probe in probes:
            # the launch file configures, then activates once inactive
            assert probe.wait_for_lifecycle_state('sim', 'active', UP) == 'active'
            assert wait_until(lambda p=probe: p.counts['tared'] > 20, WAIT), probe.counts
            assert wait_until(lambda p=probe: p.counts['joint_states'] > 10, WAIT), probe.counts
            assert wait_until(lambda p=probe: p.counts['grasp/state'] >= 1, WAIT), probe.counts
            assert wait_until(lambda p=probe: p.truth is not None, WAIT)
            # no force_model argument: the sim graph's default, the simulated rig's model
            assert probe.parameter('perception', 'model_path') == str(force_model_path())
        # /diagnostics is shared: each status names its node with the namespace
        for node in ('sim', 'perception', 'grasp_controller'):
            for namespace, _ in GRAPHS:
                path = f'{namespace}/{node}'.lstrip('/')
                assert wait_until(lambda p=path: any(name.startswith(f'{p}: ')
                                                   for name in left.statuses), WAIT), path
        commands = [watch_frames(probe) for probe in probes]
        seen: list[set[str]] = [set(), set()]
        for index, (namespace, _) in enumerate(GRAPHS):
            assert wait_until(lambda i=index, n=namespace: seen[i].update(
                graph_names(left, n)) or bool(seen[i]), WAIT), namespace
        results: dict[str, Any] = {}
        started = time.monotonic()
        threads = [grasp_in_thread(probe, results, namespace or '/')
                   for probe, (namespace, _) in zip(probes, GRAPHS, strict=True)]
        while any(thread.is_alive() for thread in threads):
            for index, (namespace, _) in enumerate(GRAPHS):  # the controllers' inputs
                seen[index] |= graph_names(left, namespace)
            time.sleep(0.5)
        print(f'two concurrent grasps: {time.monotonic() - started:.1f} s')

        # names: nothing shared but the ROS-wide topics; a clock each
        names_left, names_right = seen
        assert names_left & names_right <= ROS_WIDE, sorted(names_left & names_right - ROS_WIDE)
        print(f'names: {len(names_left)} and {len(names_right)}, shared: '
              f'{sorted(names_left & names_right)}')
        assert {'/sim', '/perception', '/grasp_controller', '/clock'} <= names_left
        assert {'/right/sim', '/right/perception', '/right/grasp_controller', '/right/clock',
                '/right/grasp', '/right/tactile/state', '/right/joint_states'} <= names_right
        assert '/clock' not in names_right

        # each grasp LIFTED, by its own ground truth (the controller never sees it)
        for probe, (namespace, _) in zip(probes, GRAPHS, strict=True):
            answer = results[namespace or '/']
            assert not isinstance(answer, Exception), (namespace, repr(answer))
            accepted, result, _ = answer
            assert accepted and result is not None, (namespace, probe.last_grasp_state)
            truth = probe.truth
            assert (result.outcome, truth.object_state) == (
                Grasp.Result.LIFTED, SimGroundTruth.OBJECT_HELD), (namespace, result.message,
                                                                   truth)
            assert truth.object_height == pytest.approx(0.01, abs=0.003), namespace
            print(f'{namespace or "/"}: outcome {result.outcome} ({result.message}); ground '
                  f'truth {truth.object_state} at {truth.object_height * 1000:.1f} mm')

        # joint names and frame ids carry each graph's prefix
        for probe, frames, (namespace, prefix) in zip(probes, commands, GRAPHS, strict=True):
            assert probe.joint_names == [prefix + name for name in JOINT_NAMES], namespace
            for topic in ('tactile/frames', 'tactile/state', 'grasp/state', 'sim/ground_truth'):
                assert probe.frame_ids[topic] == prefix + BASE_FRAME, (namespace, topic)
            assert frames == {'gripper/command': prefix + BASE_FRAME,
                              'arm/cmd_vel': prefix + 'base_link'}, namespace
