"""A generated fault stream through the real serial_sensor_node over a real pty.

The library benchmark (``bench_fault_streams.py``) checks FrameDecoder + StreamAssembler;
this one checks the node around them: reader thread, SensorStream, clock stamping,
lifecycle, publishing, /diagnostics.

1. ``forte_driver/test/serial/scripted_device.py`` generates one START session of the
   independent encoder's fault stream (garbage, false sync, bit flips anywhere,
   truncation, gaps, duplicates, delayed frames, CRC-valid implausible frames, device
   overruns, device-time wrap at 2**64) followed by device restarts (first-scan flag),
   and plays the device on a pty: it acknowledges STOP / IDENTIFY (+ INFO) / SET_RATE /
   START and, after the START ACK, writes the stream in random chunks (1 B .. 4 KiB) as
   fast as the node reads (faster than real time).
2. The node runs in its own process (``autostart:=true reliable:=true``); this process
   records tactile/frames (reliable, KEEP_ALL) and /diagnostics in a
   SingleThreadedExecutor thread. When the stream is written and the published sample
   count has stopped growing, the node is deactivated through its lifecycle service
   (the final flush counts pending gaps) and the counters are read from the last
   /diagnostics message of the inactive node.
3. Every published row is compared with the generator's truth: invented (no intact scan
   with that device time), altered (other readings, or not an exact multiple of 1/1024),
   missing, out of order, and sequence errors (the unwrapped sequence must be the
   device's own from the host's START on: offset 0 in the first session, one constant
   offset per restarted session, increasing); counters expected vs reported.

Run: ``python benchmarks/bench_node_fault_stream.py [--scans N] [--seed S]``.
"""
from __future__ import annotations

import argparse
import bisect
import gc
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'forte_driver' / 'test' / 'serial'))

from forte_ros.isolation import isolate_ros_network  # noqa: E402

isolate_ros_network()

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from lifecycle_msgs.msg import Transition  # noqa: E402
from lifecycle_msgs.srv import ChangeState  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from scripted_device import OneStartSessionGenerator, ScriptedDevice  # noqa: E402

from forte_msgs.msg import TactileFrames  # noqa: E402
from forte_ros.qos import reliable  # noqa: E402

PERIOD_US = 500
TIME_MODULUS = 1 << 64
NODE_NAME = 'serial_sensor_node'


