"""The force calibration procedure (paper Sec. IV-A) against a rig interface (pure, no rclpy).

:class:`ForceCalibration` drives the session: for each indentor, an operator prompt (the
indentor is mounted), theta_zeroF by the contact rule (:mod:`.force_plan`; kept in the
session, so a resumed session does not search again), then the indentor's pending trials,
each recorded, aligned to the load cell by sample time (:mod:`.load_cell`) and kept on disk
the moment it is complete (:mod:`.session_store`). A dropped trial (frame or load-cell gap,
a stale sensor mid-trial) is reported and repeated, up to ``max_attempts`` attempts; one
that never succeeds is reported lost, never filled in. Finally the contract's ``.npz``.

It talks to the hardware (or the simulation) only through a :class:`CalibrationRig`: the
ROS rig (:mod:`forte_commissioning.ros.calibration_rig`) over topics and services, and
:class:`.scene_rig.SceneRig` on a :mod:`forte_sim` scene without ROS. The rig's awaitables
are whatever its event loop needs (rclpy futures in the node, plain coroutines for the scene
rig); the procedure only awaits them, so one procedure serves the robot, the simulated
graph and the offline tests.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from forte_commissioning.force_plan import ContactRule, ForceCalibrationConfig, TrialPlan
from forte_commissioning.load_cell import align_load_cell
from forte_commissioning.session_store import SessionStore
from forte_commissioning.trial_recording import RecordingBuffer
from forte_ros.sensor_identity import SensorIdentity, check_identity

__all__ = ['CalibrationRig', 'ForceCalibration', 'RigError', 'SessionReport', 'StaleSensor']


class RigError(RuntimeError):
    """The rig cannot go on (stale sensor, no load cell, no contact): the text says why."""


#: The theta_zeroF search repeats its closing command this often [s]: the same goal and
#: speed again (harmless to a servo already moving there), so a command published before
#: the gripper's subscription matched, or lost, does not leave the gripper standing open.
RESEND_SECONDS = 0.5
#: A joint report this far past the position at a command, in the commanded direction, is
#: the gripper following it [rad] (3 steps of a 4096-step servo turn; above its jitter).
MOTION_TOLERANCE = 0.005
#: The gripper must follow a trial's command within this much recording [s]: longer than
#: the frames a loaded machine or a simulator ahead of real time holds in its queues.
MOTION_TIMEOUT = 10.0


class DeviceMismatch(RigError):
    """The sensor is not the one the session was recorded with (another board, firmware,
    rate, channel order or full scale): its trials cannot go into one dataset."""


class StaleSensor(RigError):
    """The frames stopped while the procedure waited for them (the attempt is repeated if
    the rig is ready again)."""


class CalibrationRig(Protocol):
    """What the procedure needs of the gripper, its sensor and the load cell."""

    #: True when the rig is a simulation (a new scene per trial, no operator).
    simulation: bool

    @property
    def joint_position(self) -> float | None:
        """Latest servo position report [rad], None before the first."""

    def command(self, angle: float, profile_velocity: float = 0.0) -> None:
        """Send a servo position [rad] at ``profile_velocity`` [rad/s] (0: the default)."""

    def start_recording(self) -> RecordingBuffer:
        """Record every frame, load-cell and joint message from now on."""

    def stop_recording(self) -> None:
        """Stop recording."""

    async def wait_samples(self, count: int) -> None:
        """Until the recording holds ``count`` frames; :class:`RigError` if the sensor
        goes stale."""

    async def wait_load_cell(self, time_ns: int) -> bool:
        """Until a load-cell sample at or after ``time_ns`` arrived; False after a timeout."""

    async def new_scene(self, plan: TrialPlan, search: bool) -> None:
        """Simulation: a fresh scene for the trial (or the search); robot: nothing."""

    async def prompt(self, message: str) -> None:
        """Tell the operator ``message`` and wait until they continue."""

    async def check_ready(self) -> None:
        """:class:`RigError` unless the sensor is fresh and the load cell publishes."""

    def sensor_identity(self) -> dict | None:
        """The sensor's identity (forte_msgs/SensorInfo fields), None if unknown."""


