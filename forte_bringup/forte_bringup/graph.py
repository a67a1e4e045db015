"""The three FORTE graphs (hardware, simulation, bag replay) as data.

One description, two front ends: the launch files (``launch/*.launch.py``, for ``ros2
launch`` on a ROS 2 install) and :mod:`forte_bringup.bringup` (``forte_bringup`` on a bare
machine) both build their processes from :data:`GRAPHS`, so both start the same node
executables under the same node names, with the same parameter file and remappings.
Pure data (no rclpy, no launch).
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml


@dataclass(frozen=True)
class NodeSpec:
    """One node of a graph.

    Attributes
    ----------
    package, executable : str
        ROS package and console script (``ros2 run <package> <executable>``).
    name : str
        Node name (set with ``__node:=``); the key of its block in the parameter YAML.
    lifecycle : bool
        Managed node: configured and activated after start-up.
    remappings : tuple of (str, str)
        Fixed remappings ``(from, to)``; argument-driven ones are in ``argument_remaps``.
    argument_remaps : tuple of (str, str)
        ``(topic, argument name)``: remap ``topic`` to the value of that argument.
    argument_parameters : tuple of (str, str)
        ``(parameter, argument name)``: set the parameter from that argument when given.
    fixed_parameters : tuple of (str, object)
        Parameters this graph always sets on the node (after the YAML), e.g. ``dry_run``.
    """

    package: str
    executable: str
    name: str
    lifecycle: bool = False
    remappings: tuple[tuple[str, str], ...] = ()
    argument_remaps: tuple[tuple[str, str], ...] = ()
    argument_parameters: tuple[tuple[str, str], ...] = ()
    fixed_parameters: tuple[tuple[str, object], ...] = ()


@dataclass(frozen=True)
class Argument:
    """A graph argument (``ros2 launch ... name:=value`` / ``forte_bringup ... name:=value``).

    ``kind`` is the type of the node parameter the argument sets (``str``, ``float``,
    ``int`` or ``bool``): ``rate:=0`` must reach a double parameter as 0.0, not as the
    integer 0 that rclpy would refuse.
    """

    name: str
    default: str
    description: str
    kind: str = 'str'

    def typed(self, text: str) -> object:
        """The argument text as a parameter value of :attr:`kind`.

        Raises
        ------
        ValueError
            If the text is not a value of that kind.
        """
        if self.kind == 'float':
            return float(text)
        if self.kind == 'int':
            return int(text)
        if self.kind == 'bool':
            if text.lower() not in ('true', 'false', '1', '0'):
                raise ValueError(f'{self.name}: expected true or false, got {text!r}')
            return text.lower() in ('true', '1')
        return text


def parameter_text(value: object) -> str:
    """A typed value as the text of ``--ros-args -p name:=<text>`` (YAML, type preserved)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, int):
        return str(value)
    text = str(value)
    return text if isinstance(yaml.safe_load(text or "''"), str) else "'" + text.replace(
        "'", "''") + "'"


@dataclass(frozen=True)
class GraphSpec:
    """A whole graph: its nodes, its parameter file, its arguments."""

    name: str
    description: str
    params_file: str
    nodes: tuple[NodeSpec, ...]
    arguments: tuple[Argument, ...] = field(default_factory=tuple)

    def argument(self, name: str) -> Argument:
        """The argument called ``name``."""
        for argument in self.arguments:
            if argument.name == name:
                return argument
        raise KeyError(f'graph {self.name} has no argument {name!r}')

    def node(self, name: str) -> NodeSpec:
        """The node called ``name``."""
        for spec in self.nodes:
            if spec.name == name:
                return spec
        raise KeyError(f'graph {self.name} has no node {name!r}')


