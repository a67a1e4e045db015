"""The sequential detector (forte_perception.slip.sequential): known-answer inputs.

Quantised signals (q = QUANTUM) at 2 kHz, 1 LSB white noise, updates every 4 samples. The
scene starts with 3 s of quiet (the quiet levels need one 0.2 s block; the vetoes 0.5 s of
history).
"""
from __future__ import annotations

import numpy as np
import pytest

from forte_perception.slip.sequential import SequentialDetector, SequentialParams
from forte_perception.testing import tightening
from forte_ros.contract import QUANTUM

FS = 2000.0
ONSET = 6000  # 3 s


def scene(n: int = 16000, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, 1.0, (n, 6)) + 40.0  # LSB, an offset like a held grip


def sine(n: int, start: int, stop: int, frequency: float, amplitude: float) -> np.ndarray:
    t = np.arange(n) / FS
    out = amplitude * np.sin(2 * np.pi * frequency * t)
    out[:start] = 0.0
    out[stop:] = 0.0
    return out


def detect(lsb: np.ndarray, chunk: int | None = None):
    x = np.round(lsb) * QUANTUM
    detector = SequentialDetector(FS, 4)
    if chunk is None:
        ends, slip, state = detector.update(x)
        return ends, slip, state.slipping.any(axis=1), detector
    parts = [detector.update(x[i:i + chunk]) for i in range(0, x.shape[0], chunk)]
    return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2].slipping.any(axis=1) for p in parts]), detector)


def test_quiet_hold_never_alarms():
    _, slip, slipping, _ = detect(scene(40000))
    assert not slip.any() and not slipping.any()


@pytest.mark.parametrize('amplitude', [5.0, 30.0])
def test_stick_slip_vibration_alarms_within_40_ms(amplitude):
    x = scene()
    x[:, :3] += sine(x.shape[0], ONSET, ONSET + 2000, 25.0, amplitude)[:, None]
    x[:, 3:] += 0.5 * sine(x.shape[0], ONSET, ONSET + 2000, 25.0, amplitude)[:, None]
    ends, slip, slipping, _ = detect(x)
    alarms = ends[slip]
    assert alarms.size and ONSET <= alarms[0] <= ONSET + 0.04 * FS
    assert slipping[(ends > alarms[0]) & (ends < ONSET + 2000)].mean() >= 0.9


def test_the_leading_finger_alone_alarms():
    x = scene()
    x[:, 3:] += sine(x.shape[0], ONSET, ONSET + 1000, 20.0, 8.0)[:, None]  # right only
    ends, slip, _, _ = detect(x)
    assert slip.any() and ONSET <= ends[slip][0] <= ONSET + 0.05 * FS


def test_a_closing_step_is_vetoed():
    x = scene()
    ramp = np.clip((np.arange(x.shape[0]) - ONSET) / 40.0, 0.0, 1.0) * 300.0  # 300 LSB, 20 ms
    x += ramp[:, None]
    ends, slip, _, detector = detect(x)
    assert not slip.any()
    assert detector.vetoed >= 1  # the step did alarm the CUSUM: the veto took it


def test_hum_switching_on_is_vetoed():
    x = scene()
    # 70 Hz motor hum of 20 LSB switched on with 50 ms raised-cosine edges (a motor speeding up)
    edge = 0.5 - 0.5 * np.cos(np.pi * np.clip((np.arange(x.shape[0]) - ONSET) / 100.0, 0, 1))
    x += (edge * sine(x.shape[0], ONSET, x.shape[0], 70.0, 20.0))[:, None]
    _, slip, _, detector = detect(x)
    assert not slip.any() and detector.vetoed >= 1


def test_any_chunking_gives_the_same_events_and_state():
    x = scene()
    x[:, :3] += sine(x.shape[0], ONSET, ONSET + 1500, 30.0, 10.0)[:, None]
    batch = detect(x)
    for chunk in (1 + 6, 20, 333):
        ends, slip, slipping, _ = detect(x, chunk)
        assert np.array_equal(ends, batch[0])
        assert np.array_equal(slip, batch[1]) and np.array_equal(slipping, batch[2])


