"""Test helpers: a node executable as a child process, and an rclpy probe to talk to it.

Used by the shutdown and lifecycle tests of every FORTE package, which start the real
console scripts, let them publish, stop them with SIGINT or SIGTERM and check the exit
code, the time to exit and the output.

:class:`NodeProcess` refuses to start unless ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and
a ``ROS_DOMAIN_ID`` are set (the tests' conftest does it with
``forte_ros.isolation.isolate_ros_network``): no DDS traffic leaves loopback.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile

#: Words whose presence in a node's output means it did not stop cleanly.
FAILURE_MARKERS = ('Traceback', 'RCLError', 'InvalidHandle', 'Exception ignored')


def ros_args(**parameters: Any) -> list[str]:
    """``--ros-args -p name:=value ...`` for ``parameters`` (bools as true/false)."""
    words = ['--ros-args']
    for name, value in parameters.items():
        if isinstance(value, bool):
            text = 'true' if value else 'false'
        elif isinstance(value, (list, tuple)):
            text = '[' + ', '.join(repr(item) for item in value) + ']'
        else:
            text = str(value)
        words += ['-p', f'{name}:={text}']
    return words


def check_isolated_network() -> None:
    """Raise unless DDS discovery is confined to this machine and a domain id is set."""
    if os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') != 'LOCALHOST' or not os.environ.get(
            'ROS_DOMAIN_ID'):
        raise RuntimeError('set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a private '
                           'ROS_DOMAIN_ID first (forte_ros.isolation)')


def find_executable(name: str) -> str:
    """A node executable found as ``ros2 run`` finds it, else on ``PATH``.

    colcon installs console scripts in ``<prefix>/lib/<package>/``, which is not on
    ``PATH``; a name containing ``/`` is returned unchanged.

    Raises
    ------
    FileNotFoundError
        If no prefix on ``AMENT_PREFIX_PATH`` and no ``PATH`` entry has it.
    """
    if '/' in name:
        return name
    for prefix in filter(None, os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)):
        for candidate in sorted(Path(prefix, 'lib').glob(f'*/{name}')):
            if candidate.is_file() and os.access(candidate, os.X_OK):
                return str(candidate)
    found = shutil.which(name)
    if found is None:
        raise FileNotFoundError(f'{name}: in no <prefix>/lib/<package>/ of AMENT_PREFIX_PATH '
                                'and not on PATH (source install/setup.bash)')
    return found


class NodeProcess:
    """A node executable in a child process; stdout and stderr are collected (merged).

    Parameters
    ----------
    command : list of str
        Executable and arguments, e.g. ``['sim_node', *ros_args(autostart=True)]``; a bare
        executable name is found with :func:`find_executable`.
    env : dict, optional
        Extra environment variables.
    """

    def __init__(self, command: list[str], env: dict[str, str] | None = None) -> None:
        check_isolated_network()
        command = [find_executable(command[0]), *command[1:]]
        self.command = command
        self._lines: list[str] = []
        self._lock = threading.Lock()
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
            env={**os.environ, 'PYTHONUNBUFFERED': '1', **(env or {})})
        self._pump = threading.Thread(target=self._read, daemon=True)
        self._pump.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            with self._lock:
                self._lines.append(line)

    @property
    def output(self) -> str:
        """Everything the process wrote so far."""
        with self._lock:
            return ''.join(self._lines)

    def wait_for_output(self, text: str, timeout: float = 20.0) -> bool:
        """Wait until ``text`` appears in the output (False on timeout or exit)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output:
                return True
            if self.process.poll() is not None:
                self._pump.join(timeout=2.0)
                return text in self.output
            time.sleep(0.05)
        return text in self.output

    def stop(self, signum: int = signal.SIGINT, timeout: float = 10.0) -> tuple[int | None, float]:
        """Send ``signum`` and wait for the exit.

        Returns
        -------
        tuple
            ``(exit code, seconds from the signal to the exit)``; the code is None if the
            process had to be killed after ``timeout``.
        """
        started = time.monotonic()
        if self.process.poll() is None:
            self.process.send_signal(signum)
        try:
            code = self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            return None, time.monotonic() - started
        elapsed = time.monotonic() - started
        self._pump.join(timeout=5.0)
        return code, elapsed

    def stop_cleanly(self, signum: int = signal.SIGINT, within: float = 5.0) -> float:
        """Send ``signum`` and assert the clean stop of docs/contracts.md: the signal is
        acknowledged (``<SIGNAME> received: stopping``), exit code 0 within ``within`` [s],
        no traceback or error marker in the output. Returns the seconds it took."""
        code, elapsed = self.stop(signum, timeout=3 * within)
        name = signal.Signals(signum).name
        print(f'{Path(self.command[0]).name} {name}: stopped in {elapsed:.3f} s')
        assert code == 0, f'exit code {code} after {name}:\n{self.output}'
        assert elapsed < within, f'{elapsed:.2f} s to stop after {name}:\n{self.output}'
        assert not self.failures(), self.output
        assert f'{name} received: stopping' in self.output, self.output
        return elapsed

    def kill(self) -> None:
        """SIGKILL if still running (test clean-up)."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait(10.0)
        self._pump.join(timeout=5.0)

    def failures(self) -> list[str]:
        """Output lines that show an unclean stop (see :data:`FAILURE_MARKERS`)."""
        return [line for line in self.output.splitlines()
                if any(marker in line for marker in FAILURE_MARKERS)]

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.kill()


def wait_until(condition: Callable[[], Any], timeout: float = 20.0,
               period: float = 0.05) -> Any:
    """Poll ``condition`` until it returns a true value or ``timeout`` [s] passes."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(period)
    return condition()


