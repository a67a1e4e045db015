"""Bags of slip lifts -> labelled recordings that ``forte_tune_slip`` sweeps.

On a graph (simulated or real), the slip characterisation lifts
(:mod:`forte_commissioning.ros.slip_lift_node`) are recorded with ``record:=true``; this
module turns each bag into the labelled recording format of
:mod:`forte_perception.evaluation.labelled_recordings`::

    python -m forte_evaluation.ros.slip_bags out/bags/lift_* --output out/slip_rec
    ros2 run forte_commissioning forte_tune_slip out/slip_rec/*.npz --labels onsets.csv

- **frames**: the ``tactile/frames`` messages in device sequence order, rows concatenated
  (channel order checked against the contract). A sequence gap (dropped frames, a driver
  restart) starts a new *trial*, which the sweep runs through a fresh detector.
- **onsets**: in a simulator bag, every rise of ``sim/ground_truth``'s ``slip_onsets``
  counter, placed at the first row after the previous ground-truth message (whose stamp is
  its last sample): at or before the true onset, by less than one message (10 ms), so
  latencies come out that much long rather than short; otherwise none, and the onsets come
  from a CSV label file (:mod:`forte_perception.evaluation.onset_labels`) whose
  ``onset_s`` counts from the bag's first tactile row (the recording's row 0), named after
  the bag folder.
- **mask**: with ``--evaluate-before-lift S``, flags count from S seconds before the first
  upward ``arm/cmd_vel`` command on (the lift, as the paper evaluates); all rows otherwise.

A bag of a namespaced graph (``namespace:=right``: ``/right/tactile/frames``, ...) is read in
its namespace: ``--namespace right`` (``/`` for the root), or by default the only namespace
whose topics the bag holds; a bag holding several is refused with the list
(:mod:`forte_driver.replay.bag_namespace`).
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from forte_driver.replay.bag_namespace import namespace_label, read_namespaced
from forte_perception.evaluation.labelled_recordings import LabelledRecording, save_labelled
from forte_ros.contract import CHANNEL_NAMES, stamp_seconds

__all__ = ['main', 'recording_from_bag']

#: Topics read, relative to the namespace of the graph that recorded the bag.
_TOPICS = ('tactile/frames', 'sim/ground_truth', 'arm/cmd_vel')


def _stamp(message) -> float:
    return stamp_seconds(message.header.stamp)


def _read(bag: Path, namespace: str | None) -> tuple[str, dict[str, list]]:
    """The namespace read and the decoded messages of :data:`_TOPICS` in it."""
    from geometry_msgs.msg import TwistStamped
    from rclpy.serialization import deserialize_message

    from forte_msgs.msg import SimGroundTruth, TactileFrames

    classes = dict(zip(_TOPICS, (TactileFrames, SimGroundTruth, TwistStamped), strict=True))
    namespace, raw = read_namespaced(bag, _TOPICS, namespace)
    return namespace, {name: [deserialize_message(message.data, classes[name])
                              for message in messages] for name, messages in raw.items()}


def _frames(messages: list, bag: Path, namespace: str = ''
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Rows (n, 6), trial ids (n,), sample times (n,) [s], sample period [s]."""
    if not messages:
        raise ValueError(f'{bag}: no tactile/frames messages in namespace '
                         f'{namespace_label(namespace)}')
    messages = sorted(messages, key=lambda m: m.first_sequence)
    period = float(messages[0].sample_period)
    rows, trials, times, trial, expected = [], [], [], 0, None
    for m in messages:
        if list(m.channel_names) != list(CHANNEL_NAMES):
            raise ValueError(f'{bag}: channels {list(m.channel_names)}, expected '
                             f'{list(CHANNEL_NAMES)}')
        if m.sample_period != period:
            raise ValueError(f'{bag}: sample period changes ({m.sample_period} s)')
        if expected is not None and m.first_sequence != expected:
            trial += 1
        count = int(m.sample_count)
        rows.append(np.asarray(m.data, np.float64).reshape(count, len(CHANNEL_NAMES)))
        trials.append(np.full(count, trial, np.int64))
        times.append(_stamp(m) + period * np.arange(count))
        expected = m.first_sequence + count
    return np.vstack(rows), np.concatenate(trials), np.concatenate(times), period


