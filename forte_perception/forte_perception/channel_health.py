"""Per-channel input validity and health of the tactile stream (pure, no ROS).

A raw value is *invalid* when it is NaN, inf, or finite with ``|x| > input_limit`` (the
transducer's normalised range: the protocol clips at +-1024 counts = +-1.0, the simulator at
-1.0 and 1 - 1/1024, the legacy ASCII parser refuses values outside [-1, 1]; so anything
beyond 1.0 did not come from the transducer). An invalid value affects only its own channel:

- the pipeline substitutes the channel's last valid value (0.0 if it has none yet) so that
  the vectorised streaming arithmetic keeps running (the substitute is in range, so it adds no
  rounding trouble to the sliding DFT or the running sums), and
- every output whose window holds a substituted sample is *masked*
  (:meth:`ChannelHealth.masked`): a filtered window of W samples ending at sample t
  depends on the raw samples ``t - (W + M - 1) + 1 .. t`` (M = median length), so it is
  masked when the channel's last invalid raw sample up to t is within that reach.

Health flags (``HEALTH_*``, bits of ``TactileState.channel_health``):

- ``NON_FINITE`` / ``OUT_OF_RANGE``: an invalid value in this chunk (invalidating);
- ``MASKED``: a substituted sample is within this channel's median, contact or slip windows;
- ``STUCK``: the raw value has been exactly constant for ``stuck_samples`` or more (reported,
  not invalidating: a quiet, well-quantised sensor may hold one value for a while);
- ``RAILED``: a value within one count (1/1024) of ``+-input_limit`` in this chunk, i.e. at
  the clip level (reported, not invalidating).
"""
from __future__ import annotations

import numpy as np

from forte_ros.contract import N_CHANNELS

__all__ = ['HEALTH_MASKED', 'HEALTH_NON_FINITE', 'HEALTH_OUT_OF_RANGE', 'HEALTH_RAILED',
           'HEALTH_STUCK', 'LEVEL_ERROR', 'LEVEL_OK', 'LEVEL_WARN', 'NEVER', 'ONE_COUNT',
           'ChannelHealth', 'channel_report']

HEALTH_NON_FINITE = 1
HEALTH_OUT_OF_RANGE = 2
HEALTH_MASKED = 4
HEALTH_STUCK = 8
HEALTH_RAILED = 16
#: One protocol count in normalised units (1024 counts = 1.0).
ONE_COUNT = 1.0 / 1024.0
#: "No invalid sample yet": far enough in the past for every window reach.
NEVER = -(1 << 62)