def test_alarms_in_the_servo_gate_are_vetoed_and_a_later_slip_is_heard():
    """A 30 ms 40 LSB ringing right after a servo step (the gripper's own motion) alarms
    without the gate and not inside it; a slip 0.3 s later, beyond the 0.1 s hold, is heard
    within 40 ms."""
    x = scene()
    x[:, :] += sine(x.shape[0], ONSET, ONSET + 60, 25.0, 40.0)[:, None]
    later = ONSET + 600
    x[:, :3] += sine(x.shape[0], later, later + 2000, 25.0, 30.0)[:, None]
    ends, slip, _, _ = detect(x)
    assert ONSET <= ends[slip][0] < ONSET + 200  # the servo's transient alarms ungated
    detector = SequentialDetector(FS, 4)
    hold = int(SequentialParams().servo_hold * FS)
    gated = (ends >= ONSET) & (ends < ONSET + hold)
    _, slip, _ = detector.update(np.round(x) * QUANTUM, gated=gated)
    alarms = ends[slip]
    assert not ((alarms >= ONSET) & (alarms < later)).any()
    assert alarms.size and later <= alarms[0] <= later + 0.04 * FS


@pytest.mark.parametrize('slip_before', [None, 60])
@pytest.mark.parametrize('known', [True, False])
def test_a_tightening_alone_never_alarms(slip_before, known):
    """A 60 LSB tightening (15 ms) told to the gate, its motion known or not, raises no
    alarm, alone or 30 ms after a 0.3 LSB vibration too weak for the drift (its ringing and
    step are the servo's)."""
    x = scene()
    x += tightening(x.shape[0], ONSET)[:, None]
    if slip_before is not None:
        x[:, :3] += sine(x.shape[0], ONSET - slip_before, ONSET, 25.0, 0.3)[:, None]
    ends = np.arange(3, x.shape[0], 4)
    stop = ONSET + 30 + int(SequentialParams().servo_hold * FS)
    _, alarms, _ = SequentialDetector(FS, 4).update(
        np.round(x) * QUANTUM, gated=(ends >= ONSET) & (ends < stop),
        servo=(np.where(ends >= ONSET, stop, -1), np.full(ends.shape, known)))
    assert not alarms.any()


def test_a_slip_that_made_the_servo_move_is_not_gated():
    """An 8 LSB one-finger slip, and 20 ms later the controller's tightening (its gross-slip
    reaction): the fast excess was above the drift before the servo moved, so the gate does
    not veto and the slip is heard within 50 ms, inside the hold."""
    x = scene()
    step = ONSET + 40
    x += tightening(x.shape[0], step)[:, None]
    x[:, :3] += sine(x.shape[0], ONSET, ONSET + 2000, 25.0, 8.0)[:, None]
    ends = np.arange(3, x.shape[0], 4)
    hold = int(SequentialParams().servo_hold * FS)
    gated = (ends >= step) & (ends < step + hold)
    servo = (np.where(ends >= step, step + hold, -1), np.zeros(ends.shape, bool))
    x = np.round(x) * QUANTUM
    _, alarms, _ = SequentialDetector(FS, 4).update(x, gated=gated, servo=servo)
    assert alarms.any() and ONSET <= ends[alarms][0] <= ONSET + 0.05 * FS
    detector, chunked = SequentialDetector(FS, 4), []  # the same in 20-sample chunks
    for start in range(0, x.shape[0], 20):
        rows = slice(start // 4, (start + 20) // 4)
        chunked.append(detector.update(x[start:start + 20], gated=gated[rows],
                                       servo=(servo[0][rows], servo[1][rows]))[1])
    assert np.array_equal(np.concatenate(chunked), alarms)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match='high_band'):
        SequentialDetector(FS, 4, params=SequentialParams(high_band=(60.0, 1500.0)))
    with pytest.raises(ValueError, match='shift_length'):
        SequentialDetector(FS, 4, params=SequentialParams(shift_length=0))
    with pytest.raises(ValueError, match='servo_hold'):
        SequentialDetector(FS, 4, params=SequentialParams(servo_hold=-0.1))
