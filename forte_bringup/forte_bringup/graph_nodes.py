"""Which nodes of a graph start for its arguments (both front ends).

Pure (no rclpy, no launch). A graph's :class:`~forte_bringup.graph.NodeSpec` list holds every
node it can start; two are optional:

- ``visualization`` (forte_visualization), on unless ``visualization:=false``;
- ``robot_state_publisher`` with the gripper's URDF for the graph's ``prefix``, on unless
  ``robot_state_publisher:=false`` (the default of the hardware graph, which a robot's
  launch includes: the robot's own robot_state_publisher has the gripper);
- ``rviz2`` with the graph's view (:mod:`forte_bringup.rviz_view`), on with ``rviz:=true``.

The last two are not FORTE's: they start only where installed; without one (a bare machine:
neither has a wheel) the graph logs one line
(:data:`~forte_bringup.robot_model.ROBOT_STATE_PUBLISHER_MISSING`,
:data:`~forte_bringup.robot_model.RVIZ_MISSING`) and runs without it.

The launch files (:mod:`forte_bringup.launch_support`) and ``forte_bringup``
(:mod:`forte_bringup.bringup`) both start exactly :func:`started_nodes`, and both give
perception its force model through :func:`force_model_source` and
:func:`prepare_force_model` (the sim graph's default: the simulated rig's cached model; on
hardware without one, :data:`NO_FORCE_MODEL_WARNING`).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import yaml

from forte_bringup.graph import PERCEPTION, GraphSpec, NodeSpec
from forte_bringup.robot_model import (
    ROBOT_STATE_PUBLISHER_MISSING,
    RVIZ_MISSING,
    installed_executable,
)

__all__ = ['NO_FORCE_MODEL_WARNING', 'enabled', 'force_model_source', 'prepare_force_model',
           'started_nodes']


#: Packages of the graphs' nodes that are not FORTE's -> the line logged where it is missing.
NOT_FORTE = {'robot_state_publisher': ROBOT_STATE_PUBLISHER_MISSING, 'rviz2': RVIZ_MISSING}


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
        One line per wanted node that is not installed
        (:data:`~forte_bringup.robot_model.ROBOT_STATE_PUBLISHER_MISSING`,
        :data:`~forte_bringup.robot_model.RVIZ_MISSING`); else nothing.

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
        if spec.package in NOT_FORTE and \
                installed_executable(spec.package, spec.executable, environ) is None:
            notes.append(NOT_FORTE[spec.package])
            continue
        nodes.append(spec)
    return nodes, notes


#: Logged by the front ends when the hardware graph starts without a force model.
NO_FORCE_MODEL_WARNING = (
    'no force model (force_model:= empty, no perception model_path in the YAML): FORTE and '
    'NO_SLIP grasps will end FAULT INVALID_INPUT (no valid force estimate); ON_OFF works. '
    'Calibrate this gripper (ros2 launch forte_commissioning calibrate_force.launch.py '
    'mode:=hardware, then forte_train_force) and give force_model:=<model.npz>. The '
    "simulated rig's model is never used on hardware.")


def _yaml_parameter(path: str | Path | None, node: str, name: str) -> object | None:
    """Value of parameter ``name`` of ``node`` in a parameter YAML (None: not set there).

    Looks in the blocks keyed ``/**``, ``node`` and ``/node``; an empty value counts as
    not set.
    """
    if not path:
        return None
    try:
        document = yaml.safe_load(Path(path).read_text(encoding='utf-8'))
    except (OSError, yaml.YAMLError):
        return None
    value = None
    for key in ('/**', node, f'/{node}'):
        block = document.get(key) if isinstance(document, dict) else None
        parameters = block.get('ros__parameters') if isinstance(block, dict) else None
        if isinstance(parameters, dict) and parameters.get(name) not in (None, ''):
            value = parameters[name]
    return value


def force_model_source(graph: GraphSpec, arguments: Mapping[str, str],
                       params: str | Path | None, overlay: str | Path | None = None) -> str:
    """Where perception's force model comes from in this graph.

    Parameters
    ----------
    graph : GraphSpec
        The graph.
    arguments : mapping of str to str
        Argument values (``force_model``).
    params, overlay : str or Path, optional
        The parameter YAML and the overlay (perception's ``model_path``).

    Returns
    -------
    str
        ``'argument'`` (``force_model:=``), ``'yaml'`` (the YAML or overlay sets
        ``model_path``), ``'sim'`` (the sim graph's default: the simulated rig's model,
        which the front ends then give as ``force_model``) or ``'none'``.
    """
    if arguments.get('force_model', ''):
        return 'argument'
    if any(_yaml_parameter(path, PERCEPTION.name, 'model_path') for path in (params, overlay)):
        return 'yaml'
    return 'sim' if graph.sim_force_model else 'none'


def prepare_force_model(source: str, graph_name: str, say: Callable[[str], None]) -> str | None:
    """Make the sim graph's default force model if it is not cached yet; warn on hardware
    without a model.

    Parameters
    ----------
    source : str
        :func:`force_model_source` of the graph and its arguments.
    graph_name : str
        The graph (``hardware`` warns when there is no model).
    say : callable
        Takes each line to show (the one before a 6-13 s training comes before it).

    Returns
    -------
    str or None
        The model file to give perception (``force_model``) for source ``'sim'``; else None.
    """
    if source == 'sim':
        from forte_evaluation.sim_force_model import default_force_model_file, force_model_path

        if not force_model_path().is_file():
            say(f"making the simulated rig's force model (6-13 s, once; cached as "
                f'{force_model_path()})')
        path = str(default_force_model_file())
        say(f"force model: the simulated rig's, {path}")
        return path
    if source == 'none' and graph_name == 'hardware':
        say(f'WARNING: {NO_FORCE_MODEL_WARNING}')
    return None
