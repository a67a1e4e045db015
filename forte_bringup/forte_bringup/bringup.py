"""``forte_bringup``: bring up a FORTE graph on a machine without ``ros2 launch``.

Starts the same node executables as ``launch/<graph>.launch.py`` (from
:data:`forte_bringup.graph.GRAPHS`) as child processes with the same node names, the same
parameter YAML (``--ros-args --params-file``) and the same remappings; configures and
activates the lifecycle nodes through their ``change_state`` services
(lifecycle_msgs/srv/ChangeState); prefixes and logs every child's output; and on Ctrl-C
(or SIGTERM, or a child exiting) deactivates the lifecycle nodes and stops every child
(SIGINT, then SIGTERM, then SIGKILL after timeouts).

Usage::

    forte_bringup sim                              # simulated scene + perception + control
    forte_bringup sim object:=soda_can record:=true
    forte_bringup replay bag:=out/bags/run1 rate:=2.0
    forte_bringup hardware sensor_port:=/dev/forte_sensor gripper_port:=/dev/forte_gripper \\
        arm_cmd_vel_topic:=/servo_node/delta_twist_cmds
    forte_bringup sim namespace:=right prefix:=right_   # a second gripper on the domain

Arguments are the launch files' (``name:=value``; ``forte_bringup <graph> --help`` lists
them), ``visualization:=false`` and ``robot_state_publisher:=false`` among them; where
robot_state_publisher is not installed one line says so and the graph runs without it.
ROS network: unless ``--domain-id`` is given or ``ROS_DOMAIN_ID`` is set, a free domain id
is reserved; discovery is always confined to this machine
(:func:`forte_ros.isolation.isolate_ros_network`). The id is printed so that other
terminals can join (``export ROS_DOMAIN_ID=<id> ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
"""
from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any, TextIO

from forte_bringup.graph import (
    GRAPHS,
    RECORDER,
    TRANSITION_ATTEMPTS,
    TRANSITION_RETRY_DELAY,
    GraphSpec,
    NodeSpec,
    argument_settings,
    clock_remappings,
    namespaced_parameter_file,
    node_arguments,
    overlay_nodes,
    parameter_text,
    params_file,
    recorder_topics,
)
from forte_bringup.graph_nodes import force_model_source, prepare_force_model, started_nodes
from forte_ros.contract import graph_namespace
from forte_ros.isolation import isolate_ros_network

#: lifecycle_msgs/msg/Transition ids used here.
TRANSITION_CONFIGURE = 1
TRANSITION_ACTIVATE = 3
TRANSITION_DEACTIVATE = 4
TRANSITION_CLEANUP = 2


class BringupError(RuntimeError):
    """The graph could not be brought up (missing executable, node not appearing, ...)."""


def find_executable(package: str, executable: str) -> str:
    """Path of a package's node executable, as ``ros2 run`` would find it.

    Looks in ``<prefix>/lib/<package>/`` of every ``AMENT_PREFIX_PATH`` entry, then on
    ``PATH``.

    Raises
    ------
    BringupError
        If it is found nowhere.
    """
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        candidate = Path(prefix) / 'lib' / package / executable
        if prefix and candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    found = shutil.which(executable)
    if found is None:
        raise BringupError(
            f'executable {executable} of {package} not found (source install/setup.bash)'
        )
    return found


def node_command(
    spec: NodeSpec,
    params: Path,
    arguments: dict[str, str],
    executable: str | None = None,
    graph: GraphSpec | None = None,
    overlay: Path | None = None,
) -> list[str]:
    """Command line of one node: executable and ``--ros-args`` as the launch file sets them.

    Parameters
    ----------
    spec : NodeSpec
        The node.
    params : Path
        Parameter YAML of the graph.
    arguments : dict
        Graph argument values; empty strings mean "not given" (the YAML value stays).
    executable : str, optional
        Path of the executable (default: :func:`find_executable`).
    graph : GraphSpec, optional
        The graph whose argument kinds type the values (default: text as given).
    overlay : Path, optional
        Parameter overlay for this node, loaded after ``params`` (``params_overlay``).

    A ``namespace`` argument starts the node in it (``-r __ns:=``); ``params`` and ``overlay``
    must then be keyed for it (:func:`forte_bringup.graph.namespaced_parameter_file`).

    Raises
    ------
    BringupError
        If an argument value is not of its kind (e.g. ``rate:=fast``), or the namespace or
        prefix is not valid.
    """
    try:
        namespace = graph_namespace(arguments.get('namespace', ''))
        remappings, parameters = argument_settings(spec, arguments, graph)
        command_line = node_arguments(spec, arguments, graph)
    except ValueError as error:
        raise BringupError(str(error)) from error
    command = [executable or find_executable(spec.package, spec.executable), *command_line,
               '--ros-args', '-r', f'__node:={spec.name}']
    if namespace:
        command += ['-r', f'__ns:={namespace}']
    command += ['--params-file', str(params)]
    if overlay is not None:
        command += ['--params-file', str(overlay)]
    for source, target in remappings:
        command += ['-r', f'{source}:={target}']
    for parameter, value in parameters.items():  # untyped without a graph: the text as given
        text = value if graph is None and '\n' not in str(value) else parameter_text(value)
        command += ['-p', f'{parameter}:={text}']  # a URDF (several lines) always quoted
    for parameter, value in spec.fixed_parameters:
        command += ['-p', f'{parameter}:={parameter_text(value)}']
    return command


