"""The gripper's own motion is not slip: the servo gate of the sequential detector.

Derivation
----------
A servo command step (the controller's tightening, 0.0154 rad) shakes the fingers: the
step and the compliant fingers' response put power into the 10-50 Hz band for tens of
milliseconds. The PSD modes average over 200 ms and veto level shifts, so they rarely hear
it; the sequential detector's 30 ms band power does (closed loop, sequential mode: the lift's
false flags came 20-30 ms after a gross-slip tightening, in 3 of 3 traced trials). The
pipeline does not see the servo; whoever owns it reports each command change with the
pipeline sample it applies from (the perception node from ``gripper/command`` and its
stamp, the offline closed loop from the state machine's output). An alarm at an update
ending within ``hold`` samples from such a sample is vetoed like the level-shift and hum
vetoes: the CUSUM restarts, and what remains after the hold is heard again.

Cost of the gate: a slip that begins within ``hold`` after a tightening is heard up to
``hold`` later (the statistic restarts during it).

The step also moves the pressure level by many LSB, and the level-shift veto looks at the
running mean over its last two ``shift_length`` spans: for two spans after a step it
blames every alarm on it. Where the motion's duration is known (the command's step over
its profile velocity: the perception node's ``gripper/command``, the closed loop's
commands) the gate covers the motion plus ``hold``; after that the step is over and its
leak into the band has decayed (the band-pass's low corner at 10 Hz: a time constant of
about 16 ms), so the level-shift veto's spans do not look into the gated interval. Where
it is unknown (a recorded command without a speed, as in the slip set, whose closing steps
rise over 10-100 ms) the step stays in the spans.

A slip can also be what made the controller move: its gross-slip reaction tightens 10-30
ms after an onset that the fast band power is still accumulating. The servo cannot have
caused what the band power showed before it moved, so when a finger's fast excess was
already above the CUSUM's drift at the update before a gated interval began, that interval
vetoes nothing: neither its gate nor its step in the level-shift veto's spans.
:meth:`ServoGate.latest` tells the detector where each update's latest interval ends and
whether its motion was known.
"""
from __future__ import annotations

from collections import deque

import numpy as np

__all__ = ['ServoGate']


class ServoGate:
    """Intervals of pipeline samples following servo command changes.

    Parameters
    ----------
    hold : int
        Samples gated after each change [samples]; 0 turns the gate off.
    """

    def __init__(self, hold: int) -> None:
        if int(hold) != hold or hold < 0:
            raise ValueError(f'servo gate hold must be an integer >= 0 samples, got {hold}')
        self.hold = int(hold)
        self.reset()

    def reset(self) -> None:
        """Forget every change."""
        self._intervals: deque[list] = deque()  # [start, stop, motion known] in samples
        self._last = (-1, False)  # stop and motion known of the latest forgotten interval

    def moved(self, sample: int, motion: int | None = None) -> None:
        """The servo command changed, taking effect at pipeline sample ``sample``; the
        servo needs ``motion`` samples to get there (None: unknown). Gates
        ``[sample, sample + motion + hold)``."""
        if self.hold == 0:
            return
        if motion is not None and (int(motion) != motion or motion < 0):
            raise ValueError(f'servo motion must be an integer >= 0 samples, got {motion}')
        start = int(sample)
        stop, known = start + int(motion or 0) + self.hold, motion is not None
        if self._intervals and start <= self._intervals[-1][1]:
            last = self._intervals[-1]
            last[0], last[1], last[2] = min(last[0], start), max(last[1], stop), last[2] and known
        else:
            self._intervals.append([start, stop, known])

    def gated(self, samples: np.ndarray) -> np.ndarray | None:
        """Which of the ascending pipeline ``samples`` (m,) lie in a gated interval
        ((m,) bool); None when none can (nothing pending). Intervals wholly before the
        first sample are forgotten."""
        samples = self._forget(samples)
        if not self._intervals or not samples.size:
            return None
        mask = np.zeros(samples.shape, bool)
        for start, stop, _ in self._intervals:
            mask |= (samples >= start) & (samples < stop)
        return mask

    def latest(self, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each of the ascending pipeline ``samples`` (m,), the end of the latest gated
        interval that began at or before it ((m,) int64; -1 before the first change) and
        whether every motion in it had a known duration ((m,) bool): from that end on
        the servo's own motion is over and its ringing has decayed."""
        samples = self._forget(samples)
        stop = np.full(samples.shape, self._last[0], np.int64)
        known = np.full(samples.shape, self._last[1], bool)
        for start, interval_stop, interval_known in self._intervals:
            began = samples >= start
            stop = np.where(began, interval_stop, stop)
            known = np.where(began, interval_known, known)
        return stop, known

    def _forget(self, samples: np.ndarray) -> np.ndarray:
        """Drop the intervals wholly before the first of ``samples``; ``samples`` as int64."""
        samples = np.asarray(samples, np.int64)
        intervals = self._intervals
        if samples.size:
            while intervals and intervals[0][1] <= samples[0]:
                start, stop, known = intervals.popleft()
                self._last = (stop, known)
        return samples
