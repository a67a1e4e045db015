"""The servo gate (forte_perception.slip.servo_gate): intervals of gated pipeline samples."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from forte_perception.pipeline import PerceptionPipeline, PipelineConfig
from forte_perception.slip.params import SlipParams
from forte_perception.slip.sequential import SequentialParams
from forte_perception.slip.servo_gate import ServoGate
from forte_perception.testing import ringing_after_a_step, tightening_then_slip


def test_samples_after_a_change_are_gated_for_hold_samples():
    gate = ServoGate(200)
    assert gate.gated(np.arange(10)) is None  # nothing pending
    gate.moved(1000)
    mask = gate.gated(np.array([999, 1000, 1199, 1200]))
    assert mask.tolist() == [False, True, True, False]


def test_overlapping_changes_merge_and_old_intervals_are_forgotten():
    gate = ServoGate(100)
    gate.moved(0)
    gate.moved(50)    # overlaps: one interval [0, 150)
    gate.moved(400)   # apart: [400, 500)
    assert gate.gated(np.array([149, 150, 399, 499])).tolist() == [True, False, False, True]
    assert gate.gated(np.array([500, 600])) is None  # both intervals lie behind


def test_latest_is_the_end_of_the_latest_interval_begun_and_whether_its_motion_was_known():
    gate = ServoGate(100)
    stop, known = gate.latest(np.array([0, 50]))
    assert stop.tolist() == [-1, -1] and not known.any()  # no change yet
    gate.moved(1000, motion=30)  # [1000, 1130)
    gate.moved(1050)  # unknown motion, merged: [1000, 1150), not known
    stop, known = gate.latest(np.array([999, 1000, 1400]))
    assert stop.tolist() == [-1, 1150, 1150] and known.tolist() == [False, False, False]
    gate.moved(2000, motion=30)  # [2000, 2130), known
    assert gate.gated(np.array([1500])).tolist() == [False]  # forgets [1000, 1150)
    stop, known = gate.latest(np.array([1500, 1999, 2000, 2129, 2130]))
    assert stop.tolist() == [1150, 1150, 2130, 2130, 2130]
    assert known.tolist() == [False, False, True, True, True]
    assert gate.gated(np.array([2129, 2130])).tolist() == [True, False]  # motion + hold
    with pytest.raises(ValueError, match='motion'):
        gate.moved(3000, motion=-1)


def test_hold_zero_turns_the_gate_off_and_bad_holds_are_refused():
    gate = ServoGate(0)
    gate.moved(10)
    assert gate.gated(np.arange(20)) is None
    assert (gate.latest(np.arange(20))[0] == -1).all()
    for bad in (-1, 2.5):
        with pytest.raises(ValueError, match='hold'):
            ServoGate(bad)


@pytest.mark.parametrize('mode', ['sequential', 'robust', 'paper'])
def test_pipeline_gates_only_the_sequential_mode(mode):
    """The pipeline told of a servo change at the ringing's first sample: the sequential
    mode flags nothing there; the PSD modes give the same outputs whether told or not."""
    x = ringing_after_a_step()
    outputs = []
    for told in (False, True):
        pipeline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode=mode)))
        flags = []
        for start in range(0, x.shape[0], 20):
            if told and start == 8000:
                pipeline.servo_moved()
            out = pipeline.process(x[start:start + 20])
            flags.append((out.slip, out.slipping, tuple(out.psd_max_db)))
        outputs.append(flags)
    ungated, gated = outputs
    if mode == 'sequential':
        assert any(slip for slip, _, _ in ungated[400:])  # the ringing alarms ungated
        assert not any(slip or slipping for slip, slipping, _ in gated[400:])
    else:
        assert [f[:2] for f in gated] == [f[:2] for f in ungated]
        assert np.array_equal(np.array([f[2] for f in gated]),
                              np.array([f[2] for f in ungated]), equal_nan=True)


@pytest.mark.parametrize('slip', [True, False])
def test_pipeline_hears_a_slip_that_made_the_servo_move(slip):
    """Told of a tightening at its first sample, the sequential pipeline flags nothing for
    the tightening alone, and flags an 8 LSB one-finger slip that began 20 ms before it (the
    controller's gross-slip reaction) within 50 ms of the slip's onset, inside the hold."""
    at = 8000
    onset = at - 40
    x = tightening_then_slip(at=at, slip_at=onset if slip else None)
    pipeline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode='sequential')))
    flagged = []
    for start in range(0, x.shape[0], 20):
        if start == at:
            pipeline.servo_moved()
        if pipeline.process(x[start:start + 20]).slip:
            flagged.append(start + 19)
    if not slip:
        assert flagged == []
        return
    assert flagged and onset <= flagged[0] <= onset + 100


@pytest.mark.parametrize('ring_exempt', [False, True])
@pytest.mark.parametrize('motion', [0.015, None])
def test_pipeline_hears_a_slip_after_a_known_motion_s_gate(motion, ring_exempt, monkeypatch):
    """A tightening told with its motion (15 ms at the profile velocity): an 8 LSB slip
    beginning 30 ms after the gate is flagged within 50 ms (the step is over and decayed,
    the level-shift veto no longer blames it). Told without its motion, the step stays in
    the veto's spans: without the ringing exemption the slip is flagged later; with it (the
    default) the slip's 25 Hz ringing has shown a whole period within 50 ms and is heard
    through the step all the same."""
    if not ring_exempt:
        defaults = SequentialParams.from_slip
        monkeypatch.setattr(SequentialParams, 'from_slip', classmethod(
            lambda cls, slip: replace(defaults(slip), ring_crossings=0)))
    at = 8000
    gate_end = at + int(round((0.1 + (motion or 0.0)) * 2000))
    onset = gate_end + 60
    x = tightening_then_slip(at=at, slip_at=onset)
    pipeline = PerceptionPipeline(PipelineConfig(slip=SlipParams(mode='sequential')))
    flagged = []
    for start in range(0, x.shape[0], 20):
        if start == at:
            pipeline.servo_moved(motion=motion)
        if pipeline.process(x[start:start + 20]).slip:
            flagged.append(start + 19)
    assert flagged and flagged[0] >= onset
    if motion is None and not ring_exempt:
        assert flagged[0] > onset + 100
    else:
        assert flagged[0] <= onset + 100
