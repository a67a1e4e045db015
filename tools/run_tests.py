"""Run the workspace's tests, one pytest process per package, and sum the results.

One process per package is how ``colcon test`` runs them. The shared pytest plugin
(:mod:`forte_ros.pytest_plugin`, loaded by every conftest) makes that safe for the rclpy
tests: a test module that leaves threads, child processes or rclpy's default context
running is an error of that module, so no module slows the ones after it, and a module that
skips at import (no launch stack) skips alone, with its reason.

Usage: ``python tools/run_tests.py [--package NAME ...] [--jobs N] [--burners N]
[pytest args...]`` from the repository root (``make test-python``). ``--package`` repeats
(default: every package of ``pytest.ini``'s ``testpaths``); ``--jobs N`` runs N packages at a
time (default 2, or 1 on a one-core machine): the packages of :data:`LIVE_GRAPHS` one after
another at the runner's priority, the others beside them at niceness
:data:`BESIDE_NICENESS`, each one's output printed whole when it ends (with ``--jobs 1``
straight through); ``--burners N`` runs N CPU-bound processes at
normal priority beside the tests, as a motion planner loads a robot's computer: the
live-graph tests must pass so, docs/testing.md). Prints pytest's own output per package,
then a line per package (tests and wall time), the slowest tests, every skipped test with
its reason, and a closing ``pytest: N passed, N failed, N skipped`` line. Exits 1 if a test
failed or errored, a package's pytest ended abnormally, or a test file reported no test at
all (a renamed or crashed module must not pass silently; with ``-k``/``-m`` selecting, a
file may rightly report nothing).
"""
from __future__ import annotations

import argparse
import ast
import configparser
import contextlib
import os
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: pytest's exit codes that still mean "ran to the end": 0 all passed, 1 some failed, 5 no
#: test collected (judged per file below).
COMPLETED = (0, 1, 5)
#: How many of the slowest tests the summary lists.
SLOWEST = 15
#: Packages whose tests are mostly live graphs in real time (the bench twin's 2 kHz sensor
#: board emulated in Python, the demo's grasps, procedures over the drivers). They run one
#: after another at the runner's priority, never beside each other: side by side on two
#: cores, the one at the lower priority starved (frame gaps of up to 0.9 s from the twin's
#: sensor, servo status packets lost; CI 2026-11-28). The longest (forte_bringup) goes first.
#: With none of them chosen, the first package chosen takes their place.
LIVE_GRAPHS = ('forte_bringup', 'forte_commissioning')
#: Niceness of the packages run beside the live-graph ones: they fill the idle core without
#: taking it from the real-time graphs.
BESIDE_NICENESS = 10
PRINTING = threading.Lock()


@dataclass(frozen=True)
class TestResult:
    """One test case of a junit report: ``outcome`` is passed, failed or skipped (an error
    counts as failed); ``file`` is relative to the repository root."""

    file: str
    name: str
    seconds: float
    outcome: str
    reason: str = ''


def packages(root: Path = ROOT) -> dict[str, list[Path]]:
    """The test folders of ``pytest.ini``'s ``testpaths`` grouped by package (their first
    path part), in the order listed."""
    config = configparser.ConfigParser()
    config.read(root / 'pytest.ini')
    grouped: dict[str, list[Path]] = {}
    for folder in config['pytest']['testpaths'].split():
        if (root / folder).is_dir():
            grouped.setdefault(Path(folder).parts[0], []).append(root / folder)
    return grouped


def test_files(folders: list[Path]) -> list[Path]:
    """Every ``test_*.py`` below ``folders``, sorted."""
    return sorted(path for folder in folders for path in folder.rglob('test_*.py'))


def skip_reason(skipped: ElementTree.Element) -> str:
    """The reason of a junit ``<skipped>`` element: a module skipped at import is reported
    as ``collection skipped`` with ``(path, line, 'Skipped: reason')`` as its text."""
    message, text = skipped.get('message', ''), skipped.text or ''
    if message == 'collection skipped':
        with contextlib.suppress(ValueError, SyntaxError, IndexError, TypeError):
            return 'whole module: ' + ast.literal_eval(text)[2].removeprefix('Skipped: ')
    return message


