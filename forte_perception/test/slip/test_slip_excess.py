"""A finger's CUSUM input (forte_perception.slip.excess): the mean and the largest channel,
the coherent sum, the excess of what varies within the window; known answers."""
import math

import numpy as np
import pytest

from forte_perception.slip.excess import coherent_excess, demeaned_excess, pooled_excess


def test_one_channel_alone_is_pooled_at_its_excess_less_the_offset():
    z = np.array([[12.0, 0.0, 0.0, 3.0, 3.0, 3.0],        # one channel of the left finger
                  [9.0, 9.0, 9.0, np.nan, 1.0, np.nan],   # a whole finger; one usable channel
                  [np.nan] * 3 + [-2.0, -1.0, 0.0]])      # a blind finger, a quiet one
    np.testing.assert_allclose(pooled_excess(z, math.inf), [[4.0, 3.0], [9.0, 1.0],
                                                            [np.nan, -1.0]])
    np.testing.assert_allclose(pooled_excess(z, 4.0), [[8.0, 3.0], [9.0, 1.0],
                                                       [np.nan, -1.0]])


@pytest.mark.parametrize('offset', [math.inf, 4.0])
def test_every_channel_usable_pools_as_the_masked_rule_bit_for_bit(offset):
    """Rows whose six channels are all finite take a path without masking; it must give the
    masked rule's numbers exactly (mean of the usable channels, largest less the offset),
    whatever the magnitudes, or chunks with a NaN elsewhere would pool differently."""
    rng = np.random.default_rng(11)
    for scale in (1e-3, 1.0, 30.0, 1e4):
        z = scale * rng.standard_normal((400, 6))
        masked = z.copy()
        masked[-1] = np.nan                              # the last row forces the masked rule
        got = pooled_excess(z, offset)
        want = pooled_excess(masked, offset)[:-1]
        assert np.array_equal(got[:-1], want)
        grouped = z[:, [[0, 1, 2], [3, 4, 5]]]
        np.testing.assert_allclose(got, np.fmax(grouped.mean(axis=2),
                                                grouped.max(axis=2) - offset), rtol=1e-12)


