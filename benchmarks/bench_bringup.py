"""Benchmark of the bag tooling: recording and replay-reading cost of 2 kHz tactile frames.

Prints, for one minute of tactile frames (6000 TactileFrames of 20 samples, 100 msg/s):

- write: BagWriter (rosbags MCAP rosbag2) vs a baseline that appends the same CDR bytes to
  a plain file (the cheapest possible recorder), messages/s and x realtime;
- read: forte_driver.replay.mcap_source.read_bag (damage-tolerant, record-by-record) vs the mcap
  library's own indexed reader (make_reader().iter_messages), messages/s and the ratio;
- decode: rclpy deserialize_message per message (what bag_replay_node does) in x realtime.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message, serialize_message

from forte_driver.replay.bags import BagWriter, TopicSpec, read_bag
from forte_msgs.msg import TactileFrames
from forte_ros.contract import CHANNEL_NAMES

MESSAGES = 6000  # 60 s at 100 messages/s
RECORDED_SECONDS = MESSAGES / 100.0


def payloads() -> list[bytes]:
    rng = np.random.default_rng(0)
    out = []
    for index in range(MESSAGES):
        message = TactileFrames(sample_count=20, sample_period=0.0005,
                                first_sequence=20 * index)
        message.channel_names = list(CHANNEL_NAMES)
        message.data = rng.normal(0.0, 0.01, 120).tolist()
        out.append(serialize_message(message))
    return out


def best_of(runs: int, function) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    data = payloads()
    folder = Path(tempfile.mkdtemp(prefix='bench_bringup_'))
    counter = iter(range(1000))

    def write_bag() -> None:
        with BagWriter(folder / f'bag{next(counter)}') as bag:
            bag.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
            for index, payload in enumerate(data):
                bag.write('tactile/frames', index * 10_000_000, payload)

    def write_plain() -> None:
        with (folder / f'plain{next(counter)}.bin').open('wb') as stream:
            for index, payload in enumerate(data):
                stream.write(index.to_bytes(8, 'little'))
                stream.write(len(payload).to_bytes(4, 'little'))
                stream.write(payload)

    bag_write = best_of(3, write_bag)
    plain_write = best_of(3, write_plain)
    bag = sorted(folder.glob('bag*'))[0]
    mcap_file = next(bag.glob('*.mcap'))

    def read_ours() -> None:
        count = sum(1 for _ in read_bag(bag))
        assert count == MESSAGES

    def read_mcap() -> None:
        with mcap_file.open('rb') as stream:
            count = sum(1 for _ in make_reader(stream).iter_messages())
        assert count == MESSAGES

    ours_read = best_of(3, read_ours)
    mcap_read = best_of(3, read_mcap)
    decode = best_of(3, lambda: [deserialize_message(p, TactileFrames) for p in data])

    print(f'bag tooling, {MESSAGES} TactileFrames (= {RECORDED_SECONDS:.0f} s at 2 kHz, '
          f'{mcap_file.stat().st_size / 1e6:.1f} MB MCAP)')
    print(f'  write  BagWriter (rosbags MCAP)   {MESSAGES / bag_write:10.0f} msg/s  '
          f'{RECORDED_SECONDS / bag_write:7.0f} x realtime')
    print(f'  write  baseline plain append      {MESSAGES / plain_write:10.0f} msg/s  '
          f'{RECORDED_SECONDS / plain_write:7.0f} x realtime   '
          f'ratio BagWriter/baseline time {bag_write / plain_write:.2f}')
    print(f'  read   mcap_source.read_bag       {MESSAGES / ours_read:10.0f} msg/s  '
          f'{RECORDED_SECONDS / ours_read:7.0f} x realtime')
    print(f'  read   baseline mcap make_reader  {MESSAGES / mcap_read:10.0f} msg/s  '
          f'{RECORDED_SECONDS / mcap_read:7.0f} x realtime   '
          f'ratio ours/baseline time {ours_read / mcap_read:.2f}')
    print(f'  decode rclpy deserialize_message  {MESSAGES / decode:10.0f} msg/s  '
          f'{RECORDED_SECONDS / decode:7.0f} x realtime')


if __name__ == '__main__':
    main()
