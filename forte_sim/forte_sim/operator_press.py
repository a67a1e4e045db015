"""A scripted operator who presses one finger with a thumb (pure, no rclpy).

Commissioning's guided press test (issue 24) asks the operator to press each finger alone,
at its tip and at its root: a symmetric close on a centred indentor moves both fingers
alike and cannot tell a swapped finger pair. In simulation and on the bench twin this
module plays that operator, with the simulator's own finger and sensor physics
(:mod:`forte_sim.model`):

- the thumb's force ``F(t)`` is a trapezoid: a ramp of ``ramp`` s up to ``force`` N, a
  hold of ``hold`` s, a ramp down (a hand presses smoothly);
- the finger deflects as its fin-ray spring at the pressed place: ``F = g s(u) (k1 d +
  k3 d^3)`` with ``s(u)`` :func:`~forte_sim.model.contact_stiffness_scale` and ``g = 1 +
  a1 + a2`` the unrelaxed stiffness of the standard linear solid (a press of a second
  or two leaves the relaxation branches where they were);
- the pressed finger's three channels read :func:`~forte_sim.model.channel_gains` at the
  pressed place times :func:`~forte_sim.model.pressure_response` of the deflection; the
  other finger feels nothing.

So a tip press reads distal > middle > root on the pressed finger, and a root press shifts
the response toward the root pair (in this model the distal pair still reads most, its base
gain being the largest; the root pair's share of the finger's response grows from about
0.13 to 0.27). The press adds to the scene's readings, which carry the sensor's offsets and
noise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from forte_ros.contract import FINGER_CHANNELS, N_CHANNELS, SAMPLE_RATE
from forte_sim.model import (
    DEFAULT_MODEL,
    GripperModel,
    channel_gains,
    contact_stiffness_scale,
    pressure_response,
)

__all__ = ['PRESS_LOCATIONS', 'OperatorPress', 'ScriptedOperator', 'press_deflection']

#: Where the operator presses, along the finger (0 = tip, 1 = root) [-]: the tip beside the
#: distal pair (centre 0.15), the root on the root pair (centre 0.85).
PRESS_LOCATIONS = {'tip': 0.10, 'root': 0.85}
#: Extent of a thumb's contact along the finger [-] (about 15 mm of a 150 mm finger).
THUMB_SPREAD = 0.10
_NEWTON_STEPS = 30


def press_deflection(model: GripperModel, force: np.ndarray, location: float) -> np.ndarray:
    """Finger deflection under a press of ``force`` at ``location`` [mm].

    Parameters
    ----------
    model : GripperModel
        Finger stiffness (``finger_k1``, ``finger_k3``, relaxation amplitudes).
    force : numpy.ndarray
        Press force [N] (>= 0), any shape.
    location : float
        Pressed place, 0 = tip, 1 = root [-].

    Returns
    -------
    numpy.ndarray
        Deflection [mm], same shape: the root of ``g s(u) (k1 d + k3 d^3) = F`` (Newton
        from the linear solution; the cubic is monotonic, so it converges).
    """
    force = np.maximum(np.asarray(force, dtype=np.float64), 0.0)
    stiffness = ((1.0 + sum(model.relaxation_amplitudes))
                 * contact_stiffness_scale(location))
    linear = model.finger_k1 * stiffness
    cubic = model.finger_k3 * stiffness
    deflection = force / linear
    for _ in range(_NEWTON_STEPS):
        residual = linear * deflection + cubic * deflection ** 3 - force
        deflection = deflection - residual / (linear + 3.0 * cubic * deflection ** 2)
    return deflection


@dataclass(frozen=True)
class OperatorPress:
    """One press of one finger.

    Attributes
    ----------
    finger : int
        0 = left, 1 = right (contract finger order).
    location : float
        Pressed place, 0 = tip, 1 = root [-].
    force : float
        Peak press force [N].
    start : int
        Sample index at which the force starts to rise [samples].
    ramp : float
        Rise and fall time [s].
    hold : float
        Time at the peak force [s].
    """

    finger: int
    location: float
    force: float = 4.0
    start: int = 0
    ramp: float = 0.25
    hold: float = 1.0

    def __post_init__(self) -> None:
        if self.finger not in (0, 1):
            raise ValueError(f'finger must be 0 (left) or 1 (right), got {self.finger}')
        if not 0.0 <= self.location <= 1.0:
            raise ValueError(f'location must be within 0..1, got {self.location}')
        for label, value in (('force', self.force), ('ramp', self.ramp),
                             ('hold', self.hold)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{label} must be finite and > 0, got {value}')

    @property
    def stop(self) -> int:
        """First sample after the press [samples]."""
        return self.start + int(math.ceil((2.0 * self.ramp + self.hold) * SAMPLE_RATE))

    def force_at(self, samples: np.ndarray) -> np.ndarray:
        """Press force at the sample indices ``samples`` [N] (0 outside the press)."""
        elapsed = (np.asarray(samples, dtype=np.float64) - self.start) / SAMPLE_RATE
        rise = np.clip(elapsed / self.ramp, 0.0, 1.0)
        fall = np.clip((2.0 * self.ramp + self.hold - elapsed) / self.ramp, 0.0, 1.0)
        return self.force * np.minimum(rise, fall)


class ScriptedOperator:
    """Presses scheduled on a sample clock; adds their channel pressures to a scan stream.

    Parameters
    ----------
    model : GripperModel
        Finger and sensor parameters (the scene's).
    """

    def __init__(self, model: GripperModel = DEFAULT_MODEL) -> None:
        self.model = model
        self._presses: list[OperatorPress] = []

    def schedule(self, press: OperatorPress) -> None:
        """Add a press (its ``start`` is a sample index of the stream)."""
        self._presses.append(press)

    @property
    def presses(self) -> tuple[OperatorPress, ...]:
        """Every press scheduled and not yet forgotten."""
        return tuple(self._presses)

    def busy_until(self) -> int:
        """First sample after the last scheduled press (0 without one) [samples]."""
        return max((press.stop for press in self._presses), default=0)

    def signal(self, first_sample: int, count: int) -> np.ndarray:
        """Channel pressures the presses add to samples [first, first + count).

        Returns
        -------
        numpy.ndarray, shape (count, 6)
            Normalised pressure of every channel (0 where nobody presses). Presses that
            ended before ``first_sample`` are forgotten (the stream reads forward only).
        """
        out = np.zeros((count, N_CHANNELS))
        self._presses = [press for press in self._presses if press.stop > first_sample]
        samples = np.arange(first_sample, first_sample + count)
        for press in self._presses:
            if press.start >= first_sample + count:
                continue
            deflection = press_deflection(self.model, press.force_at(samples), press.location)
            gains = channel_gains(self.model, press.location, THUMB_SPREAD, press.finger)
            columns = list(FINGER_CHANNELS[press.finger])
            out[:, columns] += pressure_response(self.model, deflection)[:, None] * gains
        return out
