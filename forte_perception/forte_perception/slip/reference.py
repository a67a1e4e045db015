"""The straightforward slip features: a ``scipy.signal.welch`` PSD of every window.

The definition the fast :class:`~forte_perception.slip.detector.SlipDetector` is measured against
(tests, benchmarks), and the PSD its guarded decisions are re-made from.
"""
from __future__ import annotations

import numpy as np
from scipy import signal

from forte_perception.slip.decision import decide_updates
from forte_perception.slip.params import SlipFeatures, SlipParams, check_frames
from forte_perception.slip.robust import level_shift_veto
from forte_ros.contract import N_CHANNELS, SAMPLE_RATE

__all__ = ['reference_psd_max_db', 'slip_features_reference']


def reference_psd_max_db(window: np.ndarray, fs: float, params: SlipParams) -> np.ndarray:
    """Straightforward PSD feature of one window with ``scipy.signal.welch``.

    Parameters
    ----------
    window : ndarray, shape (N, 6)
    fs : float
        Sampling rate [Hz].
    params : SlipParams

    Returns
    -------
    ndarray, shape (6,)
        ``max over f_min <= f <= f_max of 10*log10(P + eps)`` [dB re 1/Hz].
    """
    n = int(params.window)
    f, p = signal.welch(window, fs=fs, window='hann', nperseg=n, noverlap=0,
                        detrend='constant', return_onesided=True, scaling='density', axis=0)
    band = (f >= params.f_min) & (f <= params.f_max)
    return np.max(10.0 * np.log10(p[band] + params.psd_floor(fs)), axis=0)


def slip_features_reference(frames: np.ndarray, fs: float = SAMPLE_RATE,
                            params: SlipParams | None = None,
                            vectorized: bool = False) -> SlipFeatures:
    """The straightforward baseline: a Welch PSD of every window at every update.

    Same signature and output as :func:`slip_features`; used by the tests and benchmarks.

    Parameters
    ----------
    vectorized : bool
        False: one ``scipy.signal.welch`` call per window (the definition, and what guarded
        decisions use). True: welch over blocks of stacked windows (much faster; FFT
        batching may change the last bits, ~1e-14 dB).
    """
    params = params or SlipParams()
    params.validate(fs)
    x = check_frames(frames)
    n, hop = int(params.window), int(params.hop)
    if x.shape[0] < n:
        return SlipFeatures()
    ends = np.arange(n - 1, x.shape[0], hop)
    floor = params.psd_floor(fs)
    psd = np.empty((ends.size, N_CHANNELS))
    if vectorized:
        windows = np.lib.stride_tricks.sliding_window_view(x, n, axis=0)[::hop]  # (m, 6, N)
        for b in range(0, ends.size, 2000):
            f, p = signal.welch(windows[b:b + 2000], fs=fs, window='hann', nperseg=n,
                                noverlap=0, detrend='constant', scaling='density', axis=-1)
            band = (f >= params.f_min) & (f <= params.f_max)
            psd[b:b + 2000] = np.max(10.0 * np.log10(p[..., band] + floor), axis=-1)
    else:
        for i, t in enumerate(ends):
            psd[i] = reference_psd_max_db(x[t - n + 1:t + 1], fs, params)
    cv, fv, sl, act, _ = decide_updates(np.ascontiguousarray(psd.T), 0, params,
                                        np.zeros((N_CHANNELS, 0)))
    fv = fv.T
    veto = level_shift_veto(x, 0, ends, psd, sl, params, fs)  # robust mode only
    sl[veto] = False
    fv[veto] = 0.0
    return SlipFeatures(ends.astype(np.int64), psd, cv.T, fv, sl, act)

