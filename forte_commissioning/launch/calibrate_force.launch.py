"""FORTE force calibration (paper Sec. IV-A) through ROS: the procedure node
``forte_calibrate_force`` with the simulated rig or with the real sensor and gripper.

    ros2 launch forte_commissioning calibrate_force.launch.py mode:=sim quick:=true
    ros2 launch forte_commissioning calibrate_force.launch.py mode:=hardware \\
        sensor_port:=/dev/forte_sensor gripper_port:=/dev/forte_gripper \\
        load_cell_topic:=/load_cell/wrench load_cell_axis:=z load_cell_sign:=-1
    ros2 service call /force_calibration/continue std_srvs/srv/Trigger   # after each prompt

``mode:=sim``: ``sim_node`` in the calibration scene (reliable frames, the load cell on
``load_cell/wrench``), driven by the procedure through its lifecycle (a fresh scene per
trial). ``mode:=hardware``: the serial sensor driver (reliable frames) and the gripper
driver (lifecycle nodes, configured and activated, parameters from ``params_file``) and the
procedure; the load cell is the lab's own driver, publishing geometry_msgs/WrenchStamped
stamped with sample times on ``load_cell_topic``. Neither starts perception or the grasp
controller: the procedure alone commands the gripper. The launch ends when the procedure
does and exits with its code (0 done, 1 trials lost, 2 refused: no data; in simulation
also 2 when the sim node dies first; :mod:`forte_commissioning.ros.launch_verdict`): the
session is in ``session_dir`` (resumable); ``forte_train_force <session_dir>/calibration.npz``
then trains the model. ``--show-args`` lists every argument.

``namespace:=NAME`` starts every node of the session in that namespace (the procedure finds
the sim node and the topics by relative names; its prompts are then answered on
``/NAME/force_calibration/continue``); ``prefix:=PREFIX`` is the TF / joint-name
prefix of the sim node or the drivers (forte_bringup.graph; e.g. to calibrate one gripper of
a robot with two).

Measured in simulation (2-core machine): ``quick:=true`` about 2 min, the full protocol
(6 x 40 trials) 18 min at the default ``real_time_factor:=4.0``; then
``forte_train_force <session_dir>/calibration.npz`` (about 15 min per CV kind for the full
set, seconds with ``--folds 0``). On the robot the session takes as long as its trials
(6 x 40 x 15 s = 1 h plus the mounting).
"""
from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from forte_bringup.graph import (
    GRAPHS,
    Argument,
    argument_settings,
    namespaced_parameter_file,
)
from forte_bringup.launch_support import node_actions
from forte_commissioning.ros.launch_verdict import ProcedureVerdict
from forte_ros.contract import check_prefix, graph_namespace

#: Every argument: name, default, description, kind of the parameter it sets.
ARGUMENTS = (
    Argument('mode', 'sim', "'sim': the simulated calibration rig (sim_node); 'hardware': "
             'the serial sensor and the Dynamixel gripper drivers'),
    Argument('session_dir', 'force_calibration_session', 'session folder (trials, bags, '
             'dataset); an unfinished session there is resumed'),
    Argument('output', '', 'calibration dataset .npz (empty: calibration.npz in session_dir)'),
    Argument('quick', 'false', 'quick protocol: 8 trials per indentor, 6 s holds '
             '(forte_sim.dataset.QUICK_PROTOCOL)', kind='bool'),
    Argument('trials_per_indentor', '', 'trials per indentor (empty: 40, or 8 with quick)',
             kind='int'),
    Argument('seed', '', 'seed of the closure draws and simulated scenes (empty: 0)',
             kind='int'),
    Argument('load_cell_topic', 'load_cell/wrench', 'load cell topic '
             '(geometry_msgs/WrenchStamped, header stamp = sample time)'),
    Argument('load_cell_axis', 'z', 'wrench.force component that reads the squeeze: x, y '
             'or z'),
    Argument('load_cell_sign', '1', 'sign that makes a squeeze positive: 1 or -1', kind='int'),
    Argument('auto_continue', 'false', 'headless: continue after each operator prompt by '
             'itself after auto_continue_delay seconds', kind='bool'),
    Argument('auto_continue_delay', '10.0', 'wait after a prompt with auto_continue [s]',
             kind='float'),
    Argument('real_time_factor', '4.0', 'mode sim: simulated seconds per wall second (the '
             'procedure must keep up: 4 is safe on 2 cores)', kind='float'),
    Argument('params_file', '', 'mode hardware: parameter YAML of the drivers (default: '
             'config/hardware.yaml of forte_bringup)'),
    Argument('sensor_port', '', 'mode hardware: serial device of the tactile sensor (empty: '
             'the YAML value)'),
    Argument('gripper_port', '', 'mode hardware: serial device of the U2D2 (empty: the '
             'YAML value)'),
    Argument('namespace', '', 'ROS namespace of every node of the session, e.g. right '
             '(empty: the root namespace)'),
    Argument('prefix', '', 'TF / joint-name prefix of the sim node or the drivers, e.g. '
             'right_ (empty: none)'),
)
#: Arguments that set a parameter of the procedure node when not empty.
PROCEDURE_PARAMETERS = ('session_dir', 'output', 'quick', 'trials_per_indentor', 'seed',
                        'load_cell_topic', 'load_cell_axis', 'load_cell_sign',
                        'auto_continue', 'auto_continue_delay')
