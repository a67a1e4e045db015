"""forte_ros: what every FORTE package shares below its own code.

Two kinds of module, told apart by what they import:

- Pure (no rclpy, importable by the pure cores and before ``rclpy.init``):
  :mod:`forte_ros.contract` (channel names and order, finger groups, sample rate, value
  range: the sensor contract of docs/contracts.md, declared once),
  :mod:`forte_ros.parameter_table` (:class:`ParameterSpec`, the one shape of every node's
  parameter table), :mod:`forte_ros.isolation` (DDS discovery confined to loopback and a
  domain id of the process's own, for tests, demos and benchmarks) and
  :mod:`forte_ros.sensor_identity` (what a force model was trained on against the sensor it
  runs on).
- ROS (import rclpy or ROS messages):
  :mod:`forte_ros.node_runner` (:func:`run_node` and :class:`NodeRunner`, the body of every
  node's ``main``: SIGINT and SIGTERM only request a stop; the executor stops, threads are
  stopped and joined, lifecycle nodes go through their ``shutdown`` transition, then the
  nodes are destroyed and the context shut down; exit code 0, no traceback;
  :func:`publish_quietly` for threads that may race with the end of the context),
  :mod:`forte_ros.lifecycle` (:class:`ForteLifecycleNode`, the base of the FORTE managed
  nodes: an invalid ``change_state`` request is refused with ``success=false`` and a
  warning, and the node keeps running), :mod:`forte_ros.executor_calls`
  (:func:`call_in_executor`, for action-client calls from a thread other than the one
  spinning the client, ros2/rclpy#1123), :mod:`forte_ros.qos` (the QoS profiles of
  docs/contracts.md, defined once), :mod:`forte_ros.diagnostics` (the one way nodes build
  ``/diagnostics`` messages), :mod:`forte_ros.parameters` (declare a node's parameter table
  and read it back) and :mod:`forte_ros.testing` (run node executables as child processes
  and nodes in a spinning test graph).

This package imports nothing on its own import: the names below are loaded on first use, so
``import forte_ros.contract`` never loads rclpy.
"""
from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module that defines it (loaded on first access).
_LAZY = {
    'call_in_executor': 'forte_ros.executor_calls',
    'ForteLifecycleNode': 'forte_ros.lifecycle',
    'shut_down_lifecycle': 'forte_ros.lifecycle',
    'NodeRunner': 'forte_ros.node_runner',
    'publish_quietly': 'forte_ros.node_runner',
    'run_node': 'forte_ros.node_runner',
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    return getattr(importlib.import_module(_LAZY[name]), name)
