"""Calibration dataset: contract format and CLI (training on it: forte_bringup test_evaluate)."""
import json

import numpy as np
import pytest

from forte_ros.contract import CHANNEL_NAMES
from forte_sim import INDENTORS
from forte_sim.dataset import (
    DATASET_KEYS,
    CalibrationProtocol,
    generate_calibration_dataset,
    load_dataset,
    save_dataset,
)
from forte_sim.dataset_tool import main

SMALL = CalibrationProtocol(trials_per_indentor=2, quiet_seconds=1.0, hold_seconds=3.0,
                            release_seconds=1.0, seed=3)


@pytest.fixture(scope='module')
def dataset():
    return generate_calibration_dataset(SMALL)


def test_dataset_follows_the_contract(dataset, tmp_path):
    path = save_dataset(tmp_path / 'calibration', dataset)
    assert path.suffix == '.npz'
    with np.load(path, allow_pickle=False) as data:
        assert sorted(data.files) == sorted(DATASET_KEYS + ('sensor_identity',))
        identity = json.loads(str(data['sensor_identity']))
        assert identity['source'] == 'sim' and identity['device_id'] == 'simulator'
        assert identity['sample_rate'] == 2000.0
        assert tuple(identity['channel_names']) == CHANNEL_NAMES
        frames = data['frames']
        assert frames.dtype == np.float32 and frames.shape[1] == 6
        n = frames.shape[0]
        assert data['force'].shape == (n,) and data['force'].dtype == np.float32
        assert data['trial'].dtype == np.int32 and data['indentor'].dtype == np.int32
        assert data['fs'].shape == () and float(data['fs']) == 2000.0
        assert tuple(data['channel_names']) == CHANNEL_NAMES
        assert tuple(data['indentor_names']) == tuple(INDENTORS)
        assert int(data['tare_samples']) == 2000
    per_trial = 2000 + 6000 + 2000
    assert n == 12 * per_trial
    trial = dataset['trial']
    np.testing.assert_array_equal(np.unique(trial), np.arange(12))
    assert np.all(np.diff(trial) >= 0)                         # contiguous runs
    np.testing.assert_array_equal(dataset['indentor'][::per_trial], np.repeat(np.arange(6), 2))
    loaded = load_dataset(path)
    np.testing.assert_array_equal(loaded['frames'], dataset['frames'])


def test_trials_start_quiet_and_squeeze_the_load_cell(dataset):
    force = dataset['force'].reshape(12, -1)
    frames = dataset['frames'].reshape(12, -1, 6)
    assert np.abs(force[:, :2000]).max() < 0.05               # no contact while taring
    assert np.all(frames[:, :2000].std(axis=1) < 0.02)
    peaks = force.max(axis=1)
    assert peaks.max() > 3.0 and peaks.min() >= 0.0           # random closures
    assert np.abs(force[:, -500:]).max() < 0.2                # released at the end


def test_load_dataset_refuses_damaged_files(tmp_path, dataset):
    broken = dict(dataset)
    broken['force'] = broken['force'][:-5]
    np.savez(tmp_path / 'short.npz', **broken)
    with pytest.raises(ValueError, match='force has'):
        load_dataset(tmp_path / 'short.npz')
    missing = {key: value for key, value in dataset.items() if key != 'trial'}
    np.savez(tmp_path / 'missing.npz', **missing)
    with pytest.raises(ValueError, match='missing keys'):
        load_dataset(tmp_path / 'missing.npz')


def test_cli_writes_the_dataset(tmp_path, capsys):
    out = tmp_path / 'tiny.npz'
    code = main(['--output', str(out), '--trials-per-indentor', '1', '--hold-seconds', '1'])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert report['trials'] == 6 and out.exists()
    assert load_dataset(out)['frames'].shape[0] == report['samples']


def test_cli_refuses_bad_arguments(tmp_path):
    assert main(['--output', str(tmp_path / 'x.npz'), '--trials-per-indentor', '0']) == 2
    assert main(['--output', str(tmp_path / 'x.npz'), '--hold-seconds', '-1']) == 2
