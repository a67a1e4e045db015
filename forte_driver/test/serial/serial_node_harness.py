"""Test helper: the serial sensor lifecycle node with a recording subscriber, spun by one
executor in a thread (real rclpy, real DDS), and the check of published rows against what
the emulated device delivered."""
from __future__ import annotations

import threading
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from forte_driver.bench_devices.emulated_sensor import EmulatedSensor
from forte_driver.serial.serial_sensor_node import SerialSensorNode
from forte_msgs.msg import TactileFrames
from forte_ros.qos import SENSOR_FRAMES, reliable
from forte_ros.testing import check_isolated_network, wait_until

try:
    from forte_ros.testing import ExecutorThread
except ImportError:  # until forte_ros.testing has it (issue 16): the same code, once here
    class ExecutorThread:
        """Nodes of a private rclpy context spun by one executor in a daemon thread.

        The set-up every in-process node test repeats: ``rclpy.init`` of a fresh context,
        the nodes built in :attr:`context`, one executor, one thread, and the tear-down in
        reverse. Single-threaded on purpose: rclpy's MultiThreadedExecutor re-dispatches
        ready entities in a loop (ros2/rclpy#1223) and starves the nodes' own threads (a
        driver's reader) of the GIL.

        Use: ``ros = ExecutorThread()``; build the nodes with ``context=ros.context``;
        ``ros.spin(node, peer)``; at the end ``ros.close()`` (or :meth:`stop`, a clean-up
        of the nodes' own, then :meth:`close`).
        """

        def __init__(self) -> None:
            check_isolated_network()
            self.context = rclpy.Context()
            rclpy.init(context=self.context)
            self.nodes: list[Node] = []
            self.executor = SingleThreadedExecutor(context=self.context)
            self._thread: threading.Thread | None = None

        def spin(self, *nodes: Node) -> None:
            """Add ``nodes`` to the executor and spin it in a daemon thread."""
            for node in nodes:
                self.executor.add_node(node)
                self.nodes.append(node)
            self._thread = threading.Thread(target=self.executor.spin, daemon=True)
            self._thread.start()

        def stop(self, timeout: float = 2.0) -> None:
            """Shut the executor down and join its thread (the nodes still exist)."""
            self.executor.shutdown(timeout_sec=timeout)
            if self._thread is not None:
                self._thread.join(timeout=timeout)

        def close(self, timeout: float = 2.0) -> None:
            """:meth:`stop`, destroy the nodes, shut the context down."""
            self.stop(timeout)
            for node in self.nodes:
                node.destroy_node()
            rclpy.try_shutdown(context=self.context)


class Harness:
    """Driver node + recording subscriber spun by one executor in a thread; a context
    manager (closes on exit)."""

    def __init__(self, port: str, **parameters) -> None:
        self.ros = ExecutorThread()
        overrides = [Parameter('port', value=port)]
        overrides += [Parameter(name, value=value) for name, value in parameters.items()]
        self.node = SerialSensorNode(context=self.ros.context, parameter_overrides=overrides)
        self.listener = Node('frames_listener', context=self.ros.context)
        self.frames: list[TactileFrames] = []
        self.diagnostics: list[DiagnosticArray] = []
        # reliable: a deeper queue than the contract's 50, a recorder must lose nothing
        qos = reliable(1000) if parameters.get('reliable', False) else SENSOR_FRAMES
        self.listener.create_subscription(TactileFrames, 'tactile/frames', self.frames.append, qos)
        self.listener.create_subscription(DiagnosticArray, '/diagnostics',
                                          self.diagnostics.append, 10)
        self.ros.spin(self.node, self.listener)

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def activate(self) -> SerialSensorNode:
        """Configure and activate the node (both transitions must succeed); returns it."""
        node = self.node
        node.trigger_configure()
        assert node.lifecycle_state == 'inactive'
        node.trigger_activate()
        assert node.lifecycle_state == 'active'
        return node

    def wait_published(self, samples: int, timeout: float = 20.0) -> bool:
        """Wait until the node has published more than ``samples`` samples."""
        return self.wait(lambda: self.node.counters['published_samples'] > samples, timeout)

    def wait(self, condition, timeout: float = 20.0) -> bool:
        """Poll ``condition`` until true or ``timeout`` [s] passes; whether it became true."""
        return bool(wait_until(condition, timeout, period=0.02))

    @staticmethod
    def system_minus_monotonic_ns() -> int:
        """ROS (system) time minus the monotonic clock of the emulator's instants [ns]."""
        return time.time_ns() - time.monotonic_ns()

    def rows(self) -> list[tuple[int, int, tuple]]:
        """(sequence, device time [us], values) of every published row."""
        out = []
        for message in self.frames:
            data = np.asarray(message.data).reshape(message.sample_count, 6)
            for i, row in enumerate(data):
                out.append((message.first_sequence + i,
                            message.device_time_us + i * 500, tuple(row)))
        return out

    def close(self) -> None:
        """Stop spinning, stop the driver's reader and port, destroy the nodes."""
        self.ros.stop()
        if self.node.lifecycle_state in ('inactive', 'active'):
            self.node._shutdown_io()
        self.ros.close()


def check_batches_are_gap_free_and_true(harness: Harness, sensor: EmulatedSensor) -> int:
    """Every published row is a scan the device delivered intact, with its exact values,
    and no batch spans a gap. Returns the number of rows."""
    truth = {time_us: values for _, _, time_us, values in sensor.delivered}
    rows = harness.rows()
    for _, time_us, values in rows:
        assert truth[time_us] == values  # KeyError = invented sample
    for message in harness.frames:
        first = message.device_time_us
        for i in range(message.sample_count):
            assert first + 500 * i in truth  # consecutive device scans only
    assert len({time_us for _, time_us, _ in rows}) == len(rows)  # nothing duplicated
    return len(rows)


def diagnostic_records(harness: Harness) -> list[tuple[bytes, str, dict[str, str]]]:
    """(level, message, {key: value}) of every sensor diagnostics status received so far."""
    return [(status.level, status.message, {kv.key: kv.value for kv in status.values})
            for array in list(harness.diagnostics) for status in array.status
            if status.name.endswith('tactile sensor')]
