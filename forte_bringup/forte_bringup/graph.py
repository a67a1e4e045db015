"""The three FORTE graphs (hardware, simulation, bag replay) as data.

One description, two front ends: the launch files (``launch/*.launch.py``, for ``ros2
launch`` on a ROS 2 install) and :mod:`forte_bringup.bringup` (``forte_bringup`` on a bare
machine) both build their processes from :data:`GRAPHS`, so both start the same node
executables under the same node names, with the same parameter file and remappings.
Pure data (no rclpy, no launch).

Several graphs share one ROS domain through the ``namespace`` and ``prefix`` arguments
(:func:`forte_ros.contract.graph_namespace`, :func:`~forte_ros.contract.check_prefix`): the
namespace holds every node, topic, service and action of the graph (a namespaced sim graph
also moves its clock to ``<namespace>/clock``), the prefix is prepended to every frame id and
joint name its nodes publish or consume (their ``prefix`` parameter). Only ``/rosout``,
``/parameter_events``, ``/diagnostics`` (and ``/tf``, ``/tf_static`` where a graph publishes
TF) stay global. Every graph ends with :data:`VISUALIZATION` and
:data:`ROBOT_STATE_PUBLISHER`, each with an on/off argument; which nodes start is
:func:`forte_bringup.graph_nodes.started_nodes`.
"""
from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from forte_bringup.robot_model import robot_state_publisher_parameters
from forte_ros.contract import check_prefix, graph_namespace


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
    enabled_by : str
        A ``bool`` argument that turns the node on or off ('' = always started).
    robot_model : bool
        robot_state_publisher: ``robot_description`` the gripper's URDF for ``prefix``
        (:func:`argument_settings`).
    rviz_view : bool
        rviz2: started with the view generated for the graph's namespace and prefix
        (:func:`node_arguments`, :mod:`forte_bringup.rviz_view`).

    A node of a package outside FORTE (robot_state_publisher, rviz2) starts only where it
    is installed (:mod:`forte_bringup.graph_nodes`).

    Every node whose messages carry frame ids or joint names has a ``prefix`` parameter,
    set from the graph's ``prefix`` argument through ``argument_parameters``.
    """

    package: str
    executable: str
    name: str
    lifecycle: bool = False
    remappings: tuple[tuple[str, str], ...] = ()
    argument_remaps: tuple[tuple[str, str], ...] = ()
    argument_parameters: tuple[tuple[str, str], ...] = ()
    fixed_parameters: tuple[tuple[str, object], ...] = ()
    enabled_by: str = ''
    robot_model: bool = False
    rviz_view: bool = False


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
    """A typed value as the text of ``--ros-args -p name:=<text>`` (YAML, type preserved).

    A string YAML would read as another type is single-quoted; a string of several lines
    (a URDF) is a double-quoted YAML scalar with escapes, so that it arrives unchanged.
    """
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, int):
        return str(value)
    text = str(value)
    if '\n' in text or '\r' in text:
        return json.dumps(text)  # a JSON string is a YAML double-quoted scalar
    try:
        plain = isinstance(yaml.safe_load(text or "''"), str)
    except yaml.YAMLError:
        plain = False
    return text if plain else "'" + text.replace("'", "''") + "'"


@dataclass(frozen=True)
class GraphSpec:
    """A whole graph: its nodes, its parameter file, its arguments.

    ``private_clock``: the graph publishes its own ``/clock`` (the simulator); under a
    namespace every node of the graph then uses ``<namespace>/clock`` instead, so that two
    simulations on one domain do not drive each other's clocks.

    ``sim_force_model``: without a force model (no ``force_model`` argument, no
    perception ``model_path`` in the YAML or overlay) perception gets the simulated rig's
    model (:func:`forte_evaluation.sim_force_model.default_force_model_file`); only the sim
    graph, whose sensor is that rig's.
    """

    name: str
    description: str
    params_file: str
    nodes: tuple[NodeSpec, ...]
    arguments: tuple[Argument, ...] = field(default_factory=tuple)
    private_clock: bool = False
    sim_force_model: bool = False

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
        own name is left out), then ``/clock`` to ``<namespace>/clock`` in a namespaced
        graph with a private clock (:func:`clock_remappings`).
    parameters : dict
        Parameter name -> value of every argument parameter given, in the order of
        ``spec.argument_parameters`` (the fixed parameters are not included); for the
        robot-model node also ``robot_description``, the gripper's URDF for ``prefix``
        (:func:`forte_bringup.robot_model.expand_gripper`).

    Raises
    ------
    ValueError
        If a value is not of its argument's kind (``argument rate:=fast: ...``), or the
        ``namespace`` or ``prefix`` is not a valid one.
    """
    remappings = list(spec.remappings)
    for source, argument in spec.argument_remaps:
        target = arguments.get(argument, '')
        if target and target != source:
            remappings.append((source, target))
    remappings += clock_remappings(graph, arguments)
    check_prefix(arguments.get('prefix', ''))
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
    use_sim_time = arguments.get('use_sim_time', '')
    if use_sim_time:  # empty: the YAML's (every node's block says the graph's own time)
        parameters['use_sim_time'] = Argument('use_sim_time', '', '', 'bool').typed(
            use_sim_time)
    if spec.robot_model:
        parameters.update(robot_state_publisher_parameters(arguments.get('prefix', '')))
    return remappings, parameters


