"""Contract of the simulated scene API used by the closed-loop tools (no ROS)."""
import numpy as np
import pytest

from forte_ros.contract import QUANTUM
from forte_sim import CATEGORIES, OBJECT_RESTING, OBJECTS, make_scene, objects_in_category


def test_catalogue_has_the_papers_categories_and_counts():
    counts = {category: len(objects_in_category(category)) for category in CATEGORIES}
    assert counts == {'fragile_rigid': 7, 'fragile_deformable': 7, 'slippery': 9,
                      'everyday': 8}
    assert len(OBJECTS) == 31
    for name in ('raspberry', 'soda_can', 'apple', 'jam_jar', 'raw_egg', 'potato_chip'):
        assert name in OBJECTS


def test_step_returns_quantised_frames_and_truth():
    scene = make_scene('grasp', object_name='raspberry', seed=0)
    frames, truth = scene.step(37, scene.initial_angle, 0.0)
    assert frames.shape == (37, 6) and frames.dtype == np.float64
    codes = frames / QUANTUM
    np.testing.assert_array_equal(codes, np.rint(codes))
    assert np.all(frames >= -1.0) and np.all(frames < 1.0)
    assert truth.finger_force.shape == (37, 2)
    assert truth.object_state[-1] == OBJECT_RESTING
    assert scene.time == pytest.approx(37 * 0.0005)
    assert scene.joint_position == pytest.approx(scene.initial_angle)


def test_unknown_names_and_bad_commands_are_refused():
    with pytest.raises(ValueError, match='unknown object'):
        make_scene('grasp', object_name='unobtainium')
    with pytest.raises(ValueError, match='unknown scene'):
        make_scene('teleport')
    scene = make_scene('grasp', object_name='apple')
    with pytest.raises(ValueError, match='finite'):
        scene.step(10, float('nan'), 0.0)
    with pytest.raises(ValueError, match='n_samples'):
        scene.step(0, 0.5, 0.0)
