"""The force calibration procedure on a simulated rig without ROS: resume after an
interruption, dropped and repeated trials, refusals, the dataset it writes."""
from __future__ import annotations

import asyncio
import json

import numpy as np
import pytest

from forte_commissioning.force_calibration import (
    DeviceMismatch,
    ForceCalibration,
    RigError,
    StaleSensor,
)
from forte_commissioning.force_plan import ForceCalibrationConfig
from forte_commissioning.scene_rig import SceneRig, run_offline
from forte_commissioning.session_store import SessionError, SessionStore
from forte_perception.force_training import load_calibration
from forte_sim import make_scene
from forte_sim.dataset import DATASET_KEYS, CalibrationProtocol

#: 2 indentors x 3 trials of 0.5 + 1.0 + 0.5 s: small, every feature of the protocol.
CONFIG = ForceCalibrationConfig(
    protocol=CalibrationProtocol(trials_per_indentor=3, quiet_seconds=0.5, hold_seconds=1.0,
                                 release_seconds=0.5, seed=4),
    indentors=('flat_wide', 'sphere'))


class Interrupted(Exception):
    """Stands for Ctrl-C / a crash in the middle of a trial."""


class InterruptingRig(SceneRig):
    """Stops the session in the middle of the trial ``at_trial`` (after its quiet part)."""

    def __init__(self, at_trial: int) -> None:
        super().__init__()
        self.at_trial = at_trial
        self.trial = None

    async def new_scene(self, plan, search):
        self.trial = None if search else plan.trial
        await super().new_scene(plan, search)

    async def wait_samples(self, count):
        if self.trial == self.at_trial and count > CONFIG.tare_samples:
            raise Interrupted
        await super().wait_samples(count)


class LossyRig(SceneRig):
    """Loses the load cell (or the frames) for a while in the first attempt of a trial."""

    def __init__(self, trial: int, what: str) -> None:
        super().__init__()
        self.target, self.what = trial, what
        self.trial, self.attempts = None, 0

    async def new_scene(self, plan, search):
        self.trial = None if search else plan.trial
        self.attempts += plan.trial == self.target and not search
        await super().new_scene(plan, search)

    def deliver(self, first, frames, load, joint):
        if self.trial == self.target and self.attempts == 1 and 1400 <= first < 1600:
            if self.what == 'frames':
                return
            load = np.full(len(load), np.nan)
        super().deliver(first, frames, load, joint)


def run(folder, rig, config=CONFIG):
    return run_offline(folder, config, rig, log=lambda text: None)


def trials_of(path):
    data = np.load(path, allow_pickle=False)
    return {int(t): (data['frames'][data['trial'] == t], data['force'][data['trial'] == t])
            for t in np.unique(data['trial'])}


@pytest.fixture(scope='module')
def reference(tmp_path_factory):
    """An uninterrupted session."""
    folder = tmp_path_factory.mktemp('reference')
    report = run(folder, SceneRig())
    return folder, report


def test_a_session_writes_the_contract_dataset(reference):
    folder, report = reference
    assert report.done == report.total == 6 and not report.dropped and not report.lost
    with np.load(report.dataset, allow_pickle=False) as data:
        assert sorted(data.files) == sorted([*DATASET_KEYS, 'sensor_identity'])
        assert data['frames'].dtype == np.float32 and data['force'].dtype == np.float32
        assert data['trial'].dtype == np.int32 and data['indentor'].dtype == np.int32
        assert list(data['indentor_names']) == ['flat_wide', 'sphere']
        assert int(data['tare_samples']) == 1000 and float(data['fs']) == 2000.0
        assert json.loads(str(data['sensor_identity']))['source'] == 'sim'
        lengths = np.bincount(data['trial'])
        # quiet 1000 + hold 2000 + release 1000 samples per trial; the hold ends when a
        # joint report (one per 20-sample batch) shows the opening: up to one batch longer
        assert ((lengths >= 4000) & (lengths <= 4020)).all(), lengths
        force = data['force']
    dataset = load_calibration(report.dataset)       # the trainer's own checks
    assert 1.0 < float(force.max()) < 9.0
    assert abs(float(np.median(dataset['force'][dataset['trial'] == 0][:1000]))) < 0.01
    # theta_zeroF by the contact rule: where the first finger touches, within the 22 mrad
    # the indentor's centring (+-1.5 mm, forte_sim.state) moves it from the nominal angle
    for name, theta in report.theta_zero_force.items():
        assert abs(theta - make_scene('calibration', indentor=name).theta_zero_force) < 0.025


