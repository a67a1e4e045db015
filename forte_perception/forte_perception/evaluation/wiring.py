"""Slip detection under the ways a lab can wire the six transducers, and with one lost (issue 38).

A lab plugs the six pressure transducers into the board's six inputs. Nothing in the signals
says which input carries which channel, and labs get it wrong: a finger's tubes reversed
(distal on the root input), the two fingers swapped, tubes crossed between fingers, or a
channel lost (a leaking tube, a dead transducer: the pipeline masks it). The detector's
grouping of inputs into fingers (:data:`forte_ros.contract.FINGER_CHANNELS`) is then wrong
too, so a slip under one physical finger may reach two of the detector's fingers, or one
finger's channel may sit between two quiet ones.

Each scene is run as the perception node runs it: :class:`~forte_perception.pipeline.
PerceptionPipeline` fed ``chunk`` samples at a time (20: the driver's 100 Hz messages), the
scene's servo command changes passed to :meth:`~forte_perception.pipeline.
PerceptionPipeline.servo_moved` (the node's ``gripper/command``), a masked channel fed as
NaN (the pipeline's invalid value). A chunk whose output says ``slip`` is one flag at the
chunk's last sample, scored by :func:`~forte_perception.evaluation.slip_metrics.scene_outcome`
with the chunk as the update spacing.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from forte_perception.evaluation.benchmark import SensorInput, servo_changes
from forte_perception.evaluation.labels import SlipScene
from forte_perception.evaluation.slip_metrics import SceneOutcome, scene_outcome, summarise
from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.slip.detector import SlipParams
from forte_ros.contract import N_CHANNELS

__all__ = ['WIRINGS', 'Wiring', 'alone', 'masked', 'run_scene', 'wiring_summary']


@dataclass(frozen=True)
class Wiring:
    """One way the transducers reach the inputs.

    Attributes
    ----------
    name : str
    inputs : tuple of int, length 6
        ``inputs[k]``: the physical channel read on input ``k`` (the identity: as built).
    lost : int or None
        The input that reads nothing valid (NaN), if any.
    """

    name: str
    inputs: tuple[int, ...] = tuple(range(N_CHANNELS))
    lost: int | None = None

    def apply(self, frames: np.ndarray) -> np.ndarray:
        """The frames (n, 6) as this wiring delivers them (a copy)."""
        out = np.asarray(frames, np.float64)[:, list(self.inputs)].copy()
        if self.lost is not None:
            out[:, self.lost] = np.nan
        return out


#: Wirings a lab could build: within a finger, between fingers, across them.
WIRINGS: tuple[Wiring, ...] = (
    Wiring('as built'),
    Wiring('each finger reversed (distal <-> root)', (2, 1, 0, 5, 4, 3)),
    Wiring('each finger rotated', (1, 2, 0, 4, 5, 3)),
    Wiring('fingers swapped', (3, 4, 5, 0, 1, 2)),
    Wiring('middle channels crossed between fingers', (0, 4, 2, 3, 1, 5)),
    Wiring('distal channels crossed between fingers', (3, 1, 2, 0, 4, 5)),
    Wiring('scrambled', (4, 0, 5, 2, 3, 1)),
)


def masked(channel: int) -> Wiring:
    """The as-built wiring with input ``channel`` lost."""
    return Wiring(f'input {channel} lost', lost=int(channel))


def alone(channel: int) -> Wiring:
    """Input ``channel`` the only one of its finger's inputs that reads that finger.

    Its finger's two other inputs read the other finger's transducers at the same places (a
    tube pair crossed, or a sensor with fewer elements than FORTE's three per finger): a slip
    under that finger reaches one of the detector finger's three inputs, beside two that
    carry the other finger, while the other detector finger reads the other finger whole.
    """
    channel = int(channel)
    finger, place = divmod(channel, 3)
    other = 3 * (1 - finger)
    inputs = list(range(N_CHANNELS))
    for position in range(3):
        if position != place:
            inputs[3 * finger + position] = other + position
    return Wiring(f'input {channel} alone reads its finger', tuple(inputs))


def run_scene(scene: SlipScene, mode: str, wiring: Wiring, chunk: int = 20,
              config: PipelineConfig | None = None) -> SceneOutcome:
    """Run ``scene`` through a pipeline in slip ``mode`` (or ``config``) under ``wiring``.

    Parameters
    ----------
    scene : SlipScene
    mode : str
        ``SlipParams.mode`` (ignored when ``config`` is given).
    wiring : Wiring
    chunk : int
        Samples per pipeline call.
    config : PipelineConfig, optional

    Returns
    -------
    SceneOutcome
        Flags at the last sample of every chunk whose output says slip; the update spacing
        is ``chunk``.
    """
    pipeline = PerceptionPipeline(config or PipelineConfig(slip=SlipParams(mode=mode)))
    frames = wiring.apply(scene.frames)
    changes = servo_changes(SensorInput(scene.frames, scene.frames, scene.fs,
                                        scene.context)).tolist()
    flags = []
    for start in range(0, frames.shape[0], chunk):
        stop = min(start + chunk, frames.shape[0])
        while changes and changes[0] < stop:
            pipeline.servo_moved(int(changes.pop(0)))
        if pipeline.process(frames[start:stop]).slip:
            flags.append(stop - 1)
    updates = -(-frames.shape[0] // chunk)
    return scene_outcome(scene, np.asarray(flags, np.int64), chunk, updates)


def wiring_summary(scenes: Sequence[SlipScene], mode: str, wirings: Sequence[Wiring],
                   chunk: int = 20) -> dict[str, dict]:
    """Pooled metrics (:func:`~forte_perception.evaluation.slip_metrics.summarise`) of
    every wiring on ``scenes``, by wiring name."""
    return {w.name: summarise([run_scene(s, mode, w, chunk) for s in scenes])
            for w in wirings}
