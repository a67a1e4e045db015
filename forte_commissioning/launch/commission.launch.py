"""Sensor commissioning of a FORTE gripper: the hardware graph and ``forte_commission``; the
launch ends when the commissioning does and exits with its verdict, as ``forte_commission``
does: 0 PASS, 1 FAIL, 2 no data (a device that died, the bench twin's links that never
came; :mod:`forte_commissioning.ros.launch_verdict`).

On the robot (the operator presses each finger when the terminal says so; the rig's
indentor stands between the open fingers for the leak test)::

    ros2 launch forte_commissioning commission.launch.py sensor_port:=/dev/forte_sensor \\
        gripper_port:=/dev/forte_gripper output:=$PWD/commissioning

On the bench twin (its scripted operator presses; optionally with an injected fault)::

    ros2 launch forte_commissioning commission.launch.py target:=bench_twin \\
        sensor_fault:=reversed:left_middle output:=$PWD/commissioning

``target:=bench_twin`` also starts ``bench_twin_node`` (forte_sim) on the rig's scene
(``scene:=calibration``, the indentor ``indentor``), whose device links become the ports of
the hardware graph. The report (``report.txt``, ``report.png``, ``recording.npz``) goes to
``output``. ``ros2 launch forte_commissioning commission.launch.py --show-args`` lists the
arguments.

One gripper of several on a ROS domain::

    ros2 launch forte_commissioning commission.launch.py target:=bench_twin namespace:=right \\
        prefix:=right_ output:=$PWD/commissioning_right

``namespace:=NAME`` starts every node (the hardware graph, ``forte_commission``, the bench
twin) in that namespace, as the main graphs do (forte_bringup.graph, launch_support);
``prefix:=PREFIX`` is the TF / joint-name prefix of the drivers, of the joints
``forte_commission`` reads and of the bench twin's frame. The bench twin's default links are
then ``/tmp/forte_bench/NAME/sensor`` and ``.../gripper``, so that two twins do not share one.
"""
import sys

from launch import LaunchContext, LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    ExecuteProcess,
    IncludeLaunchDescription,
    OpaqueFunction,
    RegisterEventHandler,
)
from launch.event_handlers import OnProcessExit
from launch.events.process import ProcessExited
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from forte_bringup.graph import Argument
from forte_commissioning.ros.launch_verdict import ProcedureVerdict
from forte_ros.contract import check_prefix, graph_namespace

#: Every argument, typed (a bad value stops the launch with the reason).
ARGUMENTS = (
    Argument('target', 'hardware', 'hardware: the gripper on sensor_port / gripper_port; '
             'bench_twin: also start the bench twin and let its scripted operator press'),
    Argument('sensor_port', '', 'serial device of the tactile sensor (bench_twin: the '
             'link the twin creates; empty: /tmp/forte_bench/sensor)'),
    Argument('gripper_port', '', 'serial device of the Dynamixel interface (bench_twin: the '
             'link the twin creates; empty: /tmp/forte_bench/gripper)'),
    Argument('output', 'commissioning', 'folder of report.txt, report.png, recording.npz'),
    Argument('headless', 'auto', 'true: the bench twin presses (sim/operator_press); '
             'false: the operator is prompted; auto: true for bench_twin'),
    Argument('press_force', '4.0', 'force of the bench twin\'s presses [N]', 'float'),
    Argument('squeeze_current', '0.25', 'servo current limit of the leak test\'s squeeze [A]',
             'float'),
    Argument('squeeze_seconds', '12.0', 'hold of the leak test [s]', 'float'),
    Argument('sensor_fault', '', 'bench_twin: sensor faults injected into the readings, '
             'e.g. reversed:left_middle (forte_sim bench_twin_node sensor_fault)'),
    Argument('seed', '0', 'bench_twin: seed of the simulated rig', 'int'),
    Argument('indentor', 'flat_wide', 'bench_twin: the rig\'s indentor (forte_sim.INDENTORS)'),
    Argument('device_timeout', '120.0', 'bench_twin: longest wait for the twin\'s device '
             'links before the drivers start [s]', 'float'),
    Argument('namespace', '', 'ROS namespace of every node, topic, service and action of the '
             'commissioning (hardware graph, forte_commission, bench twin), e.g. right; '
             'bench_twin links default to /tmp/forte_bench/<namespace>/; empty: the root '
             'namespace'),
    Argument('prefix', '', 'TF / joint-name prefix of the gripper: its drivers publish and '
             'forte_commission reads <prefix>forte_left_finger_joint ..., e.g. right_ '
             '(empty: none)'),
)
TARGETS = ('hardware', 'bench_twin')
BENCH_FOLDER = '/tmp/forte_bench'


