"""pytest hooks every FORTE package's tests load (through its ``conftest.py``).

Two things make one pytest process per package (as ``colcon test`` runs it) as reliable as
one process per file:

- **A module-level skip skips that module only.** launch_testing's pytest plugin, present
  wherever a ROS install or the launch kit is, imports every test module while pytest
  collects its *folder* (to look for ``generate_test_description``). A module that skips at
  import (``pytest.importorskip('launch_pytest', reason=...)``) then raises out of the
  folder's collection, and pytest reports the whole folder as one skip: every other test
  in it silently not run. :func:`pytest_pycollect_makemodule` hands such a module to
  pytest's own module collector, which imports it again and reports the skip, with its
  reason, for that file alone. (It also makes a file passed by path that skips report
  ``skipped`` instead of ``found no collectors``, exit 4.)
- **A module leaves nothing running.** :func:`leak_guard` compares what is alive at the end
  of each test module with what was alive at its start: Python threads, child processes,
  and rclpy's default context. Anything left is an error of that module (ended, so that
  later modules start clean): DDS participants, spinning threads and 2 kHz node processes
  left by one module once slowed the rclpy tests of the next until they timed out.

Also :func:`pytest_configure`, which registers the markers of :data:`MARKERS` unless already
known (the workspace's pytest.ini or a plugin), so that a package's tests collect under
``--strict-markers`` as ``colcon test`` runs them, whether pytest-timeout is installed or not
(without it, ``timeout`` sets no limit). A conftest that imports it registers them.

No ROS import here: the conftests load this module before isolating the DDS domain.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

#: ``markers`` lines :func:`pytest_configure` registers unless already known.
MARKERS = (
    'slow: takes more than ~20 s',
    'timeout(seconds): fail the test after this many seconds (pytest-timeout; inert without it)',
)
#: How long threads and child processes of a module get to end after its last test [s].
GRACE = 5.0
#: Threads of libraries that live for the whole process by design, matched by name prefix:
#: launch's asyncio default executor and pytest-timeout's watchdog come and go with the
#: event loop / the test; rclpy's signal handler thread is one per process.
PROCESS_WIDE_THREADS = ('asyncio_', 'ThreadPoolExecutor-', 'pytest_timeout')
#: Child processes that live as long as the interpreter by design, matched in their command
#: line: multiprocessing's resource tracker and forkserver, started by the first process pool
#: and reused by every later one (ending them would break those).
PROCESS_WIDE_CHILDREN = ('multiprocessing.resource_tracker', 'multiprocessing.forkserver')


def _marker_name(line: str) -> str:
    return line.split(':')[0].split('(')[0].strip()


@pytest.hookimpl(trylast=True)  # after the plugins have registered theirs
def pytest_configure(config: pytest.Config) -> None:
    known = {_marker_name(line) for line in config.getini('markers')}
    for line in MARKERS:
        if _marker_name(line) not in known:
            config.addinivalue_line('markers', line)


@pytest.hookimpl(wrapper=True)
def pytest_pycollect_makemodule(module_path: Path, parent: pytest.Collector):
    """Give a module whose import skipped to pytest's module collector (see the module
    docstring); every other outcome passes through unchanged."""
    try:
        return (yield)
    except pytest.skip.Exception:
        return pytest.Module.from_parent(parent, path=module_path)


def child_processes() -> set[int]:
    """Process ids of this process's live children but :data:`PROCESS_WIDE_CHILDREN`
    (Linux ``/proc``; empty elsewhere)."""
    children = set()
    own = os.getpid()
    for entry in Path('/proc').glob('[0-9]*/stat'):
        try:
            fields = entry.read_text().rsplit(')', 1)[1].split()
        except (OSError, IndexError):
            continue  # ended meanwhile
        # fields after the command name: state, ppid, ...; a zombie is already ended
        if int(fields[1]) == own and fields[0] != 'Z':
            pid = int(entry.parent.name)
            if not any(name in _command_line(pid) for name in PROCESS_WIDE_CHILDREN):
                children.add(pid)
    return children


def _new_threads(before: set[threading.Thread]) -> list[threading.Thread]:
    return [thread for thread in threading.enumerate()
            if thread not in before and thread.is_alive()
            and not thread.name.startswith(PROCESS_WIDE_THREADS)]


def _default_context_running() -> bool:
    rclpy = sys.modules.get('rclpy')
    return rclpy is not None and rclpy.ok()


def leaks(threads_before: set[threading.Thread], children_before: set[int],
          context_before: bool, grace: float = GRACE) -> list[str]:
    """What is alive now that was not before, after waiting up to ``grace`` [s] for it to
    end; one line per leak."""
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        if not _new_threads(threads_before) and not (child_processes() - children_before):
            break
        time.sleep(0.05)
    found = [f'thread {thread.name!r} (target {getattr(thread, "_target", None)!r})'
             for thread in _new_threads(threads_before)]
    found += [f'child process {pid}: {_command_line(pid)}'
              for pid in sorted(child_processes() - children_before)]
    if _default_context_running() and not context_before:
        found.append('rclpy default context still initialised (rclpy.init without '
                     'rclpy.shutdown)')
    return found


def _command_line(pid: int) -> str:
    try:
        return Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode()[:200]
    except OSError:
        return '(ended)'


def _end(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


@pytest.fixture(scope='module', autouse=True)
def leak_guard() -> Iterator[None]:
    """Error the module that leaves threads, child processes or rclpy's default context
    running after its last test, and end the processes it left (see the module docstring).
    """
    threads = set(threading.enumerate())
    children = child_processes()
    context = _default_context_running()
    yield
    found = leaks(threads, children, context)
    if not found:
        return
    for pid in child_processes() - children:
        _end(pid)
    if _default_context_running() and not context:
        sys.modules['rclpy'].try_shutdown()
    pytest.fail('the module left these running after its last test (a test must stop what '
                'it starts):\n  ' + '\n  '.join(found), pytrace=False)
