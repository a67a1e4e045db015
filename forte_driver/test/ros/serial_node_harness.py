"""Test helper: the serial sensor lifecycle node with a recording subscriber, spun by one
executor in a thread (real rclpy, real DDS), and the check of published rows against what
the emulated device delivered."""
from __future__ import annotations

import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.parameter import Parameter

from forte_driver.emulators.emulated_sensor import EmulatedSensor
from forte_driver.ros.serial_sensor_node import SerialSensorNode
from forte_msgs.msg import TactileFrames
from forte_ros.qos import DIAGNOSTICS, SENSOR_FRAMES, reliable
from forte_ros.testing import SpinningGraph, wait_until


class Harness:
    """Driver node + recording subscriber spun by one executor in a thread; a context
    manager (closes on exit)."""

    def __init__(self, port: str, **parameters) -> None:
        self.ros = SpinningGraph('frames_listener')
        overrides = [Parameter('port', value=port)]
        overrides += [Parameter(name, value=value) for name, value in parameters.items()]
        self.node = self.ros.add(
            SerialSensorNode(context=self.ros.context, parameter_overrides=overrides))
        # reliable: a deeper queue than the contract's 50, a recorder must lose nothing
        qos = reliable(1000) if parameters.get('reliable', False) else SENSOR_FRAMES
        self.frames: list[TactileFrames] = self.ros.collect(TactileFrames, 'tactile/frames', qos)
        self.diagnostics: list[DiagnosticArray] = self.ros.collect(
            DiagnosticArray, '/diagnostics', DIAGNOSTICS)
        self.ros.start()

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
