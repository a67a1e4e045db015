"""forte_ros's node runner and lifecycle base, on a tiny node in its own process.

The node (runner_test_node.py) publishes from a thread every 2 ms and from a timer; the
tests stop it with SIGINT or SIGTERM as a terminal, a launch file or a service manager
would, and check what a user sees: exit code 0 within a few seconds, no traceback, the
lifecycle shutdown transition run (threads joined) before the context ended. A probe
node in the test process calls the lifecycle services as a (stale) lifecycle manager would.
"""
from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

import pytest
import rclpy
from lifecycle_msgs.msg import Transition
from std_msgs.msg import Int64

from forte_ros import publish_quietly
from forte_ros.testing import NodeProcess, Probe, wait_until

NODE = Path(__file__).with_name('runner_test_node.py')
STOP_TIMEOUT = 5.0  # [s] from the signal to the exit


def start(*flags: str) -> NodeProcess:
    return NodeProcess([sys.executable, str(NODE), *flags])


@pytest.fixture
def probe():
    with Probe('runner_probe') as started:
        started.count(Int64, 'runner_test/count')
        started.count(Int64, 'runner_test/tick')
        yield started


def wait_publishing(probe: Probe, process: NodeProcess, topic: str = 'runner_test/count',
                    at_least: int = 20) -> None:
    assert probe.wait_for_messages(topic, at_least, 30.0), (
        f'no messages on {topic}:\n{process.output}')


def assert_clean(process: NodeProcess, code: int | None, elapsed: float) -> None:
    assert code == 0, f'exit code {code}:\n{process.output}'
    assert elapsed < STOP_TIMEOUT, f'{elapsed:.2f} s to stop'
    assert not process.failures(), process.output


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
@pytest.mark.parametrize('flags', [(), ('--multi',)], ids=['single', 'multi'])
def test_lifecycle_node_stops_cleanly_and_runs_on_shutdown(probe, signum, flags):
    with start(*flags) as process:
        wait_publishing(probe, process)
        wait_publishing(probe, process, 'runner_test/tick', 3)
        code, elapsed = process.stop(signum)
    assert_clean(process, code, elapsed)
    output = process.output
    assert f'{signal.Signals(signum).name} received: stopping' in output
    assert 'THREAD JOINED alive=False' in output
    assert 'ON_SHUTDOWN from active' in output
    # the thread was joined before the context ended: nothing was published late
    assert 'LATE 0' in output
    assert output.index('ON_SHUTDOWN') < output.index('LATE 0')


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_plain_node_threads_stop_in_prepare_shutdown(probe, signum):
    with start('--plain') as process:
        wait_publishing(probe, process)
        code, elapsed = process.stop(signum)
    assert_clean(process, code, elapsed)
    assert 'THREAD JOINED alive=False' in process.output
    assert 'PREPARE_SHUTDOWN' in process.output


def test_thread_racing_with_the_end_of_the_context_does_not_raise(probe):
    """A thread nobody stops keeps publishing after the context is gone: counted, quiet."""
    with start('--plain', '--race') as process:
        wait_publishing(probe, process)
        code, elapsed = process.stop(signal.SIGINT)
    assert_clean(process, code, elapsed)
    assert 'LATE ' in process.output


def test_until_stops_by_itself_with_exit_code_0():
    with start('--until', '5') as process:
        assert wait_until(lambda: process.process.poll() is not None, 60.0), process.output
        assert process.process.returncode == 0, process.output
    assert 'ON_SHUTDOWN from active' in process.output
    assert not process.failures(), process.output


def test_fatal_construction_error_is_one_log_line_and_exit_code_2():
    with start('--fatal') as process:
        assert wait_until(lambda: process.process.poll() is not None, 60.0), process.output
        assert process.process.returncode == 2
    assert 'no such device: /dev/forte_nothing' in process.output
    assert 'FATAL' in process.output
    assert not process.failures(), process.output


def test_stop_latency_is_bounded_by_the_spin_period(probe):
    """Signal to exit, several times: the bounded wait keeps it well under a second."""
    times = []
    for _ in range(3):
        with start('--plain') as process:
            wait_publishing(probe, process)
            code, elapsed = process.stop(signal.SIGTERM)
        assert_clean(process, code, elapsed)
        times.append(elapsed)
    print(f'stop times [s]: {[round(t, 3) for t in times]}')
    assert min(times) < 2.0


def test_invalid_transitions_are_refused_and_the_node_keeps_running(probe):
    with start('--manual') as process:
        assert wait_until(lambda: probe.state('runner_test') == 'unconfigured', 30.0), \
            process.output
        # activate from unconfigured: rclpy 7.1.6 would raise RCLError and the node die
        assert probe.change_state('runner_test', Transition.TRANSITION_ACTIVATE) is False
        assert probe.change_state('runner_test', Transition.TRANSITION_CONFIGURE) is True
        # a second configure, as from a stale launch on the same domain
        assert probe.change_state('runner_test', Transition.TRANSITION_CONFIGURE) is False
        assert probe.change_state('runner_test', label='configure') is False
        assert probe.state('runner_test') == 'inactive'
        assert probe.change_state('runner_test', Transition.TRANSITION_ACTIVATE) is True
        wait_publishing(probe, process)
        assert probe.change_state('runner_test', Transition.TRANSITION_CONFIGURE) is False
        assert probe.change_state('runner_test', 99) is False  # no such transition
        assert process.process.poll() is None, process.output
        assert probe.state('runner_test') == 'active'
        wait_publishing(probe, process)  # still publishing
        code, elapsed = process.stop(signal.SIGINT)
    assert_clean(process, code, elapsed)
    assert process.output.count('refused in state') == 5
    assert 'ON_SHUTDOWN from active' in process.output


def test_publish_quietly_counts_instead_of_raising_once_the_publisher_is_gone():
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('quiet_publisher', context=context)
    publisher = node.create_publisher(Int64, 'quiet', 10)
    counter: dict[str, int] = {}
    assert publish_quietly(publisher, Int64(data=1), context, counter)
    node.destroy_publisher(publisher)
    assert not publish_quietly(publisher, Int64(data=2), context, counter)
    live = node.create_publisher(Int64, 'quiet', 10)
    node.destroy_node()
    rclpy.shutdown(context=context)
    time.sleep(0.01)
    assert not publish_quietly(live, Int64(data=3), context, counter)
    assert counter == {'late_publishes': 2}