def argument_settings(spec: NodeSpec, arguments: Mapping[str, str],
                      graph: GraphSpec | None = None) -> tuple[list[tuple[str, str]],
                                                               dict[str, object]]:
    """What the graph arguments set on one node: its remappings and parameters.

    The one rule for both front ends (the launch files and :mod:`forte_bringup.bringup`).

    Parameters
    ----------
    spec : NodeSpec
        The node.
    arguments : mapping of str to str
        Argument values by name; an empty or missing value means "not given" (the YAML
        value stays, the topic keeps its name).
    graph : GraphSpec, optional
        The graph whose argument kinds type the parameter values (default: the text as
        given).

    Returns
    -------
    remappings : list of (str, str)
        The node's fixed remappings, then those its arguments set (a topic remapped to its
        own name is left out).
    parameters : dict
        Parameter name -> value of every argument parameter given, in the order of
        ``spec.argument_parameters`` (the fixed parameters are not included).

    Raises
    ------
    ValueError
        If a value is not of its argument's kind (``argument rate:=fast: ...``).
    """
    remappings = list(spec.remappings)
    for source, argument in spec.argument_remaps:
        target = arguments.get(argument, '')
        if target and target != source:
            remappings.append((source, target))
    parameters: dict[str, object] = {}
    for parameter, argument in spec.argument_parameters:
        value = arguments.get(argument, '')
        if value == '':
            continue
        if graph is not None:
            try:
                value = graph.argument(argument).typed(value)
            except ValueError as error:
                raise ValueError(f'argument {argument}:={value}: {error}') from error
        parameters[parameter] = value
    return remappings, parameters


PERCEPTION = NodeSpec(
    'forte_perception', 'perception_node', 'perception',
    argument_parameters=(('model_path', 'force_model'),),
)
CONTROL = NodeSpec(
    'forte_control', 'grasp_controller_node', 'grasp_controller',
    argument_remaps=(('arm/cmd_vel', 'arm_cmd_vel_topic'),),
)

#: Lifecycle transitions a node may refuse before its graph gives up on it, and the pause
#: before asking again [s] (a device that just enumerated, a servo bus that missed one status
#: packet): the launch files and forte_bringup retry the same way.
TRANSITION_ATTEMPTS = 3
TRANSITION_RETRY_DELAY = 1.0

#: The bag recorder that ``record:=true`` adds to every graph (console script of
#: forte_bringup, installed in ``lib/forte_bringup/`` like the node executables).
RECORDER = NodeSpec('forte_bringup', 'forte_record', 'forte_recorder')

COMMON_ARGUMENTS = (
    Argument('params_file', '', 'parameter YAML for every node of this graph '
             '(default: config/<graph>.yaml of forte_bringup)'),
    Argument('force_model', '', 'force model file for perception (empty: the YAML value)'),
    Argument('arm_cmd_vel_topic', 'arm/cmd_vel', 'topic of the arm Cartesian velocity '
             'commands (TwistStamped), e.g. /servo_node/delta_twist_cmds for MoveIt Servo'),
    Argument('record', 'false', 'also record the graph topics to an MCAP bag (forte_record)'),
    Argument('bag_output', '', 'bag folder to record to (default out/bags/forte_<time>)'),
    Argument('params_overlay', '', 'second parameter YAML applied after params_file to the '
             'nodes it names (e.g. the slip setting written by forte_tune_slip); empty: none'),
)

