"""Build a launch description from a :mod:`forte_bringup.graph` graph (needs launch_ros).

Used by ``launch/*.launch.py`` only; imports ``launch`` and ``launch_ros``, which exist on a
ROS 2 install but not on a bare machine (there, :mod:`forte_bringup.bringup` starts the
same graph). Every argument is declared with its description; nodes are created in an
``OpaqueFunction`` so that an empty argument leaves the YAML value in force; lifecycle
nodes are configured on start and activated once inactive (launch_ros lifecycle events),
and a refused configure or activate is asked for again as forte_bringup does.
The recorder (``record:=true``) is a launch_ros ``Node`` too: launch_ros finds the
``forte_record`` console script in ``lib/forte_bringup/`` as ``ros2 run`` does (colcon does
not put it on ``PATH``).

``params_overlay:=FILE`` (every graph): a second parameter YAML
loaded after ``params_file`` by every node it names, so its values override the main YAML
(the arguments that set parameters, e.g. ``force_model:=``, and the graph's fixed parameters
still come last). Its top-level keys must be node names of the graph (or ``/**``), each with
a ``ros__parameters`` mapping; anything else stops the launch with the reason. Written e.g.
by the slip threshold tuning (``forte_tune_slip``,
``python -m forte_commissioning.slip_characterization``).

``namespace:=NAME`` (every graph) starts every node in that namespace (``Node(namespace=)``),
with copies of the parameter files keyed by the namespaced node names
(:func:`forte_bringup.graph.namespaced_parameter_file`), and remaps ``/clock`` to
``NAME/clock`` in the sim graph; ``prefix:=PREFIX`` sets the ``prefix`` parameter of the
nodes that publish frame ids or joint names.

``visualization:=false`` leaves out forte_visualization; robot_state_publisher (the
gripper's URDF for ``prefix``) starts unless ``robot_state_publisher:=false`` (the hardware
graph's default: a robot's launch includes it, and the robot's robot_state_publisher has the
gripper), ``rviz:=true`` adds rviz2 with the view written for the namespace and prefix
(:mod:`forte_bringup.rviz_view`); both only where installed: elsewhere one line is logged and
the graph comes up without it (:func:`forte_bringup.graph_nodes.started_nodes`).
``use_sim_time:=true|false`` sets ``use_sim_time`` on every node (empty: the graph's own).

The sim graph without a force model (no ``force_model:=``, no ``model_path`` in the YAML)
gives perception the simulated rig's model, made on first use and cached
(:func:`forte_evaluation.sim_force_model.default_force_model_file`, 6-13 s once); the
hardware graph without one logs :data:`forte_bringup.graph_nodes.NO_FORCE_MODEL_WARNING`.
"""
from __future__ import annotations

from launch import Action, LaunchContext, LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    LogInfo,
    OpaqueFunction,
    RegisterEventHandler,
    TimerAction,
)
from launch.conditions import IfCondition
from launch.events import matches_action
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from launch_ros.substitutions import FindPackageShare
from lifecycle_msgs.msg import Transition

from forte_bringup.graph import (
    GRAPHS,
    RECORDER,
    TRANSITION_ATTEMPTS,
    TRANSITION_RETRY_DELAY,
    NodeSpec,
    argument_settings,
    clock_remappings,
    namespaced_parameter_file,
    node_arguments,
    overlay_nodes,
    recorder_topics,
)
from forte_bringup.graph_nodes import force_model_source, prepare_force_model, started_nodes
from forte_ros.contract import graph_namespace