def read_junit(report: Path) -> list[TestResult]:
    """The test cases of a junit XML report written with ``junit_family=xunit1`` (which
    records each case's file); empty when pytest wrote none."""
    if not report.exists():
        return []
    results = []
    for case in ElementTree.parse(report).getroot().iter('testcase'):
        outcome, reason = 'passed', ''
        for child in case:
            if child.tag in ('failure', 'error'):
                outcome = 'failed'
            elif child.tag == 'skipped' and outcome == 'passed':
                outcome, reason = 'skipped', skip_reason(child)
        file = case.get('file', '')
        # classname is the module's dotted path, with the test's class last if it has one
        owner = case.get('classname', '').rsplit('.', 1)[-1]
        name = case.get('name', '')
        if owner and owner != Path(file).stem:
            name = f'{owner}::{name}'
        results.append(TestResult(file, name, float(case.get('time', 0)), outcome,
                                  reason.strip()))
    return results


def selects_tests(pytest_args: list[str]) -> bool:
    """True if ``pytest_args`` select a subset (``-k``, ``-m``): then a file may rightly
    collect nothing."""
    return any(arg in ('-k', '-m') or arg.startswith(('-k=', '-m=')) for arg in pytest_args)


def run_package(name: str, folders: list[Path], pytest_args: list[str], work: Path,
                root: Path, niceness: int = 0,
                streamed: bool = True) -> tuple[list[TestResult], list[str], float]:
    """Run one package's tests in one pytest process.

    Parameters
    ----------
    name, folders : str, list of Path
        The package and its test folders.
    pytest_args : list of str
        Passed on to pytest.
    work : Path
        A folder of this run: the package's junit report, its pytest base temporary folder
        (one per package, so that packages run side by side never share one) and, unless
        ``streamed``, its output.
    niceness : int
        Added to the process's nice value (0: the runner's priority).
    streamed : bool
        Output straight to this process's stdout; otherwise printed whole when it ends.

    Returns
    -------
    tuple
        ``(results, problems, seconds)``: its test cases, what makes the run fail besides a
        failed test (an abnormal exit, a file that reported nothing), its wall time [s].
    """
    begin = time.monotonic()
    report = work / f'{name}.xml'
    print(f'[tests] {name}: pytest {" ".join(str(f.relative_to(root)) for f in folders)}'
          + (f' (nice {niceness})' if niceness else ''), flush=True)
    with open(work / f'{name}.log', 'w+') as log:
        completed = subprocess.run(
            [sys.executable, '-m', 'pytest', *(str(f.relative_to(root)) for f in folders),
             '-q', '-p', 'no:cacheprovider', '-o', 'junit_family=xunit1',
             f'--junitxml={report}', f'--basetemp={work / (name + "-tmp")}', *pytest_args],
            cwd=root, stdout=None if streamed else log, stderr=None if streamed else log,
            preexec_fn=(lambda: os.nice(niceness)) if niceness else None)
        if not streamed:
            log.seek(0)
            with PRINTING:
                print(f'[tests] ----- {name} -----\n{log.read()}', end='', flush=True)
    seconds = time.monotonic() - begin
    results = read_junit(report)
    problems = []
    if completed.returncode not in COMPLETED:
        problems.append(f'{name}: pytest exited {completed.returncode} (interrupted, a usage '
                        'error or a crash: the tests after it did not run)')
    if not selects_tests(pytest_args):
        reported = {result.file for result in results}
        problems += [f'{path.relative_to(root)}: reported no test (renamed away, or the '
                     f'process died before it)' for path in test_files(folders)
                     if str(path.relative_to(root)) not in reported]
    return results, problems, seconds