def node_arguments(spec: NodeSpec, arguments: Mapping[str, str],
                   graph: GraphSpec | None = None) -> list[str]:
    """Command-line arguments of a node (before ``--ros-args``): rviz2's ``-d <view>``.

    Parameters
    ----------
    spec : NodeSpec
        The node.
    arguments : mapping of str to str
        Argument values (``namespace``, ``prefix``, ``robot_state_publisher``).
    graph : GraphSpec, optional
        The graph (whether it runs its own robot_state_publisher by default).

    Returns
    -------
    list of str
        ``['-d', <file>]`` for rviz2 (the view written for the graph's namespace and
        prefix, :func:`forte_bringup.rviz_view.write_view`); nothing for other nodes.
    """
    if not spec.rviz_view:
        return []
    from forte_bringup.rviz_view import write_view

    own_model = True
    if graph is not None:
        argument = graph.argument('robot_state_publisher')
        own_model = bool(argument.typed(arguments.get(argument.name, '') or argument.default))
    namespace = graph_namespace(arguments.get('namespace', ''))
    return ['-d', str(write_view(namespace, arguments.get('prefix', ''), own_model))]


#: ``(parameter, argument)`` of the TF / joint-name prefix, on every node that has one.
PREFIX = ('prefix', 'prefix')

PERCEPTION = NodeSpec(
    'forte_perception', 'perception_node', 'perception',
    argument_parameters=(('model_path', 'force_model'), PREFIX),
)
CONTROL = NodeSpec(
    'forte_control', 'grasp_controller_node', 'grasp_controller',
    argument_remaps=(('arm/cmd_vel', 'arm_cmd_vel_topic'),),
    argument_parameters=(PREFIX,),
)

#: forte_visualization and robot_state_publisher (the gripper's URDF), in every graph.
VISUALIZATION = NodeSpec('forte_bringup', 'forte_visualization', 'visualization',
                         argument_parameters=(PREFIX,), enabled_by='visualization')
ROBOT_STATE_PUBLISHER = NodeSpec('robot_state_publisher', 'robot_state_publisher',
                                 'robot_state_publisher', enabled_by='robot_state_publisher',
                                 robot_model=True)
#: RViz with the graph's view (``rviz:=true``), in every graph.
RVIZ = NodeSpec('rviz2', 'rviz2', 'rviz2', enabled_by='rviz', rviz_view=True)

