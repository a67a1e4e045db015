"""Fingerprint of the slip detector's outputs, to prove a change leaves a mode bit for bit.

Hashes (SHA-256 of the raw bytes) every output array of
:func:`forte_perception.slip.detector.slip_features`, of
:class:`~forte_perception.slip.detector.SlipDetector` fed in odd chunks, of
:func:`~forte_perception.slip.detector.slip_features_reference` and of the
:class:`~forte_perception.pipeline.PerceptionPipeline` (per-chunk slip, activity, finger
variances, PSD and filtered values, with one masked stretch) on seeded signals: quiet and
quantised (below 1 LSB of noise), slip-like bursts on all channels, one-finger bursts, a
ramp with a step, and random walks. Run it before and after a change and compare::

    python tools/slip_fingerprint.py > before.txt
    ... change ...
    python tools/slip_fingerprint.py > after.txt && diff before.txt after.txt

``--mode`` picks the :class:`~forte_perception.slip.detector.SlipParams` mode (default: the
dataclass default, i.e. whatever a caller who passes no mode gets).
"""
from __future__ import annotations

import argparse
import hashlib
import sys

import numpy as np
from scipy import signal

from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.slip.detector import (
    SlipDetector,
    SlipFeatures,
    SlipParams,
    slip_features,
    slip_features_reference,
)
from forte_ros.contract import FINGER_CHANNELS
from forte_ros.contract import QUANTUM as LSB
from forte_ros.contract import SAMPLE_RATE as FS


def _quantise(x: np.ndarray) -> np.ndarray:
    return np.clip(np.round(x / LSB) * LSB, -1.0, 1.0 - LSB)


def _bursts(n: int, rng: np.random.Generator, channels, onsets, amp: float) -> np.ndarray:
    b, a = signal.butter(4, [10.0, 50.0], btype='band', fs=FS)
    x = np.zeros((n, 6))
    for onset in onsets:
        k = np.arange(n) - onset
        live = (k >= 0) & (k < 0.2 * FS)
        env = np.where(live, amp * 10.0 ** (300.0 * np.clip(k, 0, None) / FS / 20.0 - 3.0), 0.0)
        for c in channels:
            burst = signal.lfilter(b, a, rng.normal(size=n))
            x[:, c] += env * burst / burst.std()
    return x


def signals() -> dict[str, np.ndarray]:
    """Seeded test signals (n, 6), normalised units."""
    out = {}
    n = 12000
    for seed in range(3):
        rng = np.random.default_rng(100 + seed)
        out[f'quiet_sub_lsb_{seed}'] = _quantise(0.3 + rng.normal(size=(n, 6)) * 0.4 * LSB)
        rng = np.random.default_rng(200 + seed)
        out[f'bursts_all_{seed}'] = _quantise(
            0.2 + rng.normal(size=(n, 6)) * 1.5 * LSB
            + _bursts(n, rng, range(6), (3000, 7000, 10000), 40 * LSB))
        rng = np.random.default_rng(300 + seed)
        out[f'bursts_left_{seed}'] = _quantise(
            0.1 + rng.normal(size=(n, 6)) * 1.5 * LSB
            + _bursts(n, rng, FINGER_CHANNELS[0], (2500, 8000), 60 * LSB))
        rng = np.random.default_rng(400 + seed)
        ramp = np.clip((np.arange(n) - 4000) / 4000.0, 0, 1)[:, None] * 80 * LSB
        step = (np.arange(n) >= 9000)[:, None] * 30 * LSB
        out[f'ramp_step_{seed}'] = _quantise(0.0 + ramp + step + rng.normal(size=(n, 6)) * LSB)
        rng = np.random.default_rng(500 + seed)
        out[f'walk_{seed}'] = (np.cumsum(rng.normal(size=(n, 6)), axis=0) * 1e-3
                               + rng.normal(size=(n, 6)) * 1e-3)
    return out


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a))
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:24]


def _features_digest(res) -> str:
    return _digest(res.sample_index, res.psd_max_db, res.channel_variance,
                   res.finger_variance, res.slip, res.active)


def _chunked(x: np.ndarray, params: SlipParams) -> str:
    det = SlipDetector(FS, params)
    parts, i, sizes = [], 0, (1, 7, 13, 333, 2, 1999, 5)
    k = 0
    while i < x.shape[0]:
        step = sizes[k % len(sizes)]
        parts.append(det.update(x[i:i + step]))
        i += step
        k += 1
    return _features_digest(SlipFeatures.concatenate(parts))


def _pipeline(x: np.ndarray, params: SlipParams) -> str:
    pipe = PerceptionPipeline(PipelineConfig(slip=params))
    x = x.copy()
    x[5000:5010, 1] = np.nan  # one masked stretch (channel health and slip mask)
    rows = []
    for i in range(0, x.shape[0], 37):
        o = pipe.process(x[i:i + 37])
        rows.append(np.concatenate([[o.slip, o.slip_active, o.slip_updates,
                                     o.slip_sample_index], np.ravel(o.finger_variance),
                                    np.ravel(o.psd_max_db), np.ravel(o.filtered)]))
    return _digest(np.array(rows, np.float64))


def fingerprint(params: SlipParams, reference: bool = True) -> dict[str, str]:
    """name -> digest of every output on every signal."""
    out = {}
    for name, x in signals().items():
        out[f'{name} slip_features'] = _features_digest(slip_features(x, FS, params))
        out[f'{name} detector_chunks'] = _chunked(x, params)
        if reference:
            out[f'{name} reference'] = _features_digest(
                slip_features_reference(x, FS, params, vectorized=True))
        out[f'{name} pipeline'] = _pipeline(x, params)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--mode', default=None, help='SlipParams mode (default: default)')
    args = parser.parse_args(argv)
    params = SlipParams() if args.mode is None else SlipParams(mode=args.mode)
    for key, value in fingerprint(params).items():
        print(f'{key}: {value}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
