"""The leak test: a squeeze held on an indentor, a sealed channel keeps its level (pure).

Each channel pair is a sealed air volume; its transducer reads the pair's pressure
difference. Through a leak the pressure equalises with ambient: the reading decays toward
the channel's zero offset as a first-order high-pass, ``exp(-t / tau)``, and keeps
decaying as long as the squeeze lasts.

What else moves a channel's level during a held squeeze, and why it is not a leak:

- the fin-ray's stress relaxation (a standard linear solid: 18 % of the force with time
  constants 1.5 s and 15 s): at a fixed angle the finger's stress falls, under a current
  limit the servo creeps closed and the deflection grows. Either way it moves all channels
  of a finger together (one material, one deflection) and levels off;
- the indentor's temperature (warmer or colder than the finger) heats or cools the
  channels under the contact: a few % of the level, with an 8 s time constant, on all
  channels of a finger alike in sign.

So the test compares each channel with the others: its retained share of the level
(end of the hold over its start, both relative to the channel's offset at rest) divided by
the median retained share of the other loaded channels, over the whole hold and over its
second half. A leak is a channel that lost too much over the hold *and* is still losing
over its second half (:class:`CommissioningLimits` ``leak_retained_min``,
``leak_continuing_max``). The median of the five other channels stands for the gripper's
common behaviour as long as at most two channels leak.
"""
from __future__ import annotations

import numpy as np

from forte_commissioning.sensor_checks.idle import FAIL, PASS, SKIP, CheckResult
from forte_commissioning.sensor_checks.limits import CommissioningLimits
from forte_commissioning.sensor_checks.run_record import CommissioningRecording, Phase
from forte_ros.contract import CHANNEL_NAMES, N_CHANNELS, SAMPLE_RATE

__all__ = ['LeakLevels', 'leak_checks', 'leak_levels']


class LeakLevels:
    """Levels of each channel in the held squeeze, relative to its offset at rest.

    Attributes
    ----------
    start, middle, end : numpy.ndarray, shape (6,)
        Median level after the settle time, in the middle of the hold and at its end
        [normalised, offset removed].
    """

    def __init__(self, start: np.ndarray, middle: np.ndarray, end: np.ndarray) -> None:
        self.start, self.middle, self.end = start, middle, end

    def shares(self) -> tuple[np.ndarray, np.ndarray]:
        """(retained over the hold, retained over its second half) per channel [-]."""
        with np.errstate(divide='ignore', invalid='ignore'):
            return self.end / self.start, self.end / self.middle


def leak_levels(recording: CommissioningRecording, squeeze: Phase, offset: np.ndarray,
                limits: CommissioningLimits) -> LeakLevels | None:
    """Levels of the squeeze phase, or None when the hold is too short to judge.

    The hold runs from ``leak_settle`` after the phase starts to its end; each level is
    the median over ``leak_window``.
    """
    settle = int(limits.leak_settle * SAMPLE_RATE)
    window = int(limits.leak_window * SAMPLE_RATE)
    first, last = squeeze.start + settle, squeeze.stop
    if last - first < 3 * window:
        return None
    centre = (first + window + last) // 2

    def level(start: int) -> np.ndarray:
        rows = recording.rows(start, start + window)
        if rows.stop - rows.start < window // 2:
            return np.full(N_CHANNELS, np.nan)
        return np.median(recording.frames[rows], axis=0) - offset

    return LeakLevels(level(first), level(centre - window // 2), level(last - window))


def leak_checks(levels: LeakLevels | None,
                limits: CommissioningLimits) -> tuple[list[CheckResult], np.ndarray]:
    """Leak verdict of each channel.

    Returns
    -------
    results : list of CheckResult
    relative : numpy.ndarray, shape (6,)
        Retained share over the hold relative to the other channels' median (NaN where
        not judged), for the report's figure.
    """
    relative = np.full(N_CHANNELS, np.nan)
    if levels is None:
        return [CheckResult('leak', name, SKIP, detail='no squeeze hold long enough to '
                            'judge') for name in CHANNEL_NAMES], relative
    retained, continuing = levels.shares()
    loaded = np.isfinite(levels.start) & (np.abs(levels.start) > limits.leak_level_min)
    results = []
    for channel, name in enumerate(CHANNEL_NAMES):
        others = [index for index in range(N_CHANNELS) if index != channel and loaded[index]]
        if not loaded[channel] or len(others) < 2:
            why = ('its level in the squeeze is below '
                   f'{limits.leak_level_min:g}' if not loaded[channel]
                   else 'fewer than two other loaded channels to compare with')
            results.append(CheckResult('leak', name, SKIP, detail=f'not judged: {why}'))
            continue
        relative[channel] = retained[channel] / np.median(retained[others])
        late = continuing[channel] / np.median(continuing[others])
        leaking = (relative[channel] < limits.leak_retained_min
                   and late < limits.leak_continuing_max)
        results.append(CheckResult(
            'leak', name, FAIL if leaking else PASS, float(relative[channel]),
            limits.leak_retained_min, 'share',
            f'keeps {100.0 * retained[channel]:.0f} % of its level over the hold '
            f'({100.0 * relative[channel]:.0f} % of the others), {100.0 * late:.0f} % '
            'of the others over its second half'))
    return results, relative
