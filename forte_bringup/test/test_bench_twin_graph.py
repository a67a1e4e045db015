"""hardware.launch.py on the bench twin: the real serial and gripper drivers grasp a
simulated object through the real protocol, the real dynamixel-sdk and two ptys.

The bench twin node (forte_sim) plays both devices, coupled through one scene, and the
robot arm (``arm/cmd_vel``); the graph is ``hardware.launch.py`` as on a robot, with the
simulated rig's force model and the freshness bounds relaxed for a shared 2-core machine
(:data:`FRESHNESS`). Each claim is checked against the
scene's ground truth, which no node of the graph sees.

Needs launch_pytest and launch_ros (the launch kit on a bare machine); skipped with that
reason otherwise.
"""
from __future__ import annotations

from pathlib import Path

import pytest

REASON = ('launch_pytest / launch_ros need a ROS 2 install (ros-jazzy-launch-pytest) or the '
          'launch kit (../shared/ros2-launch-kit)')
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)

import launch  # noqa: E402
import yaml  # noqa: E402
from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402

from forte_bringup.graph import params_file  # noqa: E402
from forte_bringup.testing import bench_twin, force_model_file, watching  # noqa: E402
from forte_ros.testing import wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch' / 'hardware.launch.py'
UP = 90.0
WAIT = 60.0
#: Object -> (seed, lift of the Grasp goal [m]); the first seed of each object. The soda
#: can needs a long lift (the closed loop's 30 mm; 50 mm here, see LIFT_SPEED): FORTE
#: catches the sliding can within it (deterministic closed loop, seeds 0, 1, 13: LIFTED /
#: HELD, the can 17-18 mm up; with 10 mm the fingers slide along a can that stays on the
#: table). The raspberry is lifted 10 mm, as in the
#: sim graph's launch test: on a loaded machine a 30 mm lift of the twin's raspberry can
#: end CRUSHED by false gross-slip tightenings (the finger levels' difference drifts past
#: the balance tolerance after 19-27 mm of lift), an open finding (docs/simulation.md).
GRASPS = {'soda_can': (0, 0.05), 'raspberry': (0, 0.01)}
#: Object height above the table that counts as carried [m] (the closed loop's success).
CARRIED_HEIGHT = 0.005
#: Lift speed of the bench grasps [m/s]: 2 mm/s instead of the controller's 5 mm/s. On the
#: shared 2-core machine the twin (a Python board at 2 kHz, the servo bus, the scene) and
#: the four graph nodes load both cores; perception then loses best-effort messages (input
#: gaps restart its slip detector) and the board skips scans, and at 5 mm/s the can slid
#: 24-30 mm before FORTE's tightening caught it (CI 2026-11-26: not carried, 1 of 2 runs
#: under a busy-loop beside it: 3 mm up); the slower lift leaves the same reaction time
#: per millimetre of slip as a robot's dedicated computer would. A fresh-clone CI run still
#: saw the can slide 26 mm at 2 mm/s (HELD, 2.2 mm up after a 30 mm lift): the can's lift is
#: 50 mm, so that the object ends carried clear of the table after such a catch.
LIFT_SPEED = 0.002


#: The controller's freshness bounds on the bench [s]: the hardware graph runs on the wall
#: clock, and on a shared 2-core machine (the twin, four graph nodes, this test, maybe a
#: benchmark) perception can trail the sensor by far more than a robot's 0.1 s; measured
#: here with one 2-process benchmark beside: faults at 0.5 s (STALE_PERCEPTION). 1.0 s is
#: the largest bound the controller accepts (forte_control.parameters.HARD_MAX_FRESHNESS).
FRESHNESS = 1.0


#: Grip force cap of the bench grasps [N]: the controller's default (the top of the force
#: model's range). hardware.yaml's 6 N stops FORTE's slip tightening on the soda can
#: (measured: FAULT FORCE_LIMIT at an estimate of 6.13 N, seed 0), docs/simulation.md.
MAX_FORCE = 8.0


