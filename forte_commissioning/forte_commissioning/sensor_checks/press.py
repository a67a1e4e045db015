"""The guided press test: one finger at a time, at its tip and at its root (pure).

Why one finger at a time: closing the gripper on a centred indentor loads both fingers
alike (the two servos move mirrored), so a swapped finger pair reads exactly like a
correct one. A press on one finger loads only that finger's three channels.

What each press gives: the change of every channel from its level just before the press
(median of the preceding :data:`BASELINE_SECONDS`) to the start of the press's plateau
(the first moment the fingers' summed change reaches 90 % of its peak, averaged over
:data:`PLATEAU_SECONDS`, median-11 filtered against impulses). Taking the start of the
plateau, not its end, keeps a leaking channel's response close to its sealed value.

What docs/contracts.md fixes and the checks verify:

- ``press_response``: each channel responds to a press on its own finger (left: channels
  0-2, right: 3-5);
- ``press_sign``: positively (a press raises the channel pair's differential pressure);
- ``press_finger``: and not to a press on the other finger;
- ``press_order`` (per finger, tip press): distal > middle > root, each by the margin
  :attr:`CommissioningLimits.order_margin`;
- ``press_shift`` (per finger, root press against tip press): the response moves toward
  the root: the root pair's share of the finger's response rises and the distal pair's
  falls (physics of the fin-ray finger: the pair under the press is squeezed most; in the
  simulated finger the distal pair still reads most at the root, its gain being largest).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forte_commissioning.sensor_checks.idle import FAIL, PASS, SKIP, CheckResult
from forte_commissioning.sensor_checks.limits import CommissioningLimits
from forte_commissioning.sensor_checks.run_record import CommissioningRecording
from forte_perception.median import MEDIAN_WINDOW, running_median
from forte_ros.contract import (
    CHANNEL_NAMES,
    DISTAL,
    FINGER_CHANNELS,
    FINGER_NAMES,
    MIDDLE,
    N_CHANNELS,
    ROOT,
    SAMPLE_RATE,
)

__all__ = ['BASELINE_SECONDS', 'PLATEAU_SECONDS', 'PressAnalysis', 'analyse_presses',
           'press_checks', 'press_response']

#: Length of the baseline before a press [s].
BASELINE_SECONDS = 0.5
#: Length of the plateau window averaged for the response [s].
PLATEAU_SECONDS = 0.2
_PLATEAU_SHARE = 0.9
_SMOOTH_SECONDS = 0.05


def press_response(recording: CommissioningRecording, start: int, stop: int) -> np.ndarray:
    """Signed change of each channel during the press in sequence numbers [start, stop).

    Returns
    -------
    numpy.ndarray, shape (6,)
        Response [normalised] (0 when the phase holds too few rows).
    """
    rows = recording.rows(start, stop)
    frames = recording.frames[rows]
    baseline_rows = recording.rows(start - int(BASELINE_SECONDS * SAMPLE_RATE), start)
    before = recording.frames[baseline_rows]
    if len(frames) < MEDIAN_WINDOW or len(before) < MEDIAN_WINDOW:
        return np.zeros(N_CHANNELS)
    change = running_median(frames - np.median(before, axis=0), MEDIAN_WINDOW)
    magnitude = np.abs(change).sum(axis=1)
    width = max(int(_SMOOTH_SECONDS * SAMPLE_RATE), 1)
    smooth = np.convolve(magnitude, np.ones(width) / width, mode='same')
    first = int(np.argmax(smooth >= _PLATEAU_SHARE * smooth.max()))
    window = change[first:first + int(PLATEAU_SECONDS * SAMPLE_RATE)]
    return window.mean(axis=0)


@dataclass(frozen=True)
class PressAnalysis:
    """Responses of the press test and what each channel did.

    Attributes
    ----------
    responses : dict
        ``(finger, place) -> (6,)`` response of every channel [normalised].
    detected : dict
        ``(finger, place) -> bool``: the press was seen on some channel.
    own : numpy.ndarray, shape (6,)
        Each channel's largest-magnitude response to presses on its own finger.
    foreign : numpy.ndarray, shape (6,)
        ... to presses on the other finger.
    """

    responses: dict
    detected: dict
    own: np.ndarray
    foreign: np.ndarray

    def responds(self, limits: CommissioningLimits) -> tuple[np.ndarray, np.ndarray]:
        """(own, foreign) boolean arrays: the channel responds to that finger's presses."""
        return (np.abs(self.own) > limits.response_min,
                np.abs(self.foreign) > limits.response_min)


def _largest(values: list[np.ndarray]) -> np.ndarray:
    """Element-wise value of largest magnitude among ``values`` (zeros without any)."""
    if not values:
        return np.zeros(N_CHANNELS)
    stacked = np.stack(values)
    return stacked[np.argmax(np.abs(stacked), axis=0), np.arange(stacked.shape[1])]


