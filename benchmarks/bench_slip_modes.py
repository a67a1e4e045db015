"""CPU per slip update of each slip mode, against the paper mode in the same run (issue 26's
budget: within 2x the paper mode's).

Two measurements, single-threaded, the least disturbed of ``--rounds`` rounds each:

- the detector alone, streaming: the paper mode's PSD detector
  (:class:`~forte_perception.slip.detector.SlipDetector`, the baseline), the robust mode's,
  and the sequential detector (:class:`~forte_perception.slip.sequential.SequentialDetector`,
  with its slipping state);
- the perception pipeline's slip step (``PerceptionPipeline._update_slip``: detector, masks
  and slipping state) of each mode, as the node runs it, and the whole pipeline per chunk.

Input: a grasp-like 2 kHz recording (``bench_perception.sensor_recording``: quantised
noise, presses, slips) median-filtered once, streamed in 20-sample chunks (one sensor
message, 5 updates at hop 4). Run from the repository root with the environment sourced::

    python benchmarks/bench_slip_modes.py [--seconds 60] [--rounds 3]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_perception import sensor_recording, threadpool_limits  # noqa: E402

from forte_perception.median import MEDIAN_WINDOW, running_median  # noqa: E402
from forte_perception.pipeline import PerceptionPipeline, PipelineConfig  # noqa: E402
from forte_perception.slip.detector import SlipDetector, SlipParams  # noqa: E402
from forte_perception.slip.sequential import SequentialDetector  # noqa: E402
from forte_ros.contract import SAMPLE_RATE as FS  # noqa: E402

CHUNK = 20
MODES = ('paper', 'robust', 'sequential')


def stream(update: Callable[[np.ndarray], object], x: np.ndarray) -> float:
    """CPU time [s] of ``update`` over ``x`` in :data:`CHUNK`-sample chunks."""
    started = time.process_time()
    for i in range(0, x.shape[0], CHUNK):
        update(x[i:i + CHUNK])
    return time.process_time() - started


def detector_update(mode: str) -> Callable[[np.ndarray], object]:
    """A fresh streaming detector of ``mode``: its ``update(filtered_chunk)``."""
    if mode == 'sequential':
        return SequentialDetector(FS, SlipParams().hop).update
    return SlipDetector(FS, SlipParams(mode=mode).features).update


def pipeline_costs(mode: str, raw: np.ndarray) -> tuple[float, float]:
    """CPU time [s] of the slip step and of the whole pipeline over ``raw``."""
    pipeline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode=mode)))
    slip_step = pipeline._update_slip
    spent = [0.0]

    def timed(filtered: np.ndarray, first_index: int) -> bool:
        started = time.process_time()
        try:
            return slip_step(filtered, first_index)
        finally:
            spent[0] += time.process_time() - started
    pipeline._update_slip = timed
    whole = stream(pipeline.process, raw)
    return spent[0], whole


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=60.0, help='recording length [s]')
    parser.add_argument('--rounds', type=int, default=3, help='rounds; the least CPU counts')
    args = parser.parse_args()
    raw = sensor_recording(args.seconds, seed=1)
    filtered = running_median(raw, MEDIAN_WINDOW)
    updates = raw.shape[0] // SlipParams().hop
    detector = dict.fromkeys(MODES, np.inf)
    step = dict.fromkeys(MODES, np.inf)
    whole = dict.fromkeys(MODES, np.inf)
    with threadpool_limits(1):
        for _ in range(args.rounds):  # modes alternate within a round (shared machines)
            for mode in MODES:
                detector[mode] = min(detector[mode], stream(detector_update(mode), filtered))
                slip_seconds, all_seconds = pipeline_costs(mode, raw)
                step[mode] = min(step[mode], slip_seconds)
                whole[mode] = min(whole[mode], all_seconds)
    per_update = 1e6 / updates
    print(f'## CPU per slip update: {args.seconds:.0f} s at {FS:.0f} Hz, {updates} updates '
          f'(hop {SlipParams().hop}), {CHUNK}-sample chunks, best of {args.rounds} rounds')
    print('| mode | detector [us/update] | x paper | pipeline slip step [us/update] | '
          'x paper | whole pipeline [us/update] | x paper |')
    print('|---|---|---|---|---|---|---|')
    for mode in MODES:
        print(f'| {mode} | {detector[mode] * per_update:.2f} | '
              f'{detector[mode] / detector["paper"]:.2f} | {step[mode] * per_update:.2f} | '
              f'{step[mode] / step["paper"]:.2f} | {whole[mode] * per_update:.2f} | '
              f'{whole[mode] / whole["paper"]:.2f} |')
    print(f'sequential slip step / paper detector alone (the paper mode before the slipping '
          f'state): {step["sequential"] / detector["paper"]:.2f}x')


if __name__ == '__main__':
    main()
