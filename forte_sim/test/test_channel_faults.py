"""Injected sensor faults: known answers of each kind, parsing, chunk invariance."""
import math

import numpy as np
import pytest

from forte_sim.channel_faults import (
    FAULT_KINDS,
    ChannelFault,
    ChannelFaultInjector,
    parse_fault,
    parse_faults,
)

LSB = 1.0 / 1024.0


def ramp_frames(n=4000):
    """Quantised readings: a rest level per channel, then a pressure step at sample 1000."""
    rest = np.array([0.02, -0.01, 0.0, 0.03, -0.02, 0.01])
    pressure = np.zeros((n, 6))
    pressure[1000:] = np.array([0.3, 0.2, 0.1, 0.25, 0.15, 0.08])
    return np.rint((rest + pressure) / LSB) * LSB, rest, pressure


def test_parse_reads_every_kind_and_writes_it_back():
    for text in ('reversed:left_middle', 'swapped_pair:left_distal,right_root',
                 'swapped_fingers', 'dead:right_middle', 'noisy:right_root:noise_lsb=5',
                 'leaking:left_root:tau=8'):
        fault = parse_fault(text)
        assert fault.label == text
        assert parse_fault(fault.label) == fault
    assert parse_fault('noisy:left_distal').noise_lsb == 4.0
    assert parse_faults('dead:left_root; reversed:right_root')[1].channels == (5,)
    assert parse_faults('') == ()
    assert set(FAULT_KINDS) == {'swapped_pair', 'swapped_fingers', 'reversed', 'dead',
                                'noisy', 'leaking'}


@pytest.mark.parametrize('text', ['broken:left_root', 'reversed', 'reversed:left_thumb',
                                  'swapped_pair:left_root', 'swapped_pair:left_root,left_root',
                                  'noisy:left_root:noise_lsb=-1', 'leaking:left_root:tau=0',
                                  'leaking:left_root:speed=3', 'noisy:left_root:noise_lsb=x'])
def test_parse_refuses_a_bad_fault(text):
    with pytest.raises(ValueError):
        parse_fault(text)


def test_swaps_exchange_columns():
    frames, _, _ = ramp_frames()
    out = ChannelFaultInjector([parse_fault('swapped_pair:left_middle,right_root')]).apply(frames)
    np.testing.assert_array_equal(out[:, [1, 5]], frames[:, [5, 1]])
    np.testing.assert_array_equal(out[:, [0, 2, 3, 4]], frames[:, [0, 2, 3, 4]])
    out = ChannelFaultInjector([parse_fault('swapped_fingers')]).apply(frames)
    np.testing.assert_array_equal(out, frames[:, [3, 4, 5, 0, 1, 2]])


def test_reversed_flips_the_pressure_about_the_rest_level():
    frames, rest, pressure = ramp_frames()
    out = ChannelFaultInjector([parse_fault('reversed:left_root')]).apply(frames)
    expected = np.rint((rest[2] - pressure[:, 2]) / LSB) * LSB
    np.testing.assert_allclose(out[:, 2], expected, atol=1e-12)
    np.testing.assert_array_equal(np.delete(out, 2, axis=1), np.delete(frames, 2, axis=1))


def test_dead_is_one_constant_code():
    frames, _, _ = ramp_frames()
    out = ChannelFaultInjector([ChannelFault('dead', (4,), level=0.0)]).apply(frames)
    assert np.all(out[:, 4] == 0.0)


def test_noisy_adds_the_stated_rms():
    frames, _, _ = ramp_frames(40000)
    out = ChannelFaultInjector([parse_fault('noisy:right_distal:noise_lsb=4')], seed=3).apply(
        frames)
    extra = (out[:, 3] - frames[:, 3]) / LSB
    assert abs(np.std(extra) - math.hypot(4.0, 1.0 / math.sqrt(12.0))) < 0.1
    np.testing.assert_array_equal(np.delete(out, 3, axis=1), np.delete(frames, 3, axis=1))


def test_a_leak_decays_toward_the_rest_level_with_its_time_constant():
    frames, rest, pressure = ramp_frames(30000)
    tau = 2.0
    out = ChannelFaultInjector([parse_fault(f'leaking:left_distal:tau={tau}')]).apply(frames)
    after = (np.arange(30000) - 1000) / 2000.0
    expected = rest[0] + pressure[1000, 0] * np.exp(-after / tau)
    assert np.max(np.abs(out[1000:, 0] - expected[1000:])) < 2.5 * LSB
    assert abs(out[-1, 0] - rest[0]) <= LSB  # equalised with ambient: back at the offset
    np.testing.assert_array_equal(out[:1000, 0], frames[:1000, 0])


def test_any_chunking_gives_the_same_stream():
    rng = np.random.default_rng(0)
    frames = np.rint(rng.normal(0.1, 0.05, (9000, 6)) / LSB) * LSB
    faults = parse_faults('leaking:left_root:tau=1.5;noisy:right_root:noise_lsb=3.5;'
                          'reversed:left_distal;swapped_pair:left_middle,right_distal')
    whole = ChannelFaultInjector(faults, seed=7).apply(frames)
    injector = ChannelFaultInjector(faults, seed=7)
    cuts = np.sort(rng.choice(np.arange(1, 9000), 40, replace=False))
    parts = [injector.apply(chunk) for chunk in np.split(frames, cuts)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_no_fault_leaves_the_stream_unchanged():
    frames, _, _ = ramp_frames()
    np.testing.assert_array_equal(ChannelFaultInjector([]).apply(frames), frames)
