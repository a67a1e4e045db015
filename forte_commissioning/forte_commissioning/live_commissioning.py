"""The live commissioning run without ROS: its schedule, its recorder, its outputs.

:class:`CommissioningSchedule` turns the protocol (:func:`.commission.protocol`) into timed
actions (start a phase, prompt the operator or ask the bench twin to press, close the
gripper on the indentor, open it); :class:`FrameRecorder` keeps the received readings
with their sequence numbers and the driver's counters; :func:`write_outputs` judges the
recording and writes ``report.txt``, ``report.png`` and ``recording.npz``. The ROS node
(:mod:`forte_commissioning.ros.commission_node`) only feeds them messages and the clock.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forte_commissioning.commissioning_figure import draw_figure
from forte_commissioning.sensor_checks import (
    DEFAULT_LIMITS,
    CommissioningLimits,
    CommissioningRecording,
    CommissioningResult,
    LinkStatistics,
    Phase,
    evaluate,
    text_report,
)
from forte_commissioning.simulated_commissioning import ProtocolStep
from forte_ros.contract import FINGER_NAMES, N_CHANNELS

__all__ = ['Action', 'CommissioningSchedule', 'FrameRecorder', 'write_outputs']


@dataclass(frozen=True)
class Action:
    """What the run must do now.

    Attributes
    ----------
    kind : str
        ``'phase'`` (a step starts: mark its boundary), ``'prompt'`` (tell the operator
        ``text``), ``'press'`` (headless: have the bench twin press ``step``),
        ``'squeeze'`` (close the gripper on the indentor), ``'open'`` (open it again),
        ``'done'`` (the protocol is over).
    step : ProtocolStep or None
    text : str
    """

    kind: str
    step: ProtocolStep | None = None
    text: str = ''


class CommissioningSchedule:
    """The protocol's steps on a clock.

    Parameters
    ----------
    steps : list of ProtocolStep
    headless : bool
        True: the bench twin presses (``press`` actions); False: the operator is prompted.
    """

    def __init__(self, steps: list[ProtocolStep], headless: bool) -> None:
        self.steps = list(steps)
        self.headless = headless
        self._start: float | None = None
        self._next = 0
        ends = np.cumsum([step.duration for step in self.steps])
        self._starts = np.concatenate(([0.0], ends[:-1]))
        self.duration = float(ends[-1]) if len(ends) else 0.0
        self.finished = False

    def start(self, now: float) -> None:
        """Start the protocol at time ``now`` [s]."""
        self._start = now

    @property
    def started(self) -> bool:
        """True once :meth:`start` was called."""
        return self._start is not None

    def advance(self, now: float) -> list[Action]:
        """Every action due by ``now`` [s] (empty before :meth:`start`)."""
        if self._start is None or self.finished:
            return []
        actions = []
        elapsed = now - self._start
        while self._next < len(self.steps) and self._starts[self._next] <= elapsed:
            step = self.steps[self._next]
            following = self.steps[self._next + 1] if self._next + 1 < len(self.steps) else None
            actions += self._actions(step, following)
            self._next += 1
        if self._next == len(self.steps) and elapsed >= self.duration:
            self.finished = True
            actions.append(Action('done'))
        return actions

    def _actions(self, step: ProtocolStep, following: ProtocolStep | None) -> list[Action]:
        actions = [Action('phase', step)]
        if step.kind == 'press':
            where = f'the {FINGER_NAMES[step.finger].upper()} finger at its {step.place.upper()}'
            actions.append(Action('press', step) if self.headless else Action(
                'prompt', step, f'PRESS {where} now and hold it ({step.duration:.0f} s)'))
        elif step.kind == 'squeeze':
            actions.append(Action('squeeze', step))
            actions.append(Action('prompt', step, f'closing on the indentor, holding '
                                  f'{step.duration:.0f} s: keep hands off'))
        elif step.name == 'rest_end':
            actions.append(Action('open', step))
        elif following is not None and following.kind == 'press' and not self.headless:
            actions.append(Action('prompt', step, 'release; next: the '
                                  f'{FINGER_NAMES[following.finger]} finger at its '
                                  f'{following.place}'))
        elif following is not None and following.kind == 'squeeze' and not self.headless:
            actions.append(Action('prompt', step, 'release; next: the gripper closes on the '
                                  'indentor'))
        return actions


class FrameRecorder:
    """Readings as they arrive (batches of consecutive rows) and the driver's counters."""

    def __init__(self) -> None:
        self._frames: list[np.ndarray] = []
        self._sequences: list[np.ndarray] = []
        self._first: tuple[int, int, int, int, float] | None = None
        self._last: tuple[int, int, int, int, float] | None = None
        self.received = 0

    @property
    def next_sequence(self) -> int:
        """Sequence number of the next row expected (0 before any)."""
        if not self._sequences:
            return 0
        return int(self._sequences[-1][-1]) + 1

    def add(self, data: np.ndarray, first_sequence: int, device_time_us: int,
            dropped: int, corrupt: int, wall_time: float) -> None:
        """One batch: ``data`` (n, 6) normalised rows starting at ``first_sequence``,
        the device time of its first row [us], the driver's cumulative counters, the wall
        time of arrival [s]. Rows not after the last recorded one are ignored."""
        data = np.asarray(data, dtype=np.float64).reshape(-1, N_CHANNELS)
        sequence = first_sequence + np.arange(len(data), dtype=np.int64)
        keep = sequence >= self.next_sequence
        if not keep.any():
            return
        self._frames.append(data[keep])
        self._sequences.append(sequence[keep])
        self.received += int(keep.sum())
        entry = (int(first_sequence), int(device_time_us), int(dropped), int(corrupt),
                 float(wall_time))
        if self._first is None:
            self._first = entry
        self._last = entry

    def link(self) -> LinkStatistics:
        """The link statistics of what was recorded."""
        if self._first is None or self._last is None:
            return LinkStatistics(0, 0, 0, 0.0)
        first, last = self._first, self._last
        return LinkStatistics(self.received, first[0], last[0], (last[1] - first[1]) * 1e-6,
                              last[2] - first[2], last[3] - first[3], last[4] - first[4])

    def recording(self, phases: list[Phase]) -> CommissioningRecording:
        """The recording with ``phases``."""
        frames = (np.concatenate(self._frames) if self._frames
                  else np.zeros((0, N_CHANNELS)))
        sequence = (np.concatenate(self._sequences) if self._sequences
                    else np.zeros(0, np.int64))
        return CommissioningRecording(frames, sequence, phases, self.link())


