"""Ground truth of the simulated scenes: label constants, per-chunk truth, slip onset labels.

Ground truth is for evaluation only: control code must never read it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forte_ros.contract import SAMPLE_RATE

# slip_type constants (same values as forte_msgs/SimGroundTruth)
SLIP_NONE = 0
SLIP_INCIPIENT = 1
SLIP_GROSS = 2
SLIP_STICK_SLIP = 3
SLIP_ROTATIONAL = 4

# object_state constants (same values as forte_msgs/SimGroundTruth)
OBJECT_NONE = 0
OBJECT_RESTING = 1
OBJECT_HELD = 2
OBJECT_DROPPED = 3
OBJECT_BROKEN = 4
OBJECT_CRUSHED = 5

_QUIET_BEFORE_ONSET = 0.1   # slip-free time before a new slip episode is labelled [s]


@dataclass
class SceneTruth:
    """Ground truth of one chunk (evaluation only; control code must never read it).

    Per-sample arrays have one row per frame of the chunk.

    Attributes
    ----------
    first_index : int
        Sample index (since the scene started) of the first frame of the chunk.
    finger_force : numpy.ndarray, shape (n, 2)
        True normal force of the left and right finger [N].
    load_cell_force : numpy.ndarray, shape (n,)
        Load cell reading [N] (calibration rig); NaN in scenes without a load cell.
    joint_position : numpy.ndarray, shape (n,)
        Actual servo angle [rad].
    lift_height : numpy.ndarray, shape (n,)
        Gripper height above the start pose [m].
    object_height : numpy.ndarray, shape (n,)
        Object height above the table [m].
    object_slip : numpy.ndarray, shape (n,)
        Object displacement downward relative to the fingers [m].
    object_rotation : numpy.ndarray, shape (n,)
        Object rotation relative to the fingers about the grasp axis [rad].
    slip_type : numpy.ndarray, shape (n,), uint8
        SLIP_* constant at each sample.
    object_state : numpy.ndarray, shape (n,), uint8
        OBJECT_* constant at each sample.
    slip_onset_indices : numpy.ndarray, shape (k,), int64
        Row indices within this chunk where a slip episode started.
    slip_onset_types : numpy.ndarray, shape (k,), uint8
        SLIP_* type of each of those onsets.
    slip_onsets : int
        Slip onsets since the scene started, including this chunk [count].
    """

    first_index: int
    finger_force: np.ndarray
    load_cell_force: np.ndarray
    joint_position: np.ndarray
    lift_height: np.ndarray
    object_height: np.ndarray
    object_slip: np.ndarray
    object_rotation: np.ndarray
    slip_type: np.ndarray
    object_state: np.ndarray
    slip_onset_indices: np.ndarray
    slip_onset_types: np.ndarray
    slip_onsets: int

    def latest(self) -> dict:
        """Values at the last sample of the chunk (the fields of SimGroundTruth).

        Returns
        -------
        dict
            finger_force (tuple of 2 floats), load_cell_force, slip_type, slip_onsets,
            object_state, lift_height, object_height, object_slip, object_rotation,
            joint_position.
        """
        return {
            'finger_force': (float(self.finger_force[-1, 0]), float(self.finger_force[-1, 1])),
            'load_cell_force': float(self.load_cell_force[-1]),
            'slip_type': int(self.slip_type[-1]),
            'slip_onsets': int(self.slip_onsets),
            'object_state': int(self.object_state[-1]),
            'lift_height': float(self.lift_height[-1]),
            'object_height': float(self.object_height[-1]),
            'object_slip': float(self.object_slip[-1]),
            'object_rotation': float(self.object_rotation[-1]),
            'joint_position': float(self.joint_position[-1]),
        }


def classify_slip(*, falling: bool, contact_lost: bool, stick_slip: bool, rotating: bool,
                  sliding: list[bool]) -> int:
    """SLIP_* type of a mechanics tick from the contact state.

    Parameters
    ----------
    falling : bool
        The object falls.
    contact_lost : bool
        The contact ran off the object (no slip label unless it falls).
    stick_slip : bool
        A stick-slip release happened in the tick or shortly before.
    rotating : bool
        Rotational slip in progress.
    sliding : list of bool
        Each finger's contact slides.
    """
    if contact_lost and not falling:
        return SLIP_NONE
    if falling:
        return SLIP_GROSS
    if stick_slip:
        return SLIP_STICK_SLIP
    if rotating:
        return SLIP_ROTATIONAL
    if sliding[0] and sliding[1]:
        return SLIP_GROSS
    if sliding[0] or sliding[1]:
        return SLIP_INCIPIENT
    return SLIP_NONE


class SlipLabels:
    """Slip type of the latest mechanics tick and the slip onsets not yet delivered.

    A slip episode's onset is labelled when slip follows at least 0.1 s without slip; it
    is placed at the first stick-slip release inside its tick (2 kHz resolution), else at
    the start of the tick.
    """

    def __init__(self) -> None:
        #: SLIP_* constant of the latest tick.
        self.slip_type = SLIP_NONE
        self._last_slip_sample = -10 ** 9
        self._onsets: list[tuple[int, int]] = []      # (sample, slip type)
        self._delivered_count = 0

    def record(self, kind: int, now: int, tick_start: int,
               events: list[tuple[int, int, float]]) -> None:
        """Label one tick.

        Parameters
        ----------
        kind : int
            SLIP_* constant of the tick.
        now : int
            Sample index of the end of the tick.
        tick_start : int
            Sample index of the start of the tick.
        events : list of (int, int, float)
            Stick-slip releases so far, (sample, finger, jumps), in time order.
        """
        if kind != SLIP_NONE:
            if now - self._last_slip_sample > _QUIET_BEFORE_ONSET * SAMPLE_RATE:
                onset = tick_start
                for sample, _, _ in reversed(events):
                    if sample < tick_start:
                        break
                    onset = sample
                self._onsets.append((onset, kind))
            self._last_slip_sample = now
        self.slip_type = kind

    def deliver(self, first: int, stop: int) -> tuple[list[tuple[int, int]], int]:
        """Hand out the onsets of samples [first, stop) and forget the older ones.

        Returns
        -------
        onsets : list of (int, int)
            (row index within the chunk, slip type) of each onset in the chunk.
        count : int
            Onsets delivered since the scene started, including these.
        """
        onsets = [(sample - first, kind) for sample, kind in self._onsets
                  if first <= sample < stop]
        self._delivered_count += len(onsets)
        self._onsets = [item for item in self._onsets if item[0] >= stop]
        return onsets, self._delivered_count


def chunk_truth(chunk: dict[str, np.ndarray], first: int, onsets: list[tuple[int, int]],
                onset_count: int) -> SceneTruth:
    """The :class:`SceneTruth` of one chunk of synthesised samples.

    Parameters
    ----------
    chunk : dict
        Per-sample arrays of the 2 kHz synthesis (:mod:`.synthesis`).
    first : int
        Sample index of the first row.
    onsets : list of (int, int)
        (row index, slip type) of the slip onsets in the chunk.
    onset_count : int
        Onsets since the scene started, including these.
    """
    return SceneTruth(
        first_index=first,
        finger_force=chunk['finger_force'],
        load_cell_force=chunk['load_cell'],
        joint_position=chunk['theta'],
        lift_height=chunk['lift'],
        object_height=chunk['height'],
        object_slip=chunk['slip'],
        object_rotation=chunk['rotation'],
        slip_type=chunk['slip_type'],
        object_state=chunk['object_state'],
        slip_onset_indices=np.array([index for index, _ in onsets], dtype=np.int64),
        slip_onset_types=np.array([kind for _, kind in onsets], dtype=np.uint8),
        slip_onsets=onset_count,
    )