#: Lifecycle transitions a node may refuse before its graph gives up on it, and the pause
#: before asking again [s] (a device that just enumerated, a servo bus that missed one status
#: packet): the launch files and forte_bringup retry the same way.
TRANSITION_ATTEMPTS = 3
TRANSITION_RETRY_DELAY = 1.0

#: The bag recorder that ``record:=true`` adds to every graph (console script of
#: forte_bringup, installed in ``lib/forte_bringup/`` like the node executables).
RECORDER = NodeSpec('forte_bringup', 'forte_record', 'forte_recorder')

def common_arguments(robot_state_publisher: str) -> tuple[Argument, ...]:
    """The arguments of every graph; ``robot_state_publisher`` is the default of the
    argument of that name ('false' for the graph a robot's launch includes)."""
    return (
        Argument('params_file', '', 'parameter YAML for every node of this graph '
                 '(default: config/<graph>.yaml of forte_bringup)'),
        Argument('force_model', '', 'force model file for perception (empty: the YAML '
                 'value)'),
        Argument('arm_cmd_vel_topic', 'arm/cmd_vel', 'topic of the arm Cartesian velocity '
                 'commands (TwistStamped), e.g. /servo_node/delta_twist_cmds for MoveIt Servo'),
        Argument('record', 'false', 'also record the graph topics to an MCAP bag '
                 '(forte_record)'),
        Argument('bag_output', '', 'bag folder to record to (default out/bags/forte_<time>)'),
        Argument('params_overlay', '', 'second parameter YAML applied after params_file to '
                 'the nodes it names (e.g. the slip setting written by forte_tune_slip); '
                 'empty: none'),
        Argument('namespace', '', 'ROS namespace of every node, topic, service and action of '
                 'the graph, e.g. right (node names unchanged inside it; a sim graph also uses '
                 '<namespace>/clock); empty: the root namespace'),
        Argument('prefix', '', 'TF / joint-name prefix prepended to every frame id and joint '
                 'name the nodes publish, e.g. right_ (right_forte_base_link, '
                 'right_forte_left_finger_joint); empty: none'),
        Argument('use_sim_time', '', 'true: every node of the graph runs on /clock '
                 '(<namespace>/clock in a namespaced sim graph); false: on the wall clock; '
                 "empty: the graph's own (sim: true, hardware and replay: false)", kind='bool'),
        Argument('visualization', 'true', 'start forte_visualization (per-pad WrenchStamped '
                 'on visualization/<side>_pad_wrench, MarkerArray on visualization/markers for '
                 'RViz)', kind='bool'),
        Argument('robot_state_publisher', robot_state_publisher,
                 "start robot_state_publisher with the gripper's URDF for prefix (TF of body, "
                 'fingers and pads; robot_description in the namespace) where it is installed '
                 '(else one line says so and the graph runs without it); false when the '
                 "robot's own robot_state_publisher has the gripper in its URDF",
                 kind='bool'),
        Argument('rviz', 'false', 'start rviz2 (where installed) with the view written for '
                 "this graph's namespace and prefix (topics in the namespace, fixed frame "
                 "<prefix>forte_base_link; the robot's /robot_description when "
                 'robot_state_publisher is false)', kind='bool'),
    )


#: The arguments of the standalone graphs (sim, replay): they publish the gripper's model.
COMMON_ARGUMENTS = common_arguments('true')

