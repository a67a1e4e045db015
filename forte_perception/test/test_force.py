"""Force features (O(1) running means) and the SVR force model."""
import json

import numpy as np
import pytest
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVR

from forte_perception.force import (
    FEATURE_NAMES,
    ForceFeatures,
    ForceModel,
    force_features,
    force_features_reference,
    window_lengths,
)
from forte_perception.testing import FS, random_walk


def test_window_lengths_and_names():
    assert window_lengths(2000.0) == (5000, 10000, 20000)
    assert len(FEATURE_NAMES) == 24
    assert FEATURE_NAMES[0] == 'left_distal_latest'
    assert FEATURE_NAMES[6] == 'left_distal_mean_2.5s'
    assert FEATURE_NAMES[23] == 'right_root_mean_10.0s'


def test_features_equal_numpy_means_including_the_first_10_s():
    x = random_walk(50000, seed=0, scale=1e-2) + 0.7
    feats = force_features(x)
    idx = np.r_[0, 1, 2, 4999, 5000, 9999, 10000, 19998, 19999, 20000, 20001, 33333, 49999]
    ref = force_features_reference(x, index=idx)
    np.testing.assert_allclose(feats[idx], ref, rtol=1e-13, atol=1e-15)
    # layout: latest frame, then 2.5 s, 5 s, 10 s means per channel
    np.testing.assert_array_equal(feats[:, :6], x)
    np.testing.assert_allclose(feats[3, 6:12], x[:4].mean(axis=0), rtol=1e-15)
    np.testing.assert_allclose(feats[30000, 18:24], x[10001:30001].mean(axis=0), rtol=1e-13)


def test_streaming_equals_batch_bit_for_bit():
    x = random_walk(45000, seed=1)
    batch = force_features(x)
    rng = np.random.default_rng(2)
    for sizes in ([20], [1, 999, 7], rng.integers(1, 5000, 40)):
        f = ForceFeatures(FS)
        parts, i, k = [], 0, 0
        while i < len(x):
            c = int(sizes[k % len(sizes)])
            parts.append(f.update(x[i:i + c])[1])
            i, k = i + c, k + 1
        np.testing.assert_array_equal(np.concatenate(parts), batch)
    np.testing.assert_array_equal(f.latest(), batch[-1])
    # selection of rows: every 20th sample
    idx, sel = ForceFeatures(FS).update(x, every=20)
    np.testing.assert_array_equal(idx, np.arange(19, len(x), 20))
    np.testing.assert_array_equal(sel, batch[19::20])


def test_long_run_with_dc_offset_stays_exact():
    """Two minutes of raw ADC counts (~2048) with steps: running sums are resynchronised."""
    rng = np.random.default_rng(3)
    n = 240000
    x = 2048.0 + np.round(rng.normal(size=(n, 6)) * 3)
    x[100000:] += 700.0
    feats = force_features(x)
    idx = np.linspace(0, n - 1, 60).astype(int)
    ref = force_features_reference(x, index=idx)
    np.testing.assert_allclose(feats[idx], ref, rtol=1e-14, atol=0)


def test_nan_is_rejected():
    f = ForceFeatures(FS)
    with pytest.raises(ValueError, match='non-finite'):
        f.update(np.full((3, 6), np.nan))
    assert f.samples_seen == 0
    assert np.isnan(f.latest()).all()


def synthetic_dataset(n_trials=12, seed=0):
    """Features and force of a made-up sensor: force = sum of channel responses."""
    rng = np.random.default_rng(seed)
    feats, force, trial = [], [], []
    for t in range(n_trials):
        level = rng.uniform(0, 6)
        n = 300
        f = level * (1 - np.exp(-np.arange(n) / 50.0)) + rng.normal(size=n) * 0.02
        gains = np.array([0.08, 0.05, 0.03, 0.07, 0.05, 0.02])
        s = f[:, None] * gains + rng.normal(size=(n, 6)) * 0.002
        hist = np.concatenate([s, s * 0.9, s * 0.8, s * 0.7], axis=1)
        feats.append(hist)
        force.append(np.clip(f, 0, None))
        trial.append(np.full(n, t))
    return np.concatenate(feats), np.concatenate(force), np.concatenate(trial)


@pytest.fixture(scope='module')
def model_and_data():
    x, y, _ = synthetic_dataset()
    return ForceModel.fit(x[::3], y[::3], force_range=(0.0, 8.0)), x, y


def test_numpy_prediction_equals_sklearn(model_and_data):
    model, x, y = model_and_data
    scaler = StandardScaler().fit(x[::3])
    svr = SVR(kernel='rbf', C=10.0, epsilon=0.05, gamma='scale').fit(scaler.transform(x[::3]),
                                                                      y[::3])
    np.testing.assert_allclose(model.decision(x), svr.predict(scaler.transform(x)),
                               rtol=0, atol=1e-9)
    rmse = np.sqrt(np.mean((model.predict(x) - y) ** 2))
    assert rmse < 0.2


def test_save_load_round_trip_without_pickle(tmp_path, model_and_data):
    model, x, _ = model_and_data
    path = tmp_path / 'force_model.npz'
    model.save(path)
    with np.load(path, allow_pickle=False) as data:
        header = json.loads(str(data['header']))
    assert header['format'] == 'forte_force_model' and header['version'] == 1
    assert header['output_units'] == 'N' and len(header['feature_names']) == 24
    loaded = ForceModel.load(path)
    np.testing.assert_array_equal(loaded.predict(x), model.predict(x))
    # unknown versions are refused
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header['version'] = 99
    arrays['header'] = np.array(json.dumps(header))
    np.savez(tmp_path / 'future.npz', **arrays)
    with pytest.raises(ValueError, match='version 99'):
        ForceModel.load(tmp_path / 'future.npz')


def test_validity_and_clipping(model_and_data):
    model, x, _ = model_and_data
    force, valid = model.predict(x[:50], return_valid=True)
    assert valid.all()
    outside = x[:3].copy()
    outside[0, 0] = model.feature_max[0] + 10 * (model.feature_max[0] - model.feature_min[0])
    outside[1, 5] = np.nan
    outside[2, 23] = np.inf
    force, valid = model.predict(outside, return_valid=True)
    assert not valid.any()
    assert np.isfinite(force[0]) and np.isnan(force[1]) and np.isnan(force[2])
    far = x[:1] * 50.0
    assert 0.0 <= model.predict(far)[0] <= 8.0  # clipped to the physical range


def test_latest_only_model_and_reduced_model(model_and_data):
    _, x, y = model_and_data
    base = ForceModel.fit(x[::3, :6], y[::3], kind='latest')
    assert base.predict(x).shape == (len(x),)  # takes (n, 24) and uses the first 6
    model = ForceModel.fit(x[::3], y[::3])
    small = model.reduced(max(5, model.support_vectors.shape[0] // 4))
    assert small.support_vectors.shape[0] < model.support_vectors.shape[0]
    assert np.sqrt(np.mean((small.predict(x) - model.predict(x)) ** 2)) < 0.2
    with pytest.raises(ValueError):
        ForceModel.fit(x[:10, :6], y[:10])  # history model needs 24 features