def relaxed_parameters(path: Path) -> Path:
    """hardware.yaml with the controller's freshness bounds at :data:`FRESHNESS` and the
    force cap at :data:`MAX_FORCE`."""
    document = yaml.safe_load(params_file('hardware').read_text())
    controller = document['grasp_controller']['ros__parameters']
    controller.update(perception_timeout=FRESHNESS, joint_state_timeout=FRESHNESS,
                      invalid_input_timeout=FRESHNESS, max_force=MAX_FORCE)
    path.write_text(yaml.safe_dump(document))
    return path


@pytest.fixture(params=sorted(GRASPS))
def grasp_object(request) -> str:
    return request.param


@pytest.fixture
def twin(grasp_object: str, tmp_path: Path):
    with bench_twin(tmp_path, grasp_object, GRASPS[grasp_object][0]) as links:
        yield links


@launch_pytest.fixture
def hardware_on_twin(twin: tuple[Path, Path], tmp_path: Path) -> launch.LaunchDescription:
    sensor, gripper = twin
    arguments = {'sensor_port': str(sensor), 'gripper_port': str(gripper),
                 'force_model': str(force_model_file(tmp_path / 'force_model.npz')),
                 'params_file': str(relaxed_parameters(tmp_path / 'hardware.yaml'))}
    return launch.LaunchDescription([
        IncludeLaunchDescription(PythonLaunchDescriptionSource(str(LAUNCH)),
                                 launch_arguments=arguments.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


@pytest.mark.launch(fixture=hardware_on_twin)
def test_a_forte_grasp_on_the_bench_twin_holds_the_object(grasp_object: str):
    from forte_msgs.action import Grasp
    from forte_msgs.msg import SimGroundTruth

    with watching() as watcher:
        states = watcher.wait_for_graph_active('hardware', UP)
        assert set(states.values()) == {'active'}, states
        assert wait_until(lambda: watcher.counts['tared'] > 20, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['joint_states'] > 10, WAIT), watcher.counts
        assert wait_until(lambda: watcher.counts['grasp/state'] >= 1, WAIT), watcher.counts
        assert wait_until(lambda: watcher.truth is not None, WAIT)
        assert watcher.truth.object_state == SimGroundTruth.OBJECT_RESTING
        goal = Grasp.Goal(controller=Grasp.Goal.FORTE, lift_distance=GRASPS[grasp_object][1],
                          lift_speed=LIFT_SPEED, timeout=90.0)
        accepted, result, feedback = watcher.grasp_once_inputs_flow(goal, timeout=180.0)
        assert accepted, watcher.last_grasp_state
        assert result is not None, ('no result', watcher.last_grasp_state)
        # the claim against the scene's ground truth (which the controller never sees): the
        # object hangs from the fingers, carried clear of the table
        truth = watcher.truth
        link = {key: value for key, value in
                watcher.status_values('perception: pipeline').items()
                if key in ('input gaps', 'lost samples', 'sequence gaps', 'messages',
                           'processing p99 [us]', 'driver dropped frames')}
        assert truth.object_state == SimGroundTruth.OBJECT_HELD, (result, truth, link)
        assert truth.object_height > CARRIED_HEIGHT, (result, truth)
        # the controller's own verdict is reported, not trusted; a fault is a failure of the
        # graph on the twin
        assert result.outcome in (Grasp.Result.LIFTED, Grasp.Result.NOT_CARRIED), result
        # model identity: the board identified itself (IDENTIFY through the real driver) and
        # perception flags the simulator-trained model as another device's (a WARN)
        values = watcher.status_values('perception: pipeline')
        assert values['model trained on device'] == 'simulator', values
        assert len(values['sensor device']) == 16 and values['sensor firmware'], values
        print(f'perception input: {link}')
        print(f'{watcher.truth.object_name} {truth.object_height * 1e3:.1f} mm up: outcome '
              f'{result.outcome} ({result.message}), '
              f'{len(feedback)} feedback messages, lift {watcher.truth.lift_height:.4f} m')
