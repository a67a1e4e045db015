"""Long fault-injection streams through the serial decoder and stream accounting.

1. Correctness at scale: a seeded stream of 1e7 scans (``--quick``: 1e6) from the
   independent encoder of ``forte_driver/test/serial/fault_streams.py`` (garbage, false
   signatures, truncation, bit flips anywhere, gaps, duplicates, reordering, CRC-valid
   implausible frames, device overruns, sequence wrap at 2**32, device times near 2**63,
   START sessions and device restarts) fed through FrameDecoder + StreamAssembler in
   random read sizes (1 B .. 4 KiB). Reports frames sent / published, invented and
   altered samples, and every counter expected vs reported.
2. Throughput, measured in this run: FrameDecoder vs a simple byte-at-a-time decoder
   written here from docs/firmware.md (which also cross-checks the decoded frames on the
   faulty stream), and the StreamAssembler (plausibility + sequence accounting).

Run: ``python benchmarks/bench_fault_streams.py [--quick] [--scans N] [--seed S]``
(``make faults`` runs the full 1e7 stream).
"""
from __future__ import annotations

import argparse
import binascii
import struct
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'forte_driver' / 'test' / 'serial'))

from fault_streams import FaultStreamGenerator, run_stream  # noqa: E402

from forte_driver.serial import protocol  # noqa: E402
from forte_driver.serial.stream import StreamAssembler  # noqa: E402

SIGNATURE = b'\xa5\x5a\x01'
LENGTHS = {0x01: 28, 0x02: 4, 0x03: 8, 0x04: 20}
SAMPLE = struct.Struct('<IQ6hHBB')


class ByteAtATimeDecoder:
    """Baseline from docs/firmware.md "Decoder rules", one byte per step.

    A candidate grows byte by byte while it matches the signature, a valid header and,
    at its full length, its CRC; when it fails, its bytes after the first are examined
    again (hunting resumes one byte after the candidate's start).
    """

    def __init__(self) -> None:
        self.candidate = bytearray()
        self.frames = 0
        self.corrupt = 0

    def feed(self, data: bytes) -> list:
        out: list = []
        for byte in data:
            self._byte(byte, out)
        return out

    def _byte(self, byte: int, out: list) -> None:
        candidate = self.candidate
        candidate.append(byte)
        size = len(candidate)
        if size <= 3:
            if byte == SIGNATURE[size - 1]:
                return
        elif size == 4:
            return
        elif size == 5:
            if LENGTHS.get(candidate[3]) == byte:
                return
            self.corrupt += 1
        elif size < 7 + candidate[4]:
            return
        else:
            crc = candidate[-2] | candidate[-1] << 8
            if binascii.crc_hqx(bytes(candidate[2:-2]), 0xFFFF) == crc:
                if candidate[3] == 0x01:
                    fields = SAMPLE.unpack_from(candidate, 5)
                    out.append(protocol.Sample(fields[0], fields[1], fields[2:8],
                                               fields[8], fields[9], fields[10]))
                else:
                    out.append(bytes(candidate))  # ACK, INFO, COMMAND: not compared
                self.frames += 1
                candidate.clear()
                return
            self.corrupt += 1
        rest = bytes(candidate[1:])
        candidate.clear()
        for again in rest:
            self._byte(again, out)


def rate(function, count: int, repeats: int = 3) -> float:
    """Best of ``repeats`` runs: items per second."""
    best = float('inf')
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return count / best


def chunks(data: bytes, size: int = 4096) -> list[bytes]:
    return [data[k:k + size] for k in range(0, len(data), size)]


def throughput(scans: int) -> None:
    generator = FaultStreamGenerator(99)
    faulty = b''.join(block.data for block in generator.blocks(scans, scans))
    clean = b''.join(protocol.encode_sample(protocol.Sample(
        s, 1_000_000 + 500 * s, tuple((s * 7 + k) % 2049 - 1024 for k in range(6))))
        for s in range(scans))
    print(f'[bench_faults] 2. throughput, {scans:,} scans fed in 4 KiB chunks (best of 3)')
    for name, data in (('clean stream', clean), ('faulty stream', faulty)):
        pieces = chunks(data)
        fast = rate(lambda p=pieces: _decode(protocol.FrameDecoder(), p), scans)
        slow = rate(lambda p=pieces: _decode(ByteAtATimeDecoder(), p), scans, repeats=1)
        same = _samples(protocol.FrameDecoder(), pieces) == _samples(ByteAtATimeDecoder(),
                                                                     pieces)
        print(f'  {name:14s} FrameDecoder {fast:11,.0f} scans/s   byte-at-a-time '
              f'{slow:9,.0f} scans/s   ratio {fast / slow:4.1f}   same frames: {same}')
    samples = protocol.FrameDecoder().feed(clean)

    def assemble() -> None:
        assembler = StreamAssembler(20, sample_period_us=500)
        for sample in samples:
            assembler.add_sample(sample)
        assembler.take_batches()

    assembled = rate(assemble, scans)
    print(f'  StreamAssembler (plausibility, sequence accounting, batches of 20): '
          f'{assembled:,.0f} scans/s = {assembled / 2000:,.0f} x the 2 kHz stream')


def _samples(decoder, pieces: list[bytes]) -> tuple[list, int]:
    """The samples a decoder finds and its corrupt count (the two must agree)."""
    samples = [item for item in _decode(decoder, pieces) if type(item) is protocol.Sample]
    return samples, decoder.corrupt_frames if hasattr(decoder, 'corrupt_frames') else \
        decoder.corrupt


def _decode(decoder, pieces: list[bytes]) -> list:
    out = []
    for piece in pieces:
        out += decoder.feed(piece)
    return out


def correctness(scans: int, seed: int) -> bool:
    print(f'[bench_faults] 1. fault streams: {scans:,} scans, seed {seed}, random reads '
          f'of 1 B .. 4 KiB')
    generator = FaultStreamGenerator(seed)
    start = time.perf_counter()
    report = run_stream(generator, scans, chunk_seed=seed + 1)
    elapsed = time.perf_counter() - start
    counts = generator.expected.counts
    print(f'  injected: {", ".join(f"{k} {v:,}" for k, v in sorted(counts.items()))}')
    print(f'  bytes {report.bytes_fed:,}; generated + decoded + checked in {elapsed:.1f} s')
    print(f'  frames sent intact {report.frames_sent:,}   published {report.published:,}   '
          f'invented {report.invented}   altered {report.altered}   '
          f'missing {report.missing}   out of order {report.order_errors}')
    for name, (expected, got) in report.counters.items():
        mark = 'ok' if expected == got else 'MISMATCH'
        print(f'  {name:16s} expected {expected:>10,}   reported {got:>10,}   {mark}')
    good = (report.invented == report.altered == report.missing == report.order_errors
            == report.counter_errors == 0)
    print(f'  result: {"0 invented, 0 altered, exact counters" if good else "FAILED"}')
    return good


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='1e6 scans instead of 1e7')
    parser.add_argument('--scans', type=int, default=None, help='stream length [scans]')
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args()
    scans = args.scans or (1_000_000 if args.quick else 10_000_000)
    good = correctness(scans, args.seed)
    throughput(100_000 if args.quick else 200_000)
    return 0 if good else 1


if __name__ == '__main__':
    sys.exit(main())
