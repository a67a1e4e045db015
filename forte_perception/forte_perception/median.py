"""Causal running median per channel (FORTE paper: median filter of size M = 11).

Output sample ``t`` is the median of input samples ``max(0, t - M + 1) .. t`` of that channel.
For the first ``M - 1`` samples after a reset the window holds only the samples seen so far
(1, 2, ..., M - 1 of them); for an even count the median is the mean of the two middle values
(``numpy.median`` convention). The filter delays a step by ``(M - 1) / 2`` samples (2.5 ms at
M = 11, 2 kHz).

Streaming and batch results are bit-for-bit equal: the median of an odd window is one of its
samples (no arithmetic), and the start-up windows are computed by the same code.
"""
from __future__ import annotations

import numpy as np

__all__ = ['MEDIAN_WINDOW', 'RunningMedian', 'running_median']

#: The paper's median filter length M [samples]: the default of the pipeline, the force
#: calibration and the offline slip tools.
MEDIAN_WINDOW = 11


class RunningMedian:
    """Streaming causal median filter over the last ``window`` samples of each column.

    Parameters
    ----------
    window : int
        Window length M [samples], >= 1.
    channels : int
        Number of columns.
    """

    def __init__(self, window: int = 11, channels: int = 6) -> None:
        if int(window) != window or window < 1:
            raise ValueError(f'median window must be an integer >= 1, got {window}')
        self.window = int(window)
        self.channels = int(channels)
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next sample starts a new start-up phase."""
        self._tail = np.zeros((0, self.channels))

    def update(self, frames: np.ndarray) -> np.ndarray:
        """Filter a chunk.

        Parameters
        ----------
        frames : ndarray, shape (n, channels)

        Returns
        -------
        ndarray, shape (n, channels)
            Filtered samples aligned with the input rows.
        """
        x = np.asarray(frames, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.channels:
            raise ValueError(f'frames must have shape (n, {self.channels}), got {x.shape}')
        n = x.shape[0]
        if n == 0:
            return np.zeros((0, self.channels))
        m = self.window
        ext = np.concatenate([self._tail, x], axis=0)
        h = self._tail.shape[0]
        out = np.empty((n, self.channels))
        # start-up rows: fewer than m samples available
        n_short = max(0, min(n, m - 1 - h))
        for i in range(n_short):
            out[i] = np.median(ext[:h + i + 1], axis=0)
        if n_short < n:
            first = h + n_short  # index in ext of the first row with a full window
            # (rows, channels, m) windows of ext[first - m + 1:]: a strided view, no copy
            # (what sliding_window_view builds, without its argument handling per call)
            base = ext[first - m + 1:]
            rows, (row_stride, column_stride) = n - n_short, base.strides
            view = np.lib.stride_tricks.as_strided(
                base, (rows, self.channels, m), (row_stride, column_stride, row_stride),
                writeable=False)
            out[n_short:] = np.partition(view, m // 2, axis=-1)[..., m // 2] if m % 2 else \
                np.median(view, axis=-1)
        self._tail = ext[-(m - 1):].copy() if m > 1 else np.zeros((0, self.channels))
        return out


def running_median(frames: np.ndarray, window: int = 11) -> np.ndarray:
    """Batch causal running median; equal to :class:`RunningMedian` fed in any chunks.

    Parameters
    ----------
    frames : ndarray, shape (n, c)
    window : int
        Window length M [samples].

    Returns
    -------
    ndarray, shape (n, c)
    """
    x = np.asarray(frames, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f'frames must be 2-D (n, c), got {x.shape}')
    filt = RunningMedian(window, x.shape[1])
    block = 1 << 16
    return np.concatenate([filt.update(x[i:i + block]) for i in range(0, x.shape[0], block)]
                          or [np.zeros((0, x.shape[1]))], axis=0)
