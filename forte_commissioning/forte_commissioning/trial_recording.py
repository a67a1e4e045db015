"""What the rig recorded during one trial or search: frames, load cell, joint (pure).

A :class:`RecordingBuffer` collects, from the moment a recording starts, every frame batch
(sample times = batch stamp + row x sample period), every load-cell sample and every joint
position, each with its own sample time [ns]. It notes what makes the trial unusable as it
happens (a sequence gap in the frames, a stale sensor, a non-finite reading) without ever
filling anything in; :meth:`RecordingBuffer.snapshot` returns the first ``n`` frames with
everything else, for :func:`.load_cell.align_load_cell`.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from forte_ros.contract import N_CHANNELS

__all__ = ['Recording', 'RecordingBuffer']


@dataclass(frozen=True)
class Recording:
    """A finished recording.

    Attributes
    ----------
    frame_times_ns : numpy.ndarray, shape (n,), int64
        Sample time of every frame [ns].
    frames : numpy.ndarray, shape (n, 6), float64
        Raw readings (not tared, not filtered).
    load_times_ns, load_values : numpy.ndarray, shape (m,)
        Load-cell sample times [ns] and force [N] (axis and sign applied).
    joint_times_ns, joint_positions : numpy.ndarray, shape (j,)
        Servo joint position reports [ns], [rad].
    problems : tuple of str
        What went wrong while recording (empty: nothing).
    """

    frame_times_ns: np.ndarray
    frames: np.ndarray
    load_times_ns: np.ndarray
    load_values: np.ndarray
    joint_times_ns: np.ndarray
    joint_positions: np.ndarray
    problems: tuple[str, ...] = ()

    def joint_at(self, time_ns: int) -> float:
        """Joint position at ``time_ns`` [rad], linear between reports (held at the ends).

        Raises
        ------
        ValueError
            No joint report was recorded.
        """
        if self.joint_times_ns.size == 0:
            raise ValueError('no joint_states recorded: is the gripper driver running?')
        origin = int(self.joint_times_ns[0])
        return float(np.interp((time_ns - origin) * 1e-9,
                               (self.joint_times_ns - origin) * 1e-9, self.joint_positions))


class RecordingBuffer:
    """Accumulates a recording as messages arrive (see the module docstring)."""

    def __init__(self) -> None:
        self._frames: list[np.ndarray] = []
        self._times: list[np.ndarray] = []
        self._load: list[tuple[int, float]] = []
        self._joint: list[tuple[int, float]] = []
        self.problems: list[str] = []
        self.count = 0
        self._next_sequence: int | None = None
        self.rejected_load = 0

    def add_frames(self, stamp_ns: int, first_sequence: int, sample_period: float,
                   data: np.ndarray) -> None:
        """A batch of consecutive samples, rows in order.

        Parameters
        ----------
        stamp_ns : int
            Sample time of the first row [ns].
        first_sequence : int
            Device sequence number of the first row.
        sample_period : float
            Time between rows [s].
        data : numpy.ndarray, shape (k, 6)
        """
        rows = np.asarray(data, dtype=np.float64).reshape(-1, N_CHANNELS)
        if self._next_sequence is not None and first_sequence != self._next_sequence:
            lost = first_sequence - self._next_sequence
            self.problems.append(f'frame sequence gap: {lost} sample(s) missing before '
                                 f'sample {self.count} of the recording')
        self._next_sequence = first_sequence + rows.shape[0]
        offsets = np.round(np.arange(rows.shape[0]) * sample_period * 1e9).astype(np.int64)
        self._times.append(int(stamp_ns) + offsets)
        self._frames.append(rows)
        self.count += rows.shape[0]

    def add_load(self, stamp_ns: int, value: float) -> None:
        """One load-cell sample [ns], [N]; a non-finite value is counted and left out."""
        if not math.isfinite(value):
            self.rejected_load += 1
            return
        self._load.append((int(stamp_ns), float(value)))

    def add_joint(self, stamp_ns: int, position: float) -> None:
        """One joint position report [ns], [rad]."""
        if math.isfinite(position):
            self._joint.append((int(stamp_ns), float(position)))

    def motion_start_ns(self, since_ns: int, direction: float, tolerance: float) -> int | None:
        """When the joint began to move in ``direction`` after ``since_ns`` [ns].

        Parameters
        ----------
        since_ns : int
            Sample time from which to look [ns]; the joint's reference position is its last
            report at or before it (the first report if none is).
        direction : float
            +1 for opening (the position rises), -1 for closing.
        tolerance : float
            Travel past the reference that counts as motion [rad].

        Returns
        -------
        int or None
            Sample time of the last report before the first one ``tolerance`` past the
            reference [ns] (the motion began after it); None while no report is.
        """
        reports = sorted(self._joint)
        if not reports:
            return None
        stamps = [stamp for stamp, _ in reports]
        index = max(bisect.bisect_right(stamps, since_ns) - 1, 0)
        reference = reports[index][1]
        still = reports[index][0]
        for stamp, position in reports[index + 1:]:
            if (position - reference) * direction > tolerance:
                return still
            still = stamp
        return None

    def add_problem(self, text: str) -> None:
        """Note something that makes the recording unusable."""
        self.problems.append(text)

    @property
    def last_load_time_ns(self) -> int | None:
        """Latest load-cell sample time [ns], or None before the first."""
        return max(stamp for stamp, _ in self._load) if self._load else None

    def frames_from(self, start: int) -> tuple[np.ndarray, np.ndarray]:
        """Frames ``start`` .. end: (times [ns] (k,), frames (k, 6))."""
        if not self._frames:
            return np.zeros(0, np.int64), np.zeros((0, N_CHANNELS))
        times = np.concatenate(self._times)
        frames = np.concatenate(self._frames)
        self._times, self._frames = [times], [frames]
        return times[start:], frames[start:]

    def load_from(self, start: int) -> tuple[np.ndarray, np.ndarray]:
        """Load-cell samples ``start`` .. end in arrival order: (times [ns], force [N])."""
        part = self._load[start:]
        return (np.array([stamp for stamp, _ in part], dtype=np.int64),
                np.array([value for _, value in part], dtype=np.float64))

    @property
    def load_count(self) -> int:
        """Load-cell samples so far [count]."""
        return len(self._load)

    def snapshot(self, samples: int | None = None) -> Recording:
        """The recording cut to its first ``samples`` frames (default all)."""
        times, frames = self.frames_from(0)
        if samples is not None:
            times, frames = times[:samples], frames[:samples]
        load_times, load_values = self.load_from(0)
        joint = np.array(self._joint, dtype=np.float64).reshape(-1, 2)
        return Recording(times, frames, load_times, load_values,
                         joint[:, 0].astype(np.int64), joint[:, 1], tuple(self.problems))
