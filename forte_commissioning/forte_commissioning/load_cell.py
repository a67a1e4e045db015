"""Load-cell force aligned to the tactile frames by sample time (pure, no rclpy).

The load cell (``geometry_msgs/WrenchStamped``) and the sensor (``forte_msgs/TactileFrames``)
are two clocks' worth of samples, each stamped with its own *sample* time mapped to ROS
time. The calibration dataset needs the load-cell force at every frame sample. The rule:

- A frame at time t gets the linear interpolation of the two load-cell samples that
  bracket it, ``t_i <= t <= t_{i+1}`` (a sample exactly at t is used as it is).
- No extrapolation: a frame before the first or after the last load-cell sample has no
  force, and neither has a frame whose bracketing samples are more than ``max_gap`` apart
  (a lost message, a paused amplifier): that is a gap, not something to invent.
- A trial with any such frame is dropped as a whole and the reason reported; the caller
  retries or records the loss. Nothing is ever filled in.

Axis and sign: the force is one component of ``wrench.force`` (``axis`` 'x', 'y' or 'z')
times ``sign`` (+1 or -1), chosen so that squeezing the load cell reads positive. The
simulated rig publishes the squeeze as +z in frame ``forte_load_cell`` (docs/simulation.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ['AXES', 'Alignment', 'align_load_cell', 'wrench_component']

#: Force axes a load cell may be read on.
AXES = ('x', 'y', 'z')


def wrench_component(force_xyz: tuple[float, float, float], axis: str, sign: float) -> float:
    """The squeeze force a wrench reports on ``axis`` [N], positive when squeezed.

    Parameters
    ----------
    force_xyz : tuple of 3 floats
        ``wrench.force`` (x, y, z) [N].
    axis : str
        One of :data:`AXES`.
    sign : float
        +1 or -1: the sign that makes a squeeze positive.

    Returns
    -------
    float
        The force [N]; NaN when the component is not finite.
    """
    if axis not in AXES:
        raise ValueError(f'load-cell axis must be one of {AXES}, got {axis!r}')
    if sign not in (1, -1, 1.0, -1.0):
        raise ValueError(f'load-cell sign must be +1 or -1, got {sign!r}')
    value = float(force_xyz[AXES.index(axis)])
    return sign * value if math.isfinite(value) else math.nan


@dataclass(frozen=True)
class Alignment:
    """Load-cell force at the frame times, or why it cannot be had.

    Attributes
    ----------
    force : numpy.ndarray, shape (n,), float64
        Force at each frame [N] (NaN where ``problem`` applies).
    problem : str
        Empty when every frame has a force; otherwise the first reason in words.
    max_interval : float
        Longest interval between the bracketing load-cell samples used [s].
    """

    force: np.ndarray
    problem: str
    max_interval: float

    @property
    def ok(self) -> bool:
        """True when every frame got a force."""
        return not self.problem


def align_load_cell(frame_times_ns: np.ndarray, load_times_ns: np.ndarray,
                    load_values: np.ndarray, max_gap: float) -> Alignment:
    """Interpolate the load cell at the frame times (the module's rule).

    Parameters
    ----------
    frame_times_ns : numpy.ndarray, shape (n,), int64
        Sample time of every frame [ns], increasing.
    load_times_ns : numpy.ndarray, shape (m,), int64
        Sample time of every load-cell sample [ns] (any order; duplicates of the same time
        keep the first; non-finite values are left out before the gap check, so a NaN
        reading is a hole like a lost message).
    load_values : numpy.ndarray, shape (m,)
        Load-cell force [N].
    max_gap : float
        Longest interval between two load-cell samples across which a frame is
        interpolated [s], > 0.

    Returns
    -------
    Alignment
    """
    if not max_gap > 0:
        raise ValueError(f'max_gap must be > 0 s, got {max_gap}')
    frames = np.asarray(frame_times_ns, dtype=np.int64)
    times = np.asarray(load_times_ns, dtype=np.int64)
    values = np.asarray(load_values, dtype=np.float64)
    if times.shape != values.shape:
        raise ValueError(f'{times.shape[0]} load-cell times for {values.shape[0]} values')
    force = np.full(frames.shape, np.nan)
    if frames.size == 0:
        return Alignment(force, '', 0.0)
    keep = np.isfinite(values)
    times, values = times[keep], values[keep]
    if times.size == 0:
        return Alignment(force, 'no finite load-cell sample', math.inf)
    order = np.argsort(times, kind='stable')
    times, values = times[order], values[order]
    unique = np.concatenate(([True], np.diff(times) > 0))
    times, values = times[unique], values[unique]
    origin = int(frames[0])
    t = (frames - origin) * 1e-9
    lc = (times - origin) * 1e-9
    if frames[0] < times[0]:
        return Alignment(force, f'{np.count_nonzero(frames < times[0])} frame(s) before the '
                         f'first load-cell sample ({(times[0] - frames[0]) * 1e-9:.4f} s '
                         'later): no extrapolation', math.inf)
    if frames[-1] > times[-1]:
        return Alignment(force, f'{np.count_nonzero(frames > times[-1])} frame(s) after the '
                         f'last load-cell sample ({(frames[-1] - times[-1]) * 1e-9:.4f} s '
                         'earlier): no extrapolation', math.inf)
    # right bracket: first load-cell sample at or after the frame
    right = np.searchsorted(times, frames, side='left')
    exact = times[np.minimum(right, times.size - 1)] == frames
    left = np.where(exact, right, right - 1)
    interval = lc[right] - lc[left]
    widest = float(interval.max())
    if widest > max_gap:
        where = int(np.argmax(interval > max_gap))
        return Alignment(force, f'load-cell gap of {widest:.4f} s (> {max_gap:g} s) at frame '
                         f'{where} ({t[where]:.4f} s into the trial)', widest)
    span = np.where(interval > 0, interval, 1.0)
    weight = np.where(exact, 0.0, (t - lc[left]) / span)
    force = values[left] + weight * (values[right] - values[left])
    return Alignment(force, '', widest)
