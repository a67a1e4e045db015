"""Report plotting from a bag: windows, decoded series, slip onsets, figures, tables."""
from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.serialization import serialize_message

from forte_bringup.report import GraspTrace, outcome_table, plot_grasp, traces_from_bag
from forte_driver.replay.bags import BagWriter, TopicSpec
from forte_msgs.msg import ServoCommand, SimGroundTruth, TactileState

SECOND = 1_000_000_000


def stamp(message, seconds: float) -> None:
    message.header.stamp.sec = int(seconds)
    message.header.stamp.nanosec = int(round((seconds - int(seconds)) * 1e9))


def write_grasps(writer: BagWriter, namespace: str = '') -> None:
    """Two grasps of 2 s each, 1 s apart; perception at 100 Hz, truth at 50 Hz.

    The topics are those of a graph in ``namespace`` ('' = root, else e.g. '/right').
    """
    names = {name: f'{namespace}/{name}' for name in ('tactile/state', 'sim/ground_truth',
                                                    'gripper/command')}
    writer.add_topic(TopicSpec(names['tactile/state'], 'forte_msgs/msg/TactileState'))
    writer.add_topic(TopicSpec(names['sim/ground_truth'], 'forte_msgs/msg/SimGroundTruth'))
    writer.add_topic(TopicSpec(names['gripper/command'], 'forte_msgs/msg/ServoCommand'))
    for grasp, start in enumerate((10.0, 13.0)):
        for k in range(200):
            t = start + k * 0.01
            message = TactileState(force=0.01 * k + grasp, force_valid=k >= 10,
                                   slip=(k == 120))
            message.filtered = [0.001 * k * (c + 1) for c in range(6)]
            message.psd_max_db = [-60.0 + c for c in range(6)]
            message.finger_variance = [0.5 * k / 200, 3.0 if k == 120 else 0.0]
            stamp(message, t)
            writer.write(names['tactile/state'], int(t * SECOND), serialize_message(message))
        for k in range(100):
            t = start + k * 0.02
            truth = SimGroundTruth(finger_force=[0.02 * k, 0.021 * k],
                                   lift_height=0.0001 * k,
                                   slip_onsets=(1 if k >= 55 else 0) + (1 if k >= 80 else 0))
            stamp(truth, t)
            writer.write(names['sim/ground_truth'], int(t * SECOND) + 1,
                         serialize_message(truth))
        for k in range(4):
            t = start + 0.5 * k
            command = ServoCommand(position=0.4 - 0.1 * k)
            stamp(command, t)
            writer.write(names['gripper/command'], int(t * SECOND) + 2,
                         serialize_message(command))


def write_bag(path, *namespaces: str):
    """A bag of :func:`write_grasps` in each of ``namespaces`` (default: the root)."""
    with BagWriter(path) as writer:
        for namespace in namespaces or ('',):
            write_grasps(writer, namespace)
    return path


@pytest.fixture
def bag(tmp_path):
    """Two grasps of 2 s each, 1 s apart, recorded in the root namespace."""
    return write_bag(tmp_path / 'bag')


def test_traces_are_cut_by_window_and_decoded(bag):
    windows = [('a / FORTE', 10 * SECOND, 12 * SECOND), ('b / ON_OFF', 13 * SECOND,
                                                        15 * SECOND)]
    first, second = traces_from_bag(bag, windows)
    assert first.label == 'a / FORTE' and second.label == 'b / ON_OFF'
    assert first.state_time.size == 200 and second.state_time.size == 200
    np.testing.assert_allclose(first.state_time, np.arange(200) * 0.01, atol=1e-6)
    np.testing.assert_allclose(second.force, 0.01 * np.arange(200) + 1.0)
    assert first.force_valid.sum() == 190
    assert first.filtered.shape == (200, 6) and first.psd_max_db.shape == (200, 6)
    assert np.flatnonzero(first.slip).tolist() == [120]
    # the true onsets: counter rises at truth samples 55 and 80 (1.10 s and 1.60 s)
    assert first.slip_onset_times == pytest.approx([1.10, 1.60], abs=1e-6)
    assert first.true_force.shape == (100, 2) and first.lift_height[-1] == pytest.approx(0.0099)
    assert first.command.tolist() == pytest.approx([0.4, 0.3, 0.2, 0.1])
    # a window that holds nothing gives an empty trace, not an error
    (empty,) = traces_from_bag(bag, [('none', 20 * SECOND, 21 * SECOND)])
    assert empty.state_time.size == 0 and empty.slip_onset_times == []


WINDOWS = [('a / FORTE', 10 * SECOND, 12 * SECOND), ('b / ON_OFF', 13 * SECOND, 15 * SECOND)]