def node_actions(spec: NodeSpec, remappings: list[tuple[str, str]],
                  overrides: dict[str, object], params_file: str,
                  overlay: str = '', namespace: str = '',
                  command_line: list[str] | None = None) -> list[Action]:
    """The actions that start one node (and drive it if it is a lifecycle node).

    Parameters
    ----------
    spec : NodeSpec
        The node.
    remappings : list of (str, str)
        Its remappings (:func:`forte_bringup.graph.argument_settings`).
    overrides : dict
        The parameters its arguments set (:func:`forte_bringup.graph.argument_settings`);
        the node's fixed parameters are added here.
    params_file : str
        Parameter YAML of the graph.
    overlay : str
        Parameter overlay YAML loaded after ``params_file`` ('' = none).
    namespace : str
        Absolute namespace of the node ('' = root); the parameter files must be keyed for
        it (:func:`forte_bringup.graph.namespaced_parameter_file`).
    command_line : list of str, optional
        Its arguments before ``--ros-args`` (:func:`forte_bringup.graph.node_arguments`).

    Returns
    -------
    list of Action
        A ``Node``; or, for a lifecycle node, the handlers that activate it once inactive
        and retry refused transitions, the ``LifecycleNode`` and the event that configures
        it.
    """
    overrides = {**overrides, **dict(spec.fixed_parameters)}
    parameters = [params_file] + ([overlay] if overlay else []) + (
        [overrides] if overrides else [])
    if not spec.lifecycle:
        return [Node(package=spec.package, executable=spec.executable, name=spec.name,
                     namespace=namespace, parameters=parameters, remappings=remappings,
                     arguments=command_line or [], output='screen', emulate_tty=True)]
    node = LifecycleNode(package=spec.package, executable=spec.executable, name=spec.name,
                         namespace=namespace, parameters=parameters, remappings=remappings,
                         output='screen', emulate_tty=True)
    configure, activate = (
        EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node),
                                    transition_id=transition))
        for transition in (Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE))
    activate_when_inactive = RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=node, start_state='configuring', goal_state='inactive',
        entities=[LogInfo(msg=f'{spec.name} configured, activating'), activate]))
    return [activate_when_inactive,
            _retry_refused(node, spec.name, 'configure', 'unconfigured', configure),
            _retry_refused(node, spec.name, 'activate', 'inactive', activate),
            node, configure]


def _retry_refused(node: LifecycleNode, name: str, transition: str, fallback_state: str,
                   request: EmitEvent) -> RegisterEventHandler:
    """Ask again, after a pause, when ``node`` refuses a transition (as forte_bringup does).

    Parameters
    ----------
    node : LifecycleNode
        The node.
    name : str
        Its node name (for the log).
    transition : str
        ``configure`` or ``activate``.
    fallback_state : str
        The state a refusal returns the node to: ``unconfigured`` after configure
        (transition event ``configuring`` -> ``unconfigured``), ``inactive`` after activate.
    request : EmitEvent
        The ChangeState event that asks for the transition.

    Returns
    -------
    RegisterEventHandler
        Re-emits ``request`` :data:`~forte_bringup.graph.TRANSITION_RETRY_DELAY` s after each
        refusal, until :data:`~forte_bringup.graph.TRANSITION_ATTEMPTS` refusals.
    """
    refusals = 0

    def again(_: LaunchContext) -> list[Action]:
        nonlocal refusals
        refusals += 1
        if refusals >= TRANSITION_ATTEMPTS:
            return [LogInfo(msg=f'{name} refused {transition} {refusals} times; giving up')]
        return [LogInfo(msg=f'{name} refused {transition}; asking again in '
                            f'{TRANSITION_RETRY_DELAY:g} s'),
                TimerAction(period=TRANSITION_RETRY_DELAY, actions=[request])]

    return RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=node, start_state=transition[:-1] + 'ing',
        goal_state=fallback_state, entities=[OpaqueFunction(function=again)]))


