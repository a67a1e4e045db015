"""Verdict types and the checks of the gripper at rest and of the sensor link (pure).

At rest (gripper open, nobody touching it) each channel's readings give its zero offset,
its white noise in LSB rms, and whether it is stuck (constant) or railed; the link
counters give the device's sample rate and the share of lost and corrupt frames.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from forte_commissioning.sensor_checks.limits import CommissioningLimits
from forte_commissioning.sensor_checks.run_record import LinkStatistics
from forte_ros.contract import (
    CHANNEL_NAMES,
    COUNTS_PER_FULL_SCALE,
    N_CHANNELS,
    QUANTUM,
    SAMPLE_RATE,
    VALUE_RANGE,
)

__all__ = ['FAIL', 'PASS', 'SKIP', 'CheckResult', 'IdleStatistics', 'idle_checks',
           'idle_statistics', 'link_checks']

PASS, FAIL, SKIP = 'PASS', 'FAIL', 'SKIP'
#: Normal-distribution factor from a median absolute deviation to a standard deviation.
_MAD_TO_SIGMA = 1.4826
#: Differences beyond this many robust standard deviations are impulses, not noise.
_OUTLIER_FACTOR = 6.0


@dataclass(frozen=True)
class CheckResult:
    """The verdict of one check on one subject.

    Attributes
    ----------
    check : str
        Check name, e.g. ``'noise'``, ``'press_sign'``, ``'leak'``.
    subject : str
        A channel name, a finger name (``'left'``), or ``'link'``.
    status : str
        ``PASS``, ``FAIL`` or ``SKIP`` (could not be judged; ``detail`` says why).
    value : float
        The measured quantity (NaN when none).
    limit : float
        The threshold it was compared with (NaN when none).
    unit : str
        Unit of ``value`` and ``limit``.
    detail : str
        One line for the report.
    """

    check: str
    subject: str
    status: str
    value: float = math.nan
    limit: float = math.nan
    unit: str = ''
    detail: str = ''


@dataclass(frozen=True)
class IdleStatistics:
    """Per-channel statistics of the rest phase, arrays of shape (6,).

    Attributes
    ----------
    offset : numpy.ndarray
        Median reading [normalised].
    noise_lsb : numpy.ndarray
        White noise [LSB rms]: the rms of the first differences over sqrt(2), differences
        beyond 6 robust standard deviations (impulses) left out.
    spread_lsb : numpy.ndarray
        Root mean square deviation from the median [LSB].
    rail_share : numpy.ndarray
        Share of readings at a rail of the range [-].
    """

    offset: np.ndarray
    noise_lsb: np.ndarray
    spread_lsb: np.ndarray
    rail_share: np.ndarray


def idle_statistics(frames: np.ndarray) -> IdleStatistics:
    """Offset, noise, spread and rail share of readings at rest.

    Parameters
    ----------
    frames : numpy.ndarray, shape (n, 6)
        Raw readings of the rest phase [normalised], n >= 3.

    Returns
    -------
    IdleStatistics
    """
    frames = np.asarray(frames, dtype=np.float64)
    if len(frames) < 3:
        raise ValueError('the rest phase needs at least 3 readings')
    offset = np.median(frames, axis=0)
    differences = np.diff(frames, axis=0)
    centred = differences - np.median(differences, axis=0)
    # robust first guess (median absolute deviation, at least one LSB since the readings
    # are quantised), then the rms of the differences within 6 of it: impulses excluded
    guess = np.maximum(_MAD_TO_SIGMA * np.median(np.abs(centred), axis=0), QUANTUM)
    kept = np.abs(centred) <= _OUTLIER_FACTOR * guess
    rms = np.sqrt(np.sum(np.where(kept, centred, 0.0) ** 2, axis=0)
                  / np.maximum(kept.sum(axis=0), 1))
    noise = rms / math.sqrt(2.0) / QUANTUM
    spread = np.sqrt(np.mean((frames - offset) ** 2, axis=0)) / QUANTUM
    high = VALUE_RANGE[1] - QUANTUM
    rail = np.mean((frames >= high - 0.5 * QUANTUM) | (frames <= VALUE_RANGE[0]), axis=0)
    return IdleStatistics(offset, noise, spread, rail)


def idle_checks(stats: IdleStatistics, limits: CommissioningLimits) -> list[CheckResult]:
    """Offset, noise, stuck and railed verdicts of each channel.

    A stuck or railed channel's noise is not judged (SKIP): it has none to measure.
    """
    results = []
    for channel in range(N_CHANNELS):
        name = CHANNEL_NAMES[channel]
        offset = float(stats.offset[channel])
        results.append(CheckResult(
            'offset', name, PASS if abs(offset) <= limits.offset_limit else FAIL,
            offset, limits.offset_limit, 'normalised',
            f'zero offset {offset:+.4f} ({offset * COUNTS_PER_FULL_SCALE:+.0f} LSB)'))
        spread = float(stats.spread_lsb[channel])
        stuck = spread < limits.stuck_limit_lsb
        results.append(CheckResult(
            'stuck', name, FAIL if stuck else PASS, spread, limits.stuck_limit_lsb,
            'LSB rms', f'readings vary by {spread:.2f} LSB rms at rest'))
        share = float(stats.rail_share[channel])
        railed = share > limits.rail_fraction
        results.append(CheckResult(
            'railed', name, FAIL if railed else PASS, share, limits.rail_fraction, '',
            f'{100.0 * share:.1f} % of the rest readings at a rail'))
        noise = float(stats.noise_lsb[channel])
        if stuck or railed:
            results.append(CheckResult('noise', name, SKIP, noise, limits.noise_limit_lsb,
                                       'LSB rms', 'not judged: the channel is '
                                       + ('stuck' if stuck else 'railed')))
        else:
            results.append(CheckResult(
                'noise', name, PASS if noise <= limits.noise_limit_lsb else FAIL, noise,
                limits.noise_limit_lsb, 'LSB rms', f'white noise {noise:.2f} LSB rms'))
    return results


def link_checks(link: LinkStatistics, limits: CommissioningLimits) -> list[CheckResult]:
    """Sample rate (device clock), lost and corrupt frames, and the host's pace."""
    results = []
    span = link.last_sequence - link.first_sequence
    if span > 0 and link.device_seconds > 0.0:
        rate = span / link.device_seconds
        error = abs(rate - SAMPLE_RATE) / SAMPLE_RATE
        results.append(CheckResult(
            'sample_rate', 'link', PASS if error <= limits.rate_tolerance else FAIL, rate,
            SAMPLE_RATE, 'Hz', f'{rate:.1f} Hz by the device clock (contract '
            f'{SAMPLE_RATE:.0f} Hz +- {100.0 * limits.rate_tolerance:.1f} %)'))
    else:
        results.append(CheckResult('sample_rate', 'link', FAIL, detail='no device time span'))
    total = max(link.received + link.dropped, 1)
    for check, count in (('dropped_frames', link.dropped), ('corrupt_frames', link.corrupt)):
        share = count / total
        results.append(CheckResult(
            check, 'link', PASS if share <= limits.drop_fraction else FAIL, share,
            limits.drop_fraction, '', f'{count} of {total} frames ({100.0 * share:.3f} %)'))
    if math.isfinite(link.wall_seconds) and link.wall_seconds > 0.0 and span > 0:
        pace = link.received / (link.wall_seconds * SAMPLE_RATE)
        results.append(CheckResult(
            'host_rate', 'link', PASS if pace >= limits.host_rate_fraction else FAIL, pace,
            limits.host_rate_fraction, '', f'the host received {100.0 * pace:.1f} % of '
            f'{SAMPLE_RATE:.0f} rows per wall second'))
    return results