GRAPHS: dict[str, GraphSpec] = {
    'hardware': GraphSpec(
        'hardware',
        'FORTE on the real gripper: serial tactile sensor, Dynamixel gripper, perception, '
        'grasp control (arm commands on arm_cmd_vel_topic)',
        'hardware.yaml',
        (
            NodeSpec('forte_driver', 'serial_sensor_node', 'serial_sensor', lifecycle=True,
                     argument_parameters=(('port', 'sensor_port'),)),
            NodeSpec('forte_driver', 'gripper_driver_node', 'gripper_driver', lifecycle=True,
                     argument_parameters=(('port', 'gripper_port'),)),
            PERCEPTION,
            CONTROL,
        ),
        (
            *COMMON_ARGUMENTS,
            Argument('sensor_port', '', 'serial device of the tactile sensor, e.g. '
                     '/dev/forte_sensor (empty: the YAML value)'),
            Argument('gripper_port', '', 'serial device of the U2D2 Dynamixel interface, '
                     'e.g. /dev/forte_gripper (empty: the YAML value)'),
        ),
    ),
    'sim': GraphSpec(
        'sim',
        'FORTE in simulation: simulated scene (sensor, servo, arm, object), perception, '
        'grasp control',
        'sim.yaml',
        (
            NodeSpec('forte_sim', 'sim_node', 'sim', lifecycle=True,
                     argument_parameters=(('object', 'object'), ('seed', 'seed'),
                                          ('real_time_factor', 'real_time_factor'))),
            PERCEPTION,
            CONTROL,
        ),
        (
            *COMMON_ARGUMENTS,
            Argument('object', '', 'object of the grasp scene, e.g. raspberry, soda_can '
                     '(empty: the YAML value)'),
            Argument('seed', '', 'seed of the scene (placement, material spread, noise; '
                     'empty: the YAML value)', kind='int'),
            Argument('real_time_factor', '', 'speed of the simulation: simulated seconds '
                     'per wall-clock second (1.0 = real time, 0.5 = half speed, 0 = as fast '
                     'as possible; perception and control follow on /clock; empty: the YAML '
                     'value)', kind='float'),
        ),
    ),
    'replay': GraphSpec(
        'replay',
        'FORTE on a recorded bag: bag replay drives perception and control; control runs '
        'dry (no servo or arm command moves anything)',
        'replay.yaml',
        (
            NodeSpec('forte_driver', 'bag_replay_node', 'bag_replay',
                     argument_parameters=(('bag_path', 'bag'), ('rate', 'rate'))),
            PERCEPTION,
            NodeSpec('forte_control', 'grasp_controller_node', 'grasp_controller',
                     argument_remaps=(('arm/cmd_vel', 'arm_cmd_vel_topic'),),
                     fixed_parameters=(('dry_run', True),)),
        ),
        (
            *COMMON_ARGUMENTS,
            Argument('bag', '', 'bag to replay (rosbag2 MCAP folder or .mcap file); required'),
            Argument('rate', '', 'replay speed factor, 1.0 = recorded timing, 0 = as fast as '
                     'possible (empty: the YAML value)', kind='float'),
        ),
    ),
}


def overlay_nodes(path: str | Path, graph: GraphSpec) -> set[str]:
    """The node names a parameter overlay sets parameters of.

    Parameters
    ----------
    path : str
        The overlay YAML.
    graph : GraphSpec
        The graph it is applied to.

    Returns
    -------
    set of str
        Its top-level keys (node names, or ``/**`` for every node).

    Raises
    ------
    ValueError
        Unreadable file, not a mapping of node names to ``{ros__parameters: mapping}``, or
        a node name the graph does not have (the message names the file and the reason).
    """
    try:
        document = yaml.safe_load(Path(path).read_text(encoding='utf-8'))
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f'params_overlay {path!r}: cannot read it ({exc})') from exc
    if not isinstance(document, dict) or not document:
        raise ValueError(f'params_overlay {path!r}: expected node_name: {{ros__parameters: '
                         '{...}} blocks')
    known = {spec.name for spec in graph.nodes} | {'/**'}
    for node, block in document.items():
        if node not in known:
            raise ValueError(f'params_overlay {path!r}: the {graph.name} graph has no node '
                             f'{node!r} (nodes: {", ".join(sorted(known))})')
        if not isinstance(block, dict) or not isinstance(block.get('ros__parameters'), dict):
            raise ValueError(f'params_overlay {path!r}: {node}: expected a ros__parameters '
                             'mapping')
    return set(document)


def config_folder() -> Path:
    """Folder of the parameter YAML files.

    The source tree next to this module when it exists (editable install: edits apply at
    once), else ``share/forte_bringup/config`` of the first prefix that has it.
    """
    source = Path(__file__).resolve().parents[1] / 'config'
    if (source / 'sim.yaml').is_file():
        return source
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        folder = Path(prefix) / 'share' / 'forte_bringup' / 'config'
        if prefix and (folder / 'sim.yaml').is_file():
            return folder
    return source


def params_file(graph: str) -> Path:
    """Default parameter YAML of ``graph``."""
    return config_folder() / GRAPHS[graph].params_file
