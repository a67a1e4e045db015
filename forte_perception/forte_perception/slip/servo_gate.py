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

A slip can also be what made the controller move: its gross-slip reaction tightens 10-30
ms after an onset that the fast band power is still accumulating. The servo cannot have
caused what the band power showed before it moved, so when a finger's fast excess was
already above the CUSUM's drift at the update before a gated interval began, that interval
vetoes nothing: neither its gate, nor its step in the level-shift veto's spans (the step
moves the level by many LSB, and the veto compares the running means of the last two
``shift_length`` spans: it would blame the slip's alarms on the step for two spans after
it). :meth:`ServoGate.latest_stop` tells the detector where each update's latest interval
ends.
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
        self._intervals: deque[list[int]] = deque()  # [start, stop) in pipeline samples
        self._last_stop = -1  # end of the latest forgotten interval

    def moved(self, sample: int) -> None:
        """The servo command changed, taking effect at pipeline sample ``sample``."""
        if self.hold == 0:
            return
        start, stop = int(sample), int(sample) + self.hold
        if self._intervals and start <= self._intervals[-1][1]:
            last = self._intervals[-1]
            last[0], last[1] = min(last[0], start), max(last[1], stop)
        else:
            self._intervals.append([start, stop])

    def gated(self, samples: np.ndarray) -> np.ndarray | None:
        """Which of the ascending pipeline ``samples`` (m,) lie in a gated interval
        ((m,) bool); None when none can (nothing pending). Intervals wholly before the
        first sample are forgotten."""
        samples = self._forget(samples)
        if not self._intervals or not samples.size:
            return None
        mask = np.zeros(samples.shape, bool)
        for start, stop in self._intervals:
            mask |= (samples >= start) & (samples < stop)
        return mask

    def latest_stop(self, samples: np.ndarray) -> np.ndarray:
        """For each of the ascending pipeline ``samples`` (m,), the end of the latest gated
        interval that began at or before it: from that sample on the servo's own motion is
        over ((m,) int64; -1 before the first change)."""
        samples = self._forget(samples)
        out = np.full(samples.shape, self._last_stop, np.int64)
        for start, stop in self._intervals:
            out = np.where(samples >= start, np.maximum(out, stop), out)
        return out

    def _forget(self, samples: np.ndarray) -> np.ndarray:
        """Drop the intervals wholly before the first of ``samples``; ``samples`` as int64."""
        samples = np.asarray(samples, np.int64)
        intervals = self._intervals
        if samples.size:
            while intervals and intervals[0][1] <= samples[0]:
                self._last_stop = max(self._last_stop, intervals.popleft()[1])
        return samples