def test_an_interrupted_session_resumes_and_loses_or_repeats_no_trial(reference, tmp_path):
    _, full = reference
    with pytest.raises(Interrupted):
        run(tmp_path, InterruptingRig(at_trial=4))
    store = SessionStore(tmp_path, CONFIG)
    assert store.resumed and store.done_count() == 4
    assert [plan.trial for plan in store.pending()] == [4, 5]
    # a temporary file left by a write that never finished is not a trial
    (store.trials_folder / '.trial_0004.npz.tmp123').write_bytes(b'half')
    rig, lines = SceneRig(), []
    report = run_offline(tmp_path, CONFIG, rig, log=lines.append)
    assert report.recorded == 2 and report.done == 6 and not report.dropped
    assert all(velocity == 0.0 for _, velocity in rig.commands)   # theta_zeroF kept
    assert any('sphere: theta_zeroF' in line and 'kept from this session' in line
               for line in lines), lines
    assert '4/6 trials done (resumed), 2 to record' in lines[0]
    resumed, reference_trials = trials_of(report.dataset), trials_of(full.dataset)
    assert sorted(resumed) == list(range(6))
    for trial, (frames, force) in reference_trials.items():        # bit for bit
        np.testing.assert_array_equal(resumed[trial][0], frames)
        np.testing.assert_array_equal(resumed[trial][1], force)
    assert json.loads((tmp_path / 'session.json').read_text())['runs'] == 3


@pytest.mark.parametrize('what, reason', [('load', 'load-cell gap'),
                                          ('frames', 'frame sequence gap')])
def test_a_trial_with_a_gap_is_dropped_reported_and_repeated(tmp_path, what, reason):
    report = run(tmp_path, LossyRig(trial=1, what=what))
    assert [(drop['trial'], drop['attempt']) for drop in report.dropped] == [(1, 0)]
    assert reason in report.dropped[0]['reason']
    assert report.done == 6 and not report.lost
    stored = json.loads((tmp_path / 'session.json').read_text())['dropped']
    assert stored[0]['trial'] == 1 and reason in stored[0]['reason']
    assert np.isfinite(load_calibration(report.dataset)['force']).all()


def test_a_trial_that_fails_every_attempt_is_lost_not_filled_in(tmp_path):
    class AlwaysLossy(LossyRig):
        async def new_scene(self, plan, search):
            await super().new_scene(plan, search)
            self.attempts = 1

    config = ForceCalibrationConfig(protocol=CONFIG.protocol, indentors=CONFIG.indentors,
                                    max_attempts=2)
    report = run(tmp_path, AlwaysLossy(trial=2, what='load'), config)
    assert report.lost == [2] and len(report.dropped) == 2 and report.done == 5
    assert sorted(trials_of(report.dataset)) == [0, 1, 3, 4, 5]