#: Frames per message and load-cell decimation of the simulated rig (fewer, larger
#: messages let the procedure keep up faster than real time).
SIM_BATCH = 100


def _typed(context: LaunchContext) -> dict:
    values = {}
    for argument in ARGUMENTS:
        text = LaunchConfiguration(argument.name).perform(context)
        try:
            values[argument.name] = argument.typed(text) if text != '' else ''
        except ValueError as error:
            raise ValueError(f'argument {argument.name}:={text}: {error}') from error
    if values['mode'] not in ('sim', 'hardware'):
        raise ValueError(f"argument mode:={values['mode']}: expected sim or hardware")
    values['namespace'] = graph_namespace(str(values['namespace']))
    check_prefix(str(values['prefix']))
    return values


def _setup(context: LaunchContext) -> list:
    values = _typed(context)
    simulation = values['mode'] == 'sim'
    procedure = {name: values[name] for name in PROCEDURE_PARAMETERS if values[name] != ''}
    procedure.update(simulation=simulation, frames_reliable=True)
    namespace = values['namespace']
    actions = []
    if simulation:
        actions.append(Node(
            package='forte_sim', executable='sim_node', name='sim', namespace=namespace,
            output='screen', parameters=[{
                'scene': 'calibration', 'object': 'flat_wide', 'reliable': True,
                'batch_size': SIM_BATCH, 'real_time_factor': values['real_time_factor'],
                'prefix': values['prefix']}]))
    else:
        graph = GRAPHS['hardware']
        params_file = values['params_file'] or PathJoinSubstitution(
            [FindPackageShare('forte_bringup'), 'config', graph.params_file]).perform(context)
        params_file = str(namespaced_parameter_file(params_file, namespace))
        arguments = {name: str(value) for name, value in values.items()}
        for spec in graph.nodes[:2]:  # serial sensor, gripper driver
            remappings, overrides = argument_settings(spec, arguments, graph)
            if spec.name == 'serial_sensor':
                overrides['reliable'] = True
            actions += node_actions(spec, remappings, overrides, params_file,
                                    namespace=namespace)
    node = Node(package='forte_commissioning', executable='forte_calibrate_force',
                name='force_calibration', namespace=namespace, output='screen',
                parameters=[procedure])
    # the session's end (or its refusal) ends the launch, with the procedure's exit code
    verdict = ProcedureVerdict('force calibration')
    ended = [verdict.procedure_ended(node)]
    if simulation:
        ended.append(verdict.device_ended(actions[0], 'the sim node'))
    return [*actions, node, *ended]


def generate_launch_description() -> LaunchDescription:
    """Launch description of the force calibration (module docstring)."""
    declared = [DeclareLaunchArgument(argument.name, default_value=argument.default,
                                      description=argument.description)
                for argument in ARGUMENTS]
    return LaunchDescription([*declared, OpaqueFunction(function=_setup)])