def moments_of(signals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power [dB], means and finger-pair products (1, 6) of one window of ``signals`` (n, 6)."""
    means = signals.mean(axis=0)
    products = np.array([(signals[:, a] * signals[:, b]).mean()
                         for a, b in ((0, 1), (0, 2), (1, 2), (3, 4), (3, 5), (4, 5))])
    return (10.0 * np.log10((signals ** 2).mean(axis=0)))[None], means[None], products[None]


def test_the_coherent_excess_of_known_windows():
    """Whitened by quiet levels of 0 dB: three equal in-phase unit sines give 10 log10(3 x
    0.5 x 3 / 3) (a channel's 0.5 plus 4.8 dB), whatever the sign of each channel; three
    orthogonal ones give the mean of the channels' powers; a constant gives nothing."""
    t = np.arange(400) / 2000.0
    sine = np.sin(2 * np.pi * 25.0 * t)
    cosine = np.cos(2 * np.pi * 25.0 * t)
    level = np.zeros(6)
    equal = 10.0 * math.log10(0.5 * 3.0)
    for signs in ((1, 1, 1), (1, -1, 1), (-1, 1, 1), (1, 1, -1), (-1, -1, -1)):
        signals = np.column_stack([s * sine for s in signs] + [sine, sine, cosine])
        got = coherent_excess(*[moments_of(signals)[0], level, *moments_of(signals)[1:]])
        assert got[0, 0] == pytest.approx(equal, abs=1e-9)
        # the right finger: two in phase and one in quadrature: (0.5 x 4 + 0.5) / 3
        assert got[0, 1] == pytest.approx(10.0 * math.log10(2.5 / 3.0), abs=1e-3)
    signals = np.column_stack([sine, cosine, 1e-3 * np.sin(2 * np.pi * 50.0 * t)] * 2)
    got = coherent_excess(*[moments_of(signals)[0], level, *moments_of(signals)[1:]])
    assert got[0, 0] == pytest.approx(10.0 * math.log10((0.5 + 0.5 + 0.5e-6) / 3.0), abs=1e-3)
    # a constant (a ramp through the band-pass) on every channel: the mean is removed
    power, means, products = moments_of(np.full((400, 6), 2.0) + 1e-3 * sine[:, None])
    assert coherent_excess(power, level, means, products)[0, 0] < -50.0  # 10.8 dB with it
    # a channel without a level or unusable: that finger unknown, the other not
    for bad_level, bad_power in ((0, None), (None, 4)):
        lv, pw = level.copy(), moments_of(signals)[0].copy()
        if bad_level is not None:
            lv[bad_level] = np.nan
        if bad_power is not None:
            pw[0, bad_power] = np.nan
        got = coherent_excess(pw, lv, *moments_of(signals)[1:])
        assert np.isnan(got[0, 0 if bad_level is not None else 1])
        assert np.isfinite(got[0, 1 if bad_level is not None else 0])


def test_the_coherent_excess_joins_the_pooled_input_less_its_offset():
    z = np.array([[2.0, 2.0, 2.0, 9.0, 0.0, 0.0]])
    coherent = np.array([[7.0, np.nan]])
    np.testing.assert_array_equal(pooled_excess(z, 4.0, coherent, 2.0), [[5.0, 5.0]])
    np.testing.assert_array_equal(pooled_excess(z, 4.0, coherent, math.inf), [[2.0, 5.0]])
    np.testing.assert_array_equal(pooled_excess(z, 4.0), [[2.0, 5.0]])
    np.testing.assert_array_equal(pooled_excess(z, math.inf, coherent, 2.0), [[5.0, 3.0]])


def test_the_demeaned_excess_of_known_windows():
    """Quiet levels of 0 dB: a unit sine over whole periods keeps its power 0.5; a constant
    of 2 on a floor of 1e-3 keeps the floor; a sine over half a period at 17.2 Hz (a
    window of 30 ms catches about that of a 17 Hz mode) keeps 1 - 8 / pi^2 of its power; NaN
    where the power or the level is."""
    t = np.arange(640) / 2000.0                          # 8 periods of 25 Hz
    for signals, floor, kept in ((np.sin(2 * np.pi * 25.0 * t), 0.0, 0.5),
                                 (np.full(t.size, 2.0), 1e-3, 1e-3)):
        signals = np.column_stack([signals] * 6)
        power = 10.0 * np.log10((signals ** 2).mean(axis=0) + floor)[None]
        got = demeaned_excess(power, np.zeros(6), signals.mean(axis=0)[None])
        np.testing.assert_allclose(got, 10.0 * math.log10(kept), atol=1e-6)
    half = np.sin(np.pi * np.arange(58) / 58.0)      # half a period of 17.2 Hz (29 ms)
    power = np.full((1, 6), 10.0 * np.log10((half ** 2).mean()))
    got = demeaned_excess(power, np.zeros(6), np.full((1, 6), half.mean()))
    np.testing.assert_allclose(got, 10.0 * np.log10((half ** 2).mean() - half.mean() ** 2))
    assert got[0, 0] == pytest.approx(10.0 * math.log10(0.5 * (1.0 - 8.0 / math.pi ** 2)),
                                      abs=0.05)
    level = np.zeros(6)
    level[1] = np.nan
    power[0, 4] = np.nan
    got = demeaned_excess(power, level, np.zeros((1, 6)))
    np.testing.assert_array_equal(np.isnan(got[0]), [False, True, False, False, True, False])
    # a window mean that rounding puts a hair over the root of the power: finite, not NaN
    assert np.isfinite(demeaned_excess(np.zeros((1, 6)), np.zeros(6),
                                       np.full((1, 6), 1.0 + 1e-15))).all()