def test_a_stale_sensor_mid_session_stops_it_and_keeps_every_trial(tmp_path):
    class GoesStale(SceneRig):
        stale = False

        async def new_scene(self, plan, search):
            self.stale = plan.trial == 3 and not search
            await super().new_scene(plan, search)

        async def wait_samples(self, count):
            if self.stale and count > CONFIG.tare_samples:
                raise StaleSensor('stale sensor: no tactile frame for 0.60 s')
            await super().wait_samples(count)

        async def check_ready(self):
            if self.stale:
                raise RigError('refused: stale sensor: the last tactile frame is 3.0 s old')

    with pytest.raises(RigError, match='stale sensor'):
        run(tmp_path, GoesStale())
    store = SessionStore(tmp_path, CONFIG)
    assert store.done_count() == 3
    assert 'stale sensor' in store.state['dropped'][0]['reason']
    assert run(tmp_path, SceneRig()).done == 6


def test_refuses_without_load_cell_data_or_with_a_load_cell_of_the_wrong_sign(tmp_path):
    class NoLoadCell(SceneRig):
        def deliver(self, first, frames, load, joint):
            super().deliver(first, frames, np.full(len(load), np.nan), joint)

    with pytest.raises(RigError, match='no load-cell sample'):
        run(tmp_path / 'none', NoLoadCell())

    class Inverted(SceneRig):
        def deliver(self, first, frames, load, joint):
            super().deliver(first, frames, -load, joint)

    with pytest.raises(RigError, match='wrong load_cell_axis or load_cell_sign'):
        run(tmp_path / 'inverted', Inverted())
    assert not SessionStore(tmp_path / 'inverted', CONFIG).done_count()


def test_a_gripper_that_does_not_follow_is_named_not_taken_for_a_missing_indentor(tmp_path):
    class Unpowered(SceneRig):
        """The fingers stay where they are, whatever is commanded."""

        def command(self, angle, profile_velocity=0.0):
            self.commands.append((float(angle), float(profile_velocity)))

    with pytest.raises(RigError, match=r'the gripper did not close: commanded 0\.000 rad '
                                       r'at 0\.05 rad/s from 0\.\d+ rad, it is at 0\.\d+ rad'):
        run(tmp_path, Unpowered())
    assert not SessionStore(tmp_path, CONFIG).done_count()


class LateRig(SceneRig):
    """Every command reaches the fingers ``delay`` batches after it is sent (a loaded
    machine, a simulator ahead of real time, a slow bus); ``ignore_trials`` drops the
    trials' commands (not the theta_zeroF search's) altogether."""

    def __init__(self, delay: int, ignore_trials: bool = False) -> None:
        super().__init__()
        self.delay, self.ignore_trials = delay, ignore_trials
        self.pending: list[tuple[int, tuple[float, float]]] = []
        self.searching = False

    async def new_scene(self, plan, search):
        self.searching = search
        await super().new_scene(plan, search)

    def command(self, angle, profile_velocity=0.0):
        self.commands.append((float(angle), float(profile_velocity)))
        if not (self.ignore_trials and not self.searching):
            self.pending.append((self.batches + self.delay, (float(angle),
                                                             float(profile_velocity))))

    def step(self):
        while self.pending and self.pending[0][0] <= self.batches:
            self._command = self.pending.pop(0)[1]
        super().step()


def test_late_commands_lengthen_the_hold_and_never_cut_the_release(reference, tmp_path):
    """Commands 1.5 s late (75 batches; half the hold and three times the release): each
    trial still has its quiet tare just before the squeeze, at least the whole hold, and the
    whole release after the fingers opened: the same peak and the same released end as on
    a rig without delay."""
    folder, _ = reference
    report = run(tmp_path, LateRig(delay=75))
    assert report.done == 6 and not report.dropped and not report.lost
    late, prompt = trials_of(report.dataset), trials_of(folder / 'calibration.npz')
    tare, hold, release = 1000, 2000, 1000
    for trial, (_frames, force) in late.items():
        # the hold runs on until the late opening reaches the fingers: 1500 samples, and up
        # to one batch until a joint report shows it
        assert tare + hold + release + 1500 <= force.size <= tare + hold + release + 1520, \
            force.size
        quiet = np.abs(force[:tare] - np.median(force[:tare]))
        assert quiet.max() < 0.05, (trial, quiet.max())          # no squeeze in the tare
        squeezed = np.flatnonzero(force > 0.1)
        assert tare <= squeezed[0] < tare + 500, (trial, squeezed[0])
        # the whole release: its last ``release`` samples start at the held force and end
        # released at least as far as on the prompt rig (the hold, 1.5 s longer, relaxed
        # the finger by up to 3 %)
        prompt_force = prompt[trial][1]
        assert abs(force[-release] - prompt_force[-release]) < \
            0.05 * prompt_force[-release] + 0.02, (trial, force[-release])
        assert force[-200:].max() <= prompt_force[-200:].max() + 0.05, \
            (trial, force[-200:].max())
        assert abs(force.max() - prompt_force.max()) < 0.02 * prompt_force.max() + 0.02