def bench_links(namespace: str) -> tuple[str, str]:
    """Default sensor and gripper links of the bench twin in ``namespace``.

    Parameters
    ----------
    namespace : str
        Absolute namespace ('' = root; forte_ros.contract.graph_namespace).

    Returns
    -------
    tuple of str
        ``<BENCH_FOLDER><namespace>/sensor`` and ``.../gripper``.
    """
    return (f'{BENCH_FOLDER}{namespace}/sensor', f'{BENCH_FOLDER}{namespace}/gripper')


#: Waits (``python -c``) until every path of argv[2:] exists, at most argv[1] seconds;
#: exit code 1 on a timeout.
WAIT_FOR_LINKS = ('import os, sys, time\n'
                  'deadline = time.monotonic() + float(sys.argv[1])\n'
                  'while not all(os.path.exists(path) for path in sys.argv[2:]):\n'
                  '    if time.monotonic() > deadline:\n'
                  '        sys.exit(1)\n'
                  '    time.sleep(0.2)\n')


def _values(context: LaunchContext) -> dict[str, object]:
    values = {}
    for argument in ARGUMENTS:
        text = LaunchConfiguration(argument.name).perform(context)
        try:
            values[argument.name] = argument.typed(text)
        except ValueError as error:
            raise ValueError(f'{argument.name}:={text!r}: {error}') from None
    if values['target'] not in TARGETS:
        raise ValueError(f"target:={values['target']!r}: expected one of {TARGETS}")
    if values['headless'] not in ('auto', 'true', 'false'):
        raise ValueError(f"headless:={values['headless']!r}: expected auto, true or false")
    values['namespace'] = graph_namespace(values['namespace'])
    check_prefix(values['prefix'])
    return values


def _actions(context: LaunchContext) -> list:
    values = _values(context)
    twin = values['target'] == 'bench_twin'
    namespace, prefix = values['namespace'], values['prefix']
    links = bench_links(namespace) if twin else ('', '')
    sensor = values['sensor_port'] or links[0]
    gripper = values['gripper_port'] or links[1]
    headless = values['headless'] == 'true' or (values['headless'] == 'auto' and twin)
    hardware = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(PathJoinSubstitution(
            [FindPackageShare('forte_bringup'), 'launch', 'hardware.launch.py'])),
        launch_arguments={'sensor_port': sensor, 'gripper_port': gripper,
                          'namespace': namespace, 'prefix': prefix}.items())
    arguments = ['--yes', '--output', str(values['output']),
                 '--press-force', str(values['press_force']),
                 '--squeeze-current', str(values['squeeze_current']),
                 '--squeeze-seconds', str(values['squeeze_seconds'])]
    commission = Node(package='forte_commissioning', executable='forte_commission',
                      name='forte_commission', namespace=namespace, output='screen',
                      parameters=[{'prefix': prefix}],
                      arguments=arguments + (['--headless'] if headless else []))
    verdict = ProcedureVerdict('commissioning')
    actions = [commission, verdict.procedure_ended(commission)]
    if not twin:
        return [hardware, *actions]
    bench = Node(package='forte_sim', executable='bench_twin_node', name='bench_twin',
                 namespace=namespace, output='screen', parameters=[{
                     'scene': 'calibration', 'object': values['indentor'],
                     'seed': values['seed'], 'sensor_fault': values['sensor_fault'],
                     'sensor_link': sensor, 'servo_link': gripper,
                     'prefix': prefix}])
    # the drivers open the twin's links once they exist (the twin's servo process takes
    # seconds to start on a loaded machine, longer than the drivers retry a configure)
    wait = ExecuteProcess(cmd=[sys.executable, '-c', WAIT_FOR_LINKS,
                               str(values['device_timeout']), sensor, gripper],
                          name='wait_for_bench_twin', output='screen')

    def after_wait(event: ProcessExited, context: LaunchContext) -> list:
        if event.returncode != 0:
            return verdict.no_data(context, 'the bench twin\'s links did not appear within '
                                            f'{values["device_timeout"]:g} s')
        return [hardware, *actions]

    return [bench, verdict.device_ended(bench, 'the bench twin'), wait,
            RegisterEventHandler(OnProcessExit(target_action=wait, on_exit=after_wait))]


def generate_launch_description() -> LaunchDescription:
    """Launch description of the commissioning run."""
    return LaunchDescription(
        [DeclareLaunchArgument(argument.name, default_value=argument.default,
                               description=argument.description) for argument in ARGUMENTS]
        + [OpaqueFunction(function=_actions)])
