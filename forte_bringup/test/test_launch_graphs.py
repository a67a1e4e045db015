"""The three launch files run under launch_pytest: each graph comes up and does its job.

- sim: every node up, the lifecycle node ``sim`` configured and activated by the launch file
  (``/sim/get_state``), the ``real_time_factor`` argument in the sim node's parameter,
  ``tactile/frames`` and ``tactile/state`` flowing, a Grasp goal (FORTE, lift 1 cm)
  accepted and answered with a result;
- replay: a bag written by :class:`forte_driver.replay.bags.BagWriter` replayed, perception
  publishing ``tactile/state`` from it;
- hardware: an emulated sensor and simulated Dynamixel servos on pseudo-terminals, both
  lifecycle nodes ``active``, frames and joint states flowing.

Every graph also runs its visualization node (``visualization``); robot_state_publisher
only where it is installed (the topics it adds: test_visualization_live.py).

Teardown: launch_pytest shuts the launch down when the test returns. A ChangeState call
still in flight then is cancelled (an error at teardown), so every test first waits until
each lifecycle node reports the final state the launch asked for (``active``): the launch's
configure and activate calls have been answered by then.

The probe node and the helpers are in :mod:`forte_bringup.testing` (shared with the graph
tests of every package).
Needs launch_pytest and launch_ros (a ROS 2 install, or the launch kit on a bare machine);
skipped with that reason otherwise.
"""
from __future__ import annotations

from pathlib import Path

import pytest

REASON = ('launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest) or the '
          'launch kit (../shared/ros2-launch-kit); on a bare machine forte_bringup starts '
          'the same graphs (test_bringup.py)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)

import launch  # noqa: E402
from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_bringup.testing import (  # noqa: E402
    emulated_devices,
    force_model_file,
    watching,
    write_quiet_bag,
)
from forte_ros.testing import wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'
#: Longest wait for a graph to come up and for each expectation [s] (2 shared cores).
UP = 90.0
WAIT = 60.0


def include(graph: str, **arguments: str) -> launch.LaunchDescription:
    """``launch/<graph>.launch.py`` with ``arguments``, ready to test at once."""
    return launch.LaunchDescription([
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(LAUNCH / f'{graph}.launch.py')),
            launch_arguments=arguments.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


# --- sim ---------------------------------------------------------------------------------
@pytest.fixture
def force_model(tmp_path: Path) -> Path:
    return force_model_file(tmp_path / 'force_model.npz')


@launch_pytest.fixture
def sim_launch(force_model: Path) -> launch.LaunchDescription:
    # 1.25, not sim.yaml's 1.0: the node's parameter then shows the argument took effect
    # (faster than real time: the test is not about real time);
    # a raspberry: 0.25 N lifts it whatever the DDS timing (FORTE on the soda can races its
    # stick-slip: demo_scenes.py)
    return include('sim', object='raspberry', force_model=str(force_model),
                   real_time_factor='1.25')


@pytest.mark.launch(fixture=sim_launch)
def test_sim_graph_serves_a_grasp():
    from forte_msgs.action import Grasp
    from forte_msgs.msg import SimGroundTruth

    with watching() as watcher:
        assert wait_until(lambda: {'sim', 'perception', 'grasp_controller', 'visualization'}
                        <= set(watcher.get_node_names()), UP), watcher.get_node_names()
        # the launch file configures, then activates once inactive
        assert watcher.wait_for_lifecycle_state('sim', 'active', UP) == 'active'
        assert watcher.parameter('sim', 'real_time_factor') == 1.25
        assert wait_until(lambda: watcher.counts['tactile/frames'] > 50, WAIT), watcher.counts
        # the controller refuses a goal before perception is tared and joint states flow
        assert wait_until(lambda: watcher.counts['tared'] > 20, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['joint_states'] > 10, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, WAIT), watcher.counts
        goal = Grasp.Goal(controller=Grasp.Goal.FORTE, lift_distance=0.01, timeout=60.0)
        accepted, result, feedback = watcher.grasp_once_inputs_flow(goal, timeout=180.0)
        assert accepted, watcher.last_grasp_state
        assert result is not None, ('no result', watcher.last_grasp_state)
        # the claim against the simulator's ground truth (which the controller never sees)
        assert (result.outcome, watcher.truth.object_state) == (
            Grasp.Result.LIFTED, SimGroundTruth.OBJECT_HELD), (result.message, watcher.truth)
        print(f'grasp: outcome {result.outcome} ({result.message}), '
              f'{len(feedback)} feedback messages')


# --- replay ------------------------------------------------------------------------------
@pytest.fixture
def quiet_bag(tmp_path: Path) -> Path:
    return write_quiet_bag(tmp_path / 'bag', messages=2000)  # 20 s of a quiet sensor


@launch_pytest.fixture
def replay_launch(quiet_bag: Path) -> launch.LaunchDescription:
    return include('replay', bag=str(quiet_bag), rate='1.0')


@pytest.mark.launch(fixture=replay_launch)
def test_replay_graph_drives_perception_from_a_bag():
    with watching() as watcher:
        assert wait_until(lambda: watcher.counts['tactile/state'] > 20, UP), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, WAIT), watcher.counts
        # node names arrive by discovery, which may trail the data under load
        assert wait_until(lambda: {'bag_replay', 'perception', 'grasp_controller',
                                 'visualization'} <= set(watcher.get_node_names()), WAIT), \
            watcher.get_node_names()


# --- hardware ----------------------------------------------------------------------------
@pytest.fixture
def devices(tmp_path: Path):
    with emulated_devices(tmp_path) as links:
        yield links


@launch_pytest.fixture
def hardware_launch(devices: tuple[Path, Path]) -> launch.LaunchDescription:
    sensor, gripper = devices
    return include('hardware', sensor_port=str(sensor), gripper_port=str(gripper))


@pytest.mark.launch(fixture=hardware_launch)
def test_hardware_graph_on_emulated_devices():
    with watching() as watcher:
        states = watcher.wait_for_graph_active('hardware', UP)
        assert set(states.values()) == {'active'}, states
        assert wait_until(lambda: watcher.counts['tactile/frames'] > 50, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['joint_states'] > 10, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['tactile/state'] > 10, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, WAIT), watcher.counts
        assert wait_until(lambda: 'visualization' in watcher.get_node_names(), WAIT), \
            watcher.get_node_names()
