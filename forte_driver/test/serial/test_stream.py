"""Known-answer tests of the stream rules (docs/serial_driver.md, "Stream rules").

Plausibility, anchoring of a session, duplicates, reordering, pending gaps, restarts
from evidence only. Samples are built as the firmware would send them (docs/firmware.md):
device time = whole multiple of the period, one sequence number per scan.
"""
from __future__ import annotations

import random

import numpy as np
import pytest

from forte_driver.serial.protocol import FLAG_OVERRUN, FLAG_SATURATED, FLAG_SESSION_START, Sample
from forte_driver.serial.stream import SequenceEvent, SequenceTracker, StreamAssembler

PERIOD = 500
BASE_TIME = 1_000_000_000  # a multiple of the period [us]


def scan(sequence: int, overruns: int = 0, flags: int = 0, time_us: int | None = None,
         values: tuple[int, ...] | None = None, saturated: int = 0,
         base_time: int = BASE_TIME) -> Sample:
    """The scan a firmware session (started at ``base_time``) sends with ``sequence``."""
    if time_us is None:
        time_us = (base_time + sequence * PERIOD) % (1 << 64)
    if values is None:
        values = tuple((sequence * 7 + k) % 1000 - 500 for k in range(6))
    return Sample(sequence % (1 << 32), time_us, values, overruns, flags, saturated)


def published(assembler: StreamAssembler) -> list[list[int]]:
    """Flush; the batches as lists of device sequence numbers (from the device times)."""
    assembler.flush()
    out = []
    for batch in assembler.take_batches():
        times = batch.device_time_us + PERIOD * np.arange(len(batch.values))
        out.append([int(t - BASE_TIME) // PERIOD for t in times])
    return out


def feed(assembler: StreamAssembler, samples) -> None:
    for sample in samples:
        assembler.add_sample(sample)


def test_lone_implausible_first_frame_never_anchors_the_session():
    # the campaign's frame: CRC-valid by chance, on nothing the device could send
    bogus = Sample(3_000_000_000, 490_000_000_000_000_000, (28158, 0, 0, 0, 0, 0), 7, 0, 0)
    # the same kind of frame made plausible on its own: readings in range, on the grid
    lone = Sample(3_000_000_000, 490_000_000_000_000_000, (11, 0, 0, 0, 0, 0), 7, 0, 0)
    for first in (bogus, lone):
        assembler = StreamAssembler(4, sample_period_us=PERIOD)
        assembler.start_session(from_zero=True)
        feed(assembler, [first] + [scan(s) for s in range(10)])
        assert published(assembler) == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9]]
        assert assembler.implausible_frames == assembler.corrupt_frames == 1
        assert assembler.dropped_frames == 0 and assembler.device_overruns == 0
        assert assembler.last_rejection.startswith('implausible frame')


def test_first_frame_waits_for_a_confirmation():
    assembler = StreamAssembler(1, sample_period_us=PERIOD)
    assembler.add_sample(scan(5))
    assert assembler.take_batches() == [] and assembler.held_frames == 1
    assembler.add_sample(scan(6))
    assert [b.first_sequence for b in assembler.take_batches()] == [5, 6]
    # a session with only one frame: never published, counted as unconfirmed
    assembler.start_session()
    assembler.add_sample(scan(20))
    assembler.start_session()
    assert assembler.take_batches() == []
    assert assembler.unconfirmed_frames == 1 and assembler.implausible_frames == 0


@pytest.mark.parametrize('bad', [
    scan(4, values=(1025, 0, 0, 0, 0, 0)),                     # reading out of range
    scan(4, values=(0, 0, 0, 0, 0, -1025)),
    scan(4, flags=0x08),                                       # undefined flag bit
    scan(4, flags=FLAG_SATURATED, saturated=0x40),             # undefined channel bit
    scan(4, flags=FLAG_SATURATED, saturated=0x01),             # clipped but not at +-1024
    scan(4, saturated=0x01, values=(1024, 0, 0, 0, 0, 0)),     # bit without the flag
    scan(4, flags=FLAG_SATURATED, values=(1024, 0, 0, 0, 0, 0)),  # flag without bits
    scan(4, time_us=BASE_TIME + 4 * PERIOD + 1),               # 1 us off the time line
    scan(4, time_us=BASE_TIME + 5 * PERIOD),                   # wrong instant for seq 4
    scan(4, overruns=1),                                       # overrun without a gap
    scan(4, flags=FLAG_OVERRUN),                               # overrun flag, no overrun
    scan(4, flags=FLAG_SESSION_START),                         # first-scan flag, seq != overruns
    scan(4, overruns=4, flags=FLAG_SESSION_START | FLAG_OVERRUN),  # first scan inside a session
    scan(2, time_us=BASE_TIME + 9 * PERIOD),                   # a repeat at another time
    scan(100_000, time_us=BASE_TIME),                          # far sequence, time unchanged
])
def test_implausible_frame_mid_stream_is_rejected_and_never_published(bad):
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in range(4)] + [bad] + [scan(s) for s in range(4, 8)])
    assert published(assembler) == [[0, 1, 2, 3], [4, 5, 6, 7]]
    assert assembler.implausible_frames == assembler.corrupt_frames == 1
    assert assembler.dropped_frames == 0 and assembler.device_overruns == 0
    assert assembler.duplicate_frames == assembler.late_frames == assembler.restarts == 0
    assert assembler.last_rejection


