"""Run rclpy nodes until SIGINT or SIGTERM, then stop them in order: the one ``main`` of FORTE.

rclpy's own signal handlers shut the context down at once, from inside the signal, while
executor callbacks and the nodes' threads still publish: they then fail with
``RCLError: publisher's context is invalid``, the process prints a traceback, lifecycle
nodes never run ``on_shutdown``, and SIGTERM ends the process without any clean-up.

:class:`NodeRunner` does it in this order instead:

1. ``rclpy.init`` without rclpy's signal handlers; Python handlers for SIGINT and SIGTERM
   that only set a stop flag (a Python handler cannot run while ``rcl_wait`` blocks in C,
   so the executor is spun with a bounded wait of ``spin_period`` seconds, 0.1 s by
   default: the stop latency; the cost is one wake-up per period);
2. on a signal (or when ``until()`` is true) the loop ends; callbacks still running in a
   multi-threaded executor are given ``drain_timeout`` seconds to finish;
3. each node is finalised while the context is still valid: ``node.prepare_shutdown()``
   if it has one (FORTE nodes stop and join their threads there; a
   :class:`~forte_ros.lifecycle.ForteLifecycleNode` takes the ``shutdown`` transition so
   ``on_shutdown`` releases devices and leaves servos as their parameters say), else a
   plain ``LifecycleNode`` is shut down through its state machine;
4. the executor runs for ``flush_time`` more (0.1 s) so that what finalising queued on it
   goes out, e.g. the result of an action goal ended by ``prepare_shutdown``;
5. the executor is shut down, the nodes destroyed, the context shut down, the previous
   signal handlers restored.

A signal-requested stop exits with code 0. Threads that may still race with the end of the
context publish through :func:`publish_quietly`, which counts instead of raising.
"""
from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from types import FrameType
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from forte_ros.lifecycle import shut_down_lifecycle

#: Signals that request a clean stop.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

ExecutorFactory = Callable[[Context], Executor]


def publish_quietly(publisher: Any, message: Any, context: Context,
                    counter: dict[str, int] | None = None) -> bool:
    """Publish unless the context or the publisher is already gone.

    For threads that may still run while the process stops: an ``RCLError`` or
    ``InvalidHandle`` raised because the context was shut down or the publisher destroyed
    is counted in ``counter['late_publishes']`` instead of propagating; any other failure
    (context still valid) is raised.

    Parameters
    ----------
    publisher : rclpy.publisher.Publisher
        Where to publish.
    message : Any
        The message.
    context : rclpy.context.Context
        The context of the publisher's node.
    counter : dict, optional
        Receives the count of dropped late publishes.

    Returns
    -------
    bool
        True if published.
    """
    if context.ok():
        try:
            publisher.publish(message)
            return True
        except RuntimeError:  # RCLError and InvalidHandle derive from RuntimeError
            if context.ok() and not _destroyed(publisher):
                raise
    if counter is not None:
        counter['late_publishes'] = counter.get('late_publishes', 0) + 1
    return False


def _destroyed(publisher: Any) -> bool:
    try:
        with publisher.handle:
            return False
    except RuntimeError:
        return True


