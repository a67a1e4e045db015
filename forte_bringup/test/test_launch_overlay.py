"""The ``params_overlay`` launch argument: a second parameter YAML over the graph's own.

- every launch file declares it (typed as a file path, described, default '' = none);
- the nodes the overlay names get it after ``params_file`` (so it overrides the YAML) and
  before the argument parameters; the others do not; a bad overlay stops the launch with
  the reason;
- under launch_pytest, the replay graph's perception node comes up with the overlay's slip
  setting (written by the slip tuning's :func:`write_overlay`).

Needs launch / launch_ros (and launch_pytest for the last test): a ROS 2 install or the
launch kit; skipped with that reason otherwise.
"""
from __future__ import annotations

from pathlib import Path

import pytest

REASON = ('launch / launch_ros / launch_pytest need a ROS 2 install (or the launch kit, '
          '../shared/ros2-launch-kit); forte_bringup starts the same graphs (test_bringup.py)')
launch = pytest.importorskip('launch', reason=REASON)
pytest.importorskip('launch_ros', reason=REASON)
launch_pytest = pytest.importorskip('launch_pytest', reason=REASON)

from launch.actions import IncludeLaunchDescription  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402
from launch_ros.actions import Node  # noqa: E402

from forte_bringup.graph import GRAPHS, overlay_nodes  # noqa: E402
from forte_bringup.testing import watching, write_quiet_bag  # noqa: E402
from forte_perception.evaluation.threshold_sweep import write_overlay  # noqa: E402
from forte_perception.slip.params import SlipParams  # noqa: E402
from forte_ros.testing import launch_file_actions, launch_file_description, wait_until  # noqa: E402

LAUNCH = Path(__file__).resolve().parents[1] / 'launch'
TUNED = SlipParams(mode='paper', threshold=1.5)
UP = 90.0


def node_parameters(graph: str, **arguments: str) -> dict[str, list]:
    """Node name -> the ``parameters`` list its launch_ros Node gets (nothing started)."""
    _, actions = launch_file_actions(LAUNCH / f'{graph}.launch.py', **arguments)
    found = {}
    for action in actions:
        if isinstance(action, Node) and action.node_executable != 'forte_record':
            found[as_text(action._Node__node_name)] = action._Node__parameters
    return found


def as_text(entry) -> str:
    """A name or parameters entry (text, substitutions, or a dict of them) as text."""
    if isinstance(entry, str):
        return entry
    if isinstance(entry, dict):
        return repr({as_text(k): v for k, v in entry.items()})
    if hasattr(entry, 'param_file'):                  # launch_ros ParameterFile
        entry = entry.param_file
    parts = entry if isinstance(entry, (list, tuple)) else [entry]
    return ''.join(p.perform(launch.LaunchContext()) if hasattr(p, 'perform') else str(p)
                   for p in parts)


@pytest.fixture
def overlay_file(tmp_path: Path) -> Path:
    path = tmp_path / 'slip_overlay.yaml'
    write_overlay(path, TUNED, 'test overlay')
    return path


@pytest.mark.parametrize('graph', sorted(GRAPHS))
def test_every_launch_file_declares_the_overlay(graph: str):
    (argument,) = [a for a in launch_file_description(LAUNCH / f'{graph}.launch.py')
                   .get_launch_arguments()
                   if a.name == 'params_overlay']
    assert argument.default_value[0].perform(launch.LaunchContext()) == ''
    assert 'params_file' in argument.description and len(argument.description) > 40


def test_the_overlay_reaches_the_nodes_it_names(overlay_file: Path, tmp_path: Path):
    bag = str(tmp_path / 'bag')
    without = node_parameters('replay', bag=bag)
    assert all(len(p) >= 1 for p in without.values())
    params = node_parameters('replay', bag=bag, params_overlay=str(overlay_file),
                             force_model='/tmp/model.npz')
    perception = [as_text(p) for p in params['perception']]
    assert perception[0].endswith('replay.yaml') and perception[1] == str(overlay_file)
    assert 'model_path' in perception[2]            # argument parameters still come last
    assert str(overlay_file) not in [as_text(p) for p in params['grasp_controller']]
    assert str(overlay_file) not in [as_text(p) for p in params['bag_replay']]


@pytest.mark.parametrize('text, words', [
    ('perceptoin:\n  ros__parameters: {slip_threshold: 1.0}\n', "no node 'perceptoin'"),
    ('perception:\n  slip_threshold: 1.0\n', 'ros__parameters mapping'),
    ('- 1\n- 2\n', 'expected node_name'),
    ('perception: [\n', 'cannot read it'),
])
def test_a_bad_overlay_is_refused(tmp_path: Path, text: str, words: str):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ValueError, match='params_overlay') as error:
        overlay_nodes(str(path), GRAPHS['sim'])
    assert words in str(error.value)
    with pytest.raises(ValueError, match='cannot read'):
        overlay_nodes(str(tmp_path / 'missing.yaml'), GRAPHS['sim'])


@pytest.fixture
def quiet_bag(tmp_path: Path) -> Path:
    return write_quiet_bag(tmp_path / 'bag', messages=1000)


@launch_pytest.fixture
def replay_with_overlay(quiet_bag: Path, overlay_file: Path) -> launch.LaunchDescription:
    return launch.LaunchDescription([
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(LAUNCH / 'replay.launch.py')),
            launch_arguments={'bag': str(quiet_bag), 'rate': '1.0',
                              'params_overlay': str(overlay_file)}.items()),
        launch_pytest.actions.ReadyToTest(),
    ])


@pytest.mark.launch(fixture=replay_with_overlay)
def test_perception_comes_up_with_the_overlay_setting():
    with watching() as watcher:
        assert wait_until(lambda: 'perception' in set(watcher.get_node_names()), UP), \
            watcher.get_node_names()
        assert wait_until(lambda: watcher.parameter('perception', 'slip_threshold') is not None,
                        UP)
        assert watcher.parameter('perception', 'slip_threshold') == 1.5
        assert watcher.parameter('perception', 'slip_mode') == 'paper'
        # replay.yaml's own values that the overlay does not name stay in force
        assert watcher.parameter('perception', 'slip_window') == 400
        assert wait_until(lambda: watcher.counts['tactile/state'] > 5, UP), watcher.counts
