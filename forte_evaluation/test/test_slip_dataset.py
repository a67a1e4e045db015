"""The simulator's part of the labelled slip set (forte_evaluation.slip_dataset): labels from
the ground truth, the split, determinism, the cache keyed by the generator sources."""
import numpy as np
import pytest

from forte_evaluation import slip_dataset
from forte_evaluation.slip_dataset import (
    SIM_SEEDS,
    build_set,
    dataset_hash,
    sim_keys,
    sim_objects,
    sim_scene,
)
from forte_perception.evaluation.labels import EVALUATE_FROM, FINGER_BOTH
from forte_perception.evaluation.scenes import make_scene
from forte_sim import CATEGORIES, OBJECTS


def test_the_split_is_disjoint_by_object_and_seed_and_covers_every_category():
    tune, held = sim_objects('tune'), sim_objects('held_out')
    assert set(tune).isdisjoint(held) and set(tune) | set(held) == set(OBJECTS)
    for category in CATEGORIES:
        assert any(OBJECTS[n].category == category for n in tune)
        assert any(OBJECTS[n].category == category for n in held)
    assert set(SIM_SEEDS['tune']).isdisjoint(SIM_SEEDS['held_out'])
    keys = sim_keys()
    assert len(keys) == len(set(keys)) == 2 * 2 * len(OBJECTS)
    with pytest.raises(ValueError, match='split'):
        sim_scene(tune[0], SIM_SEEDS['held_out'][0], 'firm')
    with pytest.raises(ValueError, match='grip'):
        sim_scene(tune[0], SIM_SEEDS['tune'][0], 'loose')


def test_a_marginal_grip_slips_with_labelled_stick_slip():
    scene = sim_scene('jam_jar', 1, 'marginal')     # held-out: jam_jar, seed 1
    assert scene.split == 'held_out' and scene.family == 'sim_slippery'
    assert scene.events.shape[0] >= 1 and 'stick_slip' in scene.event_kinds
    assert all(f == FINGER_BOTH for f, k in zip(scene.event_fingers, scene.event_kinds,
                                                strict=True) if k == 'stick_slip')
    lift = int(2.5 * 2000)
    assert scene.events[0, 0] >= lift                 # slip starts once the arm lifts
    holding = np.zeros(scene.n_samples, bool)
    for a, b in scene.holding:
        assert a >= EVALUATE_FROM
        holding[a:b] = True
    for onset, end in scene.events:
        assert not holding[onset:end + 1000].any()
    assert np.all(scene.context['arm_velocity'][lift:lift + 12000] == 0.001)


def test_a_firm_grip_of_a_light_object_holds_still():
    scene = sim_scene('potato_chip', 0, 'firm')    # tune
    assert scene.events.shape == (0, 2)
    assert scene.params['final_object_state'] == 2    # HELD
    holding_s = sum(b - a for a, b in scene.holding) / scene.fs
    assert holding_s > 3.0
    # the close (servo moving) is not holding still
    joint = scene.context['joint_position']
    moving = np.flatnonzero(np.diff(joint, prepend=joint[0]) != 0)   # sample i moved from i-1
    assert moving.size
    holding = np.zeros(scene.n_samples, bool)
    for a, b in scene.holding:
        holding[a:b] = True
    assert not holding[moving].any()


def test_simulator_scenes_are_determined_by_object_seed_and_grip():
    a = sim_scene('apple', 0, 'marginal')
    b = sim_scene('apple', 0, 'marginal')
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.events, b.events)
    codes = a.frames * 1024.0
    np.testing.assert_array_equal(codes, np.rint(codes))


def test_the_cache_is_keyed_by_the_generator_sources(tmp_path, monkeypatch):
    source = tmp_path / 'generator.py'
    source.write_text('A = 1\n')
    monkeypatch.setattr(slip_dataset, 'source_files', lambda: [source])
    first = dataset_hash()
    source.write_text('A = 2\n')
    assert dataset_hash() != first
    small = [make_scene('ramp', 'p0', 0), make_scene('ramp', 'p1', 1)]
    monkeypatch.setattr(slip_dataset.slip_scenes, 'signal_scenes', lambda: list(small))
    monkeypatch.setattr(slip_dataset, 'sim_scenes', lambda: [sim_scene('potato_chip', 0,
                                                                       'firm')])
    built, info = build_set(tmp_path / 'cache', log=lambda *_: None)
    assert not info['cached'] and len(built) == 3
    loaded, info2 = build_set(tmp_path / 'cache', log=lambda *_: None)
    assert info2['cached'] and info2['path'] == info['path']
    for x, y in zip(built, loaded, strict=True):
        assert x.name == y.name
        np.testing.assert_array_equal(x.frames, y.frames)
        np.testing.assert_array_equal(x.holding, y.holding)
    source.write_text('A = 3\n')
    _, info3 = build_set(tmp_path / 'cache', log=lambda *_: None)
    assert not info3['cached'] and info3['path'] != info['path']