class SpinningGraph:
    """Nodes of one test in a private context, spun by one SingleThreadedExecutor in a thread.

    The set-up every in-process node test needs: a context of its own (tests in one process
    never share DDS state), a listener node for the test's subscriptions, a spinning thread,
    and a close that stops the thread before the nodes are destroyed. Single-threaded: rclpy
    7.1.6's MultiThreadedExecutor re-dispatches ready work in a loop (ros2/rclpy#1452).

    Parameters
    ----------
    name : str
        Node name of the listener (the test's own node, :attr:`node`).

    Examples
    --------
    >>> graph = SpinningGraph()
    >>> driver = graph.add(SerialSensorNode(context=graph.context))
    >>> frames = graph.collect(TactileFrames, 'tactile/frames', qos)
    >>> graph.start(); wait_until(lambda: frames); graph.close()
    """

    def __init__(self, name: str = 'forte_test_listener') -> None:
        check_isolated_network()
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._nodes = [self.node]
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None

    def add(self, node: Any) -> Any:
        """Spin ``node`` (created with ``context=self.context``) too; returns it."""
        self.executor.add_node(node)
        self._nodes.append(node)
        return node

    def collect(self, message_type: type, topic: str, qos: QoSProfile | int = 10,
                arrival_times: bool = False) -> list:
        """A list that receives every message on ``topic`` (``(time.monotonic(), message)``
        pairs with ``arrival_times``)."""
        received: list = []
        if arrival_times:
            self.node.create_subscription(
                message_type, topic, lambda message: received.append((time.monotonic(), message)),
                qos)
        else:
            self.node.create_subscription(message_type, topic, received.append, qos)
        return received

    def start(self) -> SpinningGraph:
        """Start spinning in a daemon thread; returns self."""
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        return self

    def _spin(self) -> None:
        while not self._closing.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def stop(self) -> None:
        """Stop spinning; the nodes still exist (for a clean-up of their own before
        :meth:`close`)."""
        self._closing.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.executor.shutdown(timeout_sec=1.0)

    def close(self) -> None:
        """:meth:`stop`, destroy every node (last added first), shut the context down."""
        self.stop()
        for node in reversed(self._nodes):
            node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> SpinningGraph:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class Probe(SpinningGraph):
    """A spinning node of its own that counts messages and calls services.

    Parameters
    ----------
    name : str
        Node name of the probe.
    """

    def __init__(self, name: str = 'forte_test_probe') -> None:
        super().__init__(name)
        self.counts: dict[str, int] = {}
        self._clients: dict[tuple[type, str], Any] = {}
        self.start()

    def count(self, message_type: type, topic: str, qos: QoSProfile | int = 10) -> None:
        """Count the messages on ``topic`` in ``counts[topic]``."""
        self.counts[topic] = 0

        def on_message(_message: Any) -> None:
            self.counts[topic] += 1

        self.node.create_subscription(message_type, topic, on_message, qos)

    def wait_for_messages(self, topic: str, at_least: int, timeout: float) -> bool:
        """True once ``at_least`` more messages arrived on the counted ``topic`` than when
        called, False after ``timeout`` [s]."""
        before = self.counts[topic]
        return wait_until(lambda: self.counts[topic] >= before + at_least, timeout)

    def call(self, service_type: type, name: str, request: Any,
             timeout: float = 10.0) -> Any | None:
        """Call a service; the response, or None if none answered within ``timeout``."""
        client = self._clients.get((service_type, name))
        if client is None:
            client = self._clients[(service_type, name)] = self.node.create_client(
                service_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        future = client.call_async(request)
        if not wait_until(future.done, timeout, period=0.01):
            return None
        return future.result()

    def change_state(self, node: str, transition_id: int = 0, label: str = '') -> bool | None:
        """``<node>/change_state``: its ``success``, or None without an answer."""
        request = ChangeState.Request()
        request.transition.id = transition_id
        request.transition.label = label
        response = self.call(ChangeState, f'{node}/change_state', request)
        return None if response is None else response.success

    def state(self, node: str) -> str | None:
        """``<node>/get_state``: the label of the current state, or None without an answer."""
        response = self.call(GetState, f'{node}/get_state', GetState.Request())
        return None if response is None else response.current_state.label


def launch_file_actions(path: str | Path, **arguments: str) -> tuple[Any, list]:
    """What a launch file amounts to for ``arguments``, as ``ros2 launch`` would evaluate
    it, with nothing started.

    The declared arguments are evaluated first (the given values, the defaults for the
    rest), ``SetLaunchConfiguration`` actions applied, and every ``OpaqueFunction``,
    included launch file and nested ``LaunchDescription`` opened in place.

    Parameters
    ----------
    path : str or Path
        The ``.launch.py`` file.
    **arguments : str
        Launch arguments, as typed after ``ros2 launch`` (``name:=value``).

    Returns
    -------
    tuple
        ``(context, actions)``: the launch context after evaluation (its
        ``launch_configurations`` hold every argument's value) and the remaining actions
        (launch_ros ``Node``, ``ExecuteProcess``, ``LogInfo``, ...) in launch order.
    """
    import launch
    from launch.actions import (
        DeclareLaunchArgument,
        IncludeLaunchDescription,
        OpaqueFunction,
        SetLaunchConfiguration,
    )
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    def expand(entities: list, context: Any) -> list:
        actions = []
        for entity in entities:
            if isinstance(entity, (DeclareLaunchArgument, SetLaunchConfiguration)):
                entity.execute(context)
            elif isinstance(entity, (OpaqueFunction, IncludeLaunchDescription)):
                actions += expand(entity.execute(context) or [], context)
            elif isinstance(entity, launch.LaunchDescription):
                actions += expand(entity.entities, context)
            else:
                actions.append(entity)
        return actions

    context = launch.LaunchContext()
    context.launch_configurations.update(arguments)
    source = PythonLaunchDescriptionSource(str(path))
    return context, expand(source.get_launch_description(context).entities, context)


def launch_file_description(path: str | Path) -> Any:
    """The ``LaunchDescription`` of a ``.launch.py`` file (its declared arguments:
    ``get_launch_arguments()``), nothing evaluated."""
    import launch
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    return PythonLaunchDescriptionSource(str(path)).get_launch_description(
        launch.LaunchContext())


def gripper_goal(position: float, max_effort: float = 0.0) -> Any:
    """A ``control_msgs/action/GripperCommand`` goal: ``position`` [rad] of each finger
    joint, ``max_effort`` (0 = the driver's default)."""
    from control_msgs.action import GripperCommand

    goal = GripperCommand.Goal()
    goal.command.position = float(position)
    goal.command.max_effort = float(max_effort)
    return goal


def parallel_gripper_goal(names: list[str], positions: list[float],
                          velocity: list[float] = (), effort: list[float] = ()) -> Any:
    """A ``control_msgs/action/ParallelGripperCommand`` goal: one entry per named joint
    (positions [rad], velocities [rad/s], efforts; empty lists leave the defaults)."""
    from control_msgs.action import ParallelGripperCommand

    goal = ParallelGripperCommand.Goal()
    goal.command.name = list(names)
    goal.command.position = [float(value) for value in positions]
    goal.command.velocity = [float(value) for value in velocity]
    goal.command.effort = [float(value) for value in effort]
    return goal