class NodeRunner:
    """Context manager that owns rclpy's context, the executor and the stop signals.

    Parameters
    ----------
    args : list of str, optional
        Command line for ``rclpy.init`` (``--ros-args ...``); default ``sys.argv``.
    executor_factory : callable, optional
        ``factory(context) -> Executor``, called after ``rclpy.init`` (an rclpy executor
        cannot be created before); default a ``SingleThreadedExecutor``.
    spin_period : float
        Longest wait of one ``spin_once`` [s]: the latency of a stop request.
    drain_timeout : float
        How long callbacks still running in other executor threads may take to finish
        after the loop ended [s].
    flush_time : float
        How long the executor keeps running after the nodes were finalised [s].
    context : rclpy.context.Context, optional
        Context to initialise; default rclpy's default context.

    Examples
    --------
    >>> with NodeRunner(args) as runner:            # doctest: +SKIP
    ...     node = runner.add_node(MyNode())
    ...     runner.spin()
    """

    def __init__(self, args: list[str] | None = None, *,
                 executor_factory: ExecutorFactory | None = None,
                 spin_period: float = 0.1, drain_timeout: float = 2.0,
                 flush_time: float = 0.1, context: Context | None = None) -> None:
        if not 0.0 < spin_period <= 1.0:
            raise ValueError(f'spin_period must be in (0, 1] s, got {spin_period}')
        self._args = args
        self._executor_factory = executor_factory or (
            lambda context: SingleThreadedExecutor(context=context))
        self.spin_period = spin_period
        self.drain_timeout = drain_timeout
        self.flush_time = flush_time
        self.context = context if context is not None else rclpy.get_default_context()
        self.executor: Executor | None = None
        self.nodes: list[Node] = []
        self.stop_signal: int | None = None
        self._stop = threading.Event()
        self._previous_handlers: dict[int, Any] = {}
        self._closed = False

    # ---- context manager ----------------------------------------------------------------
    def __enter__(self) -> NodeRunner:
        self._install_signal_handlers()  # first: a signal during init already counts
        try:
            rclpy.init(args=self._args, context=self.context,
                       signal_handler_options=SignalHandlerOptions.NO)
            self.executor = self._executor_factory(self.context)
        except BaseException:
            self._restore_signal_handlers()
            raise
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # ---- stop requests --------------------------------------------------------------------
    @property
    def stop_requested(self) -> bool:
        """True once a stop signal arrived or :meth:`request_stop` was called."""
        return self._stop.is_set()

    def request_stop(self) -> None:
        """Ask :meth:`spin` to return (thread-safe; also what the signal handlers do)."""
        self._stop.set()

    def _on_signal(self, signum: int, _frame: FrameType | None) -> None:
        # Only set the flag: the main thread may be inside an rclpy call holding locks.
        if self.stop_signal is None:
            self.stop_signal = signum
        self._stop.set()

    def _install_signal_handlers(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return  # Python delivers signals to the main thread only
        for signum in STOP_SIGNALS:
            self._previous_handlers[signum] = signal.signal(signum, self._on_signal)

    def _restore_signal_handlers(self) -> None:
        for signum, handler in self._previous_handlers.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)
        self._previous_handlers.clear()

    # ---- nodes and spinning -------------------------------------------------------------------
    def add_node(self, node: Node) -> Node:
        """Spin ``node`` with this runner's executor and finalise it at the end."""
        self.executor.add_node(node)
        self.nodes.append(node)
        return node

    @property
    def logger(self) -> Any:
        """The first node's logger (or a ``node_runner`` logger before there is a node)."""
        if self.nodes:
            return self.nodes[0].get_logger()
        return rclpy.logging.get_logger('node_runner')

    def spin(self, until: Callable[[], bool] | None = None) -> None:
        """Execute callbacks until a stop request, ``until()`` true or the context ends."""
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=self.spin_period)
            if until is not None and until():
                break
        if self.stop_signal is not None:
            self.logger.info(f'{signal.Signals(self.stop_signal).name} received: stopping')

    # ---- finalisation ---------------------------------------------------------------------------
    def close(self) -> None:
        """Finalise the nodes, destroy them, shut the context down (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            if self.executor is not None and self.context.ok():
                self._drain_callbacks()
                for node in reversed(self.nodes):
                    self._finalise(node)
                self._flush()
            self._shutdown_executor()
            for node in reversed(self.nodes):
                try:
                    node.destroy_node()
                except Exception as error:  # noqa: BLE001 - keep stopping the others
                    self.logger.error(f'destroying {node.get_name()} failed: {error}')
        finally:
            rclpy.try_shutdown(context=self.context)
            self._restore_signal_handlers()

    def _drain_callbacks(self) -> None:
        """Let callbacks running in other executor threads finish (bounded)."""
        # rclpy 7.1.6's Executor.shutdown() never waits for them (it tests the flag it has
        # just set), so wait on the executor's own tracker of running callbacks.
        tracker = getattr(self.executor, '_work_tracker', None)
        if tracker is not None and not tracker.wait(self.drain_timeout):
            self.logger.warning(f'callbacks still running after {self.drain_timeout} s')

    def _flush(self) -> None:
        """Run what finalising queued (e.g. sending a goal result) for ``flush_time``."""
        deadline = time.monotonic() + self.flush_time
        while time.monotonic() < deadline and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=min(0.02, self.flush_time))
            except Exception as error:  # noqa: BLE001 - a stopping process must not die here
                self.logger.error(f'callback failed while stopping: {error}')

    def _finalise(self, node: Node) -> None:
        hook = getattr(node, 'prepare_shutdown', None)
        try:
            if callable(hook):
                hook()
            elif isinstance(node, LifecycleNode):
                shut_down_lifecycle(node)
        except Exception as error:  # noqa: BLE001 - a stopping process must not die here
            self.logger.error(f'finalising {node.get_name()} failed: {error}')

    def _shutdown_executor(self) -> None:
        if self.executor is None:
            return
        self.executor.shutdown(timeout_sec=self.drain_timeout)
        # MultiThreadedExecutor: drop queued callbacks, wait for the pool's threads (they
        # are not daemons: a running one would otherwise hold the process at exit)
        pool = getattr(self.executor, '_executor', None)
        if isinstance(pool, ThreadPoolExecutor):
            pool.shutdown(wait=True, cancel_futures=True)


def run_node(node_factory: Callable[[], Node], args: list[str] | None = None, *,
             executor_factory: ExecutorFactory | None = None,
             until: Callable[[Node], bool] | None = None,
             fatal_errors: tuple[type[Exception], ...] = (),
             spin_period: float = 0.1, name: str = 'node_runner') -> int:
    """Create one node, spin it until SIGINT/SIGTERM, finalise it; the body of a ``main``.

    Parameters
    ----------
    node_factory : callable
        ``factory() -> Node``, called after ``rclpy.init`` (e.g. the node class).
    args : list of str, optional
        Command line for ``rclpy.init``; default ``sys.argv``.
    executor_factory : callable, optional
        ``factory(context) -> Executor``; default a ``SingleThreadedExecutor``.
    until : callable, optional
        ``until(node) -> bool``, checked after every ``spin_once``: stop when true.
    fatal_errors : tuple of exception types
        Errors of the node's construction reported as one fatal log line (exit code 2)
        instead of a traceback, e.g. a missing input file.
    spin_period : float
        Longest wait of one ``spin_once`` [s] (stop latency).
    name : str
        Logger name of a fatal construction error (there is no node yet).

    Returns
    -------
    int
        Exit code: 0 after a stop signal or ``until``, 2 after a fatal construction error.
    """
    with NodeRunner(args, executor_factory=executor_factory,
                    spin_period=spin_period) as runner:
        try:
            node = node_factory()
        except fatal_errors as error:
            rclpy.logging.get_logger(name).fatal(str(error))
            return 2
        runner.add_node(node)
        runner.spin(until=(lambda: until(node)) if until is not None else None)
    return 0
