"""Sensor noise generated in fixed blocks, so that any chunking yields the same stream.

Every block of :data:`NOISE_BLOCK` samples draws from its own generator seeded by
(seed, stream, block index); the stateful parts (low-frequency AR(1) noise, drift random
walk) carry their state from block to block in order. Reading samples [a, b) therefore
returns the same numbers however the reads are split.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from forte_ros.contract import SAMPLE_RATE
from forte_sim.model import GripperModel

#: Samples per noise block (1.024 s at 2 kHz).
NOISE_BLOCK = 2048

_NOISE_STREAM = 0x5E45


class SensorNoise:
    """Additive sensor noise of the 6 channels: white, low-frequency, drift, impulses.

    Parameters
    ----------
    model : GripperModel
        Noise amplitudes.
    seed : int
        Seed of the scene.
    channels : int
        Number of channels.
    """

    def __init__(self, model: GripperModel, seed: int, channels: int = 6) -> None:
        self._model = model
        self._seed = int(seed)
        self._channels = channels
        pole = math.exp(-1.0 / (model.low_frequency_time * SAMPLE_RATE))
        self._ar_b = np.array([model.low_frequency_noise * math.sqrt(1.0 - pole * pole)])
        self._ar_a = np.array([1.0, -pole])
        self._ar_state = np.zeros((1, channels))
        self._drift = np.zeros(channels)
        self._drift_step = model.drift_per_sqrt_second / math.sqrt(SAMPLE_RATE)
        self._blocks: dict[int, np.ndarray] = {}
        self._next_block = 0

    def _generate(self, block: int) -> np.ndarray:
        model = self._model
        rng = np.random.default_rng((self._seed, _NOISE_STREAM, block))
        shape = (NOISE_BLOCK, self._channels)
        white = rng.standard_normal(shape) * model.white_noise
        excitation = rng.standard_normal(shape)
        low, self._ar_state = lfilter(self._ar_b, self._ar_a, excitation, axis=0,
                                      zi=self._ar_state)
        steps = rng.standard_normal(shape) * self._drift_step
        drift = np.cumsum(steps, axis=0) + self._drift
        self._drift = drift[-1].copy()
        noise = white + low + drift
        expected = model.impulse_rate * self._channels * NOISE_BLOCK / SAMPLE_RATE
        count = int(rng.poisson(expected))
        if count:
            rows = rng.integers(0, NOISE_BLOCK, count)
            columns = rng.integers(0, self._channels, count)
            low_amp, high_amp = model.impulse_amplitude
            amplitudes = rng.uniform(low_amp, high_amp, count) * rng.choice((-1.0, 1.0), count)
            noise[rows, columns] += amplitudes
        return noise

    def read(self, start: int, stop: int) -> np.ndarray:
        """Noise of samples [start, stop).

        Parameters
        ----------
        start, stop : int
            Sample indices since the scene started; must not go backwards past blocks
            that were already discarded (the scene reads forward only).

        Returns
        -------
        numpy.ndarray, shape (stop - start, channels)
        """
        first_block = start // NOISE_BLOCK
        last_block = (stop - 1) // NOISE_BLOCK
        while self._next_block <= last_block:
            self._blocks[self._next_block] = self._generate(self._next_block)
            self._next_block += 1
        for old in [key for key in self._blocks if key < first_block]:
            del self._blocks[old]
        if first_block == last_block:
            offset = first_block * NOISE_BLOCK
            return self._blocks[first_block][start - offset:stop - offset]
        parts = []
        for block in range(first_block, last_block + 1):
            offset = block * NOISE_BLOCK
            lo = max(start, offset) - offset
            hi = min(stop, offset + NOISE_BLOCK) - offset
            parts.append(self._blocks[block][lo:hi])
        return np.concatenate(parts, axis=0)


#: Samples per block of load cell noise (1 s at 2 kHz).
LOAD_CELL_BLOCK = 2000

_LOAD_CELL_STREAM = 0x10AD


def load_cell_reading(force: np.ndarray, first_sample: int, seed: int,
                      noise_std: float) -> np.ndarray:
    """Load cell reading: the true force plus noise drawn in fixed blocks.

    Every block of :data:`LOAD_CELL_BLOCK` samples draws from its own generator seeded by
    (seed, stream, block index), so any chunking yields the same stream.

    Parameters
    ----------
    force : numpy.ndarray, shape (n,)
        True force of samples [first_sample, first_sample + n) [N].
    first_sample : int
        Sample index of the first row since the scene started.
    seed : int
        Seed of the scene.
    noise_std : float
        Standard deviation of the load cell noise [N].

    Returns
    -------
    numpy.ndarray, shape (n,)
    """
    noise = np.empty_like(force)
    block = LOAD_CELL_BLOCK
    stop = first_sample + len(force)
    position = first_sample
    while position < stop:
        block_index = position // block
        block_start = block_index * block
        rng = np.random.default_rng((seed, _LOAD_CELL_STREAM, block_index))
        values = rng.standard_normal(block) * noise_std
        lo = position - block_start
        hi = min(stop, block_start + block) - block_start
        noise[position - first_sample:position - first_sample + hi - lo] = values[lo:hi]
        position = block_start + hi
    return force + noise
