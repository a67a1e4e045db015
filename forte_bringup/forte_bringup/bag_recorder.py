"""``forte_record``: record the FORTE graph's topics to a ROS 2 MCAP bag.

A recorder node subscribes to each wanted topic as soon as a publisher appears, with the
type and a QoS compatible with what the publishers offer (best effort if any publisher
is best effort, transient local if every publisher is), receives the messages serialized
(no decode) and streams them to a rosbag2 MCAP bag (:class:`forte_driver.replay.bags.BagWriter`)
stamped with the receive time of the node's clock (sim time when ``use_sim_time``).
Data are on disk in 1 MiB chunks as they arrive; ``metadata.yaml`` is written when the
recorder stops (Ctrl-C, SIGTERM, ``--duration``). A recorder killed hard leaves an MCAP
file without summary that the replay tools still read up to the last complete chunk.

Usage::

    forte_record -o out/bags/run1                # the contract's topics
    forte_record -o out/bags/run1 --topics tactile/frames tactile/state
    forte_record -o out/bags/run1 --all --duration 30

The recorder joins the ROS domain of its environment (``ROS_DOMAIN_ID``); discovery is
kept on this machine unless ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is set otherwise.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from forte_driver.replay.bags import DEFAULT_TOPICS, BagWriter, TopicSpec

#: Topics that exist in every ROS 2 graph and are never worth recording with ``--all``.
IGNORED_TOPICS = frozenset({'/parameter_events', '/rosout'})


def _message_class(msgtype: str) -> type:
    package, _, name = msgtype.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)


class BagRecorder:
    """Records topics of the graph to a bag; wraps an rclpy node.

    Parameters
    ----------
    output : str or Path
        Bag folder to create.
    topics : sequence of str, optional
        Topic names (relative names are resolved in the root namespace); by default the
        contract's topics (:data:`forte_driver.replay.bags.DEFAULT_TOPICS`).
    record_all : bool
        Record every topic that appears (except ``/rosout`` and ``/parameter_events``).
    node_name : str
        Name of the recorder node.
    """

    def __init__(
        self,
        output: str | Path,
        topics: list[str] | None = None,
        record_all: bool = False,
        node_name: str = 'forte_recorder',
    ) -> None:
        from rclpy.node import Node

        self.node = Node(node_name)
        self.writer = BagWriter(output)
        self.record_all = record_all
        names = topics if topics else [spec.name for spec in DEFAULT_TOPICS]
        self.wanted = {name if name.startswith('/') else '/' + name for name in names}
        self.subscriptions: dict[str, Any] = {}
        self.received: dict[str, int] = {}
        self._timer = self.node.create_timer(0.2, self.discover)
        self.discover()

    def _qos_for(self, topic: str):
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        infos = self.node.get_publishers_info_by_topic(topic)
        reliable = all(
            info.qos_profile.reliability == ReliabilityPolicy.RELIABLE for info in infos
        )
        transient = all(
            info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for info in infos
        )
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1000,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=(
                DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE
            ),
        ), reliable, transient

    def discover(self) -> None:
        """Subscribe to wanted topics that have publishers now (called periodically)."""
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.subscriptions or topic in IGNORED_TOPICS:
                continue
            if not (self.record_all or topic in self.wanted):
                continue
            if not self.node.get_publishers_info_by_topic(topic):
                continue
            msgtype = types[0]
            try:
                cls = _message_class(msgtype)
            except (ImportError, AttributeError, ValueError):
                self.node.get_logger().warning(f'{topic}: type {msgtype} not installed; skipped')
                self.subscriptions[topic] = None
                continue
            qos, reliable, transient = self._qos_for(topic)
            self.writer.add_topic(TopicSpec(topic, msgtype, reliable=reliable,
                                            transient_local=transient, depth=qos.depth))
            self.received[topic] = 0
            self.subscriptions[topic] = self.node.create_subscription(
                cls, topic, self._callback(topic), qos, raw=True
            )
            self.node.get_logger().info(
                f'recording {topic} [{msgtype}] '
                f'({"reliable" if reliable else "best effort"}'
                f'{", transient local" if transient else ""})'
            )

    def _callback(self, topic: str):
        def on_message(data: bytes) -> None:
            self.writer.write(topic, self.node.get_clock().now().nanoseconds, data)
            self.received[topic] += 1

        return on_message

    def close(self) -> None:
        """Stop subscribing and finish the bag (idempotent)."""
        for subscription in self.subscriptions.values():
            if subscription is not None:
                self.node.destroy_subscription(subscription)
        self.subscriptions = {topic: None for topic in self.subscriptions}
        self.writer.close()

    def summary(self) -> str:
        """One line per recorded topic with its message count."""
        lines = [f'{self.writer.path}:']
        lines += [f'  {topic}: {count}' for topic, count in sorted(self.received.items())]
        return '\n'.join(lines)


def default_output() -> Path:
    """``out/bags/forte_<UTC time>`` under the current folder."""
    return Path('out') / 'bags' / datetime.utcnow().strftime('forte_%Y%m%d_%H%M%S')


def main(argv: list[str] | None = None) -> int:
    """Entry point ``forte_record``."""
    parser = argparse.ArgumentParser(prog='forte_record', description=__doc__.split('\n')[0])
    parser.add_argument('-o', '--output', type=Path, default=None,
                        help='bag folder to create (default out/bags/forte_<time>)')
    parser.add_argument('--topics', nargs='+', default=None,
                        help='topics to record (default: the contract topics)')
    parser.add_argument('--all', action='store_true', help='record every topic')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='stop after this many seconds (default: until Ctrl-C)')
    command_line = [sys.argv[0], *(sys.argv[1:] if argv is None else argv)]
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

    from rclpy.utilities import remove_ros_args

    from forte_ros import NodeRunner  # imports rclpy: after the environment is settled

    # ROS arguments (``--ros-args ... [--]``, as ros2 run / launch_ros add them, e.g.
    # ``-r __node:=forte_recorder``) go to rclpy; the rest must be ours (a typo fails)
    args = parser.parse_args(remove_ros_args(command_line)[1:])
    started = time.monotonic()

    def duration_over() -> bool:
        return bool(args.duration) and time.monotonic() - started >= args.duration

    # SIGINT / SIGTERM end the spin; the bag is finished while the context is still valid
    with NodeRunner(command_line) as runner:
        recorder = BagRecorder(args.output or default_output(), args.topics, args.all)
        runner.add_node(recorder.node)
        print(f'[forte_record] recording to {recorder.writer.path} '
              f'(ROS_DOMAIN_ID={os.environ.get("ROS_DOMAIN_ID", "0")})', flush=True)
        try:
            runner.spin(until=duration_over)
        finally:
            recorder.close()
            print('[forte_record] bag closed\n' + recorder.summary(), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
