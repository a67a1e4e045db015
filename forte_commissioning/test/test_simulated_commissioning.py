"""Commissioning on the simulator (issue 24's done-when): 0 false verdicts over 20 seeded
healthy runs, and every injected fault found, with its channel named, in 20 seeded runs of
each kind (the faulted channel changes with the seed), and only that fault is reported."""
import itertools
import time

import numpy as np
import pytest

from forte_commissioning.sensor_checks import text_report
from forte_commissioning.simulated_commissioning import run_simulated
from forte_sim.channel_faults import ChannelFault

SEEDS = range(20)
CHANNELS = ('left_distal', 'left_middle', 'left_root', 'right_distal', 'right_middle',
            'right_root')
PAIRS = list(itertools.combinations(range(6), 2))  # 6 inside a finger, 9 across


def fault_for(kind: str, seed: int) -> ChannelFault:
    """The fault of ``kind`` for ``seed``: its channel(s) and strength vary with the seed."""
    rng = np.random.default_rng((seed, 24))
    if kind == 'swapped_pair':
        return ChannelFault(kind, PAIRS[(seed * 7) % len(PAIRS)])
    if kind == 'swapped_fingers':
        return ChannelFault(kind)
    channel = (seed * 5 + len(kind)) % 6
    if kind == 'noisy':  # "noisy: > 3 LSB rms"
        return ChannelFault(kind, (channel,), noise_lsb=float(rng.uniform(3.2, 6.0)))
    if kind == 'leaking':
        return ChannelFault(kind, (channel,), tau=float(rng.uniform(2.0, 15.0)))
    return ChannelFault(kind, (channel,))


def test_healthy_devices_pass_every_check():
    start = time.perf_counter()
    false_verdicts = []
    for seed in SEEDS:
        result = run_simulated((), seed=seed).result
        false_verdicts += [(seed, check) for check in result.checks if check.status != 'PASS']
        false_verdicts += [(seed, finding) for finding in result.findings]
    print(f'20 healthy runs in {time.perf_counter() - start:.1f} s')
    assert not false_verdicts


@pytest.mark.parametrize('kind', ['swapped_pair', 'swapped_fingers', 'reversed', 'dead',
                                  'noisy', 'leaking'])
def test_every_injected_fault_is_found_and_named(kind):
    start = time.perf_counter()
    missed = []
    for seed in SEEDS:
        fault = fault_for(kind, seed)
        result = run_simulated((fault,), seed=seed).result
        found = [(finding.kind, set(finding.channels)) for finding in result.findings]
        if found != [(kind, set(fault.channels))]:  # found, named, and nothing else
            missed.append((seed, fault.label, found))
        assert not result.passed
    print(f'{kind}: 20 runs in {time.perf_counter() - start:.1f} s')
    assert not missed


def test_the_report_names_the_channel_and_the_fix():
    run = run_simulated((ChannelFault('reversed', (1,)),), seed=3)
    report = text_report(run.result)
    assert 'VERDICT: FAIL' in report
    assert 'reversed [left_middle]: left_middle reads negative on a press' in report
    assert 'swap its two tubes' in report
    assert 'FAIL   press_sign       left_middle' in report
    healthy = text_report(run_simulated((), seed=3).result)
    assert 'VERDICT: PASS' in healthy and 'FAIL' not in healthy.replace('PASS, 0 FAIL', '')
