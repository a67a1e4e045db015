"""call_in_executor runs a call in the thread that spins the executor (ros2/rclpy#1123)."""
from __future__ import annotations

import threading

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor

from forte_ros import call_in_executor


@pytest.fixture
def executor():
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('executor_calls_test', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    yield executor
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def test_the_call_runs_in_the_spinning_thread_and_returns_its_value(executor):
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    seen = []

    def where(offset: int) -> int:
        seen.append(threading.get_ident())
        return offset + 1

    assert call_in_executor(executor, where, 41, timeout=10.0) == 42
    assert seen == [spinner.ident] and spinner.ident != threading.get_ident()


def test_an_executor_that_does_not_spin_times_out(executor):
    with pytest.raises(TimeoutError, match='did not run'):
        call_in_executor(executor, lambda: None, timeout=0.2)
