"""Known answers of each commissioning check on synthetic recordings (no simulator)."""
import math

import numpy as np
import pytest

from forte_commissioning.sensor_checks import (
    CommissioningLimits,
    CommissioningRecording,
    LinkStatistics,
    Phase,
    evaluate,
    text_report,
)
from forte_commissioning.sensor_checks.idle import idle_checks, idle_statistics, link_checks
from forte_commissioning.sensor_checks.leak import LeakLevels, leak_checks

RATE = 2000
LSB = 1.0 / 1024.0
LIMITS = CommissioningLimits()
#: Per-finger channel response to a 4 N press at the tip and at the root (distal, middle,
#: root), as a fin-ray finger gives them (the tip press: distal > middle > root).
TIP = np.array([0.34, 0.14, 0.08])
ROOT = np.array([0.13, 0.10, 0.08])
SQUEEZE = np.array([0.34, 0.21, 0.12, 0.31, 0.19, 0.09])
OFFSETS = np.array([0.02, -0.01, 0.0, 0.03, -0.02, 0.01])


def trapezoid(n, ramp=500):
    t = np.arange(n)
    return np.clip(np.minimum(t / ramp, (n - t) / ramp), 0.0, 1.0)


def relaxation(n, amount=0.18):
    """A finger's stress relaxation: 18 % of the level, time constants 1.5 s and 15 s."""
    t = np.arange(n) / RATE
    return 1.0 - amount * (0.55 * (1 - np.exp(-t / 1.5)) + 0.45 * (1 - np.exp(-t / 15.0)))


def synthetic_recording(seed=0, transform=None, squeeze_shape=None, noise_lsb=1.2):
    """rest 2 s, four presses (1 s rest + 1.5 s press each), squeeze 12 s, rest 1.5 s."""
    rng = np.random.default_rng(seed)
    parts, phases, position = [], [], 0

    def add(name, kind, signal, finger=-1, place=''):
        nonlocal position
        parts.append(signal)
        phases.append(Phase(name, kind, position, position + len(signal), finger, place))
        position += len(signal)

    add('rest', 'rest', np.zeros((4000, 6)))
    for finger, finger_name in enumerate(('left', 'right')):
        for place, pattern in (('tip', TIP), ('root', ROOT)):
            add(f'rest_{finger_name}_{place}', 'rest', np.zeros((2000, 6)))
            signal = np.zeros((3000, 6))
            signal[:, 3 * finger:3 * finger + 3] = trapezoid(3000)[:, None] * pattern
            add(f'press_{finger_name}_{place}', 'press', signal, finger, place)
    shape = squeeze_shape if squeeze_shape is not None else np.repeat(
        relaxation(24000)[:, None], 6, axis=1)
    close = np.clip(np.arange(24000) / 1000.0, 0.0, 1.0)[:, None]
    add('squeeze', 'squeeze', close * SQUEEZE * shape)
    add('rest_end', 'rest', np.zeros((3000, 6)))
    pressure = np.concatenate(parts)
    if transform is not None:
        pressure = transform(pressure)
    frames = OFFSETS + pressure + rng.normal(0.0, noise_lsb * LSB, pressure.shape)
    frames = np.clip(np.rint(frames / LSB), -1024, 1023) * LSB
    sequence = np.arange(len(frames))
    return CommissioningRecording(frames, sequence, phases,
                                  LinkStatistics.from_sequence(sequence, 1.0 / RATE))


def kinds(result):
    return [(finding.kind, finding.channels) for finding in result.findings]


def test_a_healthy_gripper_passes_and_relaxation_is_not_a_leak():
    result = evaluate(synthetic_recording())
    assert result.passed and not result.findings, text_report(result)
    assert {check.status for check in result.checks} == {'PASS'}
    leak = [check for check in result.checks if check.check == 'leak']
    assert len(leak) == 6 and all(abs(check.value - 1.0) < 0.03 for check in leak)


def test_fingers_relaxing_differently_are_not_a_leak():
    shape = np.column_stack([relaxation(24000, 0.10)] * 3 + [relaxation(24000, 0.25)] * 3)
    assert evaluate(synthetic_recording(squeeze_shape=shape)).passed


def test_idle_statistics_known_answers():
    rng = np.random.default_rng(1)
    frames = np.rint(rng.normal(0.0, 2.0 * LSB, (20000, 6)) / LSB) * LSB
    frames[::997, 0] += 0.1  # impulses do not count as noise
    frames[:, 1] = 0.25  # stuck
    frames[:, 2] = 1.0 - LSB  # railed
    frames[:, 3] += 0.2  # offset
    stats = idle_statistics(frames)
    assert abs(stats.noise_lsb[0] - math.hypot(2.0, 12 ** -0.5)) < 0.1
    assert stats.offset[1] == 0.25 and stats.spread_lsb[1] == 0.0
    assert stats.rail_share[2] == 1.0
    status = {(check.check, check.subject): check.status
              for check in idle_checks(stats, LIMITS)}
    assert status[('noise', 'left_distal')] == 'PASS'
    assert status[('stuck', 'left_middle')] == 'FAIL'
    assert status[('noise', 'left_middle')] == 'SKIP'
    assert status[('railed', 'left_root')] == 'FAIL'
    assert status[('offset', 'right_distal')] == 'FAIL'
    assert status[('offset', 'right_middle')] == 'PASS'


