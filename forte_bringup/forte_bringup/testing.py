"""Probes of a running FORTE graph, shared by the graph tests of every package (test support).

``test_bringup.py`` starts the graphs with :class:`forte_bringup.bringup.Bringup`,
``test_launch_graphs.py`` with ``ros2 launch``'s launch files under launch_pytest; both
watch them from the test process with the same probe: a :class:`Watcher` node in an rclpy
context of its own, spun in a background thread (:func:`watching`), that counts the
graph's messages, reads lifecycle states and parameters over the nodes' services and sends
Grasp goals. Also here: a bag of a quiet sensor for the replay graph
(:func:`write_quiet_bag`), the emulated sensor and simulated servos on pseudo-terminals
for the hardware graph (:func:`emulated_devices`), the simulated-rig force model
(:func:`force_model_file`) and a command-line module run as a child process and stopped with
Ctrl-C (:func:`python_module`, :func:`interrupt`).

Imported as ``from forte_bringup.testing import ...`` by the tests of forte_bringup and
forte_commissioning and by benchmarks/bench_graph.py; its imports are test dependencies
(tools/test/test_declared_dependencies.py, ``TEST_SUPPORT``).
"""
from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import rclpy
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from forte_ros import call_in_executor, qos
from forte_ros.contract import BASE_FRAME, CHANNEL_NAMES, SAMPLE_PERIOD
from forte_ros.testing import wait_until

#: Topics :class:`Watcher` counts (``tared``: tactile states that are tared and valid).
COUNTED = ('tactile/frames', 'tactile/state', 'joint_states', 'grasp/state', 'tared')
#: Longest wait for one answer of a polled service before asking again [s].
CALL_ATTEMPT = 5.0



