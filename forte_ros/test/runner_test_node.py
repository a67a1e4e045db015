"""A tiny node process for test_node_runner.py, run through forte_ros.run_node.

``python runner_test_node.py [--plain] [--multi] [--race] [--until N] [--fatal] [--ros-args]``

- default: a ForteLifecycleNode ``runner_test`` (configured and activated at start unless
  ``--manual``) whose thread publishes ``runner_test/count`` (std_msgs/Int64) every 2 ms
  through a lifecycle publisher, and whose timer publishes ``runner_test/tick`` (executor
  thread); ``on_shutdown`` stops and joins the thread and prints ``ON_SHUTDOWN from <state>``;
- ``--plain``: a plain Node with the same thread, stopped in ``prepare_shutdown``;
- ``--multi``: a 3-thread MultiThreadedExecutor and a 0.3 s slow timer callback;
- ``--race``: the thread is never stopped by the node: it keeps publishing (through
  publish_quietly) while the context ends; it prints ``LATE n`` from an atexit hook;
- ``--until N``: stop by itself after N ticks (exit code 0);
- ``--fatal``: the node constructor raises ValueError, reported as a fatal error (exit 2).
"""
from __future__ import annotations

import argparse
import atexit
import sys
import threading
import time

from rclpy.executors import MultiThreadedExecutor
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from std_msgs.msg import Int64

from forte_ros import ForteLifecycleNode, publish_quietly, run_node


class Publishing:
    """The thread and the timer shared by both node kinds."""

    def start_publishing(self, node: Node, race: bool, slow: bool) -> None:
        self.late = {'late_publishes': 0}
        self._stop = threading.Event()
        self._race = race
        self._tick = node.create_publisher(Int64, 'runner_test/tick', 10)
        self._ticks = 0
        node.create_timer(0.05, self._on_tick)
        if slow:
            node.create_timer(0.1, lambda: time.sleep(0.3))
        self._thread = threading.Thread(target=self._publish_loop, daemon=race)
        self._thread.start()
        atexit.register(lambda: print(f'LATE {self.late["late_publishes"]}', flush=True))

    def _on_tick(self) -> None:
        self._ticks += 1
        self._tick.publish(Int64(data=self._ticks))

    def _publish_loop(self) -> None:
        count = 0
        while not self._stop.is_set():
            count += 1
            publish_quietly(self._count, Int64(data=count), self.context, self.late)
            time.sleep(0.002)

    def stop_publishing(self) -> None:
        if self._race:
            return  # the test of a thread that outlives the context
        self._stop.set()
        self._thread.join(timeout=2.0)
        print(f'THREAD JOINED alive={self._thread.is_alive()}', flush=True)


class LifecycleTestNode(Publishing, ForteLifecycleNode):
    """Lifecycle variant: the count publisher is a lifecycle publisher."""

    def __init__(self, options: argparse.Namespace) -> None:
        ForteLifecycleNode.__init__(self, 'runner_test')
        self._count = self.create_lifecycle_publisher(Int64, 'runner_test/count', 10)
        self.start_publishing(self, options.race, options.multi)
        if not options.manual:
            self.trigger_configure()
            self.trigger_activate()

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.stop_publishing()
        print(f'ON_SHUTDOWN from {state.label}', flush=True)
        return TransitionCallbackReturn.SUCCESS


class PlainTestNode(Publishing, Node):
    """Plain variant: threads stopped in prepare_shutdown."""

    def __init__(self, options: argparse.Namespace) -> None:
        Node.__init__(self, 'runner_test')
        self._count = self.create_publisher(Int64, 'runner_test/count', 10)
        self.start_publishing(self, options.race, options.multi)

    def prepare_shutdown(self) -> None:
        self.stop_publishing()
        print('PREPARE_SHUTDOWN', flush=True)


def main() -> int:
    """Parse the test options (before ``--ros-args``) and run the node."""
    parser = argparse.ArgumentParser()
    for flag in ('--plain', '--multi', '--race', '--fatal', '--manual'):
        parser.add_argument(flag, action='store_true')
    parser.add_argument('--until', type=int, default=0)
    options, ros_arguments = parser.parse_known_args()

    def make() -> Node:
        if options.fatal:
            raise ValueError('no such device: /dev/forte_nothing')
        return (PlainTestNode if options.plain else LifecycleTestNode)(options)

    factory = None
    if options.multi:
        def factory(context):
            return MultiThreadedExecutor(num_threads=3, context=context)
    until = None
    if options.until:
        def until(node):
            return node._ticks >= options.until
    print('STARTING', flush=True)
    return run_node(make, [sys.argv[0], *ros_arguments], executor_factory=factory,
                    until=until, fatal_errors=(ValueError,), name='runner_test')


if __name__ == '__main__':
    sys.exit(main())