def analyse_presses(recording: CommissioningRecording,
                    limits: CommissioningLimits) -> PressAnalysis:
    """Responses of every press phase of ``recording``."""
    responses, detected = {}, {}
    for phase in recording.phases:
        if phase.kind != 'press':
            continue
        response = press_response(recording, phase.start, phase.stop)
        responses[(phase.finger, phase.place)] = response
        detected[(phase.finger, phase.place)] = bool(np.abs(response).max() > limits.press_min)
    own, foreign = np.zeros(N_CHANNELS), np.zeros(N_CHANNELS)
    for finger, channels in enumerate(FINGER_CHANNELS):
        mine = [value for (pressed, _), value in responses.items()
                if pressed == finger and detected[(pressed, _)]]
        others = [value for (pressed, _), value in responses.items()
                  if pressed != finger and detected[(pressed, _)]]
        own[list(channels)] = _largest(mine)[list(channels)]
        foreign[list(channels)] = _largest(others)[list(channels)]
    return PressAnalysis(responses, detected, own, foreign)


def _channel_checks(analysis: PressAnalysis, limits: CommissioningLimits,
                    pressed: set[int]) -> list[CheckResult]:
    """press_response, press_sign, press_finger of every channel."""
    results = []
    responds_own, responds_foreign = analysis.responds(limits)
    for channel, name in enumerate(CHANNEL_NAMES):
        finger = 0 if channel in FINGER_CHANNELS[0] else 1
        own, foreign = float(analysis.own[channel]), float(analysis.foreign[channel])
        if finger not in pressed:
            results.append(CheckResult('press_response', name, SKIP, detail=(
                f'no press on the {FINGER_NAMES[finger]} finger was detected')))
            results.append(CheckResult('press_sign', name, SKIP, detail='no press'))
        else:
            results.append(CheckResult(
                'press_response', name, PASS if responds_own[channel] else FAIL, own,
                limits.response_min, 'normalised', f'{own:+.3f} on a press of its own '
                f'({FINGER_NAMES[finger]}) finger'))
            if responds_own[channel]:
                results.append(CheckResult(
                    'press_sign', name, PASS if own > 0.0 else FAIL, own, 0.0, 'normalised',
                    'rises on a press' if own > 0.0 else 'falls on a press'))
            else:
                results.append(CheckResult('press_sign', name, SKIP,
                                           detail='no response to judge'))
        if 1 - finger not in pressed:
            results.append(CheckResult('press_finger', name, SKIP, detail=(
                f'no press on the {FINGER_NAMES[1 - finger]} finger was detected')))
        else:
            results.append(CheckResult(
                'press_finger', name, FAIL if responds_foreign[channel] else PASS, foreign,
                limits.response_min, 'normalised', f'{foreign:+.3f} on a press of the '
                f'{FINGER_NAMES[1 - finger]} finger'))
    return results


def _finger_checks(analysis: PressAnalysis, limits: CommissioningLimits,
                   finger: int) -> list[CheckResult]:
    """press_order (tip press) and press_shift (root against tip) of one finger."""
    name = FINGER_NAMES[finger]
    channels = list(FINGER_CHANNELS[finger])
    responds_own, responds_foreign = analysis.responds(limits)
    tip = analysis.responses.get((finger, 'tip'))
    root = analysis.responses.get((finger, 'root'))
    usable = all(responds_own[channel] and not responds_foreign[channel]
                 for channel in channels)
    reason = ('' if usable else 'not judged: a channel of this finger does not respond '
              'to it alone (see press_response / press_finger)')
    results = []
    if tip is None or not analysis.detected.get((finger, 'tip'), False) or not usable:
        results.append(CheckResult('press_order', name, SKIP,
                                   detail=reason or 'no tip press detected'))
    else:
        levels = np.abs(tip[channels])
        ratios = (levels[DISTAL] / max(levels[MIDDLE], 1e-12),
                  levels[MIDDLE] / max(levels[ROOT], 1e-12))
        good = min(ratios) >= limits.order_margin
        results.append(CheckResult(
            'press_order', name, PASS if good else FAIL, min(ratios), limits.order_margin,
            'ratio', 'tip press: distal/middle {:.2f}, middle/root {:.2f}'.format(*ratios)))
    if (root is None or tip is None or not usable
            or not analysis.detected.get((finger, 'root'), False)):
        results.append(CheckResult('press_shift', name, SKIP,
                                   detail=reason or 'no root press detected'))
    else:
        tip_share = np.abs(tip[channels]) / np.abs(tip[channels]).sum()
        root_share = np.abs(root[channels]) / np.abs(root[channels]).sum()
        shift = root_share - tip_share
        worst = min(shift[ROOT], -shift[DISTAL])
        results.append(CheckResult(
            'press_shift', name, PASS if worst >= limits.share_shift_min else FAIL, worst,
            limits.share_shift_min, 'share', f'tip -> root press: root share '
            f'{shift[ROOT]:+.2f}, distal share {shift[DISTAL]:+.2f}'))
    return results


def press_checks(analysis: PressAnalysis, limits: CommissioningLimits) -> list[CheckResult]:
    """Every press verdict: three per channel, two per finger, one per press."""
    pressed = {finger for (finger, _), seen in analysis.detected.items() if seen}
    results = [CheckResult(f'press_{FINGER_NAMES[finger]}_{place}', 'press',
                           PASS if seen else FAIL,
                           float(np.abs(analysis.responses[(finger, place)]).max()),
                           limits.press_min, 'normalised',
                           'press detected' if seen else 'no press seen: repeat it, firmer')
               for (finger, place), seen in analysis.detected.items()]
    results += _channel_checks(analysis, limits, pressed)
    for finger in range(len(FINGER_CHANNELS)):
        results += _finger_checks(analysis, limits, finger)
    return results
