"""Synthetic test signals shared by the perception tests (deterministic, seeded)."""
from __future__ import annotations

import numpy as np

from forte_ros.contract import QUANTUM
from forte_ros.contract import SAMPLE_RATE as FS  # [Hz], the name the signal tests use

__all__ = ['FS', 'SWEEP_DISTRACTORS', 'SWEEP_SAMPLES', 'SWEEP_SLIPS', 'band_bursts',
           'known_answer_recording', 'quantise', 'random_walk', 'ringing_after_a_step',
           'slip_bursts', 'tightening', 'tightening_then_slip']


def random_walk(n: int, seed: int = 0, scale: float = 1e-3) -> np.ndarray:
    """Brownian drift plus white noise, (n, 6)."""
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=(n, 6)), axis=0) * scale + rng.normal(size=(n, 6)) * scale


def slip_bursts(n: int, seed: int = 0, onsets: tuple[int, ...] = (6000, 16000),
                growth_db_per_s: float = 600.0, duration: float = 0.12,
                noise: float = 2e-4) -> np.ndarray:
    """Quiet noise with bursts whose 25 Hz power rises exponentially (a slip-like PSD rise).

    Every channel gets the burst (so both finger groups pass the alpha gate), each with its
    own phase and gain.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    x = rng.normal(size=(n, 6)) * noise
    for onset in onsets:
        k = np.arange(n) - onset
        on = (k >= 0) & (k < duration * FS)
        amp = np.zeros(n)
        amp[on] = 1e-3 * 10.0 ** (growth_db_per_s * k[on] / FS / 20.0)
        for c in range(6):
            gain = 0.6 + 0.1 * c
            x[:, c] += gain * amp * np.sin(2 * np.pi * 25.0 * t + rng.uniform(0, 2 * np.pi))
    return x


def quantise(x: np.ndarray) -> np.ndarray:
    """11-bit normalised quantisation (step 2/2048), clipped to [-1, 1]."""
    return np.clip(np.round(x * 1024.0) / 1024.0, -1.0, 1.0 - 1.0 / 1024.0)


def band_bursts(n: int, channels=range(6), onsets: tuple[int, ...] = (3000, 6000, 9000),
                seed: int = 0, growth_db_per_s: float = 250.0, duration: float = 0.15,
                offset: float = 0.2, noise: float = 4e-4) -> np.ndarray:
    """A quiet in-range signal with band-limited (10-50 Hz, 4th-order Butterworth) noise
    bursts of exponentially rising power on ``channels`` (slip-like), (n, 6).

    Peak magnitude stays well inside [-1, 1] at the defaults (about 0.5).
    """
    from scipy import signal
    rng = np.random.default_rng(seed)
    b, a = signal.butter(4, [10.0, 50.0], btype='band', fs=FS)
    x = offset + rng.normal(size=(n, 6)) * noise
    for onset in onsets:
        k = np.arange(n) - onset
        live = (k >= 0) & (k < duration * FS)
        envelope = np.zeros(n)
        envelope[live] = 2e-3 * 10.0 ** (growth_db_per_s * k[live] / FS / 20.0)
        for c in channels:
            burst = signal.lfilter(b, a, rng.normal(size=n))
            x[:, c] += envelope * burst / burst.std()
    return x


def ringing_after_a_step(n: int = 12000, at: int = 8000) -> np.ndarray:
    """Quantised noise on a held grip, and a 30 ms 40 LSB 25 Hz ringing at ``at``."""
    rng = np.random.default_rng(1)
    lsb = rng.normal(0.0, 1.0, (n, 6)) + 300.0
    t = np.arange(n) / 2000.0
    ring = 40.0 * np.sin(2 * np.pi * 25.0 * t)
    ring[:at] = 0.0
    ring[at + 60:] = 0.0
    return np.round(lsb + ring[:, None]) * QUANTUM


def tightening(n: int, at: int) -> np.ndarray:
    """A servo tightening's pressure from sample ``at`` [LSB], (n,): the level rises 60 LSB
    over 15 ms (0.0154 rad at 1 rad/s) and the fingers ring at 25 Hz, 40 LSB, for 30 ms."""
    k = np.arange(n) - at
    ring = np.where((k >= 0) & (k < 60), 40.0 * np.sin(2 * np.pi * 25.0 * k / FS), 0.0)
    return np.clip(k / 30.0, 0.0, 1.0) * 60.0 + ring


def tightening_then_slip(n: int = 12000, at: int = 8000, slip_at: int | None = 8260,
                         amplitude: float = 8.0) -> np.ndarray:
    """Quantised noise on a held grip, a :func:`tightening` at ``at`` and (unless None) a
    25 Hz stick-slip vibration of ``amplitude`` LSB on the left finger from ``slip_at``."""
    rng = np.random.default_rng(2)
    lsb = rng.normal(0.0, 1.0, (n, 6)) + 300.0 + tightening(n, at)[:, None]
    if slip_at is not None:
        t = np.arange(n - slip_at) / FS
        lsb[slip_at:, :3] += (amplitude * np.sin(2 * np.pi * 25.0 * t))[:, None]
    return np.round(lsb) * QUANTUM


#: The known-answer recording of the threshold-sweep tests: samples per trial, labelled
#: onsets (strong rises, 1000 dB/s) and unlabelled distractors (weak rises, 60 dB/s).
SWEEP_SAMPLES = 12000
SWEEP_SLIPS = (3000, 9000)
SWEEP_DISTRACTORS = (6000,)


def known_answer_recording():
    """Two trials of :data:`SWEEP_SAMPLES`: trial 0 has the labelled slips and a distractor,
    trial 1 only a distractor (a ``LabelledRecording`` named ``known.npz``). A threshold
    between the two kinds of rise finds the slips and nothing else."""
    from forte_perception.evaluation.labelled_recordings import LabelledRecording

    strong = slip_bursts(SWEEP_SAMPLES, seed=1, onsets=SWEEP_SLIPS, growth_db_per_s=1000.0)
    weak = slip_bursts(SWEEP_SAMPLES, seed=2, onsets=SWEEP_DISTRACTORS, growth_db_per_s=60.0,
                       noise=0.0)
    quiet_trial = slip_bursts(SWEEP_SAMPLES, seed=3, onsets=SWEEP_DISTRACTORS,
                              growth_db_per_s=60.0)
    frames = np.concatenate([strong + weak, quiet_trial]) + 0.1
    trial = np.repeat([0, 1], SWEEP_SAMPLES)
    return LabelledRecording(frames, FS, np.array(SWEEP_SLIPS), trial, name='known.npz')