def test_saturated_scan_as_the_firmware_sends_it_is_accepted():
    clipped = scan(2, flags=FLAG_SATURATED, saturated=0b100001,
                   values=(-1024, 5, 6, 7, 8, 1024))
    unclipped_at_limit = scan(3, values=(1024, -1024, 0, 0, 0, 0))  # exactly +-1 inH2O
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(0), scan(1), clipped, unclipped_at_limit])
    assert published(assembler) == [[0, 1, 2, 3]]
    assert assembler.corrupt_frames == 0


def test_device_overruns_may_not_exceed_the_sequence_gap():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    # scans 3..5 dropped by the device: sequence skips 3, overruns +3, flag set
    feed(assembler, [scan(0), scan(1), scan(2), scan(6, overruns=3, flags=FLAG_OVERRUN),
                     scan(7, overruns=3), scan(9, overruns=5)])  # +2 overruns over 1 gap
    feed(assembler, [scan(10, overruns=4), scan(11, overruns=4)])
    assert published(assembler) == [[0, 1, 2], [6, 7], [10, 11]]
    assert assembler.device_overruns == 4 and assembler.implausible_frames == 1
    assert assembler.dropped_frames == 3 + 2  # 3..5 and 8..9 (9 itself was implausible)


def test_duplicates_are_dropped_and_counted_not_a_restart():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in (0, 1, 2, 2, 3, 1, 4, 0, 5)])
    assert published(assembler) == [[0, 1, 2, 3, 4, 5]]
    assert assembler.duplicate_frames == 3
    assert assembler.dropped_frames == assembler.restarts == assembler.late_frames == 0
    assert assembler.tracker.sequence_resets == 0


def test_reordered_frame_is_late_not_dropped_and_batches_never_go_back():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in (0, 1, 3, 2, 4, 5, 8, 6, 7, 9)])
    assert published(assembler) == [[0, 1], [3, 4, 5], [8, 9]]
    assert assembler.late_frames == 3
    assert assembler.dropped_frames == 0 and assembler.restarts == 0
    assert assembler.pending_gap_frames == 0


def test_gap_is_pending_inside_the_reorder_window_then_dropped():
    assembler = StreamAssembler(20, sample_period_us=PERIOD, reorder_window=4)
    feed(assembler, [scan(0), scan(2), scan(3), scan(4)])
    assert (assembler.dropped_frames, assembler.pending_gap_frames) == (0, 1)
    assembler.add_sample(scan(5))  # window is now 2..5: sequence 1 can no longer arrive
    assert (assembler.dropped_frames, assembler.pending_gap_frames) == (1, 0)
    assembler.add_sample(scan(1))  # too late: stale, not published, not counted twice
    assert assembler.stale_frames == 1 and assembler.late_frames == 0
    assert assembler.dropped_frames == 1
    assert published(assembler) == [[0], [2, 3, 4, 5]]


def test_sequence_wrap_with_large_device_times():
    base = (2 ** 63 // PERIOD - 10) * PERIOD - (2 ** 32 - 2) * PERIOD
    samples = [scan(s, base_time=base) for s in range(2 ** 32 - 2, 2 ** 32 + 3)]
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, samples[:3] + samples[4:])  # 2**32 + 1 lost
    assembler.flush()
    batches = assembler.take_batches()
    assert [(b.first_sequence, len(b.values)) for b in batches] == [
        (2 ** 32 - 2, 3), (2 ** 32 + 2, 1)]
    assert batches[1].device_time_us == samples[4].time_us
    assert assembler.dropped_frames == 1 and assembler.corrupt_frames == 0


