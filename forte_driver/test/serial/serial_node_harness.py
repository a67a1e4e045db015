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
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from forte_driver.bench_devices.emulated_sensor import EmulatedSensor
from forte_driver.serial.serial_sensor_node import SerialSensorNode
from forte_msgs.msg import TactileFrames


class Harness:
    """Driver node + recording subscriber spun by one executor in a thread."""

    def __init__(self, port: str, **parameters) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        overrides = [Parameter('port', value=port)]
        overrides += [Parameter(name, value=value) for name, value in parameters.items()]
        self.node = SerialSensorNode(context=self.context, parameter_overrides=overrides)
        self.listener = Node('frames_listener', context=self.context)
        self.frames: list[TactileFrames] = []
        self.diagnostics: list[DiagnosticArray] = []
        reliable = parameters.get('reliable', False)
        qos = (QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE) if reliable
               else qos_profile_sensor_data)
        self.listener.create_subscription(TactileFrames, 'tactile/frames', self.frames.append, qos)
        self.listener.create_subscription(DiagnosticArray, '/diagnostics',
                                          self.diagnostics.append, 10)
        # single-threaded: rclpy's MultiThreadedExecutor re-dispatches ready entities in a loop
        # (ros2/rclpy#1223) and starved the driver's reader thread of the GIL
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.listener)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def wait(self, condition, timeout: float = 20.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            time.sleep(0.02)
        return condition()

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
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(timeout=2.0)
        if self.node.lifecycle_state in ('inactive', 'active'):
            self.node._shutdown_io()
        self.node.destroy_node()
        self.listener.destroy_node()
        rclpy.try_shutdown(context=self.context)


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
