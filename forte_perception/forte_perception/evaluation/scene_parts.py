"""Shared parts of the signal-level slip scenes (:mod:`forte_perception.evaluation.scenes`):
the set's constants, the finger profiles, the draft a family builds, the quantiser and the
stick-slip burst of the first families. Split out of ``scenes`` (size); its docstring
describes them."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from forte_perception.evaluation.labels import (
    SPLITS,
)
from forte_ros.contract import QUANTUM as LSB
from forte_ros.contract import SAMPLE_RATE as FS

SET_VERSION = 2

DRIFT_LSB_PER_SQRT_S = 0.27
DETECTOR_REACH = 0.25     # [s] a distractor stays in the detector's window this long
SLIP_GRACE = 0.5          # [s] after a slip event ends, flags still count as true
LIFT_VELOCITY = 0.005     # [m/s] commanded arm velocity while lifting
GRIP_ANGLE = 0.3          # [rad] commanded servo angle while holding
SEEDS_PER_SPLIT = 4
_NOISE = (1.0, 2.0)
_NORMAL_BASE = np.array([0.026, 0.016, 0.010])
_CENTRES = np.array([0.15, 0.50, 0.85])
_TRIM = np.array([[1.00, 0.94, 1.07], [1.05, 0.97, 0.92]])
_SHEAR = np.array([1.0, 0.6, -0.5])
_VIBRATION = np.array([1.0, 0.667, 0.417])
_SHEAR_PER_RING = 1.0 / 30.0   # static shear step / ringing per release (0.004 / 0.12)


@dataclass(frozen=True)
class FingerProfile:
    """A finger / contact configuration: the "object" of the signal-level split.

    Attributes
    ----------
    name : str
    contact : float
        Contact location along the finger, 0 = tip, 1 = root [-].
    resonance_hz : float
        Bending mode rung by stick-slip releases [Hz].
    damping : float
        Damping ratio of that mode [-].
    coupling : float
        Fraction of a release the other finger feels through the object [-].
    grip_lsb : float
        Static grip reading on the strongest channel [LSB].
    """

    name: str
    contact: float
    resonance_hz: float
    damping: float
    coupling: float
    grip_lsb: float

    @property
    def split(self) -> str:
        """'tune' for p0, p2, ...; 'held_out' for p1, p3, ..."""
        return SPLITS[int(self.name[1:]) % 2]

    def pattern(self, kind: str) -> np.ndarray:
        """Channel pattern (2, 3) of 'normal', 'shear' or 'vibration', strongest |value| 1."""
        if kind == 'normal':
            kernel = 0.55 + 0.45 * np.exp(-((self.contact - _CENTRES) / 0.35) ** 2)
            base = _NORMAL_BASE * kernel
        elif kind == 'shear':
            base = _SHEAR
        else:
            base = _VIBRATION
        p = base[None, :] * _TRIM
        return p / np.abs(p).max(axis=1, keepdims=True)


PROFILES = (
    FingerProfile('p0', 0.20, 14.0, 0.08, 0.50, 120.0),
    FingerProfile('p1', 0.30, 17.0, 0.10, 0.60, 200.0),
    FingerProfile('p2', 0.40, 20.0, 0.12, 0.40, 300.0),
    FingerProfile('p3', 0.50, 23.0, 0.07, 0.70, 80.0),
    FingerProfile('p4', 0.60, 26.0, 0.10, 0.55, 250.0),
    FingerProfile('p5', 0.70, 29.0, 0.09, 0.45, 150.0),
    FingerProfile('p6', 0.35, 33.0, 0.11, 0.65, 180.0),
    FingerProfile('p7', 0.45, 38.0, 0.08, 0.50, 100.0),
)
_PROFILE = {p.name: p for p in PROFILES}


@dataclass
class _Draft:
    """What a family adds to the background: signal [LSB], labels, context, parameters."""

    signal: np.ndarray
    events: list[tuple[int, int, int, str, float]] = field(default_factory=list)
    busy: list[tuple[int, int]] = field(default_factory=list)
    servo: np.ndarray | None = None
    arm: np.ndarray | None = None
    params: dict = field(default_factory=dict)
    disturbance: np.ndarray | None = None   # hum, drift: left out of noise-free scenes


def quantise_lsb(x_lsb: np.ndarray) -> np.ndarray:
    """Values in LSB -> normalised 11-bit readings (round to the grid, clip to the ADC)."""
    return np.clip(np.rint(x_lsb), -1024, 1023) * LSB


def _loguniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def _both(pattern: np.ndarray, series: np.ndarray, weights=(1.0, 1.0)) -> np.ndarray:
    """(n, 6) from a (2, 3) pattern and a (n,) series, finger weights (left, right)."""
    w = np.repeat(np.asarray(weights, float), 3) * pattern.reshape(6)
    return series[:, None] * w[None, :]


def _resonator(frequency: float, damping: float) -> tuple[np.ndarray, np.ndarray]:
    """Unit-DC-gain 2nd-order low-pass resonator (bilinear, prewarped), as the simulator."""
    omega = 2.0 * FS * math.tan(math.pi * frequency / FS)
    k = 2.0 * FS
    a0 = k * k + 2.0 * damping * omega * k + omega * omega
    b = np.array([1.0, 2.0, 1.0]) * omega * omega / a0
    a = np.array([1.0, (2.0 * omega * omega - 2.0 * k * k) / a0,
                  (k * k - 2.0 * damping * omega * k + omega * omega) / a0])
    return b, a


def burst_component(n: int, onset: int, duration: float, rate_hz: float,
                    resonance_hz: float, damping: float, strength: float,
                    rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, int]:
    """One stick-slip burst on one finger's strongest channel.

    Returns
    -------
    ringing : ndarray (n,)
        Bending-mode ringing, peak ``|ringing|`` = ``strength`` [LSB].
    static : ndarray (n,)
        The static shear steps (negative, 1/30 of the ringing per release) [LSB].
    last : int
        Sample of the last release.
    """
    times, t = [], float(onset)
    while t < onset + duration * FS:
        times.append(int(t))
        t += max(FS / rate_hz * rng.uniform(0.8, 1.2), FS / 50.0)
    drive = np.zeros(n)
    np.add.at(drive, np.array(times), rng.uniform(0.7, 1.3, len(times)))
    drive = np.cumsum(drive)
    b, a = _resonator(resonance_hz, damping)
    ringing = lfilter(b, a, drive) - drive
    scale = strength / np.abs(ringing).max()
    return ringing * scale, -drive * scale * _SHEAR_PER_RING, times[-1]
