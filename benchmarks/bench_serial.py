"""Serial sensor path: decode throughput and driver CPU share at 2 kHz, each with a baseline.

1. Decode throughput (no I/O): the same 100 000 scans as binary frames through
   forte_driver.serial.protocol.FrameDecoder (fed in 4 KiB chunks, as the driver reads) vs two
   baselines measured in this run: a naive byte-at-a-time binary decoder, and the legacy
   ASCII lines through the strict AsciiLineDecoder.
2. Driver CPU share at 2 kHz over a real pty: the lifecycle node (binary protocol) reading
   an emulated device running in a separate process, vs the same node in legacy ASCII mode.
   CPU share = CPU time of this process (the driver only: the device is another process)
   / wall time. Also reports the achieved rate and counters.

Run: ``python benchmarks/bench_serial.py`` (``--quick`` for shorter runs).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time

from forte_ros.isolation import isolate_ros_network

isolate_ros_network()

import binascii  # noqa: E402
import struct  # noqa: E402

from forte_driver.emulators.emulated_sensor import default_signal  # noqa: E402
from forte_driver.serial import protocol  # noqa: E402


def make_streams(count: int) -> tuple[bytes, bytes]:
    """The same scans as binary frames and as legacy ASCII lines."""
    binary, ascii_lines = bytearray(), bytearray()
    for sequence in range(count):
        time_us = 1_000_000 + 500 * sequence
        values = default_signal(sequence, time_us)
        binary += protocol.encode_sample(protocol.Sample(sequence, time_us, values))
        ascii_lines += protocol.format_ascii_line([v / 1024 for v in values])
    return bytes(binary), bytes(ascii_lines)


class NaiveByteDecoder:
    """Baseline: a textbook byte-at-a-time state machine (no bulk search)."""

    def __init__(self) -> None:
        self.state = 0
        self.frame = bytearray()
        self.frames = 0
        self.corrupt = 0

    def feed(self, data: bytes) -> list:
        out = []
        for byte in data:
            if self.state == 0:
                if byte == 0xA5:
                    self.frame = bytearray([byte])
                    self.state = 1
            elif self.state == 1:
                self.state = 2 if byte == 0x5A else (1 if byte == 0xA5 else 0)
                self.frame.append(byte)
            else:
                self.frame.append(byte)
                if len(self.frame) == protocol.SAMPLE_FRAME_SIZE:
                    body = bytes(self.frame[2:-2])
                    crc = self.frame[-2] | (self.frame[-1] << 8)
                    if binascii.crc_hqx(body, 0xFFFF) == crc:
                        fields = struct.unpack_from('<IQ6hHBB', self.frame, 5)
                        out.append(protocol.Sample(fields[0], fields[1], fields[2:8]))
                        self.frames += 1
                    else:
                        self.corrupt += 1
                    self.state = 0
        return out


def decode_rate(decoder_factory, data: bytes, chunk: int = 4096) -> tuple[float, int]:
    decoder = decoder_factory()
    started = time.perf_counter()
    frames = 0
    for offset in range(0, len(data), chunk):
        frames += len(decoder.feed(data[offset:offset + chunk]))
    elapsed = time.perf_counter() - started
    return frames / elapsed, frames


def run_driver(protocol_name: str, seconds: float) -> dict:
    """The node against an emulated device in another process; returns measurements."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from forte_driver.ros.serial_sensor_node import SerialSensorNode

    link = os.path.join(tempfile.mkdtemp(prefix='forte_bench_'), 'forte_sensor')
    device = subprocess.Popen([sys.executable, '-m', 'forte_driver.emulators.emulated_sensor',
                               '--link', link, '--protocol', protocol_name, '--rate', '2000'],
                              stdout=subprocess.DEVNULL)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        deadline = time.monotonic() + 20.0
        while not os.path.lexists(link) and time.monotonic() < deadline:
            time.sleep(0.05)
        node = SerialSensorNode(context=context, parameter_overrides=[
            Parameter('port', value=link), Parameter('protocol', value=protocol_name)])
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        node.trigger_configure()
        time.sleep(0.5)
        idle0, idle_wall0 = time.process_time(), time.perf_counter()
        time.sleep(2.0)  # configured, device stopped: executor timers, DDS, idle reads
        idle = (time.process_time() - idle0) / (time.perf_counter() - idle_wall0)
        node.trigger_activate()
        time.sleep(1.0)  # warm-up: clock fit, DDS discovery
        before = node.counters
        cpu0, wall0 = time.process_time(), time.perf_counter()
        time.sleep(seconds)
        cpu1, wall1 = time.process_time(), time.perf_counter()
        after = node.counters
        node.trigger_deactivate()
        node.trigger_cleanup()
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
        device.terminate()
        device.wait(timeout=10)
    wall = wall1 - wall0
    return {
        'cpu_share': (cpu1 - cpu0) / wall,
        'idle_cpu_share': idle,
        'rate_hz': (after['received_samples'] - before['received_samples']) / wall,
        'dropped': after['dropped_frames'],
        'corrupt': after['corrupt_frames'],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='shorter runs')
    args = parser.parse_args()
    count = 20_000 if args.quick else 100_000
    seconds = 3.0 if args.quick else 10.0
    binary, ascii_lines = make_streams(count)

    print(f'[bench_serial] 1. decode throughput, {count} scans '
          f'({len(binary) / count:.0f} B/frame binary, {len(ascii_lines) / count:.0f} B/line '
          f'ASCII), fed in 4 KiB chunks')
    fast, n_fast = decode_rate(protocol.FrameDecoder, binary)
    naive, n_naive = decode_rate(NaiveByteDecoder, binary)
    lines, n_lines = decode_rate(protocol.AsciiLineDecoder, ascii_lines)
    assert n_fast == n_naive == count and n_lines == count - 0
    print(f'  FrameDecoder (binary)            {fast:12,.0f} frames/s '
          f'= {fast / 2000:,.0f} x the 2 kHz stream')
    print(f'  baseline: naive byte-at-a-time   {naive:12,.0f} frames/s')
    print(f'  baseline: ASCII line parser      {lines:12,.0f} lines/s')
    print(f'  ratio FrameDecoder / naive       {fast / naive:12.1f}')
    print(f'  ratio FrameDecoder / ASCII lines {fast / lines:12.1f}')

    print(f'[bench_serial] 2. driver node at 2 kHz over a pty, {seconds:.0f} s per protocol '
          f'(device emulated in another process)')
    results = {name: run_driver(name, seconds) for name in ('binary', 'ascii')}
    for name, result in results.items():
        label = 'binary protocol v1' if name == 'binary' else 'baseline: legacy ASCII'
        print(f'  {label:24s} CPU {100 * result["cpu_share"]:5.1f} % of one core '
              f'(idle, configured: {100 * result["idle_cpu_share"]:.1f} %), '
              f'rate {result["rate_hz"]:7.1f} Hz, dropped {result["dropped"]}, '
              f'corrupt {result["corrupt"]}')
    ratio = results['ascii']['cpu_share'] / max(results['binary']['cpu_share'], 1e-9)
    print(f'  CPU ratio ASCII / binary {ratio:.2f}')


if __name__ == '__main__':
    main()
