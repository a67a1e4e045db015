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

The step also moves the pressure level by many LSB, and the level-shift veto compares the
running means of the last two ``shift_length`` spans: for two spans after a step it would
blame every alarm on it, although the step's leak into the band has decayed well within the
hold (the band-pass's low corner at 10 Hz: a time constant of about 16 ms; the 0.0154 rad
step at the slip speed of 1 rad/s takes 15 ms). :meth:`ServoGate.settled` tells the
detector from which sample on the servo's own motion is over, and its level-shift veto
abstains while its spans reach back before that sample (the hum veto still applies).
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

    def settled(self, samples: np.ndarray) -> np.ndarray:
        """For each of the ascending pipeline ``samples`` (m,), the end of the latest gated
        interval at or before it: the sample from which the servo's own motion is over
        ((m,) int64; -1 before the first change)."""
        samples = self._forget(samples)
        out = np.full(samples.shape, self._last_stop, np.int64)
        for _, stop in self._intervals:
            out = np.where(samples >= stop, np.maximum(out, stop), out)
        return out

    def _forget(self, samples: np.ndarray) -> np.ndarray:
        """Drop the intervals wholly before the first of ``samples``; ``samples`` as int64."""
        samples = np.asarray(samples, np.int64)
        intervals = self._intervals
        if samples.size:
            while intervals and intervals[0][1] <= samples[0]:
                self._last_stop = max(self._last_stop, intervals.popleft()[1])
        return samples
