"""Bytes read from the sensor port -> stamped, gap-free batches (pure Python, no rclpy).

Used by the reader thread of :mod:`forte_driver.ros.serial_sensor_node`: one
:class:`SensorStream` per configured node holds the decoder (binary protocol v1 or legacy
ASCII lines), the :class:`~forte_driver.serial.stream.StreamAssembler` (batches, drop /
corruption / plausibility accounting) and the :class:`~forte_driver.serial.clock_sync.ClockSync`
(device clock -> host time), and pairs every completed batch with its stamp.

Rules:

- Only samples the assembler accepted feed the clock estimator (an implausible, duplicate
  or late frame never moves the clock). When one call of ``add_sample`` accepts several
  frames (a held frame confirmed by the next), the current frame is the newest of them.
- A device restart (the assembler's ``restarts`` counter grows: sequence and device time
  start again without a START from the host) resets the clock estimator; the batches of
  the old session are stamped with the old clock first.
- The clock sees device time unwrapped: the protocol's u64 microsecond counter may wrap
  (the assembler checks time modulo 2**64), so each accepted time is placed within
  +-2**63 us of the newest accepted one, and a wrap continues the count instead of
  looking like a jump back. Unwrapping restarts with the clock (new session, restart).
- A batch whose device time cannot be mapped to a host time in [0, 2**63) ns is not
  published: its rows are counted in ``unstamped_samples`` and the event is recorded as a
  reader error (it cannot happen with plausible device times).
"""
from __future__ import annotations

import time
from collections.abc import Callable

from forte_driver.serial.clock_sync import ClockSync, is_valid_host_time
from forte_driver.serial.protocol import (
    AsciiLineDecoder,
    AsciiSample,
    CorruptFrame,
    FrameDecoder,
    Sample,
)
from forte_driver.serial.reader_health import ReaderHealth
from forte_driver.serial.stream import Batch, StreamAssembler

#: The protocol's device time counter wraps at this value [us].
DEVICE_TIME_MODULUS = 1 << 64

#: A completed batch and its stamp [ns] (binary: device time mapped to host time; ASCII:
#: host-derived receive time).
StampedBatch = tuple[Batch, int]