@pytest.mark.parametrize('noise, verdict', [(2.5, 'PASS'), (3.6, 'FAIL')])
def test_the_noise_limit_is_three_lsb(noise, verdict):
    rng = np.random.default_rng(2)
    frames = np.rint(rng.normal(0.0, noise * LSB, (4000, 6)) / LSB) * LSB
    checks = idle_checks(idle_statistics(frames), LIMITS)
    assert {check.status for check in checks if check.check == 'noise'} == {verdict}


def test_link_checks_known_answers():
    good = LinkStatistics(20001, 100, 20100, 10.0, 0, 0, 10.1)
    assert {check.status for check in link_checks(good, LIMITS)} == {'PASS'}
    status = {check.check: check.status for check in link_checks(
        LinkStatistics(20001, 0, 20000, 10.1, 50, 0, 30.0), LIMITS)}
    assert status == {'sample_rate': 'FAIL', 'dropped_frames': 'FAIL',
                      'corrupt_frames': 'PASS', 'host_rate': 'FAIL'}


def test_a_leak_decays_a_channel_alone_and_keeps_decaying():
    t = np.arange(24000) / RATE
    shape = np.repeat(relaxation(24000)[:, None], 6, axis=1)
    shape[:, 4] *= np.exp(-t / 12.0)
    result = evaluate(synthetic_recording(squeeze_shape=shape))
    assert kinds(result) == [('leaking', (4,))]
    assert 'reseal' in result.findings[0].fix
    levels = LeakLevels(np.ones(6), np.ones(6), np.ones(6))
    assert {check.status for check in leak_checks(levels, LIMITS)[0]} == {'PASS'}


def test_a_drop_that_levels_off_is_not_a_leak():
    """A channel losing 30 % in the first seconds and then holding (a tube settling) keeps
    decaying no more: told apart from a leak by the second half of the hold."""
    t = np.arange(24000) / RATE
    shape = np.repeat(relaxation(24000)[:, None], 6, axis=1)
    shape[:, 2] *= 0.7 + 0.3 * np.exp(-t / 1.5)
    assert evaluate(synthetic_recording(squeeze_shape=shape)).passed


def swap(first, second):
    def transform(pressure):
        out = pressure.copy()
        out[:, [first, second]] = pressure[:, [second, first]]
        return out
    return transform


@pytest.mark.parametrize('pair', [(0, 1), (0, 2), (1, 2), (3, 4), (4, 5), (0, 3), (2, 4),
                                  (1, 5)])
def test_a_swapped_pair_is_named(pair):
    assert kinds(evaluate(synthetic_recording(transform=swap(*pair)))) == [
        ('swapped_pair', pair)]


def test_swapped_fingers_reversed_and_dead_channels():
    result = evaluate(synthetic_recording(transform=lambda p: p[:, [3, 4, 5, 0, 1, 2]]))
    assert kinds(result) == [('swapped_fingers', ())]

    def reverse(pressure):
        pressure = pressure.copy()
        pressure[:, 5] *= -1.0
        return pressure
    result = evaluate(synthetic_recording(transform=reverse))
    assert kinds(result) == [('reversed', (5,))]
    assert 'swap its two tubes' in result.findings[0].fix
    recording = synthetic_recording()
    recording.frames[:, 1] = 0.0
    assert kinds(evaluate(recording)) == [('dead', (1,))]


def test_a_channel_that_does_not_respond_but_lives():
    def block(pressure):
        pressure = pressure.copy()
        pressure[:, 3] = 0.0
        return pressure
    result = evaluate(synthetic_recording(transform=block))
    assert ('no_response', (3,)) in kinds(result)


def test_a_missing_press_asks_for_a_repeat():
    recording = synthetic_recording()
    press = recording.phase('press_right_root')
    rows = recording.rows(press.start, press.stop)
    recording.frames[rows] = recording.frames[rows.start - 1]
    result = evaluate(recording)
    assert ('press_not_detected', ()) in kinds(result)
    shift = [check for check in result.checks
             if check.check == 'press_shift' and check.subject == 'right']
    assert shift[0].status == 'SKIP'


def test_the_recording_round_trips_through_npz(tmp_path):
    recording = synthetic_recording()
    recording.link = LinkStatistics(10, 3, 12, 0.0045, 1, 2, 0.5)
    path = recording.save(tmp_path / 'commissioning.npz')
    again = CommissioningRecording.load(path)
    np.testing.assert_array_equal(again.frames, recording.frames)
    np.testing.assert_array_equal(again.sequence, recording.sequence)
    assert again.phases == recording.phases and again.link == recording.link


def test_the_text_report_lists_verdicts_and_fixes():
    def reverse(pressure):
        pressure = pressure.copy()
        pressure[:, 0] *= -1.0
        return pressure
    report = text_report(evaluate(synthetic_recording(transform=reverse)),
                         context={'device': 'bench'})
    assert report.startswith('FORTE sensor commissioning\n')
    assert 'device: bench' in report and 'VERDICT: FAIL' in report
    assert '1. reversed [left_distal]' in report and 'fix: ' in report
    assert 'PASS   noise            left_distal' in report