def parse_graph_arguments(graph: GraphSpec, items: list[str]) -> dict[str, str]:
    """``name:=value`` items to a dict over every argument of ``graph`` (defaults filled).

    Raises
    ------
    BringupError
        On a malformed item or an argument the graph does not declare.
    """
    values = {argument.name: argument.default for argument in graph.arguments}
    for item in items:
        if ':=' not in item:
            raise BringupError(f'argument {item!r} is not of the form name:=value')
        name, value = item.split(':=', 1)
        if name not in values:
            known = ', '.join(sorted(values))
            raise BringupError(f'graph {graph.name} has no argument {name!r} (known: {known})')
        values[name] = value
    return values


class _Child:
    """A started node process with its output pump."""

    def __init__(self, name: str, command: list[str], log_dir: Path, echo: TextIO | None):
        self.name = name
        self.command = command
        self.log_path = log_dir / f'{name}.log'
        self.tail: deque[str] = deque(maxlen=30)
        self._log = self.log_path.open('w')
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=True, bufsize=1,
        )
        self._pump = threading.Thread(target=self._read, args=(echo,), daemon=True)
        self._pump.start()

    def _read(self, echo: TextIO | None) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self._log.write(line)
            self._log.flush()
            self.tail.append(line.rstrip())
            if echo is not None:
                echo.write(f'[{self.name}] {line}')
                echo.flush()
        self._log.close()

    def stop(self, timeout: float) -> int:
        """SIGINT, then SIGTERM, then SIGKILL; returns the exit code."""
        for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 3.0),
                          (signal.SIGKILL, 3.0)):
            if self.process.poll() is not None:
                break
            try:
                self.process.send_signal(sig)
            except ProcessLookupError:
                break
            try:
                self.process.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        self._pump.join(timeout=2.0)
        return self.process.returncode


