"""Per-channel validity and health (issue "Never silently wrong at the edges").

Known answers from the specification (docs/perception.md, "Invalid values"): an invalid
value (NaN, inf, |x| > input_limit) affects only its channel; the other channels' outputs are
bit for bit those of the clean signal; slip decisions follow the documented rule on the
usable channels (checked against an oracle written here from the rule, on Welch PSDs);
data_valid is false exactly on the chunks with an invalid value."""
import numpy as np
import pytest

from forte_perception.channel_health import (
    HEALTH_MASKED,
    HEALTH_NON_FINITE,
    HEALTH_OUT_OF_RANGE,
    HEALTH_RAILED,
    HEALTH_STUCK,
    LEVEL_ERROR,
    LEVEL_OK,
    LEVEL_WARN,
    ChannelHealth,
    channel_report,
)
from forte_perception.force import ForceModel
from forte_perception.median import running_median
from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.slip.detector import SlipParams, slip_features_reference
from forte_perception.testing import FS, band_bursts

CHUNK = 20
#: The masked-channel oracle below implements the paper mode's documented rule.
P = SlipParams(mode='paper')
PAPER = PipelineConfig(slip=P)
M = 11
DECISION_REACH = P.window + (P.history - 1) * P.hop + M - 1  # 476 raw samples
PSD_REACH = P.window + M - 1  # 410


def run(pipe, x, chunk=CHUNK):
    return [pipe.process(x[i:i + chunk]) for i in range(0, len(x), chunk)]


def toy_model():
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.3, 0.3, size=(400, 24))
    return ForceModel.fit(x, 4.0 + 10.0 * x[:, :6].sum(axis=1), force_range=(0.0, 8.0))


def oracle(clean, bad_index, bad_channels):
    """Slip per update from the documented rule, on scipy.signal.welch PSDs.

    ``clean`` (n, 6): the signal without the invalid values (channels other than
    ``bad_channels`` are what the pipeline sees); ``bad_index``: sample indices of the
    invalid values. Returns (update end indices, slip (m,), finger variance (m, 2),
    usable (m, 6)).
    """
    ref = slip_features_reference(running_median(clean), FS, P)
    ends = ref.sample_index
    v = P.history
    usable = np.ones((ends.size, 6), bool)
    for r in bad_index:
        hit = (ends >= r) & (ends - DECISION_REACH + 1 <= r)
        for c in bad_channels:
            usable[hit, c] = False
    slip = np.zeros(ends.size, bool)
    finger = np.full((ends.size, 2), np.nan)
    for u in range(v - 1, ends.size):
        hist = ref.psd_max_db[u - v + 1:u + 1]
        var = [float(np.var(hist[:, c])) if usable[u, c] and np.all(np.diff(hist[:, c]) > P.delta)
               else 0.0 for c in range(6)]
        groups = {}
        for f, chans in enumerate(((0, 1, 2), (3, 4, 5))):
            live = [c for c in chans if usable[u, c]]
            if live:
                groups[f] = sum(var[c] for c in live) / len(live)
        if not groups:
            continue
        if min(groups.values()) < P.alpha:
            groups = dict.fromkeys(groups, 0.0)
        for f, g in groups.items():
            finger[u, f] = g
        slip[u] = max(groups.values()) > P.threshold
    return ends, slip, finger, usable


def check_against_oracle(outs, clean, bad_index, bad_channels):
    ends, slip, finger, usable = oracle(clean, bad_index, bad_channels)
    for i, o in enumerate(outs):
        inside = (ends >= CHUNK * i) & (ends < CHUNK * (i + 1))
        assert o.slip == bool(slip[inside].any()), f'state {i}'
        if o.slip_sample_index < 0:
            assert not o.slip_active
            continue
        u = int(np.flatnonzero(ends == o.slip_sample_index)[0])
        available = [usable[u, :3].any(), usable[u, 3:].any()]
        if u >= P.history - 1:
            assert o.slip_active == any(available), f'state {i}'
            np.testing.assert_allclose(o.finger_variance, finger[u], rtol=0, atol=1e-6,
                                       err_msg=f'state {i}')
        else:
            assert not o.slip_active
    return slip