GRAPHS: dict[str, GraphSpec] = {
    'hardware': GraphSpec(
        'hardware',
        'FORTE on the real gripper: serial tactile sensor, Dynamixel gripper, perception, '
        'grasp control (arm commands on arm_cmd_vel_topic)',
        'hardware.yaml',
        (
            NodeSpec('forte_driver', 'serial_sensor_node', 'serial_sensor', lifecycle=True,
                     argument_parameters=(('port', 'sensor_port'), PREFIX)),
            NodeSpec('forte_driver', 'gripper_driver_node', 'gripper_driver', lifecycle=True,
                     argument_parameters=(('port', 'gripper_port'), PREFIX)),
            PERCEPTION,
            CONTROL,
            VISUALIZATION,
            ROBOT_STATE_PUBLISHER,
            RVIZ,
        ),
        (
            # included into a robot's launch: the robot owns robot_state_publisher
            *common_arguments('false'),
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
                                          ('real_time_factor', 'real_time_factor'), PREFIX)),
            PERCEPTION,
            CONTROL,
            VISUALIZATION,
            ROBOT_STATE_PUBLISHER,
            RVIZ,
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
        private_clock=True,
        sim_force_model=True,
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
                     argument_parameters=(PREFIX,), fixed_parameters=(('dry_run', True),)),
            VISUALIZATION,
            ROBOT_STATE_PUBLISHER,
            RVIZ,
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


#: A ROS namespace token: letters, digits, underscores, not starting with a digit.
#: A TF / joint-name prefix: letters, digits, underscores and inner slashes (tf2 frame ids
#: never start with a slash).


def clock_remappings(graph: GraphSpec | None, arguments: Mapping[str, str]
                     ) -> list[tuple[str, str]]:
    """``[('/clock', '<namespace>/clock')]`` for a namespaced graph with a private clock.

    Every node of such a graph (the simulator publishing the clock, the nodes on
    ``use_sim_time``, the recorder) gets it, so that each simulation keeps its own time.

    Parameters
    ----------
    graph : GraphSpec or None
        The graph (None: no remapping).
    arguments : mapping of str to str
        Argument values; ``namespace`` is read.

    Returns
    -------
    list of (str, str)
        The remapping, or nothing (root namespace, or a graph without its own clock).
    """
    namespace = graph_namespace(arguments.get('namespace', ''))
    if graph is None or not graph.private_clock or not namespace:
        return []
    return [('/clock', f'{namespace}/clock')]


def namespaced_parameter_file(path: str | Path, namespace: str) -> Path:
    """A copy of a parameter YAML whose node blocks apply to the nodes in ``namespace``.

    rcl matches a block keyed ``sim`` to the node ``/sim`` only; under a namespace the node
    is ``/right/sim``. The copy keys each relative node name ``name`` as
    ``<namespace>/name``; ``/**`` and absolute keys stay as they are.

    Parameters
    ----------
    path : str or Path
        The parameter YAML.
    namespace : str
        Absolute namespace (:func:`graph_namespace`); '' returns ``path`` unchanged.

    Returns
    -------
    Path
        ``path``, or the copy (a new file in ``<tmp>/forte-params/``).

    Raises
    ------
    ValueError
        If the file cannot be read or is not a mapping of node names.
    """
    if not namespace:
        return Path(path)
    try:
        document = yaml.safe_load(Path(path).read_text(encoding='utf-8'))
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f'parameter file {path!r}: cannot read it ({exc})') from exc
    if not isinstance(document, dict):
        raise ValueError(f'parameter file {path!r}: expected node_name: {{ros__parameters: '
                         '{...}} blocks')
    rewritten = {(key if str(key).startswith('/') else f'{namespace}/{key}'): block
                 for key, block in document.items()}
    folder = Path(tempfile.gettempdir()) / 'forte-params'
    folder.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f'{namespace.strip("/").replace("/", "_")}_',
                                    suffix=f'_{Path(path).name}', dir=folder)
    with os.fdopen(handle, 'w', encoding='utf-8') as out:
        yaml.safe_dump(rewritten, out, sort_keys=False)
    return Path(name)


def recorder_topics(namespace: str) -> list[str]:
    """The topics ``record:=true`` records in a namespaced graph (absolute names).

    The contract's topics (:data:`forte_driver.replay.bags.DEFAULT_TOPICS`) inside
    ``namespace``; global ones (``/diagnostics``) stay global.
    """
    from forte_driver.replay.bags import DEFAULT_TOPICS

    return [spec.name if spec.name.startswith('/') else f'{namespace}/{spec.name}'
            for spec in DEFAULT_TOPICS]


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
