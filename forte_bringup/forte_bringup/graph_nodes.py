"""Which nodes of a graph start for its arguments (both front ends).

Pure (no rclpy, no launch). A graph's :class:`~forte_bringup.graph.NodeSpec` list holds every
node it can start; two are optional:

- ``visualization`` (forte_visualization), on unless ``visualization:=false``;
- ``robot_state_publisher`` with the gripper's URDF for the graph's ``prefix``, on unless
  ``robot_state_publisher:=false`` (the robot's own robot_state_publisher already has the
  gripper), and only where it is installed: without it (a bare machine: it has no wheel)
  the graph logs :data:`forte_bringup.robot_model.ROBOT_STATE_PUBLISHER_MISSING` once and
  runs without it.

The launch files (:mod:`forte_bringup.launch_support`) and ``forte_bringup``
(:mod:`forte_bringup.bringup`) both start exactly :func:`started_nodes`.
"""
from __future__ import annotations

from collections.abc import Mapping

from forte_bringup.graph import GraphSpec, NodeSpec
from forte_bringup.robot_model import robot_state_publisher_message

__all__ = ['enabled', 'started_nodes']


def enabled(graph: GraphSpec, spec: NodeSpec, arguments: Mapping[str, str]) -> bool:
    """Whether the arguments turn ``spec`` on (its ``enabled_by`` argument, default if empty).

    Raises
    ------
    ValueError
        If the argument is not ``true``/``false``/``1``/``0``
        (``argument visualization:=maybe: ...``).
    """
    if not spec.enabled_by:
        return True
    argument = graph.argument(spec.enabled_by)
    text = arguments.get(argument.name, '') or argument.default
    try:
        return bool(argument.typed(text))
    except ValueError as error:
        raise ValueError(f'argument {argument.name}:={text}: {error}') from error


def started_nodes(graph: GraphSpec, arguments: Mapping[str, str],
                  environ: Mapping[str, str] | None = None
                  ) -> tuple[list[NodeSpec], list[str]]:
    """The nodes the graph starts for ``arguments``, and the lines to log about the others.

    Parameters
    ----------
    graph : GraphSpec
        The graph.
    arguments : mapping of str to str
        Argument values by name (a missing or empty one takes its default).
    environ : mapping, optional
        Environment whose ``AMENT_PREFIX_PATH`` tells whether robot_state_publisher is
        installed (default ``os.environ``).

    Returns
    -------
    nodes : list of NodeSpec
        The nodes to start, in the graph's order.
    notes : list of str
        :data:`~forte_bringup.robot_model.ROBOT_STATE_PUBLISHER_MISSING` when the
        robot-model node is wanted but not installed; else nothing.

    Raises
    ------
    ValueError
        If an on/off argument is not a boolean.
    """
    nodes: list[NodeSpec] = []
    notes: list[str] = []
    for spec in graph.nodes:
        if not enabled(graph, spec, arguments):
            continue
        if spec.robot_model:
            missing = robot_state_publisher_message(environ)
            if missing is not None:
                notes.append(missing)
                continue
        nodes.append(spec)
    return nodes, notes