@pytest.mark.parametrize('value,flag', [(np.nan, HEALTH_NON_FINITE),
                                         (1e160, HEALTH_OUT_OF_RANGE),
                                         (-np.inf, HEALTH_NON_FINITE)])
def test_one_bad_channel_every_100_ms_blinds_nothing_else(value, flag):
    clean = band_bursts(12000)
    x = clean.copy()
    bad = np.arange(7, 12000, 200)  # every 100 ms on left_distal
    x[bad, 0] = value
    pipe = PerceptionPipeline(PAPER, model=toy_model())
    outs = run(pipe, x)
    reference = run(PerceptionPipeline(PAPER, model=toy_model()), clean)
    bad_chunks = set((bad // CHUNK).tolist())
    assert [not o.data_valid for o in outs] == [i in bad_chunks for i in range(len(outs))]
    assert outs[-1].input_gaps == 0 and outs[-1].rejected_samples == bad.size
    slip = check_against_oracle(outs, clean, bad, [0])
    assert slip.sum() > 30 and sum(o.slip for o in outs) >= 45  # three bursts detected
    assert sum(o.slip_active for o in outs) >= 0.95 * len(outs)
    for i, o in enumerate(outs):
        r = reference[i]
        # healthy channels: bit for bit the clean run
        np.testing.assert_array_equal(o.psd_max_db[1:], r.psd_max_db[1:])
        np.testing.assert_array_equal(o.filtered[1:], r.filtered[1:])
        assert not np.isinf(o.psd_max_db).any()
        assert (o.channel_health[1:] == 0).all()
        assert bool(o.channel_health[0] & flag) == (i in bad_chunks)
        if i >= 1:
            assert o.channel_health[0] & HEALTH_MASKED and np.isnan(o.psd_max_db[0])
            assert not o.force_valid and np.isnan(o.force)  # a 10 s window holds a NaN
        last = CHUNK * i + CHUNK - 1
        recent = bad[bad <= last]
        median_masked = recent.size and recent[-1] >= last - M + 1
        assert np.isnan(o.filtered[0]) == bool(median_masked)
    assert pipe.health.non_finite[0] + pipe.health.out_of_range[0] == bad.size
    assert pipe.health.non_finite[1:].sum() == 0


def test_a_whole_finger_masked_leaves_the_other_finger_deciding():
    clean = band_bursts(12000, channels=(3, 4, 5), seed=1)  # slip on the right finger only
    x = clean.copy()
    bad = np.arange(3, 12000, 200)
    x[bad, :3] = np.nan
    outs = run(PerceptionPipeline(PAPER), x)
    slip = check_against_oracle(outs, clean, bad, [0, 1, 2])
    assert slip.sum() > 30 and sum(o.slip for o in outs) >= 45
    assert sum(o.slip_active for o in outs) >= 0.95 * len(outs)
    assert all(np.isnan(o.finger_variance[0]) for o in outs[30:])
    assert all(np.isnan(o.psd_max_db[:3]).all() and np.isfinite(o.psd_max_db[3:]).all()
               for o in outs[30:])
    # without the NaNs the quiet left finger holds the paper's alpha gate shut (but for one
    # state where its noise happened to rise over a whole history)
    assert sum(o.slip for o in run(PerceptionPipeline(PAPER), clean)) <= 2


def test_every_channel_invalid_means_no_decision():
    x = band_bursts(4000)
    x[1000:1020] = np.nan
    outs = run(PerceptionPipeline(PAPER), x)
    assert not outs[50].data_valid and outs[51].data_valid
    # decisions need N + (V-1) hop + M - 1 raw samples after the last invalid one
    last_bad = 1019
    for o in outs[51:]:
        assert o.slip_active == (o.slip_sample_index - DECISION_REACH + 1 > last_bad)
        psd_clean = o.slip_sample_index - PSD_REACH + 1 > last_bad
        assert np.isfinite(o.psd_max_db).all() == psd_clean
        assert np.isnan(o.psd_max_db).all() != psd_clean
    assert outs[-1].slip_active and not any(o.contact.any() for o in outs[51:55])


def test_a_single_invalid_value_is_forgotten_after_its_windows():
    x = band_bursts(30000, onsets=())
    x[5000, 4] = np.inf
    pipe = PerceptionPipeline(PAPER, model=toy_model())
    outs = run(pipe, x)
    assert [i for i, o in enumerate(outs) if not o.data_valid] == [250]
    force_reach = 20000 + M - 1
    for i, o in enumerate(outs[251:], start=251):
        t = CHUNK * i + CHUNK - 1
        assert bool(o.channel_health[4] & HEALTH_MASKED) == (t - DECISION_REACH + 1 <= 5000)
        assert np.isnan(o.filtered[4]) == (t - M + 1 <= 5000)
        if o.tared:
            assert o.force_valid == (t - force_reach + 1 > 5000) or not o.force_valid
            if t - force_reach + 1 <= 5000:
                assert not o.force_valid and np.isnan(o.force)
    assert outs[-1].force_valid and outs[-1].channel_health.tolist() == [0] * 6


def test_contact_ignores_a_masked_channel():
    x = np.full((3000, 6), 0.1)
    x[2000:2100, 1] = 5.0  # out of range: replaced, not a contact
    outs = run(PerceptionPipeline(PAPER), x)
    assert not any(o.contact.any() for o in outs)
    y = x.copy()
    y[2000:2100, 1] = 0.5  # in range: the same pulse is a (paper) contact
    assert any(o.contact[0] for o in run(PerceptionPipeline(PAPER), y))


def test_tare_uses_the_valid_samples_of_each_channel():
    rng = np.random.default_rng(3)
    x = 0.1 + rng.normal(size=(5000, 6)) * 1e-4
    x[::50, 2] = np.nan  # 2 % of one channel
    pipe = PerceptionPipeline(PipelineConfig(tare_duration=1.0))
    run(pipe, x)
    valid = ~np.isnan(x[:2000, 2])
    np.testing.assert_allclose(pipe.baseline[2], x[:2000, 2][valid].mean(), rtol=1e-13)
    np.testing.assert_allclose(pipe.baseline[[0, 1, 3, 4, 5]],
                               x[:2000][:, [0, 1, 3, 4, 5]].mean(axis=0), rtol=1e-13)
    # a channel invalid most of the time: a requested tare fails, naming it
    pipe = PerceptionPipeline(PipelineConfig(auto_tare=False))
    y = 0.1 + rng.normal(size=(3000, 6)) * 1e-4
    y[::2, 5] = np.nan
    y[1::4, 5] = np.nan
    assert pipe.request_tare(1.0)[0]
    run(pipe, y)
    assert not pipe.tare_result.success and '[5]' in pipe.tare_result.message
    assert pipe.baseline is None


def test_stuck_and_railed_are_reported_not_invalidating():
    rng = np.random.default_rng(4)
    cfg = PipelineConfig(stuck_duration=1.0)
    x = np.round((0.1 + rng.normal(size=(6000, 6)) * 2e-3) * 1024) / 1024
    x[1000:, 3] = 0.25  # frozen from sample 1000
    x[4000:4100, 5] = 1.0  # clipped at the rail
    x[4000:4100, 1] = -1.0
    outs = run(PerceptionPipeline(cfg), x)
    assert all(o.data_valid for o in outs)
    stuck = [bool(o.channel_health[3] & HEALTH_STUCK) for o in outs]
    first = stuck.index(True)
    # constant from 1000; counted in whole chunks: flagged when 2000 samples have passed
    assert CHUNK * first + CHUNK - 1 - 1000 in range(2000 - 1, 2000 + 2 * CHUNK)
    assert all(stuck[first:])
    assert not any(o.channel_health[[0, 1, 2, 4, 5]].any() & HEALTH_STUCK for o in outs)
    railed = [i for i, o in enumerate(outs) if o.channel_health[5] & HEALTH_RAILED]
    assert railed == list(range(200, 205))
    assert [i for i, o in enumerate(outs) if o.channel_health[1] & HEALTH_RAILED] == railed
    # the sim's top code 1023/1024 is at the rail too; 1022/1024 is not
    h = ChannelHealth()
    row = np.full((1, 6), 0.0)
    row[0, 0], row[0, 1] = 1023 / 1024, 1022 / 1024
    flags, substituted = h.check(row, 0)
    assert substituted is None and flags.tolist() == [HEALTH_RAILED, 0, 0, 0, 0, 0]


def test_all_valid_input_is_bit_for_bit_the_unmasked_pipeline():
    """A limit so wide that nothing is invalid gives the same bits as the default on
    in-range input (the unmasked algorithm: compared with the batch functions in
    test_pipeline.py::test_online_equals_offline_batch)."""
    x = band_bursts(12000)
    a = run(PerceptionPipeline(PAPER, model=toy_model()), x)
    b = run(PerceptionPipeline(PipelineConfig(input_limit=1e6, slip=P), model=toy_model()), x, 20)
    for o, r in zip(a, b, strict=True):
        for name in ('psd_max_db', 'finger_variance', 'filtered', 'contact', 'channel_health'):
            np.testing.assert_array_equal(getattr(o, name), getattr(r, name))
        assert (o.slip, o.slip_active, o.data_valid, o.force_valid) == \
            (r.slip, r.slip_active, r.data_valid, r.force_valid)
        np.testing.assert_array_equal([o.force], [r.force])


def test_masked_outputs_do_not_depend_on_the_chunking():
    x = band_bursts(8000)
    x[np.arange(5, 8000, 333), 2] = np.nan
    x[4000, 5] = 3.0
    a = PerceptionPipeline(PAPER)
    b = PerceptionPipeline(PAPER)
    outs_a = run(a, x, 20)
    sizes = [7, 13, 40, 200]  # small chunks and one above the 64-row scan threshold
    i, k, outs_b = 0, 0, []
    while i < len(x):
        outs_b.append(b.process(x[i:i + sizes[k % 4]]))
        i += sizes[k % 4]
        k += 1
    # compare the states at common sample indices
    by_index = {o.sample_index: o for o in outs_b}
    common = [o for o in outs_a if o.sample_index in by_index]
    assert len(common) > 50
    for o in common:
        r = by_index[o.sample_index]
        np.testing.assert_array_equal(o.psd_max_db, r.psd_max_db)
        np.testing.assert_array_equal(o.finger_variance, r.finger_variance)
        np.testing.assert_array_equal(o.filtered, r.filtered)
        assert o.slip_active == r.slip_active


def test_channel_report_levels():
    h = ChannelHealth(stuck_samples=100)
    h.check(np.full((20, 6), 0.1), 0)
    reports, snap = channel_report(h, None, FS)
    assert [r[0] for r in reports] == [LEVEL_OK] * 6
    x = np.full((200, 6), 0.1)
    x[3, 2] = np.nan
    x[4, 2] = 7.0
    x[10, 4] = 1.0
    h.check(x, 20)
    reports, snap = channel_report(h, snap, FS)
    levels = [r[0] for r in reports]
    assert levels[2] == LEVEL_ERROR and 'NaN' in reports[2][1]
    assert reports[2][2]['non-finite values'] == '1' and reports[2][2]['out-of-range values'] == '1'
    assert levels[4] == LEVEL_WARN and 'rail' in reports[4][1]
    assert levels[0] == LEVEL_WARN and 'stuck' in reports[0][1]  # constant for 220 samples
    h.check(np.random.default_rng(0).normal(size=(20, 6)) * 0.01, 220)
    reports, snap = channel_report(h, snap, FS)
    assert [r[0] for r in reports] == [LEVEL_OK] * 6  # errors are per period
    assert reports[2][2]['non-finite values'] == '1'  # counts are cumulative