def _truth_onsets(truths: list, times: np.ndarray) -> np.ndarray:
    """Rows of the rises of the ground truth's onset counter (module docstring)."""
    if not truths:
        return np.zeros(0, np.int64)
    truths = sorted(truths, key=_stamp)
    counts = np.array([m.slip_onsets for m in truths], np.int64)
    stamps = np.array([_stamp(m) for m in truths])
    rises = np.flatnonzero(np.diff(counts) > 0) + 1     # message that first counts it
    rows = np.searchsorted(times, stamps[rises - 1], side='right')
    return np.clip(rows, 0, times.size - 1).astype(np.int64)


def recording_from_bag(bag: str | Path, evaluate_before_lift: float | None = None,
                       namespace: str | None = None) -> LabelledRecording:
    """The labelled recording of one bag (module docstring); named ``<bag folder>.npz``.

    Parameters
    ----------
    bag : str or Path
        rosbag2 folder or ``.mcap`` file.
    evaluate_before_lift : float, optional
        Mask: flags count from this long before the first upward arm command [s]; None:
        every row counts.
    namespace : str, optional
        Namespace of the graph that recorded the bag (``right``, ``/right``; ``/`` for the
        root); None: the only one whose topics the bag holds.

    Raises
    ------
    ValueError
        No tactile frames, channels not in the contract order, a changing sample period, a
        lift asked for and none found, or the topics of several namespaces and none given
        (:func:`forte_driver.replay.bag_namespace.choose_namespace`).
    """
    bag = Path(bag)
    namespace, found = _read(bag, namespace)
    frames, trial, times, period = _frames(found['tactile/frames'], bag, namespace)
    onsets = _truth_onsets(found['sim/ground_truth'], times)
    mask = None
    if evaluate_before_lift is not None:
        lifts = [_stamp(m) for m in found['arm/cmd_vel'] if m.twist.linear.z > 0.0]
        if not lifts:
            raise ValueError(f'{bag}: no upward arm/cmd_vel command (no lift to evaluate)')
        mask = times >= min(lifts) - evaluate_before_lift
    return LabelledRecording(frames, 1.0 / period, onsets, trial, False,
                             f'{bag.name.removesuffix(".mcap")}.npz', mask)


def main(argv: Sequence[str] | None = None) -> int:
    """Convert bags; exit 0, or 2 with the reason on stderr."""
    parser = argparse.ArgumentParser(prog='python -m forte_evaluation.ros.slip_bags',
                                     description=__doc__.split('\n')[0])
    parser.add_argument('bags', nargs='+', help='rosbag2 folders or .mcap files')
    parser.add_argument('--output', type=Path, default=Path('out/slip_recordings'))
    parser.add_argument('--evaluate-before-lift', type=float, default=None,
                        help='flags count from this long before the lift starts [s]')
    parser.add_argument('--namespace', default=None,
                        help='namespace of the graph that recorded the bags, e.g. right '
                             '(/ = root; default: the only one whose FORTE topics a bag '
                             'holds)')
    args = parser.parse_args(argv)
    args.output.mkdir(parents=True, exist_ok=True)
    for bag in args.bags:
        try:
            rec = recording_from_bag(bag, args.evaluate_before_lift, args.namespace)
        except (OSError, RuntimeError, ValueError) as exc:
            print(f'slip_bags: {exc}', file=sys.stderr)
            return 2
        save_labelled(args.output / rec.name, rec)
        print(f'{bag}: {rec.frames.shape[0]} rows ({rec.frames.shape[0] / rec.fs:.1f} s), '
              f'{int(rec.trial.max()) + 1} trial(s), {rec.onsets.size} ground-truth onsets '
              f'-> {args.output / rec.name}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
