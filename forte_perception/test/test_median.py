"""Causal running median: known answers, start-up definition, streaming == batch."""
import numpy as np
import pytest

from forte_perception.median import RunningMedian, running_median


def naive(x, m):
    return np.array([np.median(x[max(0, t - m + 1):t + 1], axis=0) for t in range(len(x))])


def test_impulse_is_removed_and_step_is_delayed_by_half_the_window():
    x = np.zeros((60, 6))
    x[20, :] = 1.0  # impulse
    x[40:, 1] = 1.0  # step
    y = running_median(x, 11)
    assert np.all(y[:, 0] == 0.0)
    assert np.all(y[:, 1][:45] == 0.0) and np.all(y[:, 1][45:] == 1.0)  # 5 samples later


def test_against_numpy_median_including_start_up():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(500, 6))
    for m in (1, 2, 5, 11):
        np.testing.assert_array_equal(running_median(x, m), naive(x, m))
    # start-up: median of the samples so far (mean of the two middle ones when even)
    y = running_median(x[:4], 11)
    np.testing.assert_array_equal(y[3], np.median(x[:4], axis=0))
    np.testing.assert_array_equal(y[0], x[0])


def test_streaming_equals_batch_bit_for_bit():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(3000, 6)) + np.linspace(0, 5, 3000)[:, None]
    batch = running_median(x, 11)
    for sizes in ([1], [3, 7], [10, 1, 500], rng.integers(1, 40, 200)):
        f = RunningMedian(11, 6)
        parts, i, k = [], 0, 0
        while i < len(x):
            c = int(sizes[k % len(sizes)])
            parts.append(f.update(x[i:i + c]))
            i, k = i + c, k + 1
        np.testing.assert_array_equal(np.concatenate(parts), batch)


def test_reset_and_bad_input():
    f = RunningMedian(11, 6)
    f.update(np.ones((20, 6)))
    f.reset()
    np.testing.assert_array_equal(f.update(np.full((3, 6), 2.0)), np.full((3, 6), 2.0))
    assert f.update(np.zeros((0, 6))).shape == (0, 6)
    with pytest.raises(ValueError):
        RunningMedian(0)
    with pytest.raises(ValueError):
        f.update(np.zeros((3, 5)))