class ChannelHealth:
    """Streaming validity, substitution bookkeeping and health counters of 6 channels.

    Parameters
    ----------
    input_limit : float
        Largest valid ``|x|`` [normalised units].
    stuck_samples : int
        Exactly constant this many samples or more -> ``STUCK`` [samples].

    Attributes
    ----------
    non_finite, out_of_range, railed : ndarray, shape (6,), int64
        Cumulative counts of NaN/inf values, finite out-of-range values and values at the
        rail since the last :meth:`reset` [count].
    last_invalid : ndarray, shape (6,), int64
        Absolute sample index of the channel's latest invalid raw value (``NEVER``: none).
    """

    def __init__(self, input_limit: float = 1.0, stuck_samples: int = 10000) -> None:
        self.input_limit = float(input_limit)
        self.rail_level = self.input_limit - ONE_COUNT
        self.stuck_samples = int(stuck_samples)
        self.reset()

    def reset(self) -> None:
        """Forget everything (counters, runs, substitutes)."""
        self.non_finite = np.zeros(N_CHANNELS, np.int64)
        self.out_of_range = np.zeros(N_CHANNELS, np.int64)
        self.railed = np.zeros(N_CHANNELS, np.int64)
        self.last_invalid = np.full(N_CHANNELS, NEVER, np.int64)
        self._held = [float('nan')] * N_CHANNELS
        self._runs = [0] * N_CHANNELS
        self.last_invalid_max = NEVER
        self._substitute = np.zeros(N_CHANNELS)
        self._first_index = 0
        self._row_last_invalid: np.ndarray | None = None  # (n, 6) for the current chunk
        #: (n, 6) bool: invalid values of the last checked chunk (None: all valid)
        self.chunk_invalid: np.ndarray | None = None

    def check(self, x: np.ndarray, first_index: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Check a raw chunk (n >= 1, 6) starting at absolute sample ``first_index``.

        Returns
        -------
        flags : ndarray, shape (6,), uint8
            ``NON_FINITE | OUT_OF_RANGE | STUCK | RAILED`` of this chunk (MASKED is the
            pipeline's).
        substituted : ndarray, shape (n, 6), or None
            None when every value is valid (use ``x`` as it is); otherwise a copy of ``x``
            with each invalid value replaced by the channel's last valid value.
        """
        n = x.shape[0]
        self._first_index = first_index
        self._row_last_invalid = None
        self.chunk_invalid = None
        flags = np.zeros(N_CHANNELS, np.uint8)
        # per-channel extremes as Python floats (one sort is cheaper than min and max for a
        # small chunk; NaN sorts last, so a NaN channel's maximum is NaN and fails every
        # comparison): the healthy path is then one loop of float comparisons
        if n <= 64:
            ordered = np.sort(x, axis=0)
            lo, hi = ordered[0], ordered[-1]
        else:  # min and max propagate NaN
            lo, hi = np.minimum.reduce(x, axis=0), np.maximum.reduce(x, axis=0)
        in_range, near_rail, stuck = self._scan(x, lo.tolist(), hi.tolist())
        limit, rail = self.input_limit, self.rail_level
        if stuck:
            flags[np.asarray(self._runs) >= self.stuck_samples] |= HEALTH_STUCK
        if near_rail or not in_range:
            at_rail = ((x >= rail) & (x <= limit)) | ((x <= -rail) & (x >= -limit))
            count = at_rail.sum(axis=0)
            self.railed += count
            flags[count > 0] |= HEALTH_RAILED
        if in_range:
            self._substitute = x[-1].copy()
            return flags, None
        finite = np.isfinite(x)
        valid = finite & (np.abs(np.where(finite, x, 0.0)) <= limit)
        non_finite = (~finite).sum(axis=0)
        out_of_range = (~valid).sum(axis=0) - non_finite
        self.non_finite += non_finite
        self.out_of_range += out_of_range
        self.chunk_invalid = ~valid
        flags[non_finite > 0] |= HEALTH_NON_FINITE
        flags[out_of_range > 0] |= HEALTH_OUT_OF_RANGE
        # forward fill: each invalid value takes the channel's last valid value
        rows = np.arange(n)[:, None]
        source = np.maximum.accumulate(np.where(valid, rows, -1), axis=0)  # (n, 6)
        filled = np.where(source >= 0, x[np.maximum(source, 0), np.arange(N_CHANNELS)],
                          self._substitute[None, :])
        self._substitute = filled[-1].copy()
        # per-row latest invalid index (for masks inside this chunk)
        invalid_index = np.where(valid, NEVER, first_index + rows)
        self._row_last_invalid = np.maximum(
            np.maximum.accumulate(invalid_index, axis=0), self.last_invalid[None, :])
        self.last_invalid = self._row_last_invalid[-1].copy()
        self.last_invalid_max = int(self.last_invalid.max())
        return flags, filled

    def _scan(self, x: np.ndarray, lo: list[float], hi: list[float]
              ) -> tuple[bool, bool, bool]:
        """Range, rail and run bookkeeping from the per-channel extremes of a chunk.

        Runs of exactly equal raw values are counted at chunk resolution: a channel
        continues its run when the whole chunk equals the value it held (its last value of
        the previous chunk); otherwise the run restarts at the end of the chunk (so a run is
        underestimated by less than one chunk; NaN never equals anything).

        Returns (every value in range, some value near a rail, some channel stuck).
        """
        n = x.shape[0]
        limit, rail, stuck_samples = self.input_limit, self.rail_level, self.stuck_samples
        held, runs = self._held, self._runs
        in_range, near_rail, stuck = True, False, False
        last = None
        for c in range(N_CHANNELS):
            low, high = lo[c], hi[c]
            if not (low >= -limit and high <= limit):
                in_range = False
            elif low <= -rail or high >= rail:
                near_rail = True
            if low == high and low == held[c]:
                runs[c] += n
                stuck = stuck or runs[c] >= stuck_samples
            else:
                if last is None:
                    last = x[-1].tolist()
                runs[c] = 0
                held[c] = last[c]
        return in_range, near_rail, stuck

    @property
    def constant_run(self) -> np.ndarray:
        """Current run of exactly equal raw values per channel, shape (6,) [samples]."""
        return np.asarray(self._runs, np.int64)

    def masked(self, t: np.ndarray | int, reach: int) -> np.ndarray:
        """Channels whose window of raw reach ``reach`` ending at sample(s) ``t`` holds an
        invalid sample.

        Parameters
        ----------
        t : int or ndarray, shape (k,)
            Absolute sample indices inside the chunk last given to :meth:`check` (or later).
        reach : int
            Raw samples a window depends on [samples] (filtered window W: W + M - 1).

        Returns
        -------
        ndarray, shape (6,) or (k, 6), bool
        """
        t_arr = np.asarray(t, dtype=np.int64)
        rows = self._row_last_invalid
        if rows is None:
            last = self.last_invalid if t_arr.ndim == 0 else \
                np.broadcast_to(self.last_invalid, t_arr.shape + (N_CHANNELS,))
        else:
            last = rows[np.clip(t_arr - self._first_index, 0, rows.shape[0] - 1)]
        return last >= (t_arr - reach + 1)[..., None] if t_arr.ndim else last >= t_arr - reach + 1

    def any_masked_since(self, t: int, reach: int) -> bool:
        """True if a window of reach ``reach`` ending at any sample >= t may be masked (cheap)."""
        return self.last_invalid_max >= t - reach + 1


#: Diagnostic levels (the values of diagnostic_msgs/DiagnosticStatus OK, WARN, ERROR).
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2


def channel_report(health: ChannelHealth, previous: tuple | None, fs: float
                   ) -> tuple[list[tuple[int, str, dict[str, str]]], tuple]:
    """Per-channel diagnostics for one diagnostics period.

    Parameters
    ----------
    health : ChannelHealth
    previous : tuple or None
        The second return value of the previous call (None: first period).
    fs : float
        Sampling rate [Hz] (for the stuck duration).

    Returns
    -------
    reports : list of 6 (level, message, values)
        ERROR when invalid values arrived in this period, else WARN when the channel is stuck
        or had values at the rail in this period, else OK; values hold the counts.
    snapshot : tuple
        Pass it as ``previous`` next period.
    """
    counts = (health.non_finite.copy(), health.out_of_range.copy(), health.railed.copy())
    if previous is None or previous[0] is not health:
        before = (np.zeros(N_CHANNELS, np.int64),) * 3
    else:
        before = previous[1]
    runs = health.constant_run
    reports = []
    for c in range(N_CHANNELS):
        new_non_finite = int(counts[0][c] - before[0][c])
        new_out_of_range = int(counts[1][c] - before[1][c])
        new_railed = int(counts[2][c] - before[2][c])
        stuck = bool(runs[c] >= health.stuck_samples)
        problems = []
        if new_non_finite:
            problems.append(f'{new_non_finite} NaN/inf values')
        if new_out_of_range:
            problems.append(f'{new_out_of_range} values beyond +-{health.input_limit:g}')
        level = LEVEL_ERROR if problems else LEVEL_OK
        if stuck:
            problems.append(f'stuck: constant for {runs[c] / fs:.1f} s')
        if new_railed:
            problems.append(f'{new_railed} values at the rail')
        if level == LEVEL_OK and problems:
            level = LEVEL_WARN
        values = {
            'non-finite values': str(int(counts[0][c])),
            'out-of-range values': str(int(counts[1][c])),
            'railed values': str(int(counts[2][c])),
            'invalid values this period': str(new_non_finite + new_out_of_range),
            'constant for [s]': f'{runs[c] / fs:.3f}',
            'stuck': str(stuck),
        }
        reports.append((level, '; '.join(problems) if problems else 'ok', values))
    return reports, (health, counts)
