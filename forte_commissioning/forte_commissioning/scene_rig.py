"""The calibration rig interface on a simulated scene, without ROS (pure).

:class:`SceneRig` steps a :mod:`forte_sim` calibration scene in batches only while the
procedure waits for samples, and delivers what the ROS graph would: frame batches stamped
with their first sample's time, one load-cell sample every ``load_cell_decimation``
samples (at sample indices divisible by it, as sim_node publishes them) and the joint
position at the end of each batch. A new scene per trial, as in simulation mode of the node.
Tests use it to check the procedure (resume, gaps, refusals) in a second instead of a
graph; :func:`run_offline` runs a whole session with it.
"""
from __future__ import annotations

import asyncio
from pathlib import Path

from forte_commissioning.force_calibration import ForceCalibration, RigError, SessionReport
from forte_commissioning.force_plan import ForceCalibrationConfig, TrialPlan
from forte_commissioning.session_store import SessionStore
from forte_commissioning.trial_recording import RecordingBuffer
from forte_ros.contract import SAMPLE_PERIOD
from forte_sim.scene import Scene, make_scene

__all__ = ['SceneRig', 'run_offline']

_PERIOD_NS = round(SAMPLE_PERIOD * 1e9)


class SceneRig:
    """:class:`.force_calibration.CalibrationRig` on a simulated scene.

    Parameters
    ----------
    batch : int
        Samples per frame batch.
    load_cell_decimation : int
        One load-cell sample every this many samples.
    """

    simulation = True

    def __init__(self, batch: int = 20, load_cell_decimation: int = 20) -> None:
        self.batch = batch
        self.decimation = load_cell_decimation
        self.scene: Scene | None = None
        self.buffer: RecordingBuffer | None = None
        self.commands: list[tuple[float, float]] = []
        self._command = (0.0, 0.0)
        self._origin_ns = 1_000_000_000_000
        self.prompts: list[str] = []
        self.batches = 0

    # ------------------------------------------------------------------ rig interface
    @property
    def joint_position(self) -> float | None:
        """Servo position of the scene [rad]."""
        return None if self.scene is None else self.scene.joint_position

    def command(self, angle: float, profile_velocity: float = 0.0) -> None:
        """Applies from the next batch."""
        self._command = (float(angle), float(profile_velocity))
        self.commands.append(self._command)

    def start_recording(self) -> RecordingBuffer:
        self.buffer = RecordingBuffer()
        return self.buffer

    def stop_recording(self) -> None:
        self.buffer = None

    async def wait_samples(self, count: int) -> None:
        while self.buffer is not None and self.buffer.count < count:
            self.step()

    async def wait_load_cell(self, time_ns: int) -> bool:
        for _ in range(4):
            last = self.buffer.last_load_time_ns if self.buffer is not None else None
            if last is not None and last >= time_ns:
                return True
            self.step()
        return False

    async def new_scene(self, plan: TrialPlan, search: bool) -> None:
        if self.scene is not None:
            self._origin_ns += (self.scene.sample_index + 2000) * _PERIOD_NS
        self.scene = make_scene('calibration', indentor=plan.indentor, seed=plan.seed,
                                trial=plan.trial)
        self._command = (self.scene.initial_angle, 0.0)

    async def prompt(self, message: str) -> None:
        self.prompts.append(message)

    async def check_ready(self) -> None:
        if self.scene is None:
            raise RigError('no scene')

    def sensor_identity(self) -> dict | None:
        return {'source': 'sim', 'device_id': 'simulator'}

    # ------------------------------------------------------------------ simulation
    def step(self) -> None:
        """Simulate one batch and deliver its messages to the recording."""
        scene = self.scene
        first = scene.sample_index
        angle, velocity = self._command
        frames, truth = scene.step(self.batch, angle, 0.0, profile_velocity=velocity or None)
        self.batches += 1
        self.deliver(first, frames, truth.load_cell_force, scene.joint_position)

    def deliver(self, first: int, frames, load, joint: float) -> None:
        """Hand one batch's messages to the recording (tests override it to lose some)."""
        if self.buffer is None:
            return
        stamp = self._origin_ns + first * _PERIOD_NS
        self.buffer.add_frames(stamp, first, SAMPLE_PERIOD, frames)
        for row in range(len(frames)):
            if (first + row) % self.decimation == 0:
                self.buffer.add_load(stamp + row * _PERIOD_NS, float(load[row]))
        self.buffer.add_joint(stamp + (len(frames) - 1) * _PERIOD_NS, joint)


def run_offline(folder: str | Path, config: ForceCalibrationConfig,
                rig: SceneRig | None = None, output: str | Path | None = None,
                log=print) -> SessionReport:
    """Run (or resume) a whole session on a :class:`SceneRig`.

    Returns
    -------
    SessionReport
    """
    procedure = ForceCalibration(rig or SceneRig(), SessionStore(folder, config), log, output)
    return asyncio.run(procedure.run())
