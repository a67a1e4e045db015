"""One way to build the ``/diagnostics`` messages of every FORTE node.

A node describes its state as a level, a message and ``{key: value}`` pairs; these helpers
turn that into ``diagnostic_msgs`` (values converted with ``str``), so no node builds
``KeyValue`` lists or ``DiagnosticArray`` headers by hand.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

__all__ = ['ERROR', 'OK', 'STALE', 'WARN', 'diagnostic_array', 'diagnostic_status', 'node_path']

#: Levels of ``diagnostic_msgs/DiagnosticStatus`` (bytes, as the message field wants them).
OK = DiagnosticStatus.OK
WARN = DiagnosticStatus.WARN
ERROR = DiagnosticStatus.ERROR
STALE = DiagnosticStatus.STALE


def node_path(node: Any) -> str:
    """The node's name with its namespace, as a status name starts: ``'<namespace>/<name>'``.

    ``/diagnostics`` is one topic for the whole domain, also for graphs in namespaces, so a
    status names its node with the namespace (``right/perception``); a node in the root
    namespace keeps its plain name (``perception``), the convention of ROS 2's
    diagnostic_updater. ``node``: an ``rclpy.node.Node`` (anything with
    ``get_fully_qualified_name``).
    """
    return node.get_fully_qualified_name().lstrip('/')


def diagnostic_status(name: str, level: bytes, message: str,
                      values: Mapping[str, Any] | None = None,
                      hardware_id: str = '') -> DiagnosticStatus:
    """A status with its key-value pairs.

    Parameters
    ----------
    name : str
        Status name, conventionally ``f'{node_path(node)}: <part>'``.
    level : bytes
        :data:`OK`, :data:`WARN`, :data:`ERROR` or :data:`STALE`.
    message : str
        One line for a human.
    values : mapping, optional
        Keys and values, in order; each value is converted with ``str``.
    hardware_id : str
        The device the status describes, if any.
    """
    return DiagnosticStatus(
        level=level, name=name, message=message, hardware_id=hardware_id,
        values=[KeyValue(key=str(key), value=str(value))
                for key, value in (values or {}).items()])


def diagnostic_array(stamp: Any, statuses: Iterable[DiagnosticStatus]) -> DiagnosticArray:
    """The message to publish on ``/diagnostics``: the statuses stamped with ``stamp``
    (a ``builtin_interfaces/Time``)."""
    array = DiagnosticArray(status=list(statuses))
    array.header.stamp = stamp
    return array
