"""Bags of slip lifts become labelled recordings (forte_evaluation.ros.slip_bags).

A bag written with the project's writer: 3 s of ``tactile/frames`` (20 rows per message)
with a sequence gap after 1.5 s, ``sim/ground_truth`` every 10 ms whose onset counter rises
at 2.013 s and 2.5 s, and an upward ``arm/cmd_vel`` from 1.8 s.
"""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip('rclpy')

from rclpy.serialization import serialize_message  # noqa: E402

from forte_driver.replay.bags import BagWriter, TopicSpec  # noqa: E402
from forte_evaluation.ros.slip_bags import main, recording_from_bag  # noqa: E402
from forte_perception.evaluation.labelled_recordings import load_labelled  # noqa: E402
from forte_ros.contract import CHANNEL_NAMES  # noqa: E402

T0 = 1000          # first stamp [s]
GAP_AFTER = 150    # messages before the sequence gap
ONSETS_S = (2.013, 2.5)


def stamp_of(header, seconds: float) -> None:
    whole = int(np.floor(seconds))
    header.stamp.sec = whole
    header.stamp.nanosec = int(round((seconds - whole) * 1e9))


def write_bag(path, channels=CHANNEL_NAMES, namespaces=('',)):
    """The bag of the module docstring, its topics in each of ``namespaces`` ('' = root)."""
    with BagWriter(path) as writer:
        for namespace in namespaces:
            write_lift(writer, channels, namespace)
    return path


def write_lift(writer: BagWriter, channels, namespace: str) -> None:
    """The topics of a graph in ``namespace`` (e.g. '/right') into ``writer``."""
    from geometry_msgs.msg import TwistStamped

    from forte_msgs.msg import SimGroundTruth, TactileFrames

    for name, kind in (('tactile/frames', 'forte_msgs/msg/TactileFrames'),
                       ('sim/ground_truth', 'forte_msgs/msg/SimGroundTruth'),
                       ('arm/cmd_vel', 'geometry_msgs/msg/TwistStamped')):
        writer.add_topic(TopicSpec(f'{namespace}/{name}', kind))
    for index in range(300):
        t = T0 + index * 0.01
        sequence = 20 * index + (400 if index >= GAP_AFTER else 0)   # 20 rows lost
        frames = TactileFrames(sample_count=20, sample_period=0.0005,
                               first_sequence=sequence, channel_names=list(channels))
        stamp_of(frames.header, t)
        frames.data = np.tile(np.arange(20, dtype=float)[:, None] / 1024.0 + index / 1024.0,
                              (1, 6)).ravel().tolist()
        truth = SimGroundTruth(slip_onsets=sum(t + 0.0095 >= T0 + o for o in ONSETS_S))
        stamp_of(truth.header, t + 0.0095)          # its last sample
        twist = TwistStamped()
        stamp_of(twist.header, t)
        twist.twist.linear.z = 0.001 if t >= T0 + 1.8 else 0.0
        log = int(round(t * 1e9))
        writer.write(f'{namespace}/tactile/frames', log, serialize_message(frames))
        writer.write(f'{namespace}/sim/ground_truth', log, serialize_message(truth))
        if index % 5 == 0:
            writer.write(f'{namespace}/arm/cmd_vel', log, serialize_message(twist))


def test_a_bag_becomes_a_labelled_recording(tmp_path):
    bag = write_bag(tmp_path / 'lift_3')
    rec = recording_from_bag(bag, evaluate_before_lift=0.5)
    assert rec.name == 'lift_3.npz' and rec.fs == 2000.0
    assert rec.frames.shape == (6000, 6)
    assert np.unique(rec.trial).tolist() == [0, 1]
    assert int(np.argmax(rec.trial)) == GAP_AFTER * 20        # the gap starts trial 1
    assert rec.frames[20, 0] == pytest.approx(1 / 1024)      # message order, rows in order
    # onsets at or before the truth, by less than one message (10 ms = 20 rows)
    true_rows = np.array(ONSETS_S) * 2000
    assert np.all(rec.onsets <= true_rows) and np.all(true_rows - rec.onsets < 20)
    first = int(np.argmax(rec.mask))
    assert first == pytest.approx(1.3 * 2000, abs=1) and rec.mask[first:].all()
    assert recording_from_bag(bag).mask is None


def test_the_command_and_bad_bags(tmp_path, capsys):
    write_bag(tmp_path / 'a')
    assert main([str(tmp_path / 'a'), '--output', str(tmp_path / 'rec')]) == 0
    assert '2 trial(s), 2 ground-truth onsets' in capsys.readouterr().out
    assert load_labelled(tmp_path / 'rec' / 'a.npz').onsets.size == 2
    write_bag(tmp_path / 'b', channels=list(reversed(CHANNEL_NAMES)))
    assert main([str(tmp_path / 'b'), '--output', str(tmp_path / 'rec')]) == 2
    assert 'expected' in capsys.readouterr().err
    assert main([str(tmp_path / 'missing'), '--output', str(tmp_path / 'rec')]) == 2


def assert_same_recording(rec, expected) -> None:
    assert rec.name == expected.name and rec.fs == expected.fs
    for field in ('frames', 'onsets', 'trial', 'mask'):
        np.testing.assert_array_equal(getattr(rec, field), getattr(expected, field),
                                      err_msg=field)


def test_a_namespaced_bag_gives_the_recording_of_the_root_one(tmp_path):
    """A bag of a graph with namespace:=right: its namespace is found (or given), the
    recording equals that of the same data recorded in the root namespace."""
    root = recording_from_bag(write_bag(tmp_path / 'root' / 'lift'), evaluate_before_lift=0.5)
    bag = write_bag(tmp_path / 'right' / 'lift', namespaces=('/right',))
    assert_same_recording(recording_from_bag(bag, evaluate_before_lift=0.5), root)
    assert_same_recording(recording_from_bag(bag, 0.5, namespace='right'), root)
    with pytest.raises(ValueError, match='no FORTE topics in namespace /'):
        recording_from_bag(bag, namespace='/')


def test_a_bag_of_several_namespaces_needs_one_chosen(tmp_path, capsys):
    both = write_bag(tmp_path / 'both', namespaces=('', '/right'))
    assert main([str(both), '--output', str(tmp_path / 'rec')]) == 2
    error = capsys.readouterr().err
    assert 'several namespaces (/, /right); choose one with --namespace' in error, error
    assert main([str(both), '--output', str(tmp_path / 'rec'), '--namespace', 'right']) == 0
    capsys.readouterr()
    root = recording_from_bag(write_bag(tmp_path / 'root'))
    rec = load_labelled(tmp_path / 'rec' / 'both.npz')
    np.testing.assert_array_equal(rec.frames, root.frames)
    np.testing.assert_array_equal(rec.onsets, root.onsets)
    assert main([str(both), '--output', str(tmp_path / 'rec'), '--namespace', 'x-y']) == 2
    assert 'not a valid ROS name' in capsys.readouterr().err
