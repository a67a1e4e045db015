"""Same seed, same data; any chunking of step() gives the same stream."""
import numpy as np
import pytest

from forte_sim import make_scene

# (samples, servo command offset from theta_zeroF or None = stay open, arm velocity)
PHASES = [(3000, None, 0.0), (4000, -0.015, 0.0), (14000, -0.015, 0.005),
          (2000, -0.035, 0.005)]


def _run(object_name, seed, chunking):
    """Run the phases with chunk sizes from ``chunking(remaining)``; stack every output."""
    scene = make_scene('grasp', object_name=object_name, seed=seed)
    frames, forces, heights, onsets, states = [], [], [], [], []
    for count, offset, velocity in PHASES:
        command = scene.initial_angle if offset is None else scene.theta_zero_force + offset
        left = count
        while left:
            n = min(left, chunking(left))
            chunk, truth = scene.step(n, command, velocity)
            frames.append(chunk)
            forces.append(truth.finger_force)
            heights.append(truth.object_height)
            states.append(truth.object_state)
            onsets.extend((truth.slip_onset_indices + truth.first_index).tolist())
            left -= n
    return (np.concatenate(frames), np.concatenate(forces), np.concatenate(heights),
            np.concatenate(states), onsets, scene.joint_position)


@pytest.fixture(scope='module')
def one_call():
    return _run('pringles_can', 21, lambda left: left)


def test_onsets_happen_in_the_reference_run(one_call):
    assert len(one_call[4]) >= 1            # the run exercises stick-slip


@pytest.mark.parametrize('chunking', [lambda left: 1 if left % 97 else 13,
                                      lambda left: 20,
                                      lambda left: 7,
                                      lambda left: 333],
                         ids=['1-and-13', '20', '7', '333'])
def test_chunked_equals_unchunked(one_call, chunking):
    chunked = _run('pringles_can', 21, chunking)
    np.testing.assert_array_equal(chunked[0], one_call[0])
    np.testing.assert_array_equal(chunked[1], one_call[1])
    np.testing.assert_array_equal(chunked[2], one_call[2])
    np.testing.assert_array_equal(chunked[3], one_call[3])
    assert chunked[4] == one_call[4]
    assert chunked[5] == one_call[5]


def test_random_chunk_sizes_equal_unchunked(one_call):
    rng = np.random.default_rng(0)
    chunked = _run('pringles_can', 21, lambda left: int(rng.integers(1, 700)))
    np.testing.assert_array_equal(chunked[0], one_call[0])
    assert chunked[4] == one_call[4]


def test_same_seed_same_data_other_seed_other_data(one_call):
    again = _run('pringles_can', 21, lambda left: left)
    np.testing.assert_array_equal(again[0], one_call[0])
    other = _run('pringles_can', 22, lambda left: left)
    assert not np.array_equal(other[0], one_call[0])


def test_calibration_scene_is_deterministic_and_chunk_independent():
    def run(sizes):
        scene = make_scene('calibration', indentor='edge', seed=5)
        out, loads = [], []
        for size in sizes:
            frames, truth = scene.step(size, 0.2, 0.0)
            out.append(frames)
            loads.append(truth.load_cell_force)
        return np.concatenate(out), np.concatenate(loads)
    whole = run([6000])
    parts = run([1, 2, 3, 994, 2000, 1999, 1001])
    np.testing.assert_array_equal(whole[0], parts[0])
    np.testing.assert_array_equal(whole[1], parts[1])
