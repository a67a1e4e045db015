"""Map the device clock to host (ROS) time: offset and drift from minimum-latency points.

Pure Python, no rclpy.

Every chunk read from the serial port gives one observation: the device time of the newest
sample in the chunk and the host time the chunk was received. The host time is the
sample time plus a transport latency that is always positive and varies (USB polling, OS
scheduling, driver buffering). The observations with the smallest latency lie on a line
``host = offset + (1 + drift) * device``; the others lie above it.

Estimator (windowed minimum-latency linear fit):

1. Observations are grouped in bins of ``bin_s`` of device time; each bin keeps only its
   minimum-latency observation (smallest ``host - device``).
2. A least-squares line is fitted through the bin minima of the last ``window_s`` seconds
   (slope fixed to 1 while fewer than ``min_bins_for_drift`` bins exist).
3. The line is shifted down to the lower envelope: its offset is set so that no bin
   minimum lies below it (the minimum residual becomes 0).

The mapped time of a sample is therefore its device time on the host time line plus the
smallest latency observed in the window (the irreducible USB latency cannot be measured
from one clock pair; it is typically 0.1-1 ms and is reported, not removed).
A device clock jump (new device, restart) further than ``jump_tolerance_s`` from the
model resets the estimator.

Absurd inputs never raise. Device times are used only as differences from a recent
reference (exact Python integers), so any non-negative device time works, however large
(the caller unwraps the protocol's 64-bit counter, see
:mod:`forte_driver.serial.sensor_stream`). An observation with a negative device time or a host
time outside :data:`MAX_HOST_TIME_NS` is rejected and counted in
``rejected_observations``; :meth:`ClockSync.to_host_ns` returns ``None`` for a device time
it cannot map to a representable host time (signed 64-bit nanoseconds, >= 0).
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

NANOSECONDS_PER_MICROSECOND = 1000
#: Host times [ns] must fit a signed 64-bit integer (ROS time, ``builtin_interfaces/Time``).
MAX_HOST_TIME_NS = (1 << 63) - 1


def is_valid_device_time(device_time_us: int) -> bool:
    """True if ``device_time_us`` [us] is a non-negative integer (of any size)."""
    return isinstance(device_time_us, (int, np.integer)) and device_time_us >= 0


def is_valid_host_time(host_time_ns: int) -> bool:
    """True if ``host_time_ns`` [ns] is an integer in [0, MAX_HOST_TIME_NS]."""
    return isinstance(host_time_ns, (int, np.integer)) and 0 <= host_time_ns <= MAX_HOST_TIME_NS


@dataclass(frozen=True)
class ClockModel:
    """Linear map of device time to host time.

    ``host_ns = reference_host_ns + offset_ns
    + (1 + drift) * (device_us - reference_device_us) * 1000``.

    Attributes
    ----------
    reference_device_us : int
        Device time of the reference point [us].
    reference_host_ns : int
        Host time of the reference point [ns].
    offset_ns : float
        Host time of the reference device instant, relative to reference_host_ns [ns].
    drift : float
        Relative rate error of the device clock (host seconds per device second - 1).
    """

    reference_device_us: int
    reference_host_ns: int
    offset_ns: float
    drift: float

    def to_host_ns(self, device_time_us: int) -> int:
        """Host time [ns] of a device time [us] (unbounded Python int, may be negative or
        beyond 64 bits for absurd inputs: see :meth:`ClockSync.to_host_ns`)."""
        elapsed_ns = (device_time_us - self.reference_device_us) * NANOSECONDS_PER_MICROSECOND
        return self.reference_host_ns + int(round(self.offset_ns + (1.0 + self.drift) * elapsed_ns))


class ClockSync:
    """Windowed minimum-latency estimator of device-to-host clock offset and drift.

    Parameters
    ----------
    window_s : float
        Span of device time whose bins enter the fit [s].
    bin_s : float
        Bin width [s]; each bin contributes its minimum-latency observation.
    min_bins_for_drift : int
        Bins needed before the drift is estimated (before: slope fixed to 1).
    max_drift : float
        Drift estimates are clipped to +-max_drift (crystals: < 1e-4).
    jump_tolerance_s : float
        Observations further than this from the model reset the estimator [s].

    Attributes
    ----------
    resets : int
        Estimator resets caused by device clock jumps [count].
    rejected_observations : int
        Observations ignored because a time was unusable (a negative device time, or a
        host time outside :func:`is_valid_host_time`) [count].
    """

    def __init__(self, window_s: float = 20.0, bin_s: float = 0.5,
                 min_bins_for_drift: int = 4, max_drift: float = 5e-4,
                 jump_tolerance_s: float = 1.0) -> None:
        if window_s <= 0 or bin_s <= 0 or bin_s > window_s:
            raise ValueError('need 0 < bin_s <= window_s')
        self.window_us = int(window_s * 1e6)
        self.bin_us = int(bin_s * 1e6)
        self.min_bins_for_drift = max(2, int(min_bins_for_drift))
        self.max_drift = float(max_drift)
        self.jump_tolerance_ns = int(jump_tolerance_s * 1e9)
        self.resets = 0
        self.rejected_observations = 0
        self._bins: OrderedDict[int, tuple[int, int]] = OrderedDict()
        self._model: ClockModel | None = None
        self._last_latency_ns: float | None = None
        self._late_run = 0

    def reset(self) -> None:
        """Forget every observation (new device clock)."""
        self._bins.clear()
        self._model = None
        self._last_latency_ns = None
        self._late_run = 0

    @property
    def model(self) -> ClockModel | None:
        """The current model, ``None`` before the first observation."""
        return self._model

    @property
    def drift_ppm(self) -> float:
        """Estimated drift [parts per million] (0 before estimation)."""
        return 0.0 if self._model is None else self._model.drift * 1e6

    @property
    def last_latency_s(self) -> float | None:
        """Latency of the last observation above the lower envelope [s]."""
        return None if self._last_latency_ns is None else self._last_latency_ns * 1e-9

    def add(self, device_time_us: int, host_time_ns: int) -> bool:
        """Add one observation: a sample with device time ``device_time_us`` [us] was
        received at host time ``host_time_ns`` [ns].

        Returns
        -------
        bool
            False if the observation was rejected (a time outside the representable
            range; counted in ``rejected_observations``, the model is unchanged).
        """
        if not (is_valid_device_time(device_time_us) and is_valid_host_time(host_time_ns)):
            self.rejected_observations += 1
            return False
        if self._model is not None:
            error = host_time_ns - self._model.to_host_ns(device_time_us)
            # received before it was sampled: the device clock jumped forward. Late by more
            # than the tolerance several times in a row: it jumped back (a host stall
            # alone makes one late observation, not a run of them).
            self._late_run = self._late_run + 1 if error > self.jump_tolerance_ns else 0
            if error < -self.jump_tolerance_ns or self._late_run >= 3:
                self.reset()
                self.resets += 1
        key = device_time_us // self.bin_us
        current = self._bins.get(key)
        if current is None:
            self._bins[key] = (device_time_us, host_time_ns)
            oldest_key_allowed = key - self.window_us // self.bin_us
            while self._bins and next(iter(self._bins)) < oldest_key_allowed:
                self._bins.popitem(last=False)
        elif host_time_ns - device_time_us * 1000 < current[1] - current[0] * 1000:
            self._bins[key] = (device_time_us, host_time_ns)
        else:
            self._record_latency(device_time_us, host_time_ns)
            return True
        self._fit()
        self._record_latency(device_time_us, host_time_ns)
        return True

    def _record_latency(self, device_time_us: int, host_time_ns: int) -> None:
        if self._model is not None:
            self._last_latency_ns = float(host_time_ns - self._model.to_host_ns(device_time_us))

    def _fit(self) -> None:
        points = list(self._bins.values())
        reference_device_us, reference_host_ns = points[-1]
        device = np.array([(d - reference_device_us) * 1000.0 for d, _ in points])  # ns
        host = np.array([float(h - reference_host_ns) for _, h in points])  # ns
        if len(points) >= self.min_bins_for_drift and np.ptp(device) > 0:
            slope, _ = np.polyfit(device, host, 1)
            drift = float(np.clip(slope - 1.0, -self.max_drift, self.max_drift))
        else:
            drift = 0.0 if self._model is None else self._model.drift
        residual = host - (1.0 + drift) * device
        offset = float(residual.min())  # lower envelope: no minimum lies below the line
        self._model = ClockModel(reference_device_us, reference_host_ns, offset, drift)

    def to_host_ns(self, device_time_us: int) -> int | None:
        """Host time [ns] of a device time [us]; ``None`` before the first observation and
        for a device time that cannot be mapped to a host time in [0, 2**63) ns."""
        if self._model is None or not is_valid_device_time(device_time_us):
            return None
        host_ns = self._model.to_host_ns(device_time_us)
        return host_ns if is_valid_host_time(host_ns) else None
