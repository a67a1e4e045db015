"""PerceptionPipeline: tare, contact, force and slip in chunks equal the batch functions."""
import numpy as np
import pytest

from forte_perception.force import ForceModel, force_features
from forte_perception.median import running_median
from forte_perception.pipeline import (
    PerceptionPipeline,
    PipelineConfig,
    contact_flags,
)
from forte_perception.slip.detector import SlipParams, slip_features
from forte_perception.testing import FS, random_walk, slip_bursts


def toy_model():
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.3, 0.3, size=(400, 24))
    y = 4.0 + 10.0 * x[:, :6].sum(axis=1)
    return ForceModel.fit(x, y, force_range=(0.0, 8.0))


def stream(n=16000, seed=0, growth_db_per_s=450.0):
    """Quiet, a press, two slip bursts; inside the transducer's [-1, 1] at the default growth
    (600 dB/s reaches |x| = 4: out of range, i.e. invalid at the default input_limit)."""
    x = 0.2 + slip_bursts(n, seed=seed, onsets=(9000, 13000),
                          growth_db_per_s=growth_db_per_s) + random_walk(n, seed=seed) * 0.05
    x[6000:7000] += np.linspace(0, 0.05, 1000)[:, None]  # a press: contact
    x[7000:] += 0.05
    return x


def run(pipe, x, chunk=20):
    return [pipe.process(x[i:i + chunk]) for i in range(0, len(x), chunk)]


def test_auto_tare_is_the_mean_of_the_first_quiet_samples():
    x = stream()
    pipe = PerceptionPipeline(PipelineConfig(tare_duration=2.0))
    outs = run(pipe, x)
    np.testing.assert_allclose(pipe.baseline, x[:4000].mean(axis=0), rtol=1e-13)
    assert not outs[198].tared and outs[199].tared  # 4000 samples = 200 chunks of 20
    filt = running_median(x)
    np.testing.assert_allclose(outs[-1].filtered, filt[-1] - pipe.baseline, rtol=0, atol=1e-15)


@pytest.mark.parametrize('growth,limit', [(450.0, 1.0), (600.0, 5.0)])
def test_online_equals_offline_batch(growth, limit):
    """All values valid: the unmasked PSD detector (robust mode; the batch function has no
    sequential events), equal to the batch functions."""
    x = stream(growth_db_per_s=growth)
    assert np.abs(x).max() < limit
    model = toy_model()
    psd_mode = SlipParams(mode='robust')
    pipe = PerceptionPipeline(PipelineConfig(slip=psd_mode, input_limit=limit), model=model)
    outs = run(pipe, x, chunk=20)
    filt = running_median(x)
    slip = slip_features(filt, params=psd_mode)
    feats = force_features(filt) - np.tile(pipe.baseline, 4)
    force, valid = model.predict(feats, return_valid=True)
    contact = contact_flags(filt, np.zeros((0, 6)), 200, 0.01)
    by_index = {int(s): i for i, s in enumerate(slip.sample_index)}
    n_force = 0
    for i, o in enumerate(outs):
        assert o.sample_index == 20 * i + 19
        np.testing.assert_array_equal(o.contact, contact[o.sample_index])
        if o.slip_sample_index >= 0:
            u = by_index[o.slip_sample_index]
            np.testing.assert_array_equal(o.psd_max_db, slip.psd_max_db[u])
            np.testing.assert_array_equal(o.finger_variance, slip.finger_variance[u])
            lo = np.searchsorted(slip.sample_index, 20 * i)
            assert o.slip == bool(slip.slip[lo:u + 1].any())
        if o.tared:
            assert o.force_sample_index == o.sample_index  # 20-sample chunks, 100 Hz
            np.testing.assert_allclose(o.force, force[o.force_sample_index], rtol=0, atol=1e-12)
            assert o.force_valid == valid[o.force_sample_index]
            n_force += 1
        else:
            assert np.isnan(o.force) and not o.force_valid
        assert o.data_valid and not o.channel_health.any()
    assert n_force > 500
    assert any(o.slip for o in outs) and any(o.contact.any() for o in outs)
    assert outs[-1].slip_updates == len(slip)