def _recorder_action(context: LaunchContext, namespace: str = '',
                     remappings: list[tuple[str, str]] | None = None) -> Node:
    """The ``forte_record`` node (``record:=true``), writing to ``bag_output`` if given.

    Parameters
    ----------
    context : LaunchContext
        Context the ``bag_output`` argument is read from.
    namespace : str
        Namespace of the graph ('' = root): the recorder runs in it and records the
        contract's topics inside it (:func:`forte_bringup.graph.recorder_topics`).
    remappings : list of (str, str), optional
        Its remappings (the namespaced sim graph's ``/clock``).

    Returns
    -------
    Node
        The recorder as a launch_ros node of package forte_bringup.
    """
    output = LaunchConfiguration('bag_output').perform(context)
    arguments = ['-o', output] if output else []
    if namespace:
        arguments += ['--topics', *recorder_topics(namespace)]
    return Node(package=RECORDER.package, executable=RECORDER.executable, name=RECORDER.name,
                namespace=namespace, arguments=arguments, remappings=remappings or [],
                output='screen', emulate_tty=True)


def _force_model_actions(graph_name: str, arguments: dict[str, str], params_file: str,
                         overlay: str) -> list[Action]:
    """Fill in the sim graph's default force model; warn on hardware without one.

    Parameters
    ----------
    graph_name : str
        The graph.
    arguments : dict
        Argument values; ``force_model`` is set here when the sim default applies (the
        model is made first if it is not cached yet).
    params_file, overlay : str
        The parameter YAML and the overlay ('' = none).

    Returns
    -------
    list of Action
        The log lines saying which model perception gets (or why none).
    """
    source = force_model_source(GRAPHS[graph_name], arguments, params_file, overlay or None)
    lines: list[str] = []
    path = prepare_force_model(source, graph_name, lines.append)
    if path is not None:
        arguments['force_model'] = path
    return [LogInfo(msg=line) for line in lines]


def graph_launch_description(graph_name: str) -> LaunchDescription:
    """The launch description of a graph.

    Parameters
    ----------
    graph_name : str
        ``hardware``, ``sim`` or ``replay`` (a key of :data:`forte_bringup.graph.GRAPHS`).

    Returns
    -------
    LaunchDescription
        Every argument of the graph declared with its description and default, then the
        graph's nodes that the arguments and the install select
        (:func:`forte_bringup.graph_nodes.started_nodes`; a log line for a missing
        robot_state_publisher), and the recorder if ``record:=true``.
    """
    graph = GRAPHS[graph_name]
    declared = []
    for argument in graph.arguments:
        default = argument.default
        if argument.name == 'params_file':
            default = PathJoinSubstitution(
                [FindPackageShare('forte_bringup'), 'config', graph.params_file])
        declared.append(DeclareLaunchArgument(
            argument.name, default_value=default, description=argument.description))

    def setup(context: LaunchContext) -> list[Action]:
        params_file = LaunchConfiguration('params_file').perform(context)
        arguments = {argument.name: LaunchConfiguration(argument.name).perform(context)
                     for argument in graph.arguments}
        overlay = arguments['params_overlay']
        named = overlay_nodes(overlay, graph) if overlay else set()
        actions = _force_model_actions(graph_name, arguments, params_file, overlay)
        namespace = graph_namespace(arguments['namespace'])
        params_file = str(namespaced_parameter_file(params_file, namespace))
        overlay = str(namespaced_parameter_file(overlay, namespace)) if overlay else ''
        nodes, notes = started_nodes(graph, arguments)
        actions += [LogInfo(msg=note) for note in notes]  # robot_state_publisher missing
        for spec in nodes:
            actions += node_actions(spec, *argument_settings(spec, arguments, graph),
                                     params_file,
                                     overlay if {spec.name, '/**'} & named else '',
                                     namespace, node_arguments(spec, arguments, graph))
        if IfCondition(LaunchConfiguration('record')).evaluate(context):
            actions.append(_recorder_action(context, namespace,
                                            clock_remappings(graph, arguments)))
        return actions

    return LaunchDescription([
        *declared,
        LogInfo(msg=graph.description),
        OpaqueFunction(function=setup),
    ])