class Watcher(Node):
    """Counts the graph's messages and talks to its nodes' services and actions.

    Spun by an executor in another thread (:func:`watching`); the query methods are called
    from the test's thread and wait for their futures.

    Parameters
    ----------
    context : rclpy.context.Context
        The (initialised) context of the node.
    namespace : str
        Namespace of the graph it watches ('' = root): its topics, the nodes' services and
        the ``grasp`` action are resolved in it.
    """

    def __init__(self, context: Context, namespace: str = '') -> None:
        super().__init__('graph_probe', context=context, namespace=namespace or None)
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState

        from forte_msgs.msg import GraspState, SimGroundTruth, TactileFrames, TactileState

        self.counts = dict.fromkeys(COUNTED, 0)
        self.last_grasp_state = None
        #: Latest ``sim/ground_truth`` (forte_msgs/SimGroundTruth) of the simulated scene.
        self.truth = None
        self.joint_positions: list[float] = []
        #: Joint names of the latest ``joint_states``.
        self.joint_names: list[str] = []
        #: Latest header frame_id per counted topic (and ``sim/ground_truth``).
        self.frame_ids: dict[str, str] = {}
        #: Latest /diagnostics status per status name (diagnostic_msgs/DiagnosticStatus).
        self.statuses: dict[str, Any] = {}
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                 qos.DIAGNOSTICS)
        self.create_subscription(TactileFrames, 'tactile/frames',
                                 lambda m: self._count('tactile/frames', m), qos.SENSOR_FRAMES)
        self.create_subscription(TactileState, 'tactile/state', self._on_state,
                                 qos.TACTILE_STATE)
        self.create_subscription(JointState, 'joint_states', self._on_joint_state, qos.COMMANDS)
        self.create_subscription(GraspState, 'grasp/state', self._on_grasp_state,
                                 qos.GRASP_STATE)
        self.create_subscription(SimGroundTruth, 'sim/ground_truth', self._on_truth,
                                 qos.GROUND_TRUTH)

    # -- counting ---------------------------------------------------------------------------
    def _count(self, topic: str, message: Any = None) -> None:
        self.counts[topic] += 1
        if message is not None:
            self.frame_ids[topic] = message.header.frame_id

    def _on_state(self, message: Any) -> None:
        self._count('tactile/state', message)
        self.counts['tared'] += int(message.tared and message.data_valid)

    def _on_joint_state(self, message: Any) -> None:
        self.counts['joint_states'] += 1
        self.joint_positions = list(message.position)
        self.joint_names = list(message.name)

    def _on_grasp_state(self, message: Any) -> None:
        self._count('grasp/state', message)
        self.last_grasp_state = message

    def _on_truth(self, message: Any) -> None:
        self.truth = message
        self.frame_ids['sim/ground_truth'] = message.header.frame_id

    def node_path(self, node: str) -> str:
        """Fully qualified name of ``node`` in this probe's namespace."""
        return f'{self.get_namespace().rstrip("/")}/{node}'

    def _on_diagnostics(self, message: Any) -> None:
        for status in message.status:
            self.statuses[status.name] = status

    def status_values(self, name: str) -> dict[str, str]:
        """Key -> value of the latest /diagnostics status ``name`` ({} before one came)."""
        status = self.statuses.get(name)
        return {item.key: item.value for item in status.values} if status else {}

    # -- services ---------------------------------------------------------------------------
    def call(self, service_type: Any, name: str, request: Any, timeout: float) -> Any:
        """Call a service and wait for the answer.

        Parameters
        ----------
        service_type : type
            Service class, e.g. ``lifecycle_msgs.srv.GetState``.
        name : str
            Service name.
        request : object
            The request.
        timeout : float
            Longest wait for the service and for its answer [s].

        Returns
        -------
        object or None
            The response; None if the service did not appear or answer in time.
        """
        client = self.create_client(service_type, name)
        try:
            if not client.wait_for_service(timeout_sec=timeout):
                return None
            future = client.call_async(request)
            if not wait_until(future.done, timeout):
                return None
            return future.result()
        finally:
            self.destroy_client(client)

    def lifecycle_state(self, node: str, timeout: float = 10.0) -> str | None:
        """Current lifecycle state label of ``node`` from ``/<node>/get_state``.

        Returns
        -------
        str or None
            ``unconfigured``, ``inactive``, ``active``, ``configuring``, ...; None if the
            service did not answer.
        """
        from lifecycle_msgs.srv import GetState

        response = self.call(GetState, f'{self.node_path(node)}/get_state', GetState.Request(),
                             timeout)
        return None if response is None else response.current_state.label

    def wait_for_lifecycle_state(self, node: str, label: str, timeout: float) -> str | None:
        """Poll ``/<node>/get_state`` until it reports ``label``.

        Used to let every transition a launch requested finish (the launch's ChangeState
        calls are answered once the node is in the final state) before the launch is shut
        down. Each call waits at most :data:`CALL_ATTEMPT` seconds: a request sent as soon as
        the service is discovered can reach the server before the server has matched this
        client's reply reader, and its answer is then lost; a fresh call is not.

        Returns
        -------
        str or None
            The last state seen (``label`` if it was reached in time).
        """
        deadline = time.monotonic() + timeout
        state = None
        while time.monotonic() < deadline:
            remaining = deadline - time.monotonic()
            state = self.lifecycle_state(node, min(CALL_ATTEMPT, max(1.0, remaining)))
            if state == label:
                return state
            time.sleep(0.2)
        return state

    def wait_for_graph_active(self, graph: str, timeout: float) -> dict[str, str | None]:
        """Wait until every lifecycle node of ``graph`` reports ``active``.

        A test must not end while a transition its launch asked for is still under way:
        launch_ros calls ``change_state`` from a worker thread, and a launch shut down during
        that call destroys the client under it (``InvalidHandle``: the launch service then
        exits 1). Waiting for every lifecycle node of the graph, not only the one the test
        reads, leaves no transition pending.

        Parameters
        ----------
        graph : str
            A key of :data:`forte_bringup.graph.GRAPHS`.
        timeout : float
            Longest wait for each node [s].

        Returns
        -------
        dict
            Node name -> the last state seen (``'active'`` for each node that got there).
        """
        from forte_bringup.graph import GRAPHS

        return {spec.name: self.wait_for_lifecycle_state(spec.name, 'active', timeout)
                for spec in GRAPHS[graph].nodes if spec.lifecycle}

    def parameter(self, node: str, name: str, timeout: float = 10.0) -> Any:
        """Value of parameter ``name`` of ``node`` (``/<node>/get_parameters``).

        Returns
        -------
        object or None
            The value as a Python bool / int / float / str (None: not set or no answer).
        """
        from rcl_interfaces.srv import GetParameters
        from rclpy.parameter import parameter_value_to_python

        response = self.call(GetParameters, f'{self.node_path(node)}/get_parameters',
                             GetParameters.Request(names=[name]), timeout)
        if response is None or not response.values:
            return None
        return parameter_value_to_python(response.values[0])

    # -- Grasp action -----------------------------------------------------------------------
    def grasp(self, goal: Any, timeout: float) -> tuple[bool, Any, list]:
        """Send a ``grasp`` goal (forte_msgs/action/Grasp) and wait for its result.

        Parameters
        ----------
        goal : Grasp.Goal
            The goal.
        timeout : float
            Longest wait for the server, the acceptance and the result, each [s].

        Returns
        -------
        accepted : bool
            Whether the server accepted the goal.
        result : Grasp.Result or None
            The result (None if rejected or not answered in time).
        feedback : list
            Feedback messages received.
        """
        from forte_msgs.action import Grasp

        client = ActionClient(self, Grasp, 'grasp')
        try:
            assert client.wait_for_server(timeout_sec=timeout), 'no grasp action server'
            feedback: list = []
            future = call_in_executor(self.executor, client.send_goal_async, goal,
                                      feedback.append)
            assert wait_until(future.done, timeout), 'goal not answered'
            handle = future.result()
            if not handle.accepted:
                return False, None, feedback
            result_future = call_in_executor(self.executor, handle.get_result_async)
            if not wait_until(result_future.done, timeout):
                return True, None, feedback
            return True, result_future.result().result, feedback
        finally:
            self.destroy_action_client(client)

    def grasp_once_inputs_flow(self, goal: Any, timeout: float, attempts: int = 3
                               ) -> tuple[bool, Any, list]:
        """:meth:`grasp`, sent again (at most ``attempts`` times, 1 s apart) while the
        controller refuses it before any motion because an input was stale.

        On two shared cores a graph's process can be starved for longer than the
        controller's freshness bounds (0.5 s); the controller then rightly refuses the goal
        before moving anything, and a test about the grasp itself asks again. Every refusal
        is printed.
        """
        for attempt in range(1, attempts):
            accepted, result, feedback = self.grasp(goal, timeout)
            if result is None or 'refused before any motion' not in result.message \
                    or 'STALE' not in result.message:
                return accepted, result, feedback
            print(f'grasp attempt {attempt} of {attempts}: {result.message}; asking again')
            time.sleep(1.0)
        return self.grasp(goal, timeout)

    def destroy_action_client(self, client: Any) -> None:
        """Destroy an action client of this probe in its executor's thread.

        Destroyed from the test's thread, the client's handle could be freed while the
        spinning thread adds it to a wait set (RCLError "action client pointer is invalid",
        which kills the spin thread); a probe whose executor no longer spins destroys it here.
        """
        try:
            call_in_executor(self.executor, client.destroy, timeout=5.0)
        except TimeoutError:
            client.destroy()


