"""Run every test file of the workspace in its own pytest process and sum the results.

Why one process per file: the ROS tests start real rclpy nodes, executors and DDS
participants. In one long pytest process, state left by earlier files (participants,
executor threads, sockets) slowed later rclpy tests until their timeouts failed at random,
although each file passes on its own. A process per file (as ``colcon test`` gives one
per package) removes that coupling; each process still isolates its ROS domain through
the root conftest.

Usage: ``python tools/run_tests.py [pytest args...]`` from the repository root (``make
test-python``). Prints a line per file, a line per top-level folder (for a ROS package, the
count ``colcon test`` reports for it) and a closing ``N passed, N failed, N skipped`` line;
exits non-zero if any test failed or errored, a file could not be collected, or a file
collected no test at all (pytest's exit 5: a renamed test module must not pass silently).
"""
from __future__ import annotations

import configparser
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: pytest's exit code when a file collects no test (every test deselected or none written).
NO_TESTS_COLLECTED = 5


def test_files() -> list[Path]:
    """Every ``test_*.py`` below the ``testpaths`` of pytest.ini, in a stable order."""
    config = configparser.ConfigParser()
    config.read(ROOT / 'pytest.ini')
    folders = config['pytest']['testpaths'].split()
    return sorted(path for folder in folders if (ROOT / folder).is_dir()
                  for path in (ROOT / folder).rglob('test_*.py'))


def counts_from_junit(report: Path) -> dict[str, int]:
    """Test counts of one junit XML report (zeros when pytest wrote none)."""
    totals = {'tests': 0, 'failures': 0, 'errors': 0, 'skipped': 0}
    if not report.exists():
        return totals
    for suite in ElementTree.parse(report).getroot().iter('testsuite'):
        for key in totals:
            totals[key] += int(suite.get(key, 0))
    return totals


def selects_tests(pytest_args: list[str]) -> bool:
    """True if ``pytest_args`` select a subset (``-k``, ``-m``): then a file may rightly
    collect nothing."""
    return any(arg in ('-k', '-m') or arg.startswith(('-k=', '-m=')) for arg in pytest_args)


def main(pytest_args: list[str], files: list[Path] | None = None, root: Path = ROOT) -> int:
    """Run each test file (default: :func:`test_files`) in its own pytest process.

    Returns
    -------
    int
        0 if every file passed; 1 if a test failed or errored, a file could not be
        collected, or a file collected no test without ``-k``/``-m`` selecting.
    """
    files = test_files() if files is None else files
    empty_allowed = selects_tests(pytest_args)
    passed = failed = skipped = 0
    per_package: dict[str, list[int]] = {}
    broken: list[str] = []
    started = time.monotonic()
    with tempfile.TemporaryDirectory() as folder:
        for index, path in enumerate(files):
            report = Path(folder) / f'{index}.xml'
            relative = path.relative_to(root)
            begin = time.monotonic()
            result = subprocess.run(
                [sys.executable, '-m', 'pytest', str(relative), '-q', '-p', 'no:cacheprovider',
                 f'--junitxml={report}', *pytest_args], cwd=root)
            counts = counts_from_junit(report)
            file_failed = counts['failures'] + counts['errors']
            file_passed = counts['tests'] - file_failed - counts['skipped']
            passed += file_passed
            failed += file_failed
            skipped += counts['skipped']
            package = per_package.setdefault(relative.parts[0], [0, 0, 0])
            package[0] += file_passed
            package[1] += file_failed
            package[2] += counts['skipped']
            if result.returncode == NO_TESTS_COLLECTED and not empty_allowed:
                broken.append(f'{relative} (exit 5: no test collected, a file that tests '
                              f'nothing is a failure)')
            elif result.returncode not in (0, NO_TESTS_COLLECTED) or file_failed:
                broken.append(f'{relative} (exit {result.returncode})')
            print(f'[tests] {relative}: {file_passed} passed, {file_failed} failed, '
                  f'{counts["skipped"]} skipped in {time.monotonic() - begin:.1f} s', flush=True)
    print(f'[tests] {len(files)} files in {time.monotonic() - started:.0f} s')
    for name, (package_passed, package_failed, package_skipped) in sorted(per_package.items()):
        print(f'[tests] {name}: {package_passed} passed, {package_failed} failed, '
              f'{package_skipped} skipped')
    for name in broken:
        print(f'[tests] FAILED: {name}')
    print(f'pytest: {passed} passed, {failed} failed, {skipped} skipped')
    return 1 if broken else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
