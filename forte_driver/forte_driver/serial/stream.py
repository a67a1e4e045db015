"""Sequence accounting and gap-free batching of decoded FORTE samples (pure Python).

The rules (documented with a table in ``docs/serial_driver.md``):

- A sample frame is published only if it is *plausible* as well as CRC-valid
  (:mod:`forte_driver.serial.plausibility`): readings in
  [-1024, 1024], no undefined flag or saturation bits, saturation bits consistent with the
  readings as the firmware sets them, and consistent with the stream: within a session the
  device time advances by exactly (sequence step) x period and the overrun counter by at
  most the number of skipped sequence numbers. A rejected frame counts as corrupt and as
  implausible.
- A session is anchored only by two mutually consistent frames: the first frame of a
  session is held until a second frame confirms it, so a lone implausible frame can never
  anchor (and be published with) a session.
- A repeated sequence number is a duplicate, a sequence number behind the newest one that
  fills a pending gap is late: both are counted and never published (batches never go
  back in time). A gap is *pending* while it is within the reorder window of the newest
  sequence number and counted as dropped once it ages out (or the stream is flushed or a
  new session starts), so a frame that arrives late is not counted as dropped.
- A new session starts only from evidence: the host's START acknowledgement
  (:meth:`StreamAssembler.start_session`, not counted as a restart) or a device restart
  recognised in the stream (counted): a confirmed frame with the first-scan flag, a
  confirmed frame whose sequence and device time both went back, or three mutually
  consistent frames that all disagree with the running session.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from forte_driver.serial.plausibility import check_sample_alone, stream_mismatch
from forte_driver.serial.protocol import (
    FLAG_SESSION_START,
    OVERRUN_MODULUS,
    SEQUENCE_MODULUS,
    AsciiSample,
    Sample,
)
from forte_ros.contract import COUNTS_PER_FULL_SCALE, N_CHANNELS

#: Default reorder window of :class:`StreamAssembler` [sequence numbers].
DEFAULT_REORDER_WINDOW = 64
#: Frames held at most while waiting for a confirmation [count].
MAX_HELD_FRAMES = 8
#: Mutually consistent frames that recognise a restart without other evidence [count].
RESTART_CONFIRMATIONS = 3

_HALF_SEQUENCE = SEQUENCE_MODULUS // 2
_TIME_MODULUS = 1 << 64
_HALF_TIME = _TIME_MODULUS // 2
_TIME_MASK = _TIME_MODULUS - 1
_LOW, _HIGH = -COUNTS_PER_FULL_SCALE, COUNTS_PER_FULL_SCALE


class SequenceEvent(IntEnum):
    """What one received sequence number means for the stream."""

    FIRST = 0      #: first frame of a session
    NEXT = 1       #: ahead of the newest frame (possibly after a gap)
    DUPLICATE = 2  #: a sequence number already received (within the window)
    LATE = 3       #: behind the newest frame, fills a pending gap
    STALE = 4      #: older than the reorder window (or than the session's first frame)


class SequenceTracker:
    """Unwrap 32-bit sequence numbers; count drops, duplicates and late frames.

    The unwrapped sequence is monotonic for the life of the tracker: in the first session
    it equals the device sequence; a later session continues at the previous newest
    unwrapped value + 1 (+ the frames lost before its first frame if the session is known
    to start at 0). Missing sequence numbers are held as *pending* while they are within
    ``reorder_window`` of the newest one (a late frame can still fill them) and counted in
    :attr:`dropped_frames` when they age out, at :meth:`close_gaps` or at a new session.
    A backwards or repeated sequence number is never taken as a restart here: the caller
    decides that from evidence (:meth:`restart`).

    Parameters
    ----------
    reorder_window : int
        Sequence numbers up to and including the newest one that are remembered
        [count, >= 1]. 1 = an ordered link: every gap is counted at once and only a repeat
        of the newest frame is recognised as a duplicate.

    Attributes
    ----------
    dropped_frames : int
        Sequence numbers that never arrived within the window [count].
    duplicate_frames, late_frames, stale_frames : int
        Frames classified as :class:`SequenceEvent` DUPLICATE, LATE, STALE [count].
    sessions : int
        Sessions seen (1 after the first frame) [count].
    restarts : int
        Device restarts recognised by the caller (:meth:`restart`) [count].
    """

    def __init__(self, reorder_window: int = 1) -> None:
        if reorder_window < 1:
            raise ValueError(f'reorder_window must be >= 1, got {reorder_window}')
        self.reorder_window = reorder_window
        self.dropped_frames = 0
        self.duplicate_frames = 0
        self.late_frames = 0
        self.stale_frames = 0
        self.sessions = 0
        self.restarts = 0
        self._last_device: int | None = None
        self._last_unwrapped: int | None = None
        self._missing: list[list[int]] = []  # pending gaps [low, high), ascending
        self._floor = 0                      # lowest unwrapped sequence still in the window
        self._new_session = True
        self._from_zero = False

    @property
    def sequence_resets(self) -> int:
        """Alias of :attr:`restarts` (name used by the diagnostics)."""
        return self.restarts

    @property
    def pending_gap_frames(self) -> int:
        """Missing sequence numbers still inside the window (may arrive late) [count]."""
        return sum(high - low for low, high in self._missing)

    @property
    def newest(self) -> int | None:
        """Newest unwrapped sequence number received, ``None`` before the first frame."""
        return self._last_unwrapped

    def start_session(self, from_zero: bool = False) -> None:
        """The next frame starts a new session; pending gaps are counted as dropped.

        Parameters
        ----------
        from_zero : bool
            The device restarted its sequence at 0 (START acknowledged, or its first-scan
            flag seen): a first frame with sequence k means k frames were lost.
        """
        self.close_gaps()
        self._new_session = True
        self._from_zero = from_zero

    def restart(self, from_zero: bool = False) -> None:
        """The caller recognised a device restart: count it and start a new session."""
        self.restarts += 1
        self.start_session(from_zero)

    def close_gaps(self) -> None:
        """Count every pending gap as dropped now (nothing can fill them any more)."""
        for low, high in self._missing:
            self.dropped_frames += high - low
        self._missing.clear()
        if self._last_unwrapped is not None:
            self._floor = self._last_unwrapped + 1

    def update(self, sequence: int) -> tuple[int, int, bool]:
        """Account for one received sequence number (compatibility form of :meth:`observe`).

        Returns
        -------
        tuple of (int, int, bool)
            Unwrapped sequence, sequence numbers skipped right before it (0 unless it is
            ahead of the newest frame), whether it starts a session.
        """
        event, unwrapped, gap = self.observe(sequence)
        return unwrapped, gap, event == SequenceEvent.FIRST

    def observe(self, sequence: int) -> tuple[SequenceEvent, int, int]:
        """Classify one received sequence number and update the counters.

        Parameters
        ----------
        sequence : int
            Device sequence number, modulo 2**32.

        Returns
        -------
        tuple of (SequenceEvent, int, int)
            The event, the unwrapped sequence, the sequence numbers newly missing right
            before it (FIRST and NEXT only, else 0).
        """
        last_device = self._last_device
        if self._new_session or last_device is None:
            return self._first(sequence)
        step = (sequence - last_device) % SEQUENCE_MODULUS
        newest = self._last_unwrapped
        if 0 < step < _HALF_SEQUENCE:
            unwrapped = newest + step
            gap = step - 1
            missing = self._missing
            if gap:
                missing.append([newest + 1, unwrapped])
            self._last_device = sequence
            self._last_unwrapped = unwrapped
            cutoff = unwrapped - self.reorder_window + 1
            if cutoff > self._floor:
                self._floor = cutoff
                if missing and missing[0][0] < cutoff:
                    self._age(cutoff)
            return SequenceEvent.NEXT, unwrapped, gap
        unwrapped = newest - (SEQUENCE_MODULUS - step) % SEQUENCE_MODULUS
        if unwrapped < self._floor:
            self.stale_frames += 1
            return SequenceEvent.STALE, unwrapped, 0
        for index, (low, high) in enumerate(self._missing):
            if low <= unwrapped < high:
                self._fill(index, unwrapped)
                self.late_frames += 1
                return SequenceEvent.LATE, unwrapped, 0
        self.duplicate_frames += 1
        return SequenceEvent.DUPLICATE, unwrapped, 0

    def _first(self, sequence: int) -> tuple[SequenceEvent, int, int]:
        self.sessions += 1
        gap = sequence if self._from_zero and sequence < _HALF_SEQUENCE else 0
        if self._last_unwrapped is None:
            unwrapped = sequence
        else:
            unwrapped = self._last_unwrapped + 1 + gap
        if gap:
            self._missing.append([unwrapped - gap, unwrapped])
        self._floor = unwrapped - gap
        self._last_device = sequence
        self._last_unwrapped = unwrapped
        self._new_session = self._from_zero = False
        cutoff = unwrapped - self.reorder_window + 1
        if cutoff > self._floor:
            self._floor = cutoff
            self._age(cutoff)
        return SequenceEvent.FIRST, unwrapped, gap

    def _age(self, cutoff: int) -> None:
        missing = self._missing
        while missing and missing[0][0] < cutoff:
            low, high = missing[0]
            if high <= cutoff:
                self.dropped_frames += high - low
                missing.pop(0)
            else:
                self.dropped_frames += cutoff - low
                missing[0][0] = cutoff

    def _fill(self, index: int, unwrapped: int) -> None:
        low, high = self._missing[index]
        pieces = [piece for piece in ([low, unwrapped], [unwrapped + 1, high])
                  if piece[1] > piece[0]]
        self._missing[index:index + 1] = pieces


@dataclass
class Batch:
    """Consecutive samples without any gap.

    Attributes
    ----------
    first_sequence : int
        Unwrapped sequence of the first row.
    device_time_us : int
        Device time of the first row [us] (binary) or the host-derived time of the first
        row [us] (ASCII, see the caveat in docs/serial_driver.md).
    values : numpy.ndarray
        Shape (n, 6), float64, normalised readings.
    """

    first_sequence: int
    device_time_us: int
    values: np.ndarray


class StreamAssembler:
    """Build gap-free batches from decoded samples; never invents a sample.

    Only plausible, stream-consistent frames are published (rules in the module
    docstring). A batch is emitted when it holds ``batch_size`` rows, and ended early at
    every sequence gap, corrupt or implausible frame, new session, or :meth:`flush`.

    Parameters
    ----------
    batch_size : int
        Rows per full batch.
    sample_period_us : int or None
        Scan period of the configured rate [us] (e.g. 500 at 2 kHz); ``None`` disables
        the device-time checks (e.g. ASCII). May be changed between sessions.
    reorder_window : int
        Sequence numbers a gap stays pending (late frames can fill it) [count].

    Attributes
    ----------
    tracker : SequenceTracker
        Sequence accounting (dropped, duplicate, late, stale, restarts).
    samples : int
        Samples placed into batches [count].
    corrupt_frames : int
        Corrupt frames/lines (CRC, header, malformed) plus implausible frames [count].
    implausible_frames : int
        CRC-valid frames rejected as implausible [count].
    unconfirmed_frames : int
        Lone first frames of a session that no later frame confirmed [count].
    device_overruns : int
        Samples the device reported it dropped itself (host too slow) [count].
    last_rejection : str
        Reason of the last rejected frame ('' if none).
    """

    def __init__(self, batch_size: int, sample_period_us: int | None = None,
                 reorder_window: int = DEFAULT_REORDER_WINDOW) -> None:
        if batch_size < 1:
            raise ValueError(f'batch_size must be >= 1, got {batch_size}')
        if sample_period_us is not None and sample_period_us < 1:
            raise ValueError(f'sample_period_us must be >= 1, got {sample_period_us}')
        self.batch_size = batch_size
        self.sample_period_us = sample_period_us
        self.tracker = SequenceTracker(reorder_window)
        self.samples = 0
        self.corrupt_frames = 0
        self.implausible_frames = 0
        self.unconfirmed_frames = 0
        self.device_overruns = 0
        self.last_rejection = ''
        self._head: Sample | None = None     # newest in-order frame of the session
        self._held: list[Sample] = []        # frames waiting for a confirmation
        self._rows: list[tuple[float, ...]] = []
        self._first_sequence = 0
        self._first_time_us = 0
        self._ascii_sequence = 0
        self._ready: list[Batch] = []

    # ---- counters ------------------------------------------------------------------

    @property
    def dropped_frames(self) -> int:
        """Scans lost (sequence gaps aged out of the window; device overruns included)."""
        return self.tracker.dropped_frames

    @property
    def duplicate_frames(self) -> int:
        """Frames repeating an already received sequence number [count]."""
        return self.tracker.duplicate_frames

    @property
    def late_frames(self) -> int:
        """Frames that arrived behind a newer one and filled a pending gap [count]."""
        return self.tracker.late_frames

    @property
    def stale_frames(self) -> int:
        """Frames older than the reorder window (duplicate or late, unknowable) [count]."""
        return self.tracker.stale_frames

    @property
    def restarts(self) -> int:
        """Device restarts recognised from evidence in the stream [count]."""
        return self.tracker.restarts

    @property
    def pending_gap_frames(self) -> int:
        """Missing scans still inside the reorder window [count]."""
        return self.tracker.pending_gap_frames

    @property
    def held_frames(self) -> int:
        """Frames waiting for a confirmation (not yet published or rejected) [count]."""
        return len(self._held)

    @property
    def pending_rows(self) -> int:
        """Rows of the batch being filled."""
        return len(self._rows)

    # ---- input ---------------------------------------------------------------------

    def start_session(self, from_zero: bool = False) -> None:
        """End the current batch; the next sample begins a new device session.

        Parameters
        ----------
        from_zero : bool
            START acknowledged: the device restarts at sequence 0, so a first frame with
            sequence k means k frames were lost (see :meth:`SequenceTracker.start_session`).
        """
        self._end_batch()
        if self._head is None:
            self.unconfirmed_frames += len(self._held)
        else:
            for _ in self._held:
                self._reject('disagreed with the session and was never confirmed')
        self._held = []
        self._head = None
        self.tracker.start_session(from_zero)

    def add_sample(self, sample: Sample) -> None:
        """Add one decoded binary sample (in stream order); never raises on a Sample."""
        period = self.sample_period_us
        head = self._head
        if (head is not None and not self._held and not sample.flags and not sample.saturated
                and sample.overruns == head.overruns
                and (sample.sequence - head.sequence) % SEQUENCE_MODULUS == 1
                and (period is None or (sample.time_us - head.time_us) & _TIME_MASK == period)):
            # fast path, same result as the general one: the next scan, no flags, no gap
            values = sample.values
            if len(values) == N_CHANNELS and min(values) >= _LOW and max(values) <= _HIGH:
                unwrapped = self.tracker.observe(sample.sequence)[1]
                self._head = sample
                self._append(unwrapped, sample.time_us,
                             tuple(v / COUNTS_PER_FULL_SCALE for v in values))
                return
        reason = check_sample_alone(sample)
        if reason is not None:
            self._reject(reason)
            return
        if head is not None and stream_mismatch(head, sample, period) is None:
            if self._held:
                for _ in self._held:
                    self._reject('disagreed with the session, which continued')
                self._held = []
            self._accept(sample)
            return
        self._hold(sample)

    def add_ascii_sample(self, sample: AsciiSample, time_us: int) -> None:
        """Add one ASCII sample with its host-derived time [us]; sequence is host-counted."""
        self._append(self._ascii_sequence, time_us, sample.values)
        self._ascii_sequence += 1

    def add_corrupt(self, reason: str = '') -> None:
        """A corrupt frame or line was seen (``reason``: e.g. 'crc'): end the batch."""
        self.corrupt_frames += 1
        self.last_rejection = f'corrupt frame ({reason})' if reason else 'corrupt frame'
        self._end_batch()

    def flush(self) -> None:
        """The stream stops here (e.g. deactivate): end the partial batch now and count
        the pending gaps as dropped."""
        self._end_batch()
        self.tracker.close_gaps()

    def take_batches(self) -> list[Batch]:
        """Completed batches since the last call, oldest first."""
        ready, self._ready = self._ready, []
        return ready

    # ---- internals -----------------------------------------------------------------

    def _reject(self, reason: str) -> None:
        self.corrupt_frames += 1
        self.implausible_frames += 1
        self.last_rejection = f'implausible frame: {reason}'
        self._end_batch()

    def _accept(self, sample: Sample) -> None:
        """Account for a frame consistent with the session (or anchoring it)."""
        event, unwrapped, gap = self.tracker.observe(sample.sequence)
        if event == SequenceEvent.NEXT:
            if gap:
                self._end_batch()
            self.device_overruns += (sample.overruns - self._head.overruns) % OVERRUN_MODULUS
        elif event == SequenceEvent.FIRST:
            self._end_batch()
            self.device_overruns += sample.overruns
        else:
            return  # duplicate, late or stale: counted by the tracker, never published
        self._head = sample
        self._append(unwrapped, sample.time_us,
                     tuple(v / COUNTS_PER_FULL_SCALE for v in sample.values))

    def _hold(self, sample: Sample) -> None:
        """Hold a frame that nothing confirms yet; anchor a session once confirmed."""
        self._end_batch()
        held = self._held
        period = self.sample_period_us
        for anchor in reversed(held):
            if stream_mismatch(anchor, sample, period) is not None:
                continue
            chain = [frame for frame in held
                     if frame is anchor or stream_mismatch(anchor, frame, period) is None]
            chain.append(sample)
            if self._confirmed(chain):
                self._anchor(chain)
                return
        held.append(sample)
        if len(held) > MAX_HELD_FRAMES:
            held.pop(0)
            if self._head is None:
                self.unconfirmed_frames += 1
            else:
                self._reject('disagreed with the session and was never confirmed')

    def _confirmed(self, chain: list[Sample]) -> bool:
        """Whether consistent frames ``chain`` (arrival order) anchor a session."""
        head = self._head
        if head is None:
            return True  # a session start: two consistent frames confirm each other
        if len(chain) >= RESTART_CONFIRMATIONS:
            return True
        if any(frame.flags & FLAG_SESSION_START for frame in chain):
            return True
        first = chain[0]
        step = (first.sequence - head.sequence) % SEQUENCE_MODULUS
        elapsed = (first.time_us - head.time_us) & _TIME_MASK
        return step >= _HALF_SEQUENCE and elapsed >= _HALF_TIME  # both went back

    def _anchor(self, chain: list[Sample]) -> None:
        """Start (or restart) the session at ``chain``; reject the other held frames."""
        from_zero = any(frame.flags & FLAG_SESSION_START for frame in chain)
        if self._head is not None:
            self.tracker.restart(from_zero)
        elif from_zero:
            self.tracker.start_session(from_zero=True)
        for frame in self._held:
            if not any(frame is member for member in chain):
                self._reject('disagreed with the frames that anchored the session')
        self._held = []
        self._head = None
        for frame in chain:
            self._accept(frame)

    def _end_batch(self) -> None:
        if self._rows:
            self._ready.append(Batch(self._first_sequence, self._first_time_us,
                                     np.array(self._rows, dtype=np.float64)))
            self._rows = []

    def _append(self, sequence: int, time_us: int, values: tuple[float, ...]) -> None:
        if not self._rows:
            self._first_sequence = sequence
            self._first_time_us = time_us
        self._rows.append(values)
        self.samples += 1
        if len(self._rows) >= self.batch_size:
            self._end_batch()