@contextmanager
def watching(namespace: str = '') -> Iterator[Watcher]:
    """A :class:`Watcher` in an rclpy context of its own, spun in a background thread.

    The context installs no signal handlers: the test process's SIGINT handling (pytest's,
    a launch service's) stays as it is. ``namespace``: the graph's namespace ('' = root).
    """
    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    executor = SingleThreadedExecutor(context=context)
    node = Watcher(context, namespace)
    executor.add_node(node)
    closing = threading.Event()

    def spin() -> None:
        while not closing.is_set() and context.ok():
            executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        yield node
    finally:
        # the thread ends before the executor's guard conditions and the node go (a spin
        # still waiting on a destroyed guard condition raised in the thread)
        closing.set()
        thread.join(timeout=5)
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


@contextmanager
def python_module(module: str, *arguments: str) -> Iterator[subprocess.Popen]:
    """``python -m <module> <arguments>`` as a child process (this environment).

    Its stdout and stderr are merged into one text pipe; it is killed on leaving the block
    if it is still running (a test that failed before stopping it).
    """
    process = subprocess.Popen([sys.executable, '-m', module, *arguments],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def interrupt(process: subprocess.Popen, timeout: float) -> str:
    """Send SIGINT (Ctrl-C) to ``process``; the rest of its output once it has exited.

    Raises
    ------
    subprocess.TimeoutExpired
        If it has not exited within ``timeout`` s.
    """
    process.send_signal(signal.SIGINT)
    output, _ = process.communicate(timeout=timeout)
    return output


def write_quiet_bag(path: Path, messages: int = 600, first_second: int = 1000,
                    seed: int = 0) -> Path:
    """Write a bag of a quiet sensor (``tactile/frames`` at 2 kHz) with the project's writer.

    Parameters
    ----------
    path : Path
        Bag folder to create.
    messages : int
        TactileFrames messages of 20 samples (100 per second of recording).
    first_second : int
        Header stamp and log time of the first message [s].
    seed : int
        Seed of the sensor noise.

    Returns
    -------
    Path
        ``path``.
    """
    import numpy as np
    from rclpy.serialization import serialize_message

    from forte_driver.replay.bags import BagWriter, TopicSpec
    from forte_msgs.msg import TactileFrames

    rng = np.random.default_rng(seed)
    with BagWriter(path) as writer:
        writer.add_topic(TopicSpec('tactile/frames', 'forte_msgs/msg/TactileFrames'))
        for index in range(messages):
            message = TactileFrames(sample_count=20, sample_period=SAMPLE_PERIOD,
                                    first_sequence=20 * index)
            message.header.stamp.sec = first_second + index // 100
            message.header.stamp.nanosec = (index % 100) * 10_000_000
            message.header.frame_id = BASE_FRAME
            message.channel_names = list(CHANNEL_NAMES)
            message.data = (0.05 + rng.normal(0.0, 0.001, 120)).tolist()
            writer.write('tactile/frames', first_second * 10**9 + index * 10**7,
                         serialize_message(message))
    return path


@contextmanager
def _device_processes(commands: list[list[str]], links: tuple[Path, Path], timeout: float,
                      what: str) -> Iterator[tuple[Path, Path]]:
    """Run ``python -m <command>`` for each of ``commands`` until they created ``links``;
    on exit stop each with SIGINT (SIGKILL after 10 s). Each one's output goes to
    ``<module>.log`` beside the first link (what a failing test shows)."""
    links[0].parent.mkdir(parents=True, exist_ok=True)
    processes = []
    for command in commands:
        with open(links[0].parent / f'{command[0].rsplit(".", 1)[-1]}.log', 'w') as log:
            processes.append(subprocess.Popen([sys.executable, '-m', *command], stdout=log,
                                              stderr=subprocess.STDOUT))
    try:
        assert wait_until(lambda: all(link.exists() for link in links), timeout), (
            f'{what} did not create {" and ".join(str(link) for link in links)}')
        yield links
    finally:
        for process in processes:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(5)


def emulated_devices(folder: Path, timeout: float = 20.0):
    """The emulated tactile sensor and the simulated Dynamixel pair on pseudo-terminals.

    Runs ``python -m forte_driver.emulators.emulated_sensor --link <folder>/forte_sensor``
    and ``python -m forte_driver.emulators.simulated_servo --link <folder>/forte_gripper``;
    stops both with SIGINT (SIGKILL after 10 s) on exit. A context manager yielding the
    sensor's and the gripper's device links (ports of the hardware graph).
    """
    sensor_link, servo_link = folder / 'forte_sensor', folder / 'forte_gripper'
    return _device_processes(
        [['forte_driver.emulators.emulated_sensor', '--link', str(sensor_link)],
         ['forte_driver.emulators.simulated_servo', '--link', str(servo_link)]],
        (sensor_link, servo_link), timeout, 'the emulated devices')


def bench_twin(folder: Path, object_name: str, seed: int, timeout: float = 30.0,
               scene: str = 'grasp'):
    """The bench twin node (``python -m forte_sim.ros.bench_twin_node``): both bench devices
    driven by one ``scene`` of ``object_name`` (an indentor in the calibration scene), the
    arm on ``arm/cmd_vel``, the truth on ``sim/ground_truth`` (and the load cell on
    ``load_cell/wrench`` in the calibration scene); stopped with SIGINT (SIGKILL after 10 s)
    on exit. A context manager yielding the sensor's and the gripper's device links.
    """
    sensor_link, servo_link = folder / 'bench' / 'sensor', folder / 'bench' / 'gripper'
    return _device_processes(
        [['forte_sim.ros.bench_twin_node', '--ros-args', '-p', f'sensor_link:={sensor_link}',
          '-p', f'servo_link:={servo_link}', '-p', f'object:={object_name}',
          '-p', f'seed:={seed}', '-p', f'scene:={scene}']],
        (sensor_link, servo_link), timeout, 'the bench twin')


def force_model_file(path: Path) -> Path:
    """Save the simulated-rig force model (cached across runs) to ``path`` and return it."""
    from forte_evaluation.sim_force_model import default_force_model

    default_force_model().save(path)
    return path