def phases_from_boundaries(steps: list[ProtocolStep], boundaries: list[int],
                           end: int) -> list[Phase]:
    """Phases of ``steps`` started at sequence numbers ``boundaries``; the last ends at
    ``end``. Steps that never started (an aborted run) are left out; empty ones too."""
    stops = boundaries[1:] + [end]
    return [Phase(step.name, step.kind, start, stop, step.finger, step.place)
            for step, start, stop in zip(steps, boundaries, stops) if stop > start]


def write_outputs(recording: CommissioningRecording, folder: str | Path,
                  context: dict[str, str] | None = None,
                  limits: CommissioningLimits = DEFAULT_LIMITS
                  ) -> tuple[CommissioningResult, str]:
    """Judge ``recording`` and write ``recording.npz``, ``report.png`` and, last (its
    presence means the run is complete), ``report.txt`` into ``folder`` (created); returns
    the result and the text report."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    recording.save(folder / 'recording.npz')
    result = evaluate(recording, limits)
    report = text_report(result, context=context)
    draw_figure(recording, result, folder / 'report.png', limits.leak_retained_min)
    temporary = folder / 'report.txt.partial'
    temporary.write_text(report)
    temporary.replace(folder / 'report.txt')  # last: its presence means all are written
    return result, report


def mean_joint_position(names: list[str], positions: list[float],
                        joints: tuple[str, ...]) -> float:
    """Mean position [rad] of ``joints`` in a JointState's ``names`` / ``positions``;
    NaN when none is there."""
    values = [position for name, position in zip(names, positions) if name in joints]
    return float(np.mean(values)) if values else math.nan
