"""Fault-injection streams through FrameDecoder + StreamAssembler (seeded, a few s each).

The streams come from the independent encoder in ``fault_streams.py`` (written from
docs/firmware.md with struct and binascii only): garbage, false signatures, truncation,
bit flips anywhere, gaps, duplicates, reordering, CRC-valid implausible frames, device
overruns, sequence wrap at 2**32, device times near 2**63, START sessions and device
restarts with and without evidence. Every published row must be a scan that was sent
intact, in order, and every counter must equal what the generator injected.
The long runs (1e6 / 1e7 frames) are in benchmarks/bench_fault_streams.py.
"""
from __future__ import annotations

import pytest
from fault_streams import (
    Expected,
    FaultRates,
    FaultStreamGenerator,
    encode_sample_frame,
    encode_start_ack,
    run_stream,
)

from forte_driver.serial import protocol
from forte_driver.serial.protocol import Ack, FrameDecoder, Sample


def test_independent_encoder_agrees_with_the_driver_codec():
    sample = Sample(0xFFFFFFFF, 2 ** 63 - 500, (1024, -1024, 0, 1, -1, 512), 65535, 7, 0b100001)
    frame = encode_sample_frame(*sample)
    assert frame == protocol.encode_sample(sample)
    assert FrameDecoder().feed(frame) == [sample]
    ack = FrameDecoder().feed(encode_start_ack(9, 2000))
    assert ack == [Ack(protocol.Command.START, 9, protocol.Status.OK, 2000)]


def check(report) -> None:
    assert report.invented == 0 and report.altered == 0
    assert report.missing == 0 and report.order_errors == 0
    assert {name: pair for name, pair in report.counters.items() if pair[0] != pair[1]} == {}


@pytest.mark.parametrize('seed', range(4))
def test_mixed_faults_exact_counters_and_only_true_samples(seed):
    generator = FaultStreamGenerator(seed)
    report = run_stream(generator, 25_000, chunk_seed=seed + 100, block_scans=4000)
    check(report)
    counts = generator.expected.counts
    for kind in ('garbage', 'false_sync', 'flip', 'truncate', 'gap', 'delay', 'duplicate',
                 'implausible'):
        assert counts[kind] > 50, kind
    assert generator.expected.restarts >= 1
    assert report.published == report.frames_sent - generator.expected.late


def checked_stream(seed: int, chunk_seed: int, **rates: float) -> Expected:
    """20 000 scans with only the faults ``rates`` (every other rate 0) through the driver,
    checked; what the generator injected."""
    generator = FaultStreamGenerator(seed, FaultRates.only(**rates))
    check(run_stream(generator, 20_000, chunk_seed=chunk_seed, block_scans=4000))
    return generator.expected


def test_heavy_reordering_and_duplicates_are_not_drops_or_restarts():
    expected = checked_stream(11, chunk_seed=5, gap=0.01, delay=0.1, duplicate=0.1)
    assert expected.late > 1000 and expected.duplicate > 1000


def test_many_crc_valid_implausible_frames_are_never_published():
    expected = checked_stream(12, chunk_seed=6, implausible=0.2, overrun=0.01)
    assert expected.implausible > 2000


@pytest.mark.parametrize('max_chunk', [1, 3, 35, 100_000])
def test_result_does_not_depend_on_the_read_sizes(max_chunk):
    reports = [run_stream(FaultStreamGenerator(21), 4000, chunk_seed=chunk_seed,
                          block_scans=1000, max_chunk=max_chunk)
               for chunk_seed in (1, 2)]
    for report in reports:
        check(report)
    assert reports[0].counters == reports[1].counters