class Bringup:
    """A FORTE graph running as child processes; use as a context manager.

    Parameters
    ----------
    graph : str
        ``hardware``, ``sim`` or ``replay``.
    arguments : dict, optional
        Graph argument values (see :data:`forte_bringup.graph.GRAPHS`).
    params : Path, optional
        Parameter YAML (default ``config/<graph>.yaml``, or the ``params_file`` argument).
    extra_parameters : dict, optional
        ``{node name: {parameter: value}}`` set with ``-p`` after the YAML (tests, demo).
    log_dir : Path
        Where each child's output goes (``<node name>.log``).
    echo : TextIO or None
        Stream for the children's prefixed output (None: log files only).
    """

    def __init__(
        self,
        graph: str,
        arguments: dict[str, str] | None = None,
        params: Path | None = None,
        extra_parameters: dict[str, dict[str, Any]] | None = None,
        log_dir: Path = Path('out/bringup'),
        echo: TextIO | None = sys.stdout,
    ) -> None:
        if graph not in GRAPHS:
            raise BringupError(f'unknown graph {graph!r}; expected one of {sorted(GRAPHS)}')
        self.graph = GRAPHS[graph]
        self.arguments = parse_graph_arguments(self.graph, [])
        self.arguments.update(arguments or {})
        given = self.arguments.get('params_file', '')
        self.params = Path(params or given or params_file(graph))
        if not self.params.is_file():
            raise BringupError(f'parameter file {self.params} does not exist')
        overlay = self.arguments.get('params_overlay', '')
        try:
            self.overlay_nodes = overlay_nodes(overlay, self.graph) if overlay else set()
        except ValueError as error:
            raise BringupError(str(error)) from error
        self.overlay = Path(overlay) if overlay else None
        try:
            #: the nodes it starts, and the lines to print about the others (a missing
            #: robot_state_publisher): graph_nodes.started_nodes
            self.nodes, self.notes = started_nodes(self.graph, self.arguments)
            #: absolute namespace of every node ('' = root)
            self.namespace = graph_namespace(self.arguments.get('namespace', ''))
            # under a namespace the nodes read copies keyed by their namespaced names
            self._node_params = namespaced_parameter_file(self.params, self.namespace)
            self._node_overlay = (namespaced_parameter_file(self.overlay, self.namespace)
                                  if self.overlay is not None else None)
        except ValueError as error:
            raise BringupError(str(error)) from error
        #: where perception's force model comes from (graph_nodes.force_model_source): 'sim' =
        #: the simulated rig's cached model, made at start() if missing
        self.force_model_source = force_model_source(self.graph, self.arguments, self.params,
                                                     self.overlay)
        if graph == 'replay' and not self.arguments.get('bag'):
            raise BringupError('the replay graph needs bag:=<bag folder or .mcap file>')
        self.extra_parameters = extra_parameters or {}
        #: refused configure / activate requests tolerated per node, 1 s apart (a device
        #: that just enumerated, a servo bus that missed one status packet)
        self.transition_attempts = TRANSITION_ATTEMPTS
        self.log_dir = Path(log_dir)
        self.echo = echo
        self.children: list[_Child] = []
        self._manager = None  # rclpy node calling the lifecycle services
        self._context = None
        self._executor = None

    # commands --------------------------------------------------------------------------
    def commands(self) -> dict[str, list[str]]:
        """Command line of every process of the graph (nodes, then the recorder)."""
        out = {}
        arguments = dict(self.arguments)
        if self.force_model_source == 'sim':
            from forte_evaluation.sim_force_model import force_model_path

            arguments['force_model'] = str(force_model_path())  # made by start()
        for spec in self.nodes:
            overlay = self._node_overlay if {spec.name, '/**'} & self.overlay_nodes else None
            command = node_command(spec, self._node_params, arguments, graph=self.graph,
                                   overlay=overlay)
            for parameter, value in self.extra_parameters.get(spec.name, {}).items():
                command += ['-p', f'{parameter}:={parameter_text(value)}']
            out[spec.name] = command
        if self.arguments.get('record', 'false').lower() in ('true', '1', 'yes'):
            # the forte_record console script, found like the node executables (the
            # launch files start it as a launch_ros Node of the same package)
            command = [find_executable(RECORDER.package, RECORDER.executable)]
            if self.arguments.get('bag_output'):
                command += ['-o', self.arguments['bag_output']]
            command += ['--ros-args', '-r', f'__node:={RECORDER.name}']
            if self.namespace:  # in the graph's namespace, recording the graph's topics
                command[1:1] = ['--topics', *recorder_topics(self.namespace)]
                command += ['-r', f'__ns:={self.namespace}']
            for source, target in clock_remappings(self.graph, self.arguments):
                command += ['-r', f'{source}:={target}']
            out['recorder'] = command
        return out

    def node_path(self, node: str) -> str:
        """Fully qualified name of the graph's node ``node`` (``/right/sim``, ``/sim``)."""
        return f'{self.namespace}/{node}'

    # start / stop ----------------------------------------------------------------------
    def start(self, timeout: float = 30.0) -> None:
        """Start every process, wait for the nodes, configure and activate lifecycle nodes.

        Raises
        ------
        BringupError
            If a process exits, a node does not appear within ``timeout`` s, or a
            lifecycle transition fails; everything started is stopped again first.
        """
        self.log_dir.mkdir(parents=True, exist_ok=True)
        prepare_force_model(self.force_model_source, self.graph.name, self._say)
        for note in self.notes:  # one line each, and the graph goes on without that node
            print(f'[forte_bringup] {note}', file=self.echo or sys.stderr, flush=True)
        try:
            for name, command in self.commands().items():
                self.children.append(_Child(name, command, self.log_dir, self.echo))
            self._start_manager()
            self._wait_for_nodes(timeout)
            for spec in self.nodes:
                if spec.lifecycle:
                    self.activate(spec.name, timeout)
        except BaseException:
            self.stop()
            raise

    def _say(self, line: str) -> None:
        """Show a line of the front end: warnings on stderr, the rest on ``echo``."""
        stream = sys.stderr if line.startswith('WARNING') else self.echo
        if stream is not None:
            stream.write(f'[forte_bringup] {line}\n')

    def _start_manager(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self._context = Context()
        rclpy.init(context=self._context)
        self._manager = rclpy.create_node('forte_bringup_manager', context=self._context,
                                          namespace=self.namespace or None)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self._manager)

    def _spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self._executor.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))

    def check_children(self) -> None:
        """Raise :class:`BringupError` if a child process has exited."""
        for child in self.children:
            code = child.process.poll()
            if code is not None:
                tail = '\n    '.join(child.tail)
                raise BringupError(
                    f'{child.name} exited with code {code} (log {child.log_path}):\n    {tail}'
                )

    def _wait_for_nodes(self, timeout: float) -> None:
        wanted = {(spec.name, self.namespace or '/') for spec in self.nodes}
        deadline = time.monotonic() + timeout
        while True:
            self.check_children()
            present = set(self._manager.get_node_names_and_namespaces())
            missing = {name for name, _ in wanted - present}
            if not missing:
                return
            if time.monotonic() > deadline:
                raise BringupError(f'nodes {sorted(missing)} did not appear within {timeout} s')
            self._spin(0.1)

    def _call(self, service_type, name: str, request, timeout: float):
        client = self._manager.create_client(service_type, name)
        try:
            deadline = time.monotonic() + timeout
            while not client.service_is_ready():
                self.check_children()
                if time.monotonic() > deadline:
                    raise BringupError(f'service {name} not available')
                self._spin(0.05)
            future = client.call_async(request)
            while not future.done():
                self.check_children()
                if time.monotonic() > deadline:
                    raise BringupError(f'service {name} did not answer within {timeout} s')
                self._spin(0.05)
            return future.result()
        finally:
            self._manager.destroy_client(client)

    def get_state(self, node: str, timeout: float = 5.0) -> str:
        """Current lifecycle state label of ``node`` (``unconfigured``, ``inactive``, ...)."""
        from lifecycle_msgs.srv import GetState

        return self._call(GetState, f'{self.node_path(node)}/get_state', GetState.Request(),
                          timeout).current_state.label

    def change_state(self, node: str, transition: int, timeout: float = 10.0) -> None:
        """Request a lifecycle transition of ``node`` through its ``change_state`` service.

        Raises
        ------
        BringupError
            If the service is missing or the node refuses the transition.
        """
        from lifecycle_msgs.srv import ChangeState

        request = ChangeState.Request()
        request.transition.id = transition
        response = self._call(ChangeState, f'{self.node_path(node)}/change_state', request, timeout)
        label = {1: 'configure', 2: 'cleanup', 3: 'activate',
                 4: 'deactivate'}.get(transition, transition)
        if not response.success:
            raise BringupError(f'{node}: lifecycle transition {label} refused '
                               f'(see {self.log_dir / (node + ".log")})')
        if self.echo is not None:
            self.echo.write(f'[forte_bringup] {node}: {label} done\n')

    def activate(self, node: str, timeout: float = 10.0) -> None:
        """Configure and activate ``node``, retrying refused transitions.

        The node's state is read before every request (``get_state``) so that only valid
        transitions are asked for: unconfigured -> configure, inactive -> activate. A
        refused transition is retried after 1 s, up to :attr:`transition_attempts` refusals.

        Raises
        ------
        BringupError
            After too many refusals, or if the node is in another state (e.g. finalized).
        """
        refusals = 0
        while True:
            state = self.get_state(node, timeout)
            if state == 'active':
                return
            if state == 'unconfigured':
                transition = TRANSITION_CONFIGURE
            elif state == 'inactive':
                transition = TRANSITION_ACTIVATE
            else:
                raise BringupError(f'{node} is {state}; cannot activate it')
            try:
                self.change_state(node, transition, timeout)
            except BringupError as error:
                refusals += 1
                if refusals >= self.transition_attempts:
                    raise
                if self.echo is not None:
                    self.echo.write(f'[forte_bringup] {error}; retrying in '
                                    f'{TRANSITION_RETRY_DELAY:g} s\n')
                self._spin(TRANSITION_RETRY_DELAY)

    def set_parameters(self, node: str, values: dict[str, Any], timeout: float = 10.0) -> None:
        """Set parameters of ``node`` through its ``set_parameters`` service.

        Raises
        ------
        BringupError
            If the service is missing or the node refuses a value.
        """
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request(parameters=[
            Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
        response = self._call(SetParameters, f'{self.node_path(node)}/set_parameters', request,
                              timeout)
        refused = [f'{name}: {result.reason}' for name, result
                   in zip(values, response.results, strict=True) if not result.successful]
        if refused:
            raise BringupError(f'{node} refused parameters: {"; ".join(refused)}')

    def new_scene(self, node: str = 'sim', timeout: float = 10.0, **values: Any) -> None:
        """A fresh scene on the simulator: deactivate, clean up, set ``values`` (e.g.
        ``object``, ``seed``), configure and activate again."""
        if self.get_state(node, timeout) == 'active':
            self.change_state(node, TRANSITION_DEACTIVATE, timeout)
        if self.get_state(node, timeout) == 'inactive':
            self.change_state(node, TRANSITION_CLEANUP, timeout)
        if values:
            self.set_parameters(node, values, timeout)
        self.activate(node, timeout)

    def stop(self, timeout: float = 10.0) -> dict[str, int]:
        """Deactivate lifecycle nodes, then stop every child; returns exit codes by name."""
        if self._manager is not None:
            for spec in self.nodes:
                child = next((c for c in self.children if c.name == spec.name), None)
                if spec.lifecycle and child is not None and child.process.poll() is None:
                    try:  # only an active node can be deactivated (rclpy raises otherwise)
                        if self.get_state(spec.name, 3.0) == 'active':
                            self.change_state(spec.name, TRANSITION_DEACTIVATE, 3.0)
                    except BringupError:
                        pass  # not answering: just stop the process
        codes = {}
        for child in reversed(self.children):  # recorder first, sources last
            codes[child.name] = child.stop(timeout)
        if self._manager is not None:
            import rclpy

            self._executor.shutdown()
            self._manager.destroy_node()
            rclpy.try_shutdown(context=self._context)
            self._manager = None
        self.children = []
        return codes

    def __enter__(self) -> Bringup:
        self.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.stop()


def _domain(domain_id: int | None) -> int:
    if domain_id is not None:
        return isolate_ros_network(domain_id)
    if os.environ.get('ROS_DOMAIN_ID', '').isdigit():
        return isolate_ros_network(int(os.environ['ROS_DOMAIN_ID']))
    return isolate_ros_network()


def main(argv: list[str] | None = None) -> int:
    """Entry point ``forte_bringup``."""
    parser = argparse.ArgumentParser(
        prog='forte_bringup', description='Bring up a FORTE graph without ros2 launch.',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='graph arguments (name:=value):\n' + '\n'.join(
            f'  {graph.name}: ' + ', '.join(a.name for a in graph.arguments)
            for graph in GRAPHS.values()),
    )
    parser.add_argument('graph', choices=sorted(GRAPHS), help='which graph to bring up')
    parser.add_argument('arguments', nargs='*', help='graph arguments name:=value')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID to use (default: $ROS_DOMAIN_ID or a free one)')
    parser.add_argument('--log-dir', type=Path, default=Path('out/bringup'),
                        help='folder of the per-node log files')
    parser.add_argument('--quiet', action='store_true', help="do not echo the nodes' output")
    options = parser.parse_args(argv)

    domain = _domain(options.domain_id)
    graph = GRAPHS[options.graph]
    try:
        arguments = parse_graph_arguments(graph, options.arguments)
        bringup = Bringup(options.graph, arguments, log_dir=options.log_dir,
                          echo=None if options.quiet else sys.stdout)
    except BringupError as error:
        print(f'[forte_bringup] error: {error}', file=sys.stderr)
        return 2
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    print(f'[forte_bringup] {graph.description}\n[forte_bringup] parameters {bringup.params}; '
          f'ROS_DOMAIN_ID={domain} (join with: export ROS_DOMAIN_ID={domain} '
          f'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST)', flush=True)
    code = 0
    try:
        bringup.start()
        print(f'[forte_bringup] {graph.name} graph up: '
              f'{", ".join(s.name for s in bringup.nodes)}; Ctrl-C to stop', flush=True)
        while not stop.wait(0.2):
            bringup.check_children()
    except BringupError as error:
        print(f'[forte_bringup] error: {error}', file=sys.stderr, flush=True)
        code = 1
    finally:
        codes = bringup.stop()
        print('[forte_bringup] stopped: ' + ', '.join(f'{n} ({c})' for n, c in codes.items()),
              flush=True)
    return code


if __name__ == '__main__':
    sys.exit(main())