def test_restart_recognised_from_the_first_scan_flag():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in range(10)])
    # the device restarted 1000 scans later; its first two scans were device overruns
    restart = [scan(2, overruns=2, flags=FLAG_SESSION_START | FLAG_OVERRUN,
                    base_time=BASE_TIME + 1000 * PERIOD),
               scan(3, overruns=2, base_time=BASE_TIME + 1000 * PERIOD)]
    feed(assembler, restart)
    assembler.flush()
    batches = assembler.take_batches()
    assert [(b.first_sequence, len(b.values)) for b in batches] == [(0, 10), (12, 2)]
    assert assembler.restarts == assembler.tracker.sequence_resets == 1
    assert assembler.dropped_frames == 2 and assembler.device_overruns == 2


def test_restart_recognised_when_sequence_and_time_both_go_back():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in range(10, 20)])
    feed(assembler, [scan(s, base_time=PERIOD * 2000) for s in (1, 2)])  # power cycle
    assert assembler.restarts == 1
    assembler.flush()
    assert [len(b.values) for b in assembler.take_batches()] == [10, 2]


def test_restart_without_evidence_needs_three_consistent_frames():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    feed(assembler, [scan(s) for s in range(10, 20)])
    other = [scan(s, base_time=BASE_TIME + 10_000 * PERIOD) for s in (1, 2, 3, 4)]
    feed(assembler, other[:2])  # sequence back, time forward: not yet a restart
    assert assembler.restarts == 0 and assembler.held_frames == 2
    assert [len(b.values) for b in assembler.take_batches()] == [10]
    feed(assembler, other[2:])
    assert assembler.restarts == 1 and assembler.implausible_frames == 0
    assembler.flush()
    assert [len(b.values) for b in assembler.take_batches()] == [4]


def test_lone_false_first_scan_mid_stream_is_not_a_restart():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    false_start = scan(3, overruns=3, flags=FLAG_SESSION_START | FLAG_OVERRUN,
                       base_time=BASE_TIME + 7000 * PERIOD)
    feed(assembler, [scan(s) for s in range(10)] + [false_start]
         + [scan(s) for s in range(10, 15)])
    assert published(assembler) == [list(range(10)), list(range(10, 15))]
    assert assembler.restarts == 0 and assembler.implausible_frames == 1


def test_start_acknowledged_counts_scans_lost_before_the_first_and_late_ones_fill():
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    assembler.start_session(from_zero=True)
    feed(assembler, [scan(3), scan(4), scan(1), scan(5)])
    assert published(assembler) == [[3, 4, 5]]
    assert assembler.late_frames == 1 and assembler.dropped_frames == 2  # 0 and 2
    assert assembler.restarts == 0


def test_random_crc_valid_frames_are_never_published_and_never_raise():
    rng = random.Random(3)
    assembler = StreamAssembler(20, sample_period_us=PERIOD)
    assembler.start_session(from_zero=True)
    for _ in range(20_000):
        assembler.add_sample(Sample(rng.getrandbits(32), rng.getrandbits(64),
                                    tuple(rng.randint(-32768, 32767) for _ in range(6)),
                                    rng.getrandbits(16), rng.getrandbits(8),
                                    rng.getrandbits(8)))
    assembler.flush()
    assert assembler.take_batches() == [] and assembler.samples == 0
    assert assembler.dropped_frames == 0 and assembler.device_overruns == 0
    # the extremes of every field, on the grid and in range: nothing raises either
    for time_us in (0, 2 ** 64 - 1, (2 ** 64 // PERIOD) * PERIOD - PERIOD):
        assembler.add_sample(Sample(2 ** 32 - 1, time_us, (1024,) * 6, 65535, 7, 63))


def test_without_a_period_the_time_is_not_checked():
    assembler = StreamAssembler(20)
    feed(assembler, [scan(0, time_us=0), scan(1, time_us=7), scan(2, time_us=3)])
    assembler.flush()
    assert [(b.first_sequence, len(b.values)) for b in assembler.take_batches()] == [(0, 3)]
    assert assembler.samples == 3 and assembler.corrupt_frames == 0


def test_tracker_window_of_one_counts_gaps_at_once():
    tracker = SequenceTracker()
    assert tracker.observe(7) == (SequenceEvent.FIRST, 7, 0)
    assert tracker.observe(10) == (SequenceEvent.NEXT, 10, 2)
    assert tracker.dropped_frames == 2
    assert tracker.observe(10)[0] == SequenceEvent.DUPLICATE
    assert tracker.observe(9)[0] == SequenceEvent.STALE
    assert (tracker.duplicate_frames, tracker.stale_frames, tracker.restarts) == (1, 1, 0)


def test_tracker_rejects_an_empty_window():
    with pytest.raises(ValueError, match='reorder_window'):
        SequenceTracker(0)
    with pytest.raises(ValueError, match='sample_period_us'):
        StreamAssembler(1, sample_period_us=0)
