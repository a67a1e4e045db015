"""A commissioning session played on the simulator, without ROS (pure, no rclpy).

Runs a list of :class:`SessionStep` (the procedure's protocol: rest with the gripper open,
an operator's press on one finger, a squeeze held on the rig's indentor) on a
``calibration`` scene (:func:`forte_sim.make_scene`: the rig's fixed indentor between
the fingers, no object dynamics), adds the scripted operator's presses
(:mod:`forte_sim.operator_press`) and applies injected sensor faults
(:mod:`forte_sim.channel_faults`) to the readings, exactly as the bench twin
does in real time. Returns the raw readings and the sample span of every step, what a
recording of the live procedure holds.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from forte_ros.contract import SAMPLE_RATE
from forte_sim.channel_faults import ChannelFault, ChannelFaultInjector
from forte_sim.model import quantise
from forte_sim.operator_press import OperatorPress, ScriptedOperator
from forte_sim.scene import make_scene

__all__ = ['SESSION_ACTIONS', 'SessionStep', 'SimulatedSession', 'simulate_session']

#: What a step does: ``rest`` (gripper open, nobody touches it), ``press`` (the operator
#: presses one finger), ``squeeze`` (the gripper closes on the indentor and holds).
SESSION_ACTIONS = ('rest', 'press', 'squeeze')
#: Samples per scene step (100 ms; any chunking gives the same data).
_CHUNK = 200


@dataclass(frozen=True)
class SessionStep:
    """One step of a commissioning session.

    Attributes
    ----------
    action : str
        One of :data:`SESSION_ACTIONS`.
    duration : float
        Length of the step [s]; a press fits in it (``2 ramp + hold <= duration``).
    finger : int
        ``press``: 0 = left, 1 = right.
    location : float
        ``press``: pressed place, 0 = tip, 1 = root [-].
    force : float
        ``press``: peak force [N].
    ramp : float
        ``press``: rise and fall time [s].
    position : float
        ``squeeze``: servo goal [rad] (0 = closed: the current limit sets the grip).
    max_current : float
        ``squeeze``: servo current limit [A] (grip force about
        ``(I - 0.05 A) x 26.2 N/A`` on the rig).
    """

    action: str
    duration: float
    finger: int = 0
    location: float = 0.1
    force: float = 4.0
    ramp: float = 0.25
    position: float = 0.0
    max_current: float = 0.25

    def __post_init__(self) -> None:
        if self.action not in SESSION_ACTIONS:
            raise ValueError(f'unknown action {self.action!r}; expected {SESSION_ACTIONS}')
        if not (math.isfinite(self.duration) and self.duration > 0.0):
            raise ValueError(f'duration must be finite and > 0, got {self.duration}')
        if self.action == 'press' and 2.0 * self.ramp >= self.duration:
            raise ValueError('a press needs a duration longer than its two ramps')

    @property
    def samples(self) -> int:
        """Length of the step [samples]."""
        return int(round(self.duration * SAMPLE_RATE))


@dataclass
class SimulatedSession:
    """What a simulated session recorded.

    Attributes
    ----------
    frames : numpy.ndarray, shape (n, 6)
        Raw readings (normalised, quantised, faults applied), contract channel order.
    spans : list of (int, int)
        ``[start, stop)`` sample span of each step, in step order.
    steps : tuple of SessionStep
    faults : tuple of ChannelFault
    seed : int
    """

    frames: np.ndarray
    spans: list[tuple[int, int]]
    steps: tuple[SessionStep, ...]
    faults: tuple[ChannelFault, ...]
    seed: int


def simulate_session(steps: Sequence[SessionStep], faults: Sequence[ChannelFault] = (),
                     seed: int = 0, indentor: str = 'flat_wide') -> SimulatedSession:
    """Play ``steps`` on the simulated rig and record the readings.

    Parameters
    ----------
    steps : sequence of SessionStep
        The protocol.
    faults : sequence of ChannelFault
        Sensor faults injected into the readings (none: a healthy device).
    seed : int
        Seed of the scene (sensor offsets, noise, indentor seating, temperature) and of
        the injected noise.
    indentor : str
        The rig's indentor (:data:`forte_sim.INDENTORS`).

    Returns
    -------
    SimulatedSession
    """
    scene = make_scene('calibration', seed=seed, indentor=indentor)
    operator = ScriptedOperator(scene.model)
    injector = ChannelFaultInjector(faults, seed=seed)
    parts, spans = [], []
    for step in steps:
        start = scene.sample_index
        if step.action == 'press':
            hold = step.duration - 2.0 * step.ramp
            operator.schedule(OperatorPress(step.finger, step.location, step.force, start,
                                            step.ramp, hold))
        command, current = ((step.position, step.max_current) if step.action == 'squeeze'
                            else (scene.initial_angle, None))
        remaining = step.samples
        while remaining > 0:
            count = min(_CHUNK, remaining)
            first = scene.sample_index
            frames, _ = scene.step(count, command, 0.0, max_current=current)
            parts.append(injector.apply(quantise(frames + operator.signal(first, count))))
            remaining -= count
        spans.append((start, scene.sample_index))
    return SimulatedSession(np.concatenate(parts), spans, tuple(steps), tuple(faults),
                            int(seed))