def proc_cpu_seconds(pid: int) -> float:
    """utime + stime of a process [s]."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


@dataclass(frozen=True, slots=True)
class Record:
    """The fields of one received TactileFrames message that are checked."""

    first_sequence: int
    device_time_us: int
    sample_count: int
    data: object            # array.array('d') as deserialised, sample_count x 6
    dropped_frames: int
    corrupt_frames: int


class Recorder:
    """Subscriber of tactile/frames and /diagnostics with arrival times [s, monotonic]."""

    def __init__(self, stall_s: float = 0.0) -> None:
        self.stall_s = stall_s  # one deliberate pause of the subscriber after 1000 messages
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('fault_stream_recorder', context=self.context)
        self.frames: list[tuple[float, Record]] = []
        self.diagnostics: list[tuple[float, dict[str, str]]] = []
        self.samples = 0
        # a recorder, not a contract profile: keep every frame the reliable publisher sends
        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(TactileFrames, 'tactile/frames', self._on_frames, qos)
        # a deeper queue than the contract's 10: a recorder must not lose a diagnostics period
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      reliable(100))
        self.lifecycle = self.node.create_client(ChangeState, f'/{NODE_NAME}/change_state')
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_frames(self, message: TactileFrames) -> None:
        # compact record (no per-message Python object graph): keeps the garbage collector
        # from stalling this subscriber, which the publisher's KEEP_LAST 50 history does
        # not forgive at tens of times real time
        self.frames.append((time.monotonic(), Record(
            message.first_sequence, message.device_time_us, message.sample_count,
            message.data, message.dropped_frames, message.corrupt_frames)))
        self.samples += message.sample_count
        if self.stall_s and len(self.frames) == 1000:
            time.sleep(self.stall_s)  # a recorder that stalls once (disk, GC, CPU)

    def _on_diagnostics(self, message: DiagnosticArray) -> None:
        for status in message.status:
            if status.name.endswith('tactile sensor'):
                self.diagnostics.append((time.monotonic(),
                                         {kv.key: kv.value for kv in status.values}))

    def deactivate(self, timeout: float = 10.0) -> bool:
        """Deactivate the node through its lifecycle service; whether it succeeded."""
        if not self.lifecycle.wait_for_service(timeout_sec=timeout):
            return False
        future = self.lifecycle.call_async(ChangeState.Request(
            transition=Transition(id=Transition.TRANSITION_DEACTIVATE)))
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.02)
        return future.done() and future.result().success

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(timeout=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def wait_for(condition, timeout: float, step: float = 0.05) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(step)
    return condition()


def generate(scans: int, seed: int):
    """The stream bytes, the rows to publish (unwrapped device time, readings) and the
    generator (expectations, session starts)."""
    generator = OneStartSessionGenerator(seed, wrap_after_scans=max(50, scans // 12))
    data, rows = [], []
    for block in generator.blocks(scans):
        data.append(block.data)
        rows += block.rows
    return b''.join(data), rows, generator


def published_rows(frames: list) -> list[tuple[int, int, tuple, bool]]:
    """(sequence, device time [us, mod 2**64], readings [counts], exact) of every row."""
    out = []
    for _, message in frames:
        data = np.asarray(message.data, dtype=np.float64).reshape(message.sample_count, -1)
        counts = data * 1024.0
        exact = np.all(counts == np.rint(counts), axis=1)
        for row, values in enumerate(np.rint(counts).astype(np.int64).tolist()):
            out.append((message.first_sequence + row,
                        (message.device_time_us + row * PERIOD_US) % TIME_MODULUS,
                        tuple(values), bool(exact[row])))
    return out


def compare(rows: list, published: list, generator: OneStartSessionGenerator) -> dict:
    """Published rows against the truth: invented, altered, missing, order, sequence."""
    start_time = generator.start_time_us()
    index_of = {time_us: k for k, (time_us, _) in enumerate(rows)}
    session_times = [time_us for time_us, _ in generator.session_starts]
    offsets: dict[int, int] = {}
    result = dict(published=len(published), invented=0, altered=0, order_errors=0,
                  sequence_errors=0)
    matched, last_index, last_sequence = set(), -1, -1
    for sequence, raw_time, values, exact in published:
        time_us = raw_time if raw_time >= start_time % TIME_MODULUS else raw_time + TIME_MODULUS
        if time_us < start_time:
            time_us += TIME_MODULUS
        index = index_of.get(time_us)
        if index is None:
            result['invented'] += 1
            continue
        if rows[index][1] != values or not exact:
            result['altered'] += 1
        if index <= last_index or sequence <= last_sequence:
            result['order_errors'] += 1
        last_index, last_sequence = max(index, last_index), max(sequence, last_sequence)
        matched.add(index)
        session = bisect.bisect_right(session_times, time_us) - 1
        first_time, first_sequence = generator.session_starts[session]
        device_sequence = first_sequence + (time_us - first_time) // PERIOD_US
        offset = offsets.setdefault(session, sequence - device_sequence)
        if offset != sequence - device_sequence or (session == 0 and offset != 0):
            result['sequence_errors'] += 1
    result['missing'] = len(rows) - len(matched)
    return result


def expected_counters(generator: OneStartSessionGenerator, rows: list) -> dict[str, int]:
    expected = generator.expected
    return {'dropped_frames': expected.dropped,
            'corrupt_frames': expected.decoder_corrupt + expected.implausible,
            'implausible_frames': expected.implausible,
            'duplicate_frames': expected.duplicate,
            'late_frames': expected.late,
            'device_overruns': expected.device_overruns,
            'restarts': expected.restarts,
            'samples': len(rows),
            'samples_published': len(rows),
            'reader_errors': 0,
            'unstamped_samples': 0}


def start_node(link: str, batch_size: int, log) -> subprocess.Popen:
    command = [sys.executable, '-m', 'forte_driver.ros.serial_sensor_node', '--ros-args',
               '-p', f'port:={link}', '-p', 'autostart:=true', '-p', 'reliable:=true',
               '-p', 'diagnostics_period:=0.5', '-p', f'batch_size:={batch_size}']
    return subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, cwd=str(ROOT))


def run(scans: int, seed: int, batch_size: int, speed: float | None,
        stall_s: float = 0.0) -> bool:
    began = time.perf_counter()
    stream, rows, generator = generate(scans, seed)
    counts = generator.expected.counts
    print(f'[bench_node_faults] {scans:,} scans, seed {seed}: {len(stream):,} bytes generated '
          f'in {time.perf_counter() - began:.1f} s; injected: '
          f'{", ".join(f"{k} {v:,}" for k, v in sorted(counts.items()))}')
    gc.collect()
    gc.freeze()  # the truth (millions of tuples) is never scanned by the collector again
    device = ScriptedDevice(stream, chunk_seed=seed + 1,
                            max_bytes_per_s=speed * 70_000 if speed else None)
    recorder = Recorder(stall_s)
    log_path = Path(tempfile.gettempdir()) / f'bench_node_fault_stream_{os.getpid()}.log'
    with open(log_path, 'w') as log:
        node = start_node(device.link, batch_size, log)
        try:
            return measure(device, recorder, node, stream, rows, generator, log_path)
        finally:
            node.send_signal(signal.SIGINT)
            try:
                node.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                node.kill()
                node.wait()
            recorder.close()
            device.close()


def measure(device, recorder, node, stream, rows, generator, log_path) -> bool:
    if not wait_for(lambda: device.stream_started is not None, 60.0):
        print(f'  the node never STARTed the device; log: {log_path}')
        return False
    cpu_start = proc_cpu_seconds(node.pid)
    timeout = 60.0 + len(rows) / 2000.0  # never slower than real time plus a minute
    if not wait_for(lambda: device.stream_finished is not None, timeout, 0.2):
        print('  the node stopped reading the stream (writer blocked)')
    last = [-1, time.monotonic()]

    def settled() -> bool:
        if recorder.samples != last[0]:
            last[0], last[1] = recorder.samples, time.monotonic()
        return time.monotonic() - last[1] > 2.0

    wait_for(settled, 120.0, 0.1)
    cpu_busy = proc_cpu_seconds(node.pid) - cpu_start
    frames_before = list(recorder.frames)
    deactivated_at = time.monotonic()
    deactivated = recorder.deactivate()
    wait_for(lambda: any(t > deactivated_at + 0.1 and d.get('state') == 'inactive'
                         for t, d in recorder.diagnostics), 10.0)
    time.sleep(0.3)
    frames = list(recorder.frames)
    diagnostics = next((d for t, d in reversed(recorder.diagnostics)
                        if d.get('state') == 'inactive'), {})
    return report(device, frames, frames_before, diagnostics, rows, generator, cpu_busy,
                  deactivated, len(stream))


def report(device, frames, frames_before, diagnostics, rows, generator, cpu_busy,
           deactivated, stream_bytes) -> bool:
    """Print the comparison; whether everything matched."""
    result = compare(rows, published_rows(frames), generator)
    first_arrival = frames_before[0][0] if frames_before else device.stream_started
    last_arrival = frames_before[-1][0] if frames_before else device.stream_started
    busy = max(last_arrival - device.stream_started, 1e-9)
    arrivals = [t for t, _ in frames_before]
    pause = max((b - a for a, b in zip(arrivals, arrivals[1:])), default=float('nan'))
    commands = {1: 'START', 2: 'STOP', 3: 'IDENTIFY', 4: 'SET_RATE'}
    sent = ' '.join(commands.get(c, str(c)) for _, c, _, _ in device.commands)
    print(f'  commands received: {sent}; replies held behind the stream: '
          f'{device.late_replies}; deactivate service: {"ok" if deactivated else "FAILED"}')
    print(f'  stream written in {device.stream_finished - device.stream_started:.1f} s; '
          f'first message {first_arrival - device.stream_started:.3f} s after the START '
          f'ACK, last {busy:.1f} s; messages {len(frames):,} '
          f'({len(frames) - len(frames_before)} at deactivate)')
    print(f'  speed {len(rows) * PERIOD_US * 1e-6 / busy:.1f} x real time '
          f'({stream_bytes / busy / 1e6:.2f} MB/s); node CPU {100 * cpu_busy / busy:.0f} % '
          f'of one core; longest pause between messages {1e3 * pause:.1f} ms')
    print(f'  frames sent intact {generator.expected.sent_scans:,}   rows to publish '
          f'{len(rows):,}   published {result["published"]:,}   invented '
          f'{result["invented"]}   altered {result["altered"]}   missing '
          f'{result["missing"]}   out of order {result["order_errors"]}   sequence errors '
          f'{result["sequence_errors"]}')
    node_batches = int(diagnostics.get('batches_published', -1))
    node_samples = int(diagnostics.get('samples_published', -1))
    print(f'  node published {node_batches:,} messages / {node_samples:,} rows; recorder got '
          f'{len(frames):,} / {result["published"]:,}; lost between node and recorder '
          f'{node_batches - len(frames):,} messages / {node_samples - result["published"]:,} rows')
    last_message = frames[-1][1] if frames else None
    if last_message is not None:
        last_row = published_rows(frames[-1:])[-1][1]
        print(f'  last received message holds the last row to publish: '
              f'{last_row == rows[-1][0] % TIME_MODULUS}')
    errors = 0
    for name, expected in expected_counters(generator, rows).items():
        got = diagnostics.get(name, 'absent')
        mark = 'ok' if got == str(expected) else 'MISMATCH'
        errors += mark != 'ok'
        extra = ''
        if last_message is not None and name in ('dropped_frames', 'corrupt_frames'):
            in_message = getattr(last_message, name)
            extra = f'   last TactileFrames {in_message:>10,}'
            if in_message != expected:
                extra += ' MISMATCH'
                errors += 1
        print(f'  {name:18s} expected {expected:>10,}   /diagnostics {got:>10}{extra}   '
              f'{mark}')
    print(f'  also /diagnostics: discarded_bytes {diagnostics.get("discarded_bytes")}, '
          f'sequence_resets {diagnostics.get("sequence_resets")}, clock_resets '
          f'{diagnostics.get("clock_resets")}, last_rejection '
          f'{diagnostics.get("last_rejection")!r}, last_error '
          f'{diagnostics.get("last_error", "")!r}')
    lost_rows = node_samples - result['published']
    exact = deactivated and errors == 0 and device.late_replies == 0 and all(
        result[k] == 0 for k in ('invented', 'altered', 'order_errors', 'sequence_errors'))
    good = exact and result['missing'] == 0
    if good:
        verdict = '0 invented, 0 altered, 0 missing, exact counters'
    elif exact and result['missing'] == lost_rows:
        verdict = (f'node exact (0 invented, 0 altered, exact counters, every row published) '
                   f'but {lost_rows:,} rows lost in DDS before the recorder: FAILED')
    else:
        verdict = 'FAILED'
    print(f'  result: {verdict}')
    return good


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scans', type=int, default=200_000, help='stream length [scans]')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--batch-size', type=int, default=20, help='node batch_size')
    parser.add_argument('--max-speed', type=float, default=10.0,
                        help='pace the device to at most this multiple of real time; 0: as '
                             'fast as the node reads (~28x here, where the depth-50 '
                             'publisher can outrun a subscriber: docs/serial_driver.md)')
    parser.add_argument('--stall', type=float, default=0.0,
                        help='the recorder pauses once for this long [s] after 1000 '
                             'messages (shows what reliable QoS keeps)')
    args = parser.parse_args()
    return 0 if run(args.scans, args.seed, args.batch_size, args.max_speed,
                    args.stall) else 1


if __name__ == '__main__':
    sys.exit(main())
