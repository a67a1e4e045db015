"""Bag replay source: republish tactile frames (and other topics) from an MCAP bag.

Stands in for the serial sensor driver or the simulator: perception and control run on
a recording exactly as they would online. Messages are republished unchanged, so header
stamps (sample times) are the recorded ones. Pacing follows the bag's log times scaled
by ``rate`` (1.0 = original timing, 2.0 = twice as fast), or ``rate: 0.0`` replays as
fast as possible for offline evaluation (use ``reliable: true`` and reliable subscribers
then, or best-effort subscribers may miss messages).

A truncated or corrupt bag is reported with a clear error per loss (file, byte range,
chunk or bytes, reason, messages lost) on the log, and as counts on ``/diagnostics``
(``chunks_skipped``, ``bytes_skipped``, ``messages_lost``, ``losses_of_unknown_count``);
every intact message is still replayed. The reading itself is
:mod:`forte_driver.replay.mcap_source` (no rclpy).

Parameters: ``bag_path``, ``topics``, ``rate``, ``reliable``, ``start_delay``,
``wait_for_subscribers``, ``exit_when_done`` (see their descriptors).
"""
from __future__ import annotations

import importlib
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import (
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message

from forte_driver.replay.mcap_source import BagError, BagMessage, BagReadReport, bag_files, read_bag
from forte_ros import publish_quietly, run_node
from forte_ros.diagnostics import ERROR, OK, diagnostic_array, diagnostic_status, node_path
from forte_ros.parameter_table import ParameterSpec, parameter_table
from forte_ros.parameters import declare_table, parameter_update
from forte_ros.qos import DIAGNOSTICS, GRASP_STATE, SENSOR_FRAMES, SENSOR_INFO, reliable

#: History depth of the reliable replay publishers [messages] (about 100 s of frames).
RELIABLE_DEPTH = 10000


def message_class(msgtype: str) -> type:
    """The generated Python class of a ROS type name such as ``forte_msgs/msg/TactileFrames``.

    Raises
    ------
    BagError
        If the name is malformed or its package is not installed.
    """
    parts = msgtype.split('/')
    if len(parts) != 3 or parts[1] != 'msg':
        raise BagError(f'unsupported message type name {msgtype!r} (expected pkg/msg/Name)')
    try:
        return getattr(importlib.import_module(f'{parts[0]}.msg'), parts[2])
    except (ImportError, AttributeError) as error:
        raise BagError(f'message type {msgtype} is not installed: {error}') from error


def relative_name(topic: str) -> str:
    """The bag topic as a relative name, so that namespaces and remapping apply."""
    return topic.lstrip('/')


#: Every parameter of the node, in the order of declaration (all node-only: their defaults
#: are here).
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('bag_path', str, 'rosbag2 MCAP folder or single .mcap file to replay',
                  default='', read_only=True),
    ParameterSpec('topics', list, 'bag topics to republish (relative names; published '
                  'relative so they can be remapped). Empty = every topic of the bag',
                  default=('tactile/frames',), read_only=True),
    ParameterSpec('rate', float, 'playback speed factor: 1.0 = recorded timing, 2.0 = twice '
                  'as fast, 0.0 = as fast as possible', low=0.0, high=1000.0, default=1.0),
    ParameterSpec('reliable', bool, 'publish tactile/frames reliable instead of sensor-data '
                  'best effort (use with rate 0 so nothing is dropped)', default=False,
                  read_only=True),
    ParameterSpec('start_delay', float, 'seconds to wait after start-up before the first '
                  'message', 's', 0.0, 60.0, default=0.5, read_only=True),
    ParameterSpec('wait_for_subscribers', int, 'before the first message of each topic, wait '
                  '(up to 30 s) until that many subscribers matched (0 = do not wait)', low=0,
                  high=100, default=0, read_only=True),
    ParameterSpec('exit_when_done', bool, 'shut the node down after the last message',
                  default=False, read_only=True),
])


