"""forte_train_force on generated data (the contract's calibration format)."""
import json

import numpy as np
import pytest

from forte_perception.force import ForceModel
from forte_perception.force_training import load_calibration, make_rows
from forte_perception.testing import FS
from forte_perception.tools import train_force

NAMES = ['left_distal', 'left_middle', 'left_root', 'right_distal', 'right_middle',
         'right_root']


BOARD = {'source': 'serial', 'device_id': '00000000c0ffee01', 'firmware': '1.0.0',
         'protocol_version': 1, 'sample_rate': FS, 'channel_names': NAMES,
         'counts_per_full_scale': 1024, 'adc_bits': 12}


def calibration_file(path, n_trials=12, seconds=4.0, seed=0, identity=None):
    """A contract-format dataset from a made-up sensor (force -> pressure, relaxation);
    ``identity``: the optional ``sensor_identity`` (a dict, written as JSON)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    t = np.arange(n) / FS
    frames, force, trial, indentor = [], [], [], []
    for k in range(n_trials):
        level = rng.uniform(0.5, 8.0)
        f = level * np.clip((t - 1.0) / 0.5, 0, 1)
        gains = np.array([0.03, 0.02, 0.01, 0.03, 0.02, 0.01]) * (1 + 0.2 * (k % 3))
        s = 0.1 + f[:, None] * gains + rng.normal(size=(n, 6)) * 1e-3
        frames.append(s.astype(np.float32))
        force.append((f + rng.normal(size=n) * 0.01).astype(np.float32))
        trial.append(np.full(n, k, np.int32))
        indentor.append(np.full(n, k % 3, np.int32))
    np.savez(path, frames=np.concatenate(frames), force=np.concatenate(force),
             trial=np.concatenate(trial), indentor=np.concatenate(indentor),
             indentor_names=np.array(['flat', 'round', 'edge']), fs=np.float64(FS),
             channel_names=np.array(NAMES), tare_samples=np.int64(2000),
             **({} if identity is None else {'sensor_identity': json.dumps(identity)}))
    return path


def test_rows_follow_the_contract(tmp_path):
    ds = load_calibration(calibration_file(tmp_path / 'cal.npz', n_trials=2))
    rows = make_rows(ds, stride=100)
    assert rows.features.shape == (2 * 60, 24)  # samples 2000, 2100, ... 7900 per trial
    trial0 = ds['frames'][:8000].astype(np.float64)
    tared = trial0 - trial0[:2000].mean(axis=0)
    # latest frame = median of the last 11 tared samples; 2.5 s mean over available rows
    np.testing.assert_allclose(rows.features[0, :6], np.median(tared[1990:2001], axis=0),
                               atol=1e-12)
    assert rows.indentor_names == ('flat', 'round', 'edge')


def test_bad_datasets_are_refused(tmp_path):
    path = calibration_file(tmp_path / 'cal.npz', n_trials=2)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays['channel_names'] = np.array(NAMES[::-1])
    np.savez(tmp_path / 'swapped.npz', **arrays)
    with pytest.raises(ValueError, match='contract order'):
        load_calibration(tmp_path / 'swapped.npz')
    del arrays['force']
    np.savez(tmp_path / 'missing.npz', **arrays)
    assert train_force.main([str(tmp_path / 'missing.npz')]) == 2


def test_train_force_tool(tmp_path, capsys):
    path = calibration_file(tmp_path / 'cal.npz')
    out = tmp_path / 'model.npz'
    report = tmp_path / 'cv.json'
    assert train_force.main([str(path), '-o', str(out), '--folds', '4', '--stride', '100',
                             '--report', str(report)]) == 0
    text = capsys.readouterr().out
    assert '4-fold trial-wise CV, with history features' in text and 'latest frame only' in text
    result = json.loads(report.read_text())
    assert set(result['cv_history']['per_indentor']) == {'flat', 'round', 'edge'}
    assert result['cv_history']['overall']['rmse'] < 1.0
    model = ForceModel.load(out)
    assert model.metadata['trials'] == 12 and len(model.metadata['dataset_sha256']) == 64
    assert model.force_range[1] > 7.0
    # no recorded identity: the model still knows the rate and the channel order
    assert model.metadata['sensor'] == {'sample_rate': FS, 'channel_names': NAMES}


def test_the_model_records_the_sensor_it_was_trained_on(tmp_path):
    path = calibration_file(tmp_path / 'cal.npz', n_trials=4, identity=BOARD)
    out = tmp_path / 'model.npz'
    assert train_force.main([str(path), '-o', str(out), '--folds', '0']) == 0
    assert ForceModel.load(out).metadata['sensor'] == BOARD


@pytest.mark.parametrize('identity, words', [
    ('{"source": "serial"', 'sensor_identity'),                       # not JSON
    (json.dumps({'source': 'serial'}), 'device_id'),                    # incomplete
    (json.dumps(dict(BOARD, sample_rate=1000.0)), '1000 Hz'),           # another rate
    (json.dumps(dict(BOARD, channel_names=NAMES[::-1])), 'channel order'),
])
def test_an_identity_that_disagrees_with_the_data_is_refused(tmp_path, identity, words):
    path = calibration_file(tmp_path / 'cal.npz', n_trials=2)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    np.savez(tmp_path / 'bad.npz', sensor_identity=identity, **arrays)
    with pytest.raises(ValueError, match=words):
        load_calibration(tmp_path / 'bad.npz')
