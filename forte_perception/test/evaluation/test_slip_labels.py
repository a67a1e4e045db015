"""The labelled slip scene format (forte_perception.evaluation.labels): intervals, file
round trip, refusals."""
import numpy as np
import pytest

from forte_perception.evaluation.labels import (
    FINGER_LEFT,
    SlipScene,
    load_scenes,
    save_scenes,
    subtract_intervals,
)


def labelled(name='a/p0/0', n=4000, seed=0, frames=None, context=None):
    rng = np.random.default_rng(seed)
    if frames is None:
        frames = np.rint(rng.normal(0.0, 3.0, (n, 6))) / 1024.0
    return SlipScene(name, 'a', 'tune', 'signal', 'p0', seed, frames,
                     np.array([[1500, 1800]]), [FINGER_LEFT], ('stick_slip',),
                     np.array([4.0]), np.array([[1000, 1400], [2900, n]]),
                     context=context or {'arm_velocity': np.full(n, 0.005)},
                     params={'noise_lsb': 3.0})


def test_subtract_intervals_known_answers():
    np.testing.assert_array_equal(subtract_intervals(0, 100, []), [[0, 100]])
    np.testing.assert_array_equal(subtract_intervals(0, 100, [(10, 20), (15, 30), (90, 200)]),
                                  [[0, 10], [30, 90]])
    assert subtract_intervals(0, 100, [(-5, 150)]).shape == (0, 2)
    np.testing.assert_array_equal(subtract_intervals(50, 100, [(0, 60)]), [[60, 100]])


def test_file_round_trip_is_exact(tmp_path):
    scenes = [labelled(), labelled('a/p0/2', n=3000, seed=2)]
    save_scenes(tmp_path / 'set.npz', scenes)
    back = load_scenes(tmp_path / 'set.npz')
    assert [s.name for s in back] == ['a/p0/0', 'a/p0/2']
    for a, b in zip(scenes, back, strict=True):
        np.testing.assert_array_equal(a.frames, b.frames)
        np.testing.assert_array_equal(a.events, b.events)
        np.testing.assert_array_equal(a.holding, b.holding)
        assert (b.event_kinds, b.event_fingers.tolist()) == (('stick_slip',), [FINGER_LEFT])
        assert b.params == {'noise_lsb': 3.0}
        assert set(b.context) == {'arm_velocity'}
        np.testing.assert_allclose(b.context['arm_velocity'], 0.005, rtol=1e-6)


def test_frames_off_the_11_bit_grid_are_refused(tmp_path):
    with pytest.raises(ValueError, match='quantised'):
        save_scenes(tmp_path / 'set.npz', [labelled(frames=np.full((100, 6), 0.1))])


def test_bad_labels_are_refused():
    with pytest.raises(ValueError, match='split'):
        SlipScene('x', 'a', 'train', 'signal', 'p0', 0, np.zeros((10, 6)), [], [], (), [],
                  [])
    with pytest.raises(ValueError, match='kinds'):
        SlipScene('x', 'a', 'tune', 'signal', 'p0', 0, np.zeros((10, 6)), [[1, 2]], [3],
                  ('wobble',), [1.0], [])
    with pytest.raises(ValueError, match='one finger'):
        SlipScene('x', 'a', 'tune', 'signal', 'p0', 0, np.zeros((10, 6)), [[1, 2]], [],
                  ('gross',), [1.0], [])