class ReplayClock:
    """When each bag message is due, from its log time, the start time and the rate.

    Parameters
    ----------
    rate : float
        Playback speed factor; 1.0 = recorded timing, 0.0 = as fast as possible.

    Notes
    -----
    Pure (no ROS clock); times are ``time.monotonic()`` seconds. A log time earlier than
    the previous one (bag not sorted by time) is due immediately.
    """

    def __init__(self, rate: float) -> None:
        if rate < 0.0 or rate != rate:
            raise ValueError(f'rate must be >= 0 (0 = as fast as possible), got {rate}')
        self.rate = rate
        self._first_log_time: int | None = None
        self._start: float | None = None

    def due(self, log_time: int, now: float) -> float:
        """Monotonic time [s] at which the message with ``log_time`` [ns] is due."""
        if self._first_log_time is None:
            self._first_log_time = log_time
            self._start = now
        if self.rate == 0.0:
            return now
        return self._start + (log_time - self._first_log_time) * 1e-9 / self.rate


class BagReplayNode(Node):
    """Republish the messages of a bag on their (relative) topics, paced by a thread."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('bag_replay', **kwargs)
        declare_table(self, PARAMETERS)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self.bag_path = self.get_parameter('bag_path').value
        self.topics = list(self.get_parameter('topics').value)
        self.rate = float(self.get_parameter('rate').value)
        self.reliable = bool(self.get_parameter('reliable').value)
        self.exit_when_done = bool(self.get_parameter('exit_when_done').value)
        if not self.bag_path:
            raise BagError('parameter bag_path is empty: give the bag to replay')
        files = bag_files(self.bag_path)  # raises BagError with a clear message
        self.get_logger().info(
            f'replaying {self.bag_path} ({len(files)} file(s)), topics '
            f'{self.topics or "all"}, rate {self.rate if self.rate else "as fast as possible"}'
        )

        self.report = BagReadReport()
        self.published: dict[str, int] = {}
        self.undecodable = 0
        #: publishes dropped because the process was stopping (``late_publishes``)
        self.late = {'late_publishes': 0}
        self.done = threading.Event()
        self._stop = threading.Event()
        self._replay_publishers: dict[str, Any] = {}
        self._classes: dict[str, type] = {}
        self._reported_errors = 0
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', DIAGNOSTICS)
        self._diagnostics_timer = self.create_timer(1.0, self._publish_diagnostics)
        self._thread = threading.Thread(target=self._replay, name='bag_replay', daemon=True)
        self._thread.start()

    # parameters ------------------------------------------------------------------------
    def _on_set_parameters(self, parameters: list) -> SetParametersResult:
        _, reason = parameter_update(parameters, PARAMETERS)  # kinds, finite values, ranges
        return SetParametersResult(successful=not reason, reason=reason)

    # publishing ------------------------------------------------------------------------
    def _qos(self, topic: str) -> QoSProfile:
        name = relative_name(topic)
        if name == 'grasp/state':
            return GRASP_STATE
        if name == 'tactile/sensor_info':
            return SENSOR_INFO  # latched: perception checks its model against the recording's
        if name == 'tactile/frames' and not self.reliable:
            return SENSOR_FRAMES  # sensor data, depth as in docs/contracts.md
        # Reliable with a deep history: at rate 0 the writer runs far ahead of the readers'
        # acknowledgements, and a shallow keep-last history would overwrite unacknowledged
        # samples (silent loss).
        return reliable(RELIABLE_DEPTH)

    def _publisher(self, message: BagMessage) -> Any:
        publisher = self._replay_publishers.get(message.topic)
        if publisher is None:
            cls = message_class(message.msgtype)
            self._classes[message.topic] = cls
            publisher = self.create_publisher(
                cls, relative_name(message.topic), self._qos(message.topic)
            )
            self._replay_publishers[message.topic] = publisher
            needed = int(self.get_parameter('wait_for_subscribers').value)
            deadline = time.monotonic() + 30.0
            while (needed > 0 and publisher.get_subscription_count() < needed
                   and time.monotonic() < deadline and not self._stop.is_set()):
                self._stop.wait(0.02)  # a reliable writer only delivers to matched readers
        return publisher

    def _log_new_errors(self) -> None:
        while self._reported_errors < len(self.report.errors):
            error = self.report.errors[self._reported_errors]
            self.get_logger().error(f'bag damaged, replaying what is intact: {error}')
            self._reported_errors += 1

    def _replay(self) -> None:
        try:
            self._stop.wait(float(self.get_parameter('start_delay').value))
            clock = ReplayClock(self.rate)
            for message in read_bag(self.bag_path, self.topics or None, self.report):
                if self._stop.is_set():
                    return
                self._log_new_errors()
                try:
                    publisher = self._publisher(message)
                    msg = deserialize_message(message.data, self._classes[message.topic])
                except BagError as error:
                    self.get_logger().error(f'{message.topic}: {error}; topic skipped')
                    self.undecodable += 1
                    continue
                except Exception as error:  # corrupt CDR payload inside an intact record
                    if self._stopping():
                        return
                    self.undecodable += 1
                    self.get_logger().error(
                        f'{message.topic}: message at log time {message.log_time} ns does '
                        f'not decode as {message.msgtype} ({error}); skipped'
                    )
                    continue
                clock.rate = float(self.get_parameter('rate').value)
                delay = clock.due(message.log_time, time.monotonic()) - time.monotonic()
                if delay > 0.0 and self._stop.wait(delay):
                    return
                if not publish_quietly(publisher, msg, self.context, self.late):
                    return  # the process is stopping
                self.published[message.topic] = self.published.get(message.topic, 0) + 1
            self._log_new_errors()
            total = sum(self.published.values())
            summary = ', '.join(f'{t}: {n}' for t, n in sorted(self.published.items()))
            logger = self.get_logger()
            log = logger.info if self.report.complete else logger.warning
            report = self.report
            damage = 'complete'
            if not report.complete:
                damage = (
                    f'DAMAGED (see errors above): {report.chunks_skipped} chunk(s) and '
                    f'{report.bytes_skipped} bytes skipped, {report.messages_lost} messages '
                    f'lost, {report.unknown_losses} skipped range(s) of unknown message count'
                )
            log(
                f'replay finished: {total} messages published ({summary or "none"}), '
                f'{self.undecodable} undecodable, bag {damage}'
            )
        except BagError as error:
            self.get_logger().error(f'cannot replay {self.bag_path}: {error}')
            self.report.errors.append(str(error))
        except RuntimeError:  # RCLError / InvalidHandle: the node or context ended under us
            if not self._stopping():
                raise
            self.late['late_publishes'] += 1
        finally:
            self.done.set()
            self._publish_diagnostics()

    def _stopping(self) -> bool:
        return self._stop.is_set() or not self.context.ok()

    def _publish_diagnostics(self) -> None:
        report = self.report
        if report.errors:
            level, message = ERROR, 'bag damaged; ' + report.errors[-1][:200]
        else:
            level, message = OK, 'done' if self.done.is_set() else 'replaying'
        values = {
            'published': sum(self.published.values()),
            'undecodable': self.undecodable,
            'damage_reports': len(report.errors),
            'chunks_skipped': report.chunks_skipped,
            'bytes_skipped': report.bytes_skipped,
            'messages_lost': report.messages_lost,
            'losses_of_unknown_count': report.unknown_losses,
            'done': self.done.is_set(),
        }
        status = diagnostic_status(f'{node_path(self)}: bag replay', level, message, values,
                                   hardware_id=str(self.bag_path))
        array = diagnostic_array(self.get_clock().now().to_msg(), [status])
        publish_quietly(self._diagnostics, array, self.context, self.late)

    def stop(self) -> None:
        """Stop the replay thread (idempotent) and wait for it."""
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)

    def prepare_shutdown(self) -> None:
        """Stop and join the replay thread while the context is valid (node runner)."""
        self.stop()

    def destroy_node(self) -> None:
        self.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point ``bag_replay_node``: replay until done (``exit_when_done``) or a signal.

    Returns
    -------
    int
        0, or 2 if the bag cannot be opened (one fatal log line, no traceback).
    """
    return run_node(
        BagReplayNode, args, fatal_errors=(BagError,), name='bag_replay',
        until=lambda node: node.exit_when_done and node.done.is_set())


if __name__ == '__main__':
    raise SystemExit(main())
