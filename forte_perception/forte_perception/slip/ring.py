"""Reading a ring in the band-passed signal: the sequential mode's level-shift veto exempts a
finger that rings (issue 38; the derivation is :mod:`forte_perception.slip.sequential`'s,
vetoes 1).

A level shift through the slip band's band-pass is one lobe (a step), a constant (a ramp) or
a slow swing (a 0.5-5 Hz sway); a release rings the finger's bending mode for several
cycles. :func:`alternations` counts whole swings between both sides of a fraction of the
peak; :func:`decaying_alternations` follows the lobes of a heavily damped mode from the
largest on; :func:`loudest_of_finger` marks where a release is read most clearly.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import sosfilt, sosfilt_zi

from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS

__all__ = ['alternations', 'alternations_of', 'band_passed', 'decaying_alternations',
           'decaying_alternations_of', 'held_sides', 'loudest_of_finger']


def alternations(sos: np.ndarray, x: np.ndarray, window: int, fraction: float,
                 unit_rest: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How often the band-passed ``x`` (n, 6) alternates between above ``fraction`` of its
    peak magnitude and below minus that over its last ``window`` samples, and the median
    spacing of those alternations.

    ``x`` is filtered by the second-order sections ``sos`` from a state at rest at its
    first sample (a constant passes as zero), so the window should start well after it;
    ``unit_rest``: ``scipy.signal.sosfilt_zi(sos)``, when the caller keeps it.

    Returns
    -------
    count : ndarray (6,) int
        Alternations per channel.
    spacing : ndarray (6,)
        Median samples between consecutive alternations (half a period of the oscillation
        that makes them; a cycle below the threshold counts as a longer one); inf with
        fewer than two.
    peak : ndarray (6,)
        Peak magnitude of the band-passed signal in the window [units of ``x``].
    """
    return alternations_of(band_passed(sos, x, window, unit_rest), fraction)


def band_passed(sos: np.ndarray, x: np.ndarray, window: int,
                unit_rest: np.ndarray | None = None) -> np.ndarray:
    """The last ``window`` samples of ``x`` (n, 6) through ``sos``, filtered from a state at
    rest at its first sample (a constant passes as zero); (6, window)."""
    unit_rest = sosfilt_zi(sos) if unit_rest is None else unit_rest
    rest = unit_rest[:, None, :] * x[0][None, :, None]  # (sections, 6, 2)
    return sosfilt(sos, np.ascontiguousarray(x.T), axis=-1, zi=rest)[0][:, -window:]


def alternations_of(y: np.ndarray, fraction: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`alternations` of the band-passed window ``y`` (6, w)."""
    peak = np.abs(y).max(axis=1)
    held = held_sides(y, fraction * peak)
    switch = (held[:, 1:] != held[:, :-1]) & (held[:, :-1] != 0)
    count = switch.sum(axis=1).astype(np.int64)
    spacing = np.full(y.shape[0], np.inf)
    for c in np.flatnonzero(count >= 2):
        spacing[c] = _median(np.diff(np.flatnonzero(switch[c])))
    return count, spacing, peak


def held_sides(y: np.ndarray, level: np.ndarray) -> np.ndarray:
    """The side (+1 above ``level``, -1 below ``-level``) each channel of ``y`` (6, w) last
    reached, with hysteresis: 0 until it first leaves +-``level`` (6,); (6, w) int8."""
    limit = level[:, None]
    side = (y > limit).astype(np.int8) - (y < -limit).astype(np.int8)
    latest = np.where(side != 0, np.arange(y.shape[1])[None, :], -1)  # last side taken
    np.maximum.accumulate(latest, axis=1, out=latest)
    return np.take_along_axis(side, np.maximum(latest, 0), axis=1) * (latest >= 0)


def _median(values: np.ndarray) -> float:
    """The median of ``values`` (k,), k >= 1, without ``np.median``'s overhead."""
    ordered = np.sort(values)
    return 0.5 * float(ordered[(ordered.size - 1) // 2] + ordered[ordered.size // 2])


def decaying_alternations(sos: np.ndarray, x: np.ndarray, window: int, floor: np.ndarray,
                           ratio: float, unit_rest: np.ndarray | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How many times a decaying ring alternates in the band-passed ``x`` (n, 6) over its
    last ``window`` samples: from the largest lobe on, each next lobe (of opposite sign)
    that is at least ``ratio`` of the one before it.

    A mode of damping ratio ``z`` keeps ``exp(-pi z / sqrt(1 - z**2))`` of its amplitude per
    half period, so a fraction of the *window's peak* (:func:`alternations`) misses a heavily
    damped low mode whose first lobe also carries the release's static drop, while a step
    is one lobe and a ramp of rise ``T`` two equal ones ``T`` apart: neither alternates
    twice. Lobes are the runs between crossings from above ``+floor`` to below ``-floor``
    and back (hysteresis: noise near zero does not split a lobe).

    Parameters
    ----------
    sos : ndarray
        The band-pass, second-order sections.
    x : ndarray (n, 6)
        Samples, filtered from a state at rest at the first one (as :func:`alternations`).
    window : int
        Samples read at the end of ``x``.
    floor : ndarray (6,)
        Hysteresis of each channel [units of ``x``] (inf: never a lobe).
    ratio : float
        Least ratio of a lobe to the one before it, in (0, 1).
    unit_rest : ndarray, optional
        ``scipy.signal.sosfilt_zi(sos)``, when the caller keeps it.

    Returns
    -------
    count : ndarray (6,) int
        Alternations of the decaying ring per channel.
    spacing : ndarray (6,)
        Median samples between the crossings that begin its lobes; inf with fewer than two.
    peak : ndarray (6,)
        Peak magnitude of the band-passed signal in the window [units of ``x``].
    """
    return decaying_alternations_of(band_passed(sos, x, window, unit_rest), floor, ratio)


def decaying_alternations_of(y: np.ndarray, floor: np.ndarray, ratio: float,
                             channels: np.ndarray | None = None
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`decaying_alternations` of the band-passed window ``y`` (6, w), read on
    ``channels`` (6,) bool only (default all; the others count none)."""
    peak = np.abs(y).max(axis=1)
    count = np.zeros(y.shape[0], np.int64)
    spacing = np.full(y.shape[0], np.inf)
    read = np.ones(y.shape[0], bool) if channels is None else channels
    held = held_sides(y, floor)
    for channel in np.flatnonzero(read):
        row = held[channel]
        begins = np.flatnonzero(row[1:] != row[:-1]) + 1  # each lobe's first sample
        if row[0] != 0:
            begins = np.concatenate([[0], begins])
        if begins.size < 2:  # one lobe at most: no alternation
            continue
        lobes = np.maximum.reduceat(np.abs(y[channel]), begins)  # each lobe's magnitude
        first = last = int(np.argmax(lobes))
        while last + 1 < lobes.size and lobes[last + 1] >= ratio * lobes[last]:
            last += 1
        count[channel] = last - first
        if last - first >= 2:
            spacing[channel] = _median(np.diff(begins[first + 1:last + 1]))
    return count, spacing, peak


def loudest_of_finger(power: np.ndarray) -> np.ndarray:
    """Per finger, its channel of the largest ``power`` (6,) (NaN: unusable, never the
    loudest); (6,) bool, one channel per finger with a usable one."""
    loudest = np.zeros(N_CHANNELS, bool)
    for channels in FINGER_CHANNELS:
        values = power[list(channels)]
        if np.isfinite(values).any():
            loudest[channels[int(np.nanargmax(values))]] = True
    return loudest