class SensorStream:
    """Decode, assemble and stamp the byte stream of one sensor port.

    Parameters
    ----------
    binary : bool
        Binary protocol v1 (True) or legacy ASCII lines (False).
    batch_size : int
        Rows per full batch.
    period_us : int
        Nominal sample period [us]; binary: passed to the assembler's plausibility check;
        ASCII: spacing of the host-derived times of the lines of one chunk.
    clock_window_s : float
        Window of the clock fit [s].
    health : ReaderHealth
        Where unstampable batches are recorded as reader errors.

    Attributes
    ----------
    assembler : StreamAssembler
    clock_sync : ClockSync
    unstamped_samples : int
        Rows not published because their batch could not be stamped [count].
    """

    def __init__(self, binary: bool, batch_size: int, period_us: int, clock_window_s: float,
                 health: ReaderHealth) -> None:
        self.binary = binary
        self.period_us = period_us
        self.frame_decoder = FrameDecoder()
        self.ascii_decoder = AsciiLineDecoder()
        self.assembler = StreamAssembler(batch_size,
                                         sample_period_us=period_us if binary else None)
        self.clock_sync = ClockSync(window_s=clock_window_s)
        self.health = health
        self.unstamped_samples = 0
        self._latencies: list[float] = []
        self._newest_raw_us: int | None = None  # newest accepted device time, as sent
        self._newest_unwrapped_us = 0  # the same, unwrapped

    @property
    def discarded_bytes(self) -> int:
        """Bytes the active decoder skipped while resynchronising [count]."""
        decoder = self.frame_decoder if self.binary else self.ascii_decoder
        return decoder.discarded_bytes

    def reconnected(self) -> None:
        """A (re)opened port: forget partial frames and the clock; a new session begins."""
        self.frame_decoder.reset()
        self.ascii_decoder.reset()
        self._reset_clock()
        self.assembler.start_session()

    def take_latencies(self) -> list[float]:
        """Latencies above the clock's lower envelope since the last call [s]."""
        latencies, self._latencies = self._latencies, []
        return latencies

    def feed(self, data: bytes, received_ns: int,
             on_control: Callable[[object], None]) -> list[StampedBatch]:
        """Process one chunk read at host time ``received_ns`` [ns]; returns the batches
        completed by it, oldest first, with their stamps. Control frames (Ack, Info) are
        passed to ``on_control`` in stream order."""
        if not self.binary:
            return self._feed_ascii(data, received_ns)
        assembler = self.assembler
        newest_time_us = None   # device time of the newest sample accepted in this chunk
        stamped: list[StampedBatch] = []
        pending: list[Batch] = []  # completed batches of the current device clock
        for item in self.frame_decoder.feed(data):
            if isinstance(item, Sample):
                samples_before, restarts_before = assembler.samples, assembler.restarts
                assembler.add_sample(item)
                accepted = assembler.samples != samples_before
                if assembler.restarts != restarts_before:
                    # the device restarted its clock: stamp the old session's batches with
                    # the old clock; the rows accepted by this call (the frames that
                    # confirmed the restart) belong to the new clock
                    ready = assembler.take_batches()
                    new_rows = assembler.samples - samples_before - assembler.pending_rows
                    carry: list[Batch] = []
                    while new_rows > 0 and ready:
                        carry.insert(0, ready.pop())
                        new_rows -= len(carry[0].values)
                    self._observe_clock(newest_time_us, received_ns)
                    stamped += self._stamp(pending + ready)
                    pending = carry
                    self._reset_clock()
                    self.clock_sync.resets += 1
                    newest_time_us = None
                if accepted:
                    newest_time_us = self._unwrap(item.time_us, newest=True)
            elif isinstance(item, CorruptFrame):
                assembler.add_corrupt()
            else:
                on_control(item)
        self._observe_clock(newest_time_us, received_ns)
        return stamped + self._stamp(pending + assembler.take_batches())

    def flush(self) -> list[StampedBatch]:
        """End the partial batch now; returns it (if any) stamped."""
        self.assembler.flush()
        return self._stamp(self.assembler.take_batches())

    def _feed_ascii(self, data: bytes, received_ns: int) -> list[StampedBatch]:
        items = self.ascii_decoder.feed(data)
        lines = sum(1 for item in items if isinstance(item, AsciiSample))
        received_us = received_ns // 1000
        index = 0
        for item in items:
            if isinstance(item, AsciiSample):
                # caveat: receive time, the last line of the chunk taken as newest
                time_us = received_us - (lines - 1 - index) * self.period_us
                self.assembler.add_ascii_sample(item, time_us)
                index += 1
            else:
                self.assembler.add_corrupt()
        return self._stamp(self.assembler.take_batches())

    def _reset_clock(self) -> None:
        self.clock_sync.reset()
        self._newest_raw_us = None
        self._newest_unwrapped_us = 0

    def _unwrap(self, raw_us: int, newest: bool = False) -> int:
        """Device time [us] on the unwrapped axis: within +-2**63 us of the newest accepted
        time (``newest``: ``raw_us`` is the new newest accepted time)."""
        if self._newest_raw_us is None:
            unwrapped = raw_us
        else:
            half = DEVICE_TIME_MODULUS // 2
            step = (raw_us - self._newest_raw_us + half) % DEVICE_TIME_MODULUS - half
            unwrapped = self._newest_unwrapped_us + step
        if newest:
            self._newest_raw_us, self._newest_unwrapped_us = raw_us, unwrapped
        return unwrapped

    def _observe_clock(self, device_time_us: int | None, received_ns: int) -> None:
        if device_time_us is None or not self.clock_sync.add(device_time_us, received_ns):
            return
        latency = self.clock_sync.last_latency_s
        if latency is not None:
            self._latencies.append(latency)

    def _stamp(self, batches: list[Batch]) -> list[StampedBatch]:
        stamped = []
        for batch in batches:
            if self.binary:
                stamp_ns = self.clock_sync.to_host_ns(self._unwrap(batch.device_time_us))
            else:
                stamp_ns = batch.device_time_us * 1000
            if stamp_ns is None or not is_valid_host_time(stamp_ns):
                self.unstamped_samples += len(batch.values)
                self.health.record_error('stamp', ValueError(
                    f'device time {batch.device_time_us} us of sequence '
                    f'{batch.first_sequence} cannot be mapped to ROS time'), time.monotonic())
                continue
            stamped.append((batch, stamp_ns))
        return stamped
