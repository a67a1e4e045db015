"""tools/run_tests.py judges each package run by what pytest really did: failures, files
that report nothing, a crashed process, a module that skips at import (alone, with its
reason) or leaves something running (forte_ros.pytest_plugin, loaded as every FORTE
conftest loads it)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import run_tests  # noqa: E402

#: The conftest of the scratch workspaces: the shared plugin, as the packages' conftests.
CONFTEST = 'from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule\n'
PASSING = 'def test_one():\n    assert 1 + 1 == 2\n'
FAILING = 'def test_one():\n    assert 1 + 1 == 3\n'
#: a test module whose tests were renamed away: pytest collects nothing from it
NOTHING = 'def helper():\n    return 1\n'
#: a launch test on a machine without the launch stack
NEEDS_KIT = ('import pytest\n'
             "pytest.importorskip('launch_stack_absent_here', reason='needs the launch kit')\n"
             'def test_launch():\n    pass\n')
#: a test that starts a thread and never stops it
LEAKS_A_THREAD = ('import threading\n'
                  'def test_starts_a_thread():\n'
                  '    threading.Thread(target=threading.Event().wait, name="forgotten",\n'
                  '                     daemon=True).start()\n')
#: a test that starts a child process and never stops it
LEAKS_A_PROCESS = ('import subprocess, sys\n'
                   'def test_starts_a_process():\n'
                   '    subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])\n')
#: a process pool: its resource tracker outlives it by design (not a leak)
USES_A_POOL = ('from concurrent.futures import ProcessPoolExecutor\n'
               'def test_uses_a_pool():\n'
               '    with ProcessPoolExecutor(1) as pool:\n'
               '        assert pool.submit(abs, -2).result() == 2\n')
#: a test whose process dies (as a segfault in a C extension would end it)
CRASHES = 'import os\ndef test_crash():\n    os._exit(134)\n'


def workspace(folder: Path, packages: dict[str, dict[str, str]]) -> Path:
    """A scratch workspace: ``packages`` maps a package name to its test files (name ->
    text), each in ``<package>/test/``; pytest.ini lists them as testpaths."""
    (folder / 'pytest.ini').write_text(
        '[pytest]\ntestpaths = ' + ' '.join(f'{name}/test' for name in packages) + '\n')
    (folder / 'conftest.py').write_text(CONFTEST)
    for name, files in packages.items():
        (folder / name / 'test').mkdir(parents=True)
        for file_name, text in files.items():
            (folder / name / 'test' / file_name).write_text(text)
    return folder


def run(folder: Path, capfd, *arguments: str) -> tuple[int, str]:
    code = run_tests.main(list(arguments), root=folder)
    return code, capfd.readouterr().out


@pytest.mark.parametrize(('text', 'code'), [(PASSING, 0), (FAILING, 1), (NOTHING, 1)])
def test_exit_code_follows_what_pytest_did(tmp_path, capfd, text, code):
    root = workspace(tmp_path, {'alpha': {'test_good.py': PASSING, 'test_other.py': text}})
    exit_code, output = run(root, capfd)
    assert exit_code == code
    if text is NOTHING:
        assert 'FAILED alpha/test/test_other.py: reported no test' in output
    closing = output.strip().splitlines()[-1]
    assert closing == {0: 'pytest: 2 passed, 0 failed, 0 skipped',
                       1: 'pytest: 1 passed, 1 failed, 0 skipped'}[code]


def test_a_selection_may_leave_a_file_empty(tmp_path, capfd):
    root = workspace(tmp_path, {'alpha': {'test_good.py': PASSING,
                                          'test_other.py': 'def test_two():\n    pass\n'}})
    assert run(root, capfd, '-k', 'one')[0] == 0
    assert run(root, capfd, '-k', 'nothing_matches')[0] == 0
    assert run(root, capfd)[0] == 0


def test_a_module_that_skips_at_import_skips_alone_with_its_reason(tmp_path, capfd):
    # the launch test sorts first in its folder: without the plugin's collection hook,
    # launch_testing's plugin (installed with the launch stack) would skip the whole folder
    root = workspace(tmp_path, {'alpha': {'test_a_launch.py': NEEDS_KIT,
                                          'test_b_plain.py': PASSING}})
    code, output = run(root, capfd)
    assert code == 0, output
    assert output.strip().splitlines()[-1] == 'pytest: 1 passed, 0 failed, 1 skipped'
    assert 'SKIPPED alpha/test/test_a_launch.py' in output
    assert 'whole module: needs the launch kit\n' in output


@pytest.mark.parametrize(('text', 'found'), [(LEAKS_A_THREAD, "thread 'forgotten'"),
                                             (LEAKS_A_PROCESS, 'child process'),
                                             (USES_A_POOL, None)])
def test_a_module_that_leaves_something_running_fails(tmp_path, capfd, text, found):
    root = workspace(tmp_path, {'alpha': {'test_leak.py': text, 'test_later.py': PASSING}})
    code, output = run(root, capfd)
    if found is None:
        assert code == 0, output
        return
    assert code == 1
    assert found in output
    assert 'FAILED alpha/test/test_leak.py' in output


def test_a_crashed_package_fails_and_the_next_package_still_runs(tmp_path, capfd):
    root = workspace(tmp_path, {'alpha': {'test_a_crash.py': CRASHES,
                                          'test_b_after.py': PASSING},
                                'beta': {'test_good.py': PASSING}})
    code, output = run(root, capfd)
    assert code == 1
    assert 'alpha: pytest exited 134' in output
    assert 'FAILED alpha/test/test_b_after.py: reported no test' in output
    assert '[tests] beta: 1 passed, 0 failed, 0 skipped' in output


def test_packages_can_be_chosen_and_an_unknown_one_is_refused(tmp_path, capfd):
    root = workspace(tmp_path, {'alpha': {'test_good.py': FAILING},
                                'beta': {'test_good.py': PASSING}})
    code, output = run(root, capfd, '--package', 'beta')
    assert code == 0 and '[tests] alpha' not in output
    code, output = run(root, capfd, '--package', 'gamma')
    assert code == 1 and "unknown package(s) ['gamma']" in output


def test_the_summary_lists_the_slowest_tests_first(tmp_path, capfd):
    slow = 'import time\ndef test_slow():\n    time.sleep(0.3)\n'
    root = workspace(tmp_path, {'alpha': {'test_fast.py': PASSING, 'test_slow.py': slow}})
    code, output = run(root, capfd)
    assert code == 0
    lines = output.splitlines()
    heading = lines.index('[tests] slowest 15 tests (setup + call + teardown):')
    assert lines[heading + 1].endswith('alpha/test/test_slow.py::test_slow')
    assert float(lines[heading + 1].split()[1]) >= 0.3


def test_burners_load_the_machine_while_the_tests_run_and_end_with_them(tmp_path, capfd):
    # a test that sees a burner started by its own runner (a sibling: same parent process)
    sees_burner = ('import os\n'
                   'from pathlib import Path\n'
                   'def test_sees_a_burner():\n'
                   '    siblings = [p.parent for p in Path("/proc").glob("[0-9]*/stat")\n'
                   '                if p.exists() and p.read_text().rsplit(")", 1)[1].split()[1]\n'
                   '                == str(os.getppid())]\n'
                   '    assert any(b"while True: pass" in (s / "cmdline").read_bytes()\n'
                   '               for s in siblings if (s / "cmdline").exists())\n')
    root = workspace(tmp_path, {'alpha': {'test_burner.py': sees_burner}})
    code, output = run(root, capfd, '--burners', '1')
    assert code == 0, output
    assert '1 CPU burner(s) running beside the tests' in output
    code, output = run(root, capfd)
    assert code == 1  # no burner without the option, and none left by the first run


def rendezvous(folder: Path, mine: str, theirs: str, niceness: int) -> str:
    """A test that leaves a marker file and waits (at most 30 s) for the other package's:
    it passes only if both run at the same time; it also checks its own niceness."""
    return ('import os, time\n'
            'from pathlib import Path\n'
            'def test_meets_the_other_package(tmp_path_factory):\n'
            f'    folder = Path({str(folder)!r})\n'
            f'    (folder / {mine!r}).touch()\n'
            '    deadline = time.monotonic() + 30.0\n'
            f'    while not (folder / {theirs!r}).exists() and time.monotonic() < deadline:\n'
            '        time.sleep(0.05)\n'
            f'    assert (folder / {theirs!r}).exists()\n'
            f'    assert os.nice(0) == {niceness}\n')


def test_two_packages_run_side_by_side_the_second_at_lower_priority(tmp_path, capfd):
    meeting = tmp_path / 'meeting'
    meeting.mkdir()
    own = os.nice(0)
    root = workspace(tmp_path, {
        'alpha': {'test_meet.py': rendezvous(meeting, 'alpha', 'beta', own)},
        # Linux caps niceness at 19 (this test may itself run beside another package)
        'beta': {'test_meet.py': rendezvous(meeting, 'beta', 'alpha',
                                            min(19, own + run_tests.BESIDE_NICENESS))}})
    code, output = run(root, capfd, '--jobs', '2')
    assert code == 0, output
    assert '2 packages in' in output and '(2 at a time)' in output
    assert '[tests] ----- alpha -----' in output and '[tests] ----- beta -----' in output


def test_live_graph_packages_run_one_after_another_and_the_others_beside_them(
        tmp_path, capfd, monkeypatch):
    # alpha and gamma stand for two live-graph packages: gamma must not start before alpha
    # has ended, both at the runner's priority; beta runs beside alpha at lower priority
    meeting = tmp_path / 'meeting'
    meeting.mkdir()
    own = os.nice(0)
    ends = ('import os, time\n'
            'from pathlib import Path\n'
            'def test_long_live_graph():\n'
            f'    assert os.nice(0) == {own}\n'
            '    time.sleep(1.0)\n'
            f'    (Path({str(meeting)!r}) / "alpha ended").touch()\n')
    after = ('import os\n'
             'from pathlib import Path\n'
             'def test_starts_after_the_other_live_graphs():\n'
             f'    assert os.nice(0) == {own}\n'
             f'    assert (Path({str(meeting)!r}) / "alpha ended").exists()\n')
    root = workspace(tmp_path, {
        'alpha': {'test_a_meet.py': rendezvous(meeting, 'alpha', 'beta', own),
                  'test_b_ends.py': ends},
        'beta': {'test_meet.py': rendezvous(meeting, 'beta', 'alpha',
                                            min(19, own + run_tests.BESIDE_NICENESS))},
        'gamma': {'test_after.py': after}})
    monkeypatch.setattr(run_tests, 'LIVE_GRAPHS', ('alpha', 'gamma'))
    code, output = run(root, capfd, '--jobs', '2')
    assert code == 0, output
    assert '3 packages in' in output and '(2 at a time)' in output