def outcome_counts(results: list[TestResult]) -> dict[str, int]:
    """How many of ``results`` passed, failed and were skipped."""
    return {outcome: sum(result.outcome == outcome for result in results)
            for outcome in ('passed', 'failed', 'skipped')}


def summary(per_package: dict[str, tuple[list[TestResult], float]],
            problems: list[str]) -> list[str]:
    """The closing lines: per package, the slowest tests, the skipped ones, the problems and
    the ``N passed, N failed, N skipped`` line."""
    lines = []
    every = [result for results, _ in per_package.values() for result in results]
    for name, (results, seconds) in per_package.items():
        counts = outcome_counts(results)
        lines.append(f'[tests] {name}: {counts["passed"]} passed, {counts["failed"]} failed, '
                     f'{counts["skipped"]} skipped in {seconds:.0f} s')
    lines.append(f'[tests] slowest {SLOWEST} tests (setup + call + teardown):')
    for result in sorted(every, key=lambda r: -r.seconds)[:SLOWEST]:
        lines.append(f'[tests] {result.seconds:8.1f} s  {result.file}::{result.name}')
    for result in every:
        if result.outcome == 'skipped':
            lines.append(f'[tests] SKIPPED {result.file}::{result.name}: {result.reason}')
    for result in every:
        if result.outcome == 'failed':
            lines.append(f'[tests] FAILED {result.file}::{result.name}')
    lines += [f'[tests] FAILED {problem}' for problem in problems]
    totals = outcome_counts(every)
    lines.append(f'pytest: {totals["passed"]} passed, {totals["failed"] + len(problems)} '
                 f'failed, {totals["skipped"]} skipped')
    return lines


@contextlib.contextmanager
def cpu_burners(count: int) -> Iterator[None]:
    """``count`` processes that each keep one core busy (a Python busy loop at normal
    priority) until the block ends."""
    burners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
               for _ in range(count)]
    if burners:
        print(f'[tests] {count} CPU burner(s) running beside the tests', flush=True)
    try:
        yield
    finally:
        for burner in burners:
            burner.kill()
            burner.wait()


def main(arguments: list[str], root: Path = ROOT) -> int:
    """Run the packages' tests (see the module docstring); 0 if all is well, else 1."""
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument('--package', action='append', default=[])
    parser.add_argument('--burners', type=int, default=0)
    parser.add_argument('--jobs', type=int, default=min(2, os.cpu_count() or 1))
    options, pytest_args = parser.parse_known_args(arguments)
    grouped = packages(root)
    unknown = sorted(set(options.package) - set(grouped))
    if unknown:
        print(f'[tests] unknown package(s) {unknown}; the packages are {sorted(grouped)}')
        return 1
    chosen = [name for name in grouped if not options.package or name in options.package]
    live = [name for name in LIVE_GRAPHS if name in chosen] or chosen[:1]
    beside = [name for name in chosen if name not in live]
    jobs = max(1, min(options.jobs, len(beside) + 1))
    started = time.monotonic()
    per_package: dict[str, tuple[list[TestResult], float]] = {}
    problems: list[str] = []
    with tempfile.TemporaryDirectory() as folder, cpu_burners(options.burners), \
            ThreadPoolExecutor(1) as live_lane, ThreadPoolExecutor(max(1, jobs - 1)) as lanes:
        futures = {}
        for name in live + beside:
            lane, niceness = ((live_lane, 0) if jobs == 1 or name in live
                              else (lanes, BESIDE_NICENESS))
            futures[name] = lane.submit(run_package, name, grouped[name], pytest_args,
                                        Path(folder), root, niceness=niceness,
                                        streamed=jobs == 1)
        for name, future in futures.items():
            results, found, seconds = future.result()
            per_package[name] = (results, seconds)
            problems += found
    print(f'[tests] {len(chosen)} packages in {time.monotonic() - started:.0f} s '
          f'({jobs} at a time)')
    print('\n'.join(summary(per_package, problems)), flush=True)
    failed = any(r.outcome == 'failed' for results, _ in per_package.values() for r in results)
    return 1 if failed or problems else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
