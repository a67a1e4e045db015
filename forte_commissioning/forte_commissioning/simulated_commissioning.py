"""Sensor commissioning: the protocol, and the whole run on the simulator (no rclpy).

The protocol (:func:`protocol`), the same on the robot, on the bench twin and in the pure
simulation:

1. ``rest`` (2 s): gripper open, nobody touches it: offsets, noise, stuck, railed;
2. for the left then the right finger, a press at the tip then at the root
   (``press_<finger>_<place>``, 1.5 s each, a 1 s ``rest_...`` before each): on the robot
   the operator presses when prompted, on the bench twin and here a scripted operator
   (:mod:`forte_sim.operator_press`) presses 2-5 N;
3. ``squeeze`` (12 s): the gripper closes on the indentor under a current limit and holds:
   the leak test;
4. ``rest_end`` (1.5 s): open again.

:func:`run_simulated` plays it on the simulator with optional injected faults
(:mod:`forte_sim.channel_faults`) and judges it
(:func:`forte_commissioning.sensor_checks.evaluate`): the engine of the commissioning tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forte_commissioning.sensor_checks import (
    DEFAULT_LIMITS,
    CommissioningLimits,
    CommissioningRecording,
    CommissioningResult,
    LinkStatistics,
    Phase,
    evaluate,
)
from forte_ros.contract import FINGER_NAMES, SAMPLE_PERIOD
from forte_sim.channel_faults import ChannelFault
from forte_sim.commissioning_session import SessionStep, simulate_session
from forte_sim.operator_press import PRESS_LOCATIONS

__all__ = ['ProtocolStep', 'SimulatedRun', 'protocol', 'run_simulated', 'session_steps']

#: Servo current limit of the squeeze [A]: about 5 N per finger on the rig
#: ((0.25 - 0.05) A x 1.78 N m/A / 0.068 m).
SQUEEZE_CURRENT = 0.25


@dataclass(frozen=True)
class ProtocolStep:
    """One phase of the protocol: its name, kind, duration [s], finger and place."""

    name: str
    kind: str
    duration: float
    finger: int = -1
    place: str = ''


def protocol(rest: float = 2.0, gap: float = 1.0, press: float = 1.5,
             squeeze: float = 12.0, rest_end: float = 1.5) -> list[ProtocolStep]:
    """The commissioning protocol (durations in s)."""
    steps = [ProtocolStep('rest', 'rest', rest)]
    for finger, finger_name in enumerate(FINGER_NAMES):
        for place in PRESS_LOCATIONS:
            steps.append(ProtocolStep(f'rest_{finger_name}_{place}', 'rest', gap))
            steps.append(ProtocolStep(f'press_{finger_name}_{place}', 'press', press, finger,
                                      place))
    steps += [ProtocolStep('squeeze', 'squeeze', squeeze),
              ProtocolStep('rest_end', 'rest', rest_end)]
    return steps


def session_steps(steps: list[ProtocolStep], forces: list[float]) -> list[SessionStep]:
    """The simulator's session steps for ``steps``; ``forces`` [N], one per press."""
    out, presses = [], iter(forces)
    for step in steps:
        if step.kind == 'press':
            out.append(SessionStep('press', step.duration, finger=step.finger,
                                   location=PRESS_LOCATIONS[step.place], force=next(presses)))
        elif step.kind == 'squeeze':
            out.append(SessionStep('squeeze', step.duration, max_current=SQUEEZE_CURRENT))
        else:
            out.append(SessionStep('rest', step.duration))
    return out


@dataclass
class SimulatedRun:
    """A simulated commissioning run: its recording and its result."""

    recording: CommissioningRecording
    result: CommissioningResult
    faults: tuple[ChannelFault, ...]
    seed: int


def run_simulated(faults: tuple[ChannelFault, ...] = (), seed: int = 0,
                  steps: list[ProtocolStep] | None = None,
                  limits: CommissioningLimits = DEFAULT_LIMITS) -> SimulatedRun:
    """Play the protocol on the simulated rig with ``faults`` injected, and judge it.

    The operator's press forces are drawn from the seed, uniformly in 2-5 N (a thumb).
    """
    steps = steps or protocol()
    rng = np.random.default_rng((seed, 0xC0FF))
    forces = list(rng.uniform(2.0, 5.0, sum(step.kind == 'press' for step in steps)))
    session = simulate_session(session_steps(steps, forces), faults, seed=seed)
    sequence = np.arange(len(session.frames), dtype=np.int64)
    phases = [Phase(step.name, step.kind, start, stop, step.finger, step.place)
              for step, (start, stop) in zip(steps, session.spans)]
    recording = CommissioningRecording(session.frames, sequence, phases,
                                       LinkStatistics.from_sequence(sequence, SAMPLE_PERIOD))
    return SimulatedRun(recording, evaluate(recording, limits), tuple(faults), seed)
