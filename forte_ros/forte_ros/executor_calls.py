"""Calls that must run in the thread that spins an executor.

rclpy's action client records a request (goal, result, cancel) after handing it to rcl; a
client spun by an executor in another thread can take the response before the record exists
and drop it ("Ignoring unexpected goal response"), so the future never completes
(ros2/rclpy#1123; fixed after the rclpy 7.1.6 wheel used here). A program that spins its node
in a background thread and sends goals from its main thread (the demo, the benchmarks, the
tests' probes) must therefore make those calls in the executor's thread:
:func:`call_in_executor`.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ['call_in_executor']

T = TypeVar('T')


def call_in_executor(executor: Any, function: Callable[..., T], *args: Any,
                     timeout: float = 30.0) -> T:
    """Run ``function(*args)`` in the thread that spins ``executor`` and return its value.

    Parameters
    ----------
    executor : rclpy.executors.Executor
        An executor being spun in another thread.
    function : callable
        E.g. ``client.send_goal_async``; must not block.
    *args
        Its arguments.
    timeout : float
        Longest wait for the executor to run it [s].

    Raises
    ------
    TimeoutError
        If the executor did not run it within ``timeout`` (not spinning?).
    """
    task = executor.create_task(function, *args)  # wakes the executor (its guard condition)
    deadline = time.monotonic() + timeout
    while not task.done():
        if time.monotonic() > deadline:
            task.cancel()
            raise TimeoutError(f'the executor did not run {function!r} within {timeout} s')
        time.sleep(0.002)
    return task.result()