@dataclass
class SessionReport:
    """Outcome of a run of the procedure.

    Attributes
    ----------
    done, total : int
        Finished and planned trials of the session [count].
    recorded : int
        Trials recorded by this run [count].
    dropped : list of dict
        Dropped attempts of this run: trial, indentor, attempt, reason.
    lost : list of int
        Trials that failed every attempt in this run.
    theta_zero_force : dict
        theta_zeroF per indentor [rad].
    dataset : Path or None
        The ``.npz`` written (None when no trial is finished).
    """

    done: int = 0
    total: int = 0
    recorded: int = 0
    dropped: list[dict] = field(default_factory=list)
    lost: list[int] = field(default_factory=list)
    theta_zero_force: dict = field(default_factory=dict)
    dataset: Path | None = None


class ForceCalibration:
    """The procedure (module docstring).

    Parameters
    ----------
    rig : CalibrationRig
    store : SessionStore
        The session (new or resumed); its settings are the procedure's.
    log : callable
        ``log(text)``: progress and operator messages.
    output : str or Path, optional
        Dataset file (default ``calibration.npz`` in the session folder).
    """

    def __init__(self, rig: CalibrationRig, store: SessionStore,
                 log: Callable[[str], None] = print, output: str | Path | None = None) -> None:
        self.rig = rig
        self.store = store
        self.config: ForceCalibrationConfig = store.config
        self.log = log
        self.output = output
        self.report = SessionReport(total=len(store.plan))
        self._started = time.monotonic()

    # ------------------------------------------------------------------ session
    async def run(self) -> SessionReport:
        """Run every pending trial, then write the dataset.

        Raises
        ------
        RigError
            The rig is not ready at the start or stopped being ready (every finished trial
            is on disk; run again with the same session folder to resume).
        """
        pending = self.store.pending()
        done = self.store.done_count()
        self.log(f'force calibration: {done}/{len(self.store.plan)} trials done'
                 f'{" (resumed)" if self.store.resumed else ""}, {len(pending)} to record, '
                 f'session {self.store.folder}')
        if pending:
            await self.rig.new_scene(pending[0], search=True)
            await self.rig.check_ready()
            self._check_device()
        for name in self.config.indentors:
            trials = [plan for plan in pending if plan.indentor == name]
            if trials:
                await self._indentor(name, trials)
        self.report.done = self.store.done_count()
        self.report.theta_zero_force = dict(self.store.state['theta_zero_force'])
        if self.report.done:
            self.report.dataset = self.store.write_dataset(self.output)
            self.log(f'force calibration: {self.report.done}/{self.report.total} trials in '
                     f'{self.report.dataset}; {len(self.report.dropped)} attempt(s) dropped, '
                     f'{len(self.report.lost)} trial(s) lost {self.report.lost}')
        return self.report

    async def _indentor(self, name: str, trials: list[TrialPlan]) -> None:
        index = self.config.indentors.index(name)
        self.rig.command(self.config.mount_angle)  # room to mount the indentor
        await self.rig.prompt(
            f'indentor {index + 1}/{len(self.config.indentors)}: mount {name!r} on the load '
            'cell, centred between the open fingers, then continue')
        self._check_device()  # the board may have been changed during the prompt
        theta = self.store.zero_force(name)
        if theta is None:
            theta = await self._search_with_attempts(name, trials[0])
            self.store.set_zero_force(name, theta)
        else:
            self.log(f'{name}: theta_zeroF {theta:.4f} rad (kept from this session)')
        for plan in trials:
            await self._trial_with_attempts(plan, theta)

    def _check_device(self) -> None:
        """Keep the sensor's identity; refuse a sensor other than the session's.

        Raises
        ------
        DeviceMismatch
            The session's trials were recorded on another sensor (the message names both
            and what differs); every finished trial stays in the session folder.
        """
        current = self.rig.sensor_identity()
        recorded = self.store.state.get('sensor_identity')
        if current is None:
            return
        if recorded is not None:
            check = check_identity(recorded, SensorIdentity.from_dict(current))
            differences = check.refusals + check.warnings
            if differences:
                raise DeviceMismatch(
                    f'device mismatch: this session was recorded on device '
                    f'{recorded.get("device_id") or "(unknown)"}, the sensor is now '
                    f'{current.get("device_id") or "(unknown)"} ({"; ".join(differences)}); '
                    'connect the session\'s sensor to resume it, or calibrate this one in a '
                    'new session_dir')
        self.store.set_sensor_identity(current)

    async def _search_with_attempts(self, name: str, plan: TrialPlan) -> float:
        for attempt in range(self.config.max_attempts):
            await self.rig.new_scene(plan, search=True)
            await self.rig.check_ready()
            try:
                return await self.find_zero_force(name)
            except StaleSensor as error:
                if attempt + 1 == self.config.max_attempts:
                    raise
                self.log(f'{name}: theta_zeroF search repeated: {error}')
        raise AssertionError('unreachable')  # pragma: no cover

    async def _trial_with_attempts(self, plan: TrialPlan, theta: float) -> None:
        for attempt in range(self.config.max_attempts):
            await self.rig.new_scene(plan, search=False)
            try:
                reason = await self.run_trial(plan, theta)
            except StaleSensor as error:
                self._drop(plan, attempt, str(error))
                await self.rig.check_ready()  # still stale: the session stops here
                continue
            if not reason:
                self.report.recorded += 1
                self._progress(plan)
                return
            self._drop(plan, attempt, reason)
        self.report.lost.append(plan.trial)
        self.log(f'trial {plan.trial} ({plan.indentor}) lost after '
                 f'{self.config.max_attempts} attempts')

    def _drop(self, plan: TrialPlan, attempt: int, reason: str) -> None:
        self.store.record_drop(plan, attempt, reason)
        self.report.dropped.append({'trial': plan.trial, 'indentor': plan.indentor,
                                    'attempt': attempt, 'reason': reason})
        self.log(f'trial {plan.trial} ({plan.indentor}, attempt {attempt + 1}) dropped: '
                 f'{reason}')

    def _progress(self, plan: TrialPlan) -> None:
        done = self.store.done_count()
        total = len(self.store.plan)
        elapsed = time.monotonic() - self._started
        rate = elapsed / max(self.report.recorded, 1)
        self.log(f'trial {done}/{total} recorded ({plan.indentor} '
                 f'{plan.repeat + 1}/{self.config.protocol.trials_per_indentor}, closure '
                 f'{plan.closure:.2f}); {len(self.report.dropped)} dropped; '
                 f'{elapsed:.0f} s elapsed, about {rate * (total - done):.0f} s to go')

    # ------------------------------------------------------------------ one trial
    async def run_trial(self, plan: TrialPlan, theta: float) -> str:
        """Record one trial and keep it; returns '' or why it was dropped.

        The trial's clock is the gripper's, not the procedure's: the hold is counted from
        the sample at which the joint left the open pose, the release from the sample at
        which it left the hold, and the tare is the ``tare_samples`` just before the
        squeeze began (:meth:`_motion_start`). A command delivered late (a loaded machine,
        a simulator ahead of real time, a slow bus) therefore lengthens the quiet lead-in
        and the hold, never shortens the hold or cuts off the release: ``hold_seconds``
        is the shortest hold and every trial ends with ``release_seconds`` of release.

        Raises
        ------
        StaleSensor
            The sensor went stale during the trial.
        """
        c = self.config
        # lead-in: frames recorded before the trial and then dropped, so that a load-cell
        # sample precedes the trial's first frame (a robot's load cell samples at its own
        # instants; no extrapolation means the first frame needs one before it)
        lead = c.samples(c.load_cell_max_gap)
        tare = c.tare_samples
        open_angle = theta + c.open_margin
        self.rig.command(open_angle)
        buffer = self.rig.start_recording()
        try:
            await self.rig.wait_samples(lead + tare)
            self.rig.command(plan.target(theta))
            squeeze = await self._motion_start(buffer, closing=True)
            if squeeze is None:
                return self._did_not_follow('closing')
            await self.rig.wait_samples(squeeze + c.samples(c.protocol.hold_seconds))
            self.rig.command(open_angle)
            release = await self._motion_start(buffer, closing=False)
            if release is None:
                return self._did_not_follow('opening')
            end = release + c.samples(c.protocol.release_seconds)
            await self.rig.wait_samples(end)
            recording = buffer.snapshot(end)
            await self.rig.wait_load_cell(int(recording.frame_times_ns[-1]))
            recording = buffer.snapshot(end)
        finally:
            self.rig.stop_recording()
        if recording.problems:
            return '; '.join(recording.problems)
        start = squeeze - tare
        times, frames = recording.frame_times_ns[start:], recording.frames[start:]
        aligned = align_load_cell(times, recording.load_times_ns, recording.load_values,
                                  c.load_cell_max_gap)
        if not aligned.ok:
            return aligned.problem
        force = aligned.force
        if c.tare_load_cell:
            force = force - force[:tare].mean()
        self.store.save_trial(plan, frames, force, theta, int(times[0]))
        return ''

    async def _motion_start(self, buffer: RecordingBuffer, closing: bool) -> int | None:
        """Frame index at which the gripper began to follow the command just sent.

        The joint's position when the command was sent is the reference; the first report
        beyond it by ``MOTION_TOLERANCE`` in the commanded direction is the motion, and it
        began after the last report before it (by sample time, not arrival). The frames
        received when the command was sent bound it from below (the command cannot act
        before it is sent).

        Returns
        -------
        int or None
            The index; None if the joint did not move within ``MOTION_TIMEOUT`` of
            recording after the command.
        """
        sent = buffer.count
        times, _ = buffer.frames_from(0)
        sent_ns = int(times[sent - 1])
        sign = -1.0 if closing else 1.0
        limit = sent + self.config.samples(MOTION_TIMEOUT)
        while True:
            began_ns = buffer.motion_start_ns(sent_ns, sign, MOTION_TOLERANCE)
            if began_ns is not None:
                times, _ = buffer.frames_from(0)
                return max(sent, int(np.searchsorted(times, began_ns, side='right')))
            if buffer.count >= limit:
                return None
            await self.rig.wait_samples(buffer.count + 1)

    def _did_not_follow(self, direction: str) -> str:
        where = self.rig.joint_position
        return (f'the gripper did not start {direction} within {MOTION_TIMEOUT:g} s of the '
                f'command (joint {"unknown" if where is None else f"at {where:.3f} rad"})')

    # ------------------------------------------------------------------ theta_zeroF
    async def find_zero_force(self, name: str) -> float:
        """theta_zeroF of the mounted indentor by the contact rule [rad].

        Raises
        ------
        RigError
            No load-cell data, no contact before ``search_floor``, or a load cell that does
            not read the squeeze the sensor shows (wrong axis or sign).
        """
        c = self.config
        start = self.rig.joint_position
        if start is None:
            raise RigError('no joint_states from the gripper: is its driver running?')
        if start <= c.search_floor:
            raise RigError(f'the gripper is at {start:.3f} rad, not open: open it first')
        buffer = self.rig.start_recording()
        try:
            contact_ns = await self._search(buffer, start)
            recording = buffer.snapshot()
            theta = recording.joint_at(contact_ns)
            self.rig.command(theta + c.open_margin)
            await self.rig.wait_samples(buffer.count + c.samples(c.protocol.release_seconds))
        finally:
            self.rig.stop_recording()
        self.log(f'{name}: theta_zeroF {theta:.4f} rad (contact rule, search from '
                 f'{start:.3f} rad at {c.search_velocity:g} rad/s)')
        return theta

    async def _search(self, buffer: RecordingBuffer, start: float) -> int:
        """Close slowly until the contact rule fires; returns the contact time [ns]."""
        c = self.config
        await self.rig.wait_samples(c.tare_samples)
        quiet = buffer.snapshot()
        if quiet.load_values.size == 0:
            raise RigError('no load-cell sample while the gripper was open and still: '
                           'check load_cell_topic and that the load cell publishes')
        load_baseline = float(quiet.load_values.mean()) if c.tare_load_cell else 0.0
        rule = ContactRule(quiet.frames.mean(axis=0), load_baseline, c)
        rule.sensor(quiet.frames)
        frames_done, load_done = c.tare_samples, buffer.load_count
        limit = c.tare_samples + c.samples((start - c.search_floor) / c.search_velocity + 2.0)
        sensor_ns: int | None = None
        load_seen = frames_done
        self.rig.command(c.search_floor, c.search_velocity)
        resend = c.samples(RESEND_SECONDS)
        commanded = frames_done
        while True:
            await self.rig.wait_samples(frames_done + 1)
            times, frames = buffer.frames_from(frames_done)
            frames_done += len(frames)
            if frames_done - commanded >= resend:  # a command lost in transit is repeated
                self.rig.command(c.search_floor, c.search_velocity)
                commanded = frames_done
            hit = rule.sensor(frames)
            if hit is not None and sensor_ns is None:
                sensor_ns = int(times[hit])
            load_times, load_values = buffer.load_from(load_done)
            load_hit = rule.load_cell(load_values, load_done)
            load_done += len(load_values)
            if load_hit is not None:
                contact = int(buffer.load_from(load_hit)[0][0])
                return contact if sensor_ns is None else min(contact, sensor_ns)
            self._check_load_sign(load_values - load_baseline, sensor_ns, load_times, start)
            if load_values.size:
                load_seen = frames_done
            if frames_done - load_seen > c.samples(2.0):
                self.rig.command(start)
                raise RigError('the load cell stopped publishing during the theta_zeroF '
                               'search')
            if frames_done > limit:
                self.rig.command(start)
                raise RigError(self._no_contact(start))

    def _no_contact(self, start: float) -> str:
        """Why the search ended without contact: the fingers reached the floor with
        nothing between them, or they did not close (the gripper did not follow)."""
        c = self.config
        reached = self.rig.joint_position
        if reached is None or reached > c.search_floor + 0.5 * (start - c.search_floor):
            where = 'no joint_states' if reached is None else f'at {reached:.3f} rad'
            return (f'the gripper did not close: commanded {c.search_floor:.3f} rad at '
                    f'{c.search_velocity:g} rad/s from {start:.3f} rad, it is {where}: check '
                    'the gripper driver (active? its diagnostics, gripper/command)')
        return (f'no contact down to {reached:.3f} rad: is the indentor mounted between '
                'the fingers?')

    def _check_load_sign(self, load: np.ndarray, sensor_ns: int | None,
                         load_times: np.ndarray, start: float) -> None:
        """Refuse a load cell that reads a squeeze as negative, or not at all: 0.02 rad
        of closing after the sensor's contact, timed by the load cell's own samples."""
        c = self.config
        late = sensor_ns is not None and load_times.size and \
            (int(load_times.max()) - sensor_ns) * 1e-9 * c.search_velocity > 0.02
        negative = load.size and float(load.min()) < -c.contact_force and sensor_ns is not None
        if negative or late:
            self.rig.command(start)
            shown = f'{float(load.min()):+.3f} N' if load.size else 'nothing'
            raise RigError(f'the sensor shows contact but the load cell reads {shown}: '
                           'wrong load_cell_axis or load_cell_sign, or the load cell is not '
                           'under the indentor')
