"""forte_ros: how every FORTE node process starts, stops and handles lifecycle requests.

A small pure-Python package installed by forte_msgs (``ament_python_install_package``), so
that forte_driver, forte_perception, forte_control and forte_bringup share it without
depending on each other (they all depend on forte_msgs).

- :mod:`forte_ros.node_runner`: :func:`run_node` and :class:`NodeRunner`, the body of every
  node's ``main``: SIGINT and SIGTERM only request a stop; the executor stops, threads are
  stopped and joined, lifecycle nodes go through their ``shutdown`` transition, then the
  nodes are destroyed and the context shut down; exit code 0, no traceback.
  :func:`publish_quietly` for threads that may race with the end of the context.
- :mod:`forte_ros.lifecycle`: :class:`ForteLifecycleNode`, the base of the FORTE managed
  nodes: an invalid ``change_state`` request (e.g. a second ``configure`` from a stale
  launch) is refused with ``success=false`` and a warning, and the node keeps running.
- :mod:`forte_ros.executor_calls`: :func:`call_in_executor`, for action-client calls from
  a thread other than the one spinning the client (ros2/rclpy#1123).
- :mod:`forte_ros.qos`: the QoS profiles of docs/contracts.md, defined once.
- :mod:`forte_ros.diagnostics`: :func:`diagnostic_status` and :func:`diagnostic_array`, the
  one way nodes build ``/diagnostics`` messages.
- :mod:`forte_ros.parameters`: parameter descriptors (ranges) from a node's parameter table.
- :mod:`forte_ros.testing`: run a node executable as a child process, stop it with a
  signal, check its output (used by the tests of every package).
"""
from forte_ros.executor_calls import call_in_executor
from forte_ros.lifecycle import ForteLifecycleNode, shut_down_lifecycle
from forte_ros.node_runner import NodeRunner, publish_quietly, run_node

__all__ = ['ForteLifecycleNode', 'NodeRunner', 'call_in_executor', 'publish_quietly', 'run_node',
           'shut_down_lifecycle']