def test_a_gripper_that_ignores_a_trials_command_drops_the_trial_and_names_it(tmp_path):
    report = run(tmp_path, LateRig(delay=0, ignore_trials=True))
    assert report.done == 0 and report.lost == list(range(6))
    assert len(report.dropped) == 6 * CONFIG.max_attempts
    assert all(drop['reason'].startswith('the gripper did not start closing within 10 s of '
                                         'the command (joint at ') for drop in report.dropped)


def test_a_session_folder_of_other_settings_is_refused(reference):
    folder, _ = reference
    other = ForceCalibrationConfig(protocol=CalibrationProtocol(trials_per_indentor=5),
                                   indentors=CONFIG.indentors)
    with pytest.raises(SessionError, match='other protocol'):
        SessionStore(folder, other)


def test_operator_prompts_name_each_indentor_once(tmp_path):
    rig = SceneRig()
    procedure = ForceCalibration(rig, SessionStore(tmp_path, CONFIG), log=lambda text: None)
    asyncio.run(procedure.run())
    assert len(rig.prompts) == 2
    assert "'flat_wide'" in rig.prompts[0] and "'sphere'" in rig.prompts[1]


class BoardRig(SceneRig):
    """The simulated rig reporting the identity of a serial board ``device_id``."""

    def __init__(self, device_id: str, firmware: str = '1.0.0') -> None:
        super().__init__()
        self.device_id, self.firmware = device_id, firmware

    def sensor_identity(self) -> dict:
        return {'source': 'serial', 'device_id': self.device_id, 'firmware': self.firmware,
                'protocol_version': 1, 'sample_rate': 2000.0, 'adc_bits': 12}


@pytest.mark.parametrize('other, words', [
    (BoardRig('00000000000000b2'), 'device 00000000000000a1, the sensor is now '
                                   '00000000000000b2'),
    (BoardRig('00000000000000a1', firmware='2.0.0'), 'firmware 1.0.0, sensor runs 2.0.0'),
])
def test_resuming_on_another_sensor_is_refused_and_keeps_every_trial(tmp_path, other, words):
    """A session recorded on board a1 and resumed with another board (or firmware) plugged
    in: refused with both named, nothing recorded on the wrong board, nothing lost; the
    right board resumes it."""
    class InterruptedBoard(BoardRig):
        async def wait_samples(self, count):
            if self.trial_now == 4 and count > CONFIG.tare_samples:
                raise Interrupted
            await super().wait_samples(count)

        async def new_scene(self, plan, search):
            self.trial_now = None if search else plan.trial
            await super().new_scene(plan, search)

    with pytest.raises(Interrupted):
        run(tmp_path, InterruptedBoard('00000000000000a1'))
    with pytest.raises(DeviceMismatch, match=words) as raised:
        run(tmp_path, other)
    assert 'new session_dir' in str(raised.value)
    store = SessionStore(tmp_path, CONFIG)
    assert store.done_count() == 4
    assert store.state['sensor_identity']['device_id'] == '00000000000000a1'
    report = run(tmp_path, BoardRig('00000000000000a1'))
    assert report.done == 6 and report.recorded == 2