def test_tare_requests():
    x = stream()
    pipe = PerceptionPipeline(PipelineConfig(auto_tare=False))
    outs = run(pipe, x[:4000])
    assert not outs[-1].tared and pipe.baseline is None
    ok, reason = pipe.request_tare(0.5)
    assert ok, reason
    run(pipe, x[4000:5000])
    assert pipe.tare_result.success
    np.testing.assert_allclose(pipe.baseline, x[4000:5000].mean(axis=0), rtol=1e-13)
    # during the press: refused
    run(pipe, x[5000:6400])
    assert pipe.process(x[6400:6420]).contact.any()
    ok, reason = pipe.request_tare()
    assert not ok and 'contact' in reason
    # started while quiet, then contact during the period: aborted, baseline kept
    quiet = PerceptionPipeline(PipelineConfig(auto_tare=False))
    run(quiet, x[:5800])
    assert quiet.request_tare(1.0)[0]
    run(quiet, x[5800:8000])
    assert quiet.tare_result is not None and not quiet.tare_result.success
    assert 'contact' in quiet.tare_result.message and quiet.baseline is None
    assert not quiet.request_tare(-1.0)[0]


def test_invalid_values_mask_their_channel_without_a_restart():
    x = stream()
    pipe = PerceptionPipeline()
    run(pipe, x[:5000])
    bad = x[5000:5020].copy()
    bad[5:8, 2] = np.nan
    bad[15, 0] = np.inf
    o = pipe.process(bad)
    assert not o.data_valid and o.rejected_samples == 4 and o.input_gaps == 0
    assert o.sample_index == 5019 and o.slip_active  # other channels decide: no restart
    assert o.channel_health.tolist() == [5, 0, 5, 0, 0, 0]  # NON_FINITE | MASKED
    # median window 5009..5019: holds the inf of channel 0 (5015), not the NaNs (5005-5007)
    assert np.isnan(o.filtered[0]) and np.isfinite(o.filtered[1:]).all()
    assert np.isnan(o.psd_max_db[[0, 2]]).all() and np.isfinite(o.psd_max_db[[1, 3, 4, 5]]).all()
    assert pipe.health.non_finite.tolist() == [1, 0, 3, 0, 0, 0]
    o = pipe.process(x[5020:5040])
    assert o.data_valid and o.input_gaps == 0 and o.channel_health.tolist() == [4, 0, 4, 0, 0, 0]
    # the channels come back once their windows and histories are clean (476 samples)
    outs = run(pipe, x[5040:5600])
    assert all(o.slip_active for o in outs)
    assert not outs[-1].channel_health.any() and np.isfinite(outs[-1].psd_max_db).all()


def test_marked_gap():
    x = stream()
    pipe = PerceptionPipeline()
    run(pipe, x[:5000])
    pipe.mark_gap()
    o = pipe.process(x[5000:5020])
    assert not o.data_valid and o.input_gaps == 1 and not o.slip_active and o.tared
    assert pipe.process(x[5020:5040]).data_valid


def test_reset_and_config_validation():
    pipe = PerceptionPipeline()
    run(pipe, stream()[:5000])
    pipe.reset()
    o = pipe.process(np.zeros((20, 6)))
    assert o.sample_index == 19 and not o.tared and o.slip_updates == 0
    for bad in (dict(force_rate=300.0), dict(median_window=0), dict(contact_threshold=0.0),
                dict(tare_duration=0.0), dict(contact_window=1), dict(force_rate=0.0)):
        with pytest.raises(ValueError):
            PerceptionPipeline(PipelineConfig(**bad))
    with pytest.raises(ValueError):
        pipe.process(np.zeros((4, 5)))
    assert PipelineConfig(force_rate=200.0).force_step == 10
    assert FS == PipelineConfig().fs
