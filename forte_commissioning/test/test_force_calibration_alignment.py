"""Load cell aligned to the frames by sample time: known answers, gaps, no extrapolation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from forte_commissioning.force_plan import ForceCalibrationConfig, plan_session
from forte_commissioning.load_cell import align_load_cell, wrench_component
from forte_commissioning.trial_recording import RecordingBuffer
from forte_sim.dataset import QUICK_PROTOCOL

PERIOD_NS = 500_000          # 2 kHz
ORIGIN_NS = 1_700_000_000_000_000_000


def frame_times(count: int, first: int = 0) -> np.ndarray:
    return ORIGIN_NS + (first + np.arange(count, dtype=np.int64)) * PERIOD_NS


def test_a_linear_load_cell_is_interpolated_exactly_at_every_frame():
    frames = frame_times(2000)
    # a 100 Hz load cell (every 20th sample) with a force linear in time, 3 N/s + 0.5 N,
    # its samples offset from the frames by 0.1 ms (not on the frame grid)
    load = ORIGIN_NS - 100_000 + np.arange(0, 2001, 20, dtype=np.int64) * PERIOD_NS
    value = 0.5 + 3.0 * (load - ORIGIN_NS) * 1e-9
    aligned = align_load_cell(frames, load, value, max_gap=0.02)
    assert aligned.ok, aligned.problem
    np.testing.assert_allclose(aligned.force, 0.5 + 3.0 * (frames - ORIGIN_NS) * 1e-9,
                               rtol=0, atol=1e-12)
    assert aligned.max_interval == pytest.approx(0.01)


def test_samples_on_the_frame_times_are_taken_as_they_are():
    frames = frame_times(100)
    load = frames[::20]
    value = np.array([1.0, 7.0, -2.0, 4.0, 5.0])
    aligned = align_load_cell(frames, np.append(load, frames[-1]), np.append(value, 9.0), 0.02)
    assert aligned.ok
    np.testing.assert_array_equal(aligned.force[::20], value)
    assert aligned.force[-1] == 9.0
    assert aligned.force[10] == pytest.approx(4.0)      # halfway between 1 and 7


def test_no_extrapolation_before_the_first_or_after_the_last_load_cell_sample():
    frames = frame_times(100)
    load = frames[1:-1:10]
    early = align_load_cell(frames, load, np.ones(len(load)), 0.05)
    assert not early.ok and 'before the first load-cell sample' in early.problem
    assert np.isnan(early.force).all()
    late = align_load_cell(frames, np.append(frames[0], load), np.ones(len(load) + 1), 0.05)
    assert not late.ok and 'after the last load-cell sample' in late.problem


def test_a_gap_wider_than_max_gap_drops_the_trial():
    frames = frame_times(3981)              # the last frame on a load-cell sample
    load = frames[::20]
    keep = np.ones(len(load), bool)
    keep[50:56] = False                      # 6 samples lost: an interval of 70 ms
    aligned = align_load_cell(frames, load[keep], np.ones(keep.sum()), max_gap=0.05)
    assert not aligned.ok
    assert 'load-cell gap of 0.0700 s' in aligned.problem
    assert aligned.max_interval == pytest.approx(0.07)
    # one lost message (20 ms) is within the bound and interpolated across
    keep[:] = True
    keep[50] = False
    assert align_load_cell(frames, load[keep], np.ones(keep.sum()), max_gap=0.05).ok


def test_a_nonfinite_load_cell_value_is_a_hole_not_a_value():
    frames = frame_times(400)
    load = frames[::20]
    value = np.ones(len(load))
    value[5:10] = np.nan
    aligned = align_load_cell(np.asarray(frames), np.append(load, frames[-1] + PERIOD_NS),
                              np.append(value, 1.0), max_gap=0.05)
    assert not aligned.ok and 'gap' in aligned.problem


def test_unordered_and_duplicate_load_cell_samples_are_sorted_and_deduplicated():
    frames = frame_times(41)
    load = frames[[40, 0, 20, 20]]
    aligned = align_load_cell(frames, load, np.array([2.0, 0.0, 1.0, 5.0]), 0.05)
    assert aligned.ok
    np.testing.assert_allclose(aligned.force[[0, 10, 20, 30, 40]], [0, 0.5, 1, 1.5, 2])


def test_wrench_component_axis_and_sign():
    assert wrench_component((1.0, 2.0, -3.0), 'z', -1) == 3.0
    assert wrench_component((1.0, 2.0, -3.0), 'x', 1) == 1.0
    assert math.isnan(wrench_component((float('nan'), 0.0, 0.0), 'x', 1))
    with pytest.raises(ValueError, match='axis'):
        wrench_component((0.0, 0.0, 0.0), 'w', 1)
    with pytest.raises(ValueError, match='sign'):
        wrench_component((0.0, 0.0, 0.0), 'z', 2)


def test_a_sequence_gap_in_the_frames_is_a_problem_of_the_recording():
    buffer = RecordingBuffer()
    buffer.add_frames(ORIGIN_NS, 100, 0.0005, np.zeros((20, 6)))
    buffer.add_frames(ORIGIN_NS + 20 * PERIOD_NS, 120, 0.0005, np.zeros((20, 6)))
    assert not buffer.problems
    buffer.add_frames(ORIGIN_NS + 45 * PERIOD_NS, 145, 0.0005, np.zeros((20, 6)))
    assert buffer.problems == ['frame sequence gap: 5 sample(s) missing before sample 40 of '
                               'the recording']
    recording = buffer.snapshot()
    np.testing.assert_array_equal(recording.frame_times_ns[:40], frame_times(40))
    assert recording.frame_times_ns[40] == ORIGIN_NS + 45 * PERIOD_NS


def test_the_plan_draws_the_offline_rig_s_closures_and_seats():
    # forte_sim.dataset.generate_calibration_dataset draws closure then seed per trial from
    # np.random.default_rng((seed, 0xCA1)), in indentor order: the plan must equal it
    plan = plan_session(ForceCalibrationConfig(protocol=QUICK_PROTOCOL))
    rng = np.random.default_rng((0, 0xCA1))
    expected = [(float(rng.uniform(0.0, 1.0)), int(rng.integers(0, 2 ** 31 - 1)))
                for _ in range(48)]
    assert [(trial.closure, trial.seed) for trial in plan] == expected
    assert [trial.trial for trial in plan] == list(range(48))
    assert [trial.indentor_index for trial in plan] == [i // 8 for i in range(48)]