def assert_same_traces(traces: list[GraspTrace], expected: list[GraspTrace]) -> None:
    assert len(traces) == len(expected)
    for trace, reference in zip(traces, expected):
        for name, value in vars(reference).items():
            if isinstance(value, np.ndarray):
                np.testing.assert_array_equal(getattr(trace, name), value, err_msg=name)
            else:
                assert getattr(trace, name) == value, name


def test_a_namespaced_bag_gives_the_traces_of_the_root_one(bag, tmp_path):
    """A bag of a graph with namespace:=right: the namespace is found, the traces are the
    same as those of the same data recorded in the root namespace."""
    root = traces_from_bag(bag, WINDOWS)
    assert root[0].state_time.size == 200
    right = write_bag(tmp_path / 'right', '/right')
    assert_same_traces(traces_from_bag(right, WINDOWS), root)
    assert_same_traces(traces_from_bag(right, WINDOWS, namespace='right'), root)
    assert_same_traces(traces_from_bag(bag, WINDOWS, namespace='/'), root)
    with pytest.raises(ValueError, match=r'no FORTE topics in namespace /left.*: /right'):
        traces_from_bag(right, WINDOWS, namespace='left')


def test_a_bag_of_several_namespaces_needs_one_chosen(bag, tmp_path):
    both = write_bag(tmp_path / 'both', '', '/robot/right')
    with pytest.raises(ValueError, match=r'several namespaces \(/, /robot/right\); choose one '
                                         r'with --namespace'):
        traces_from_bag(both, WINDOWS)
    root = traces_from_bag(bag, WINDOWS)
    assert_same_traces(traces_from_bag(both, WINDOWS, namespace='/robot/right'), root)
    assert_same_traces(traces_from_bag(both, WINDOWS, namespace=''), root)


def test_plot_grasp_writes_a_png(bag, tmp_path):
    (trace,) = traces_from_bag(bag, [('a / FORTE', 10 * SECOND, 12 * SECOND)])
    trace.outcome = {'outcome': 'LIFTED', 'object_state': 'HELD', 'lift_height': 0.03}
    path = plot_grasp(trace, tmp_path / 'figures' / 'a.png')
    data = path.read_bytes()
    assert data[:8] == b'\x89PNG\r\n\x1a\n' and len(data) > 20_000
    empty = plot_grasp(GraspTrace('nothing'), tmp_path / 'empty.png')  # no data, no crash
    assert empty.read_bytes()[:4] == b'\x89PNG'


def test_outcome_table_known_row():
    table = outcome_table([{'object': 'raspberry', 'controller': 'FORTE', 'outcome': 'LIFTED',
                            'object_state': 'HELD', 'object_height': 0.0301,
                            'lift_height': 0.03, 'final_force': 0.2512, 'max_true_force': 0.31,
                            'slip_events': 2, 'tightening': math.radians(1.76),
                            'true_slip_onsets': 3, 'duration': 8.04}])
    lines = table.splitlines()
    assert len(lines) == 3
    assert lines[2] == ('| raspberry | FORTE | LIFTED | HELD | 30.1 | yes | 30.0 | 0.25 | 0.31 '
                        '| 2 | 1.76 | 3 | 8.0 |')


def test_outcome_table_prints_missing_numbers_as_n_a():
    table = outcome_table([{'object': 'soda_can', 'controller': 'FORTE', 'outcome': 'FAULT',
                            'object_state': 'HELD'}])
    cells = [cell.strip() for cell in table.splitlines()[2].strip('|').split('|')]
    assert cells == ['soda_can', 'FORTE', 'FAULT', 'HELD', 'n/a', '-', 'n/a', 'n/a', 'n/a', '',
                     'n/a', '', 'n/a']


@pytest.mark.parametrize('outcome, state, height, agrees', [
    ('LIFTED', 'RESTING', 0.0, 'NO'),          # the old controller's claim on a resting can
    ('LIFTED', 'HELD', 0.0024, 'yes'),         # slid down the fingers, but hangs: carried
    ('NOT_CARRIED', 'HELD', 0.0015, 'NO'),
    ('NOT_CARRIED', 'RESTING', 0.0, 'yes'),
    ('DROPPED', 'HELD', 0.03, 'NO'),
    ('LIFTED', 'CRUSHED', 0.03, '-'),          # the truth does not say whether it hangs
    ('NO_CONTACT', 'RESTING', 0.0, '-'),       # no claim about carrying
])
def test_outcome_table_says_whether_outcome_and_truth_agree(outcome, state, height, agrees):
    table = outcome_table([{'object': 'soda_can', 'controller': 'FORTE', 'outcome': outcome,
                            'object_state': state, 'object_height': height}])
    assert table.splitlines()[2].split(' | ')[5] == agrees
