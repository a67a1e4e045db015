"""`colcon build` + `colcon test` of the FORTE packages over a stand-in ROS 2 Jazzy, from scratch.

    python3 tools/colcon_check.py [--launch-kit DIR] [--python python3.12] [--work DIR]
                                  [--keep] [--pytest-version 7.4.4] [-- COLCON_TEST_ARGS...]

What a ROS user does on Ubuntu 24.04 with ROS 2 Jazzy (README, "A machine with ROS 2
Jazzy"), rebuilt here without a ROS install, in a scratch folder (a temporary one unless
``--work``):

1. the stand-in Jazzy: a fresh venv (Python 3.12, Ubuntu 24.04's, when there is one) with
   the ROS 2 Jazzy wheels of requirements/ros.txt, colcon, Ubuntu 24.04's pytest (7.4.4),
   the launch kit's wheels (launch, launch_ros, launch_pytest, launch_testing, the ros2
   CLI) and its two interface packages built into a prefix, and a ``setup.bash`` that sets
   what /opt/ros/jazzy/setup.bash sets;
2. ``rosdep install --from-paths src``: every key of every ``<depend>``, ``<exec_depend>``,
   ``<test_depend>`` (and build keys) of the ten package.xml files, mapped to what provides
   it here (:data:`PIP_KEYS`, :data:`BASE_KEYS`, :data:`KIT_SOURCE_KEYS`), and only those: a
   Python library no package.xml declares is not installed. Then the README's ``pip`` line
   for the libraries without a rosdep key (rosbags, mcap, mcap-ros2-support);
3. ``colcon build --packages-up-to forte_description`` in a workspace of its own: that package
   alone is built, and ``xacro`` expands its installed macro (the arm integrator's view);
4. the tracked and new files of this working tree copied to ``ws/src/forte`` (a clone);
5. in ``ws``: ``colcon build --symlink-install``, ``colcon test``, ``colcon test-result
   --verbose``; then the counts per package from the test reports.

Exits non-zero on any failed step, any test error or failure, a declared key this script
does not know, or a package whose tests did not run. ROS discovery stays on loopback with a
domain id of this run's own (:mod:`forte_ros.isolation`). Heavy, about 30 minutes on 2
cores: ~5 for the stand-in (control_msgs builds in ~4), ~1 for the build, ~23 for the test
suite of every package in one pytest process per package. ``--work DIR`` keeps the
stand-in between runs (rebuilt when its inputs change); arguments after ``--`` go to
``colcon test`` (e.g. ``--packages-select forte_control``).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ('forte_ros', 'forte_msgs', 'forte_description', 'forte_driver', 'forte_sim',
            'forte_perception', 'forte_control', 'forte_evaluation', 'forte_bringup',
            'forte_commissioning')
REQUIREMENTS = ROOT / 'requirements'

#: Changed whenever build_stand_in changes what it makes (a kept stand-in is then rebuilt).
STAND_IN_VERSION = 1

#: rosdep key -> pip distribution that stands in for the apt package rosdep installs.
PIP_KEYS = {
    'python3-catkin-pkg': 'catkin-pkg',
    'python3-matplotlib': 'matplotlib',
    'python3-numpy': 'numpy',
    'python3-pytest': 'pytest',
    'python3-pytest-timeout': 'pytest-timeout',
    'python3-scipy': 'scipy',
    'python3-serial': 'pyserial',
    'python3-sklearn': 'scikit-learn',
    'python3-yaml': 'PyYAML',
    'dynamixel_sdk': 'dynamixel-sdk',
    'xacro': 'xacro',
}

#: ROS packages the stand-in Jazzy has without rosdep (the ROS wheels of requirements/ros.txt,
#: the launch kit's wheels): checked present in its ament index, not installed per key.
BASE_KEYS = {
    'ament_cmake', 'ament_cmake_pytest', 'ament_copyright', 'builtin_interfaces',
    'diagnostic_msgs', 'geometry_msgs', 'launch', 'launch_pytest', 'launch_ros',
    'launch_testing', 'lifecycle_msgs', 'rcl_interfaces', 'rclpy', 'ros2action', 'ros2cli',
    'ros2launch', 'ros2lifecycle', 'ros2topic', 'rosgraph_msgs', 'rosidl_default_generators',
    'rosidl_default_runtime', 'rosidl_runtime_py', 'sensor_msgs', 'std_msgs', 'std_srvs',
    'visualization_msgs',
}

#: Interface packages built from the launch kit's sources (not published as wheels).
KIT_SOURCE_KEYS = {'control_msgs', 'composition_interfaces'}

#: Declared keys the stand-in cannot provide, with the reason they may be left out.
UNAVAILABLE_KEYS = {
    'ament_flake8': 'no wheel on the package index; no FORTE test imports it',
    'ament_pep257': 'no wheel on the package index; no FORTE test imports it',
    'robot_state_publisher': 'C++, no wheel; view_gripper.launch.py and the graphs start it '
                             'where it is installed (the graphs say so in one line if not)',
    'joint_state_publisher_gui': 'a Qt GUI, no wheel; only view_gripper.launch.py starts it',
    'rviz2': 'C++ and Qt, no wheel; view_gripper.launch.py and the graphs (rviz:=true) '
             'start it where it is installed',
    'diagnostic_aggregator': 'C++, no wheel; only the lab starts it with '
                             'config/diagnostics_aggregator.yaml (docs/visualization.md)',
}

#: README's pip line: libraries with no rosdep key (test_declared_dependencies.PIP_ONLY).
README_PIP = ('rosbags', 'mcap', 'mcap-ros2-support', 'python-fcl')

#: Pins of constraints.txt that need a newer pytest than the stand-in's (pytest-rerunfailures
#: 16 needs pytest 8.2; colcon-core requires it): pip picks a release that works with it.
NEEDS_NEWER_PYTEST = ('pytest-rerunfailures',)


def say(message: str) -> None:
    print(f'[colcon-check] {message}', flush=True)


def find_python(requested: str | None) -> str:
    """The interpreter of the stand-in: ``requested``, else 3.12 (Ubuntu 24.04's), else 3.11."""
    pyenv = Path(os.environ.get('PYENV_ROOT', Path.home() / '.pyenv')) / 'versions'
    for candidate in ([requested] if requested else ['python3.12', 'python3.11']):
        # on PATH (a pyenv shim answers only for its selected versions), else in pyenv
        found = [shutil.which(candidate) or candidate,
                 *sorted(str(p) for p in pyenv.glob(f'{candidate[6:]}.*/bin/{candidate}'))]
        for path in found:
            if Path(path).is_file() and subprocess.run(
                    [path, '-c', 'import venv, ensurepip'], capture_output=True).returncode == 0:
                return path
    sys.exit(f'[colcon-check] no usable {requested or "python3.12 or python3.11"}')


def declared_keys() -> dict[str, set[str]]:
    """Every dependency key of the ten package.xml files -> the packages declaring it."""
    keys: dict[str, set[str]] = {}
    tags = ('depend', 'exec_depend', 'test_depend', 'build_depend', 'buildtool_depend',
            'build_export_depend')
    for package in PACKAGES:
        for element in ElementTree.parse(ROOT / package / 'package.xml').getroot():
            if element.tag in tags and element.text:
                keys.setdefault(element.text.strip(), set()).add(package)
    return {key: owners for key, owners in keys.items() if key not in PACKAGES}


def run(command: list[str], log: Path, env: dict[str, str] | None = None,
        cwd: Path | None = None, check: bool = True) -> subprocess.CompletedProcess:
    """Run ``command`` with its output appended to ``log``; on failure show the log's end."""
    with open(log, 'a') as out:
        out.write(f'\n$ {" ".join(command)}\n')
        out.flush()
        result = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT, env=env,
                                cwd=cwd)
    if check and result.returncode != 0:
        tail = log.read_text().splitlines()[-40:]
        sys.exit('\n'.join(tail) + f'\n[colcon-check] FAILED ({result.returncode}): '
                 f'{" ".join(command)} (log: {log})')
    return result


def stand_in_constraints(path: Path, pytest_version: str) -> None:
    """constraints.txt with ``pytest_version`` (Ubuntu 24.04's) instead of the project's."""
    lines = []
    for line in (REQUIREMENTS / 'constraints.txt').read_text().splitlines():
        name = line.split('==')[0].strip().lower()
        if name == 'pytest' or name in NEEDS_NEWER_PYTEST:
            continue
        lines.append(line)
    lines.append(f'pytest=={pytest_version}')
    path.write_text('\n'.join(lines) + '\n')


def fix_wheel_cmake_paths(venv: Path, python: Path) -> None:
    """Rewrite the wheel builder's paths in the wheels' CMake exports (as tools/setup.sh does)."""
    include, site = subprocess.run(
        [str(python), '-c', 'import sysconfig; p = sysconfig.get_paths(); '
                            'print(p["include"]); print(p["purelib"])'],
        capture_output=True, text=True, check=True).stdout.split('\n')[:2]
    for export in venv.glob('share/*/cmake/export_*__rosidl_generator_pyExport.cmake'):
        text = re.sub(r'/opt/python/cp3\d+-cp3\d+/include/python3\.\d+', include,
                      export.read_text())
        text = re.sub(r'/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages', site, text)
        export.write_text(text)


def build_kit_interfaces(underlay: Path, kit: Path, log: Path) -> Path:
    """composition_interfaces (launch_ros) and control_msgs from the kit's sources, built
    into a prefix of the stand-in (as ros-jazzy-* debs would install them); its path."""
    prefix = underlay / 'opt' / 'kit'
    say('building composition_interfaces and control_msgs from the kit (~4 min on 2 cores)')
    env = dict(os.environ, AMENT_PREFIX_PATH=str(underlay), CMAKE_PREFIX_PATH=str(underlay),
               PATH=f'{underlay / "bin"}:{os.environ["PATH"]}', VIRTUAL_ENV=str(underlay))
    run([str(underlay / 'bin' / 'colcon'), '--log-base', str(underlay / 'opt' / 'log'),
         'build', '--merge-install', '--base-paths', str(kit / 'composition_interfaces'),
         str(kit / 'control_msgs'), '--build-base', str(underlay / 'opt' / 'build'),
         '--install-base', str(prefix), '--cmake-args', '-DBUILD_TESTING=OFF',
         f'-DPython3_EXECUTABLE={underlay / "bin" / "python"}',
         '--event-handlers', 'console_direct-'], log, env=env, cwd=underlay)
    return prefix


def build_stand_in(underlay: Path, python_exe: str, kit: Path, pytest_version: str,
                   keys: dict[str, set[str]], log: Path) -> Path:
    """Make (or reuse) the stand-in Jazzy in ``underlay``; return its setup.bash."""
    pip_keys = sorted(key for key in keys if key in PIP_KEYS)
    inputs = hashlib.sha256()
    for path in [*sorted(REQUIREMENTS.glob('*.txt')), ROOT / 'tools' / 'alias_wheel.py',
                 *sorted(p for p in kit.rglob('*') if p.is_file())]:
        inputs.update(str(path).encode() + path.read_bytes())
    inputs.update(f'{STAND_IN_VERSION} {python_exe} {pytest_version} {pip_keys}'.encode())
    stamp = underlay / '.colcon-check-stamp'
    setup = underlay / 'setup.bash'
    if stamp.exists() and stamp.read_text() == inputs.hexdigest() and setup.exists():
        say(f'stand-in Jazzy unchanged, reused: {underlay}')
        return setup
    if underlay.exists():
        shutil.rmtree(underlay)
    say(f'stand-in Jazzy in {underlay} ({python_exe}; log: {log})')
    log.write_text('')
    run([python_exe, '-m', 'venv', str(underlay)], log)
    python = underlay / 'bin' / 'python'
    pip = [str(python), '-m', 'pip', 'install', '--disable-pip-version-check', '-q']
    constraints = underlay / 'constraints.txt'
    stand_in_constraints(constraints, pytest_version)
    # the ROS install: the Jazzy wheels, colcon and pytest (ROS's python3-colcon-* debs)
    run([*pip, '-c', str(constraints), '-r', str(REQUIREMENTS / 'ros.txt'),
         '-r', str(REQUIREMENTS / 'colcon.txt'), f'pytest=={pytest_version}'], log)
    fix_wheel_cmake_paths(underlay, python)
    # the launch stack and ros2 CLI (ros-jazzy-ros-base has them), with their runtime deps
    wheels = sorted(str(w) for w in (kit / 'wheels').glob('*.whl'))
    run([*pip, '--no-deps', *wheels], log)
    alias = subprocess.run(
        [str(python), str(ROOT / 'tools' / 'alias_wheel.py'), 'ament-index-python',
         'ros-ament-index-python', str(underlay / 'opt' / 'wheels')],
        capture_output=True, text=True, check=True).stdout.strip()
    run([*pip, '-c', str(constraints), '-r', str(REQUIREMENTS / 'launch-kit.txt'), alias], log)
    fix_wheel_cmake_paths(underlay, python)  # trajectory_msgs, for control_msgs
    # rosdep install --from-paths src: the declared keys, and only those
    distributions = [PIP_KEYS[key] for key in pip_keys]
    say(f'rosdep keys as pip packages: {", ".join(f"{k}={PIP_KEYS[k]}" for k in pip_keys)}')
    say(f"README's pip line: {' '.join(README_PIP)}")
    run([*pip, '-c', str(constraints), *distributions, *README_PIP], log)
    pip_check = subprocess.run([str(python), '-m', 'pip', 'check'], capture_output=True,
                               text=True)
    if pip_check.returncode != 0:
        sys.exit(f'[colcon-check] pip check in the stand-in:\n{pip_check.stdout}')
    prefix = build_kit_interfaces(underlay, kit, log)
    version = subprocess.run(
        [str(python), '-c', 'import sys; print("%d.%d" % sys.version_info[:2])'],
        capture_output=True, text=True, check=True).stdout.strip()
    setup.write_text(
        '# stand-in for /opt/ros/jazzy/setup.bash (tools/colcon_check.py)\n'
        'export ROS_DISTRO=jazzy ROS_VERSION=2 ROS_PYTHON_VERSION=3\n'
        f'export VIRTUAL_ENV={underlay}\n'
        f'export AMENT_PREFIX_PATH={prefix}:{underlay}\n'
        f'export CMAKE_PREFIX_PATH={prefix}:{underlay}\n'
        f'export PYTHONPATH={prefix}/lib/python{version}/site-packages\n'
        f'export LD_LIBRARY_PATH={prefix}/lib\n'
        f'export PATH={prefix}/bin:{underlay}/bin:$PATH\n'
        'export RMW_IMPLEMENTATION=${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}\n')
    stamp.write_text(inputs.hexdigest())
    return setup


def check_keys(keys: dict[str, set[str]], setup: Path) -> list[str]:
    """Problems: keys this script does not know, base keys the stand-in does not have."""
    problems = []
    known = PIP_KEYS.keys() | BASE_KEYS | KIT_SOURCE_KEYS | UNAVAILABLE_KEYS.keys()
    for key in sorted(keys.keys() - known):
        problems.append(f'{key} (declared by {", ".join(sorted(keys[key]))}): unknown to '
                        'tools/colcon_check.py; add it to PIP_KEYS or BASE_KEYS')
    script = ('for k in "$@"; do found=; IFS=: read -ra ps <<< "$AMENT_PREFIX_PATH"; '
              'for p in "${ps[@]}"; do [ -e "$p/share/$k/package.xml" ] && found=1; done; '
              '[ -n "$found" ] || echo "$k"; done')
    wanted = sorted(keys.keys() & (BASE_KEYS | KIT_SOURCE_KEYS))
    missing = subprocess.run(['bash', '-c', f'source {setup} && {script}', 'check', *wanted],
                             capture_output=True, text=True, check=True).stdout.split()
    problems += [f'{key}: not in the stand-in\'s ament index' for key in missing]
    for key in sorted(keys.keys() & UNAVAILABLE_KEYS.keys()):
        say(f'note: {key} (declared by {", ".join(sorted(keys[key]))}) left out: '
            f'{UNAVAILABLE_KEYS[key]}')
    return problems


def copy_clone(destination: Path) -> None:
    """This working tree's tracked and new (not ignored) files, as a clone would have them."""
    listed = subprocess.run(['git', 'ls-files', '-z', '--cached', '--others', '--exclude-standard'],
                            cwd=ROOT, capture_output=True, check=True).stdout.decode().split('\0')
    if destination.exists():
        shutil.rmtree(destination)
    for name in filter(None, listed):
        source = ROOT / name
        if source.is_file():
            target = destination / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)


def junit_counts(build: Path) -> dict[str, dict[str, int]]:
    """Per package: tests, errors, failures, skipped, time, from the reports colcon test wrote."""
    counts: dict[str, dict[str, int]] = {}
    for report in sorted(build.glob('*/**/*.xml')):
        try:
            root = ElementTree.parse(report).getroot()
        except ElementTree.ParseError:
            continue
        suites = [root] if root.tag == 'testsuite' else list(root.iter('testsuite'))
        if not suites:
            continue
        package = report.relative_to(build).parts[0]
        total = counts.setdefault(package, {'tests': 0, 'errors': 0, 'failures': 0,
                                            'skipped': 0, 'time': 0})
        for suite in suites:
            for key in ('tests', 'errors', 'failures', 'skipped'):
                total[key] += int(suite.get(key, 0))
            total['time'] += round(float(suite.get('time', 0)))
    return counts


def user_environment() -> dict[str, str]:
    """This process's environment without its venv and workspaces: a login shell's PATH,
    then ``setup.bash`` of the stand-in sets the rest."""
    env = {k: v for k, v in os.environ.items()
           if k not in ('VIRTUAL_ENV', 'PYTHONPATH', 'AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH',
                        'COLCON_PREFIX_PATH', 'LD_LIBRARY_PATH')}
    env['PATH'] = '/usr/local/bin:/usr/bin:/bin'
    return env


def colcon_build_and_test(ws: Path, setup: Path, logs: Path, test_args: list[str]) -> bool:
    """The ROS user's three commands in ``ws`` over ``setup``; True if colcon saw no failure."""
    shell = f'set -eo pipefail; source {setup}; cd {ws}; '
    env = user_environment()
    for name in ('build.log', 'test.log', 'test_result.log'):  # this run's only (a kept
        (logs / name).unlink(missing_ok=True)                  # --work showed old results)
    begin = time.monotonic()
    run(['bash', '-c', shell + 'colcon build --symlink-install '
         '--event-handlers console_direct- summary+'], logs / 'build.log', env=env)
    say(f'colcon build --symlink-install: {time.monotonic() - begin:.0f} s')
    begin = time.monotonic()
    extra = ' '.join(f"'{argument}'" for argument in test_args)
    tested = run(['bash', '-c', shell + 'colcon test --event-handlers console_direct- '
                  f'summary+ {extra}'], logs / 'test.log', env=env, check=False)
    say(f'colcon test: {time.monotonic() - begin:.0f} s (exit {tested.returncode}; log: '
        f'{logs / "test.log"})')
    result = run(['bash', '-c', shell + 'colcon test-result --verbose'],
                 logs / 'test_result.log', env=env, check=False)
    print((logs / 'test_result.log').read_text().split('\n', 2)[-1][-20000:], flush=True)
    return tested.returncode == 0 and result.returncode == 0


def description_alone(work: Path, setup: Path, logs: Path) -> bool:
    """``colcon build --packages-up-to forte_description`` in a workspace of its own builds that
    package alone (no Python package of FORTE), and ``xacro`` expands its installed macro."""
    ws = work / 'ws_description'
    shutil.rmtree(ws, ignore_errors=True)
    copy_clone(ws / 'src' / 'forte')
    shell = f'set -eo pipefail; source {setup}; cd {ws}; '
    env = user_environment()
    run(['bash', '-c', shell + 'colcon build --packages-up-to forte_description '
         '--event-handlers console_direct- summary+'], logs / 'build_description.log', env=env)
    built = sorted(path.name for path in (ws / 'install').iterdir() if path.is_dir())
    xacro_file = ws / 'install/forte_description/share/forte_description/urdf'
    expanded = run(['bash', '-c', shell + 'source install/setup.bash; xacro '
                    f'{xacro_file}/forte_gripper.urdf.xacro prefix:=left_'],
                   logs / 'xacro_description.log', env=env, check=False)
    text = (logs / 'xacro_description.log').read_text()
    alone = built == ['forte_description']
    expands = expanded.returncode == 0 and 'left_forte_base_link' in text
    say(f'colcon build --packages-up-to forte_description: built {built}; xacro '
        f'{"expands" if expands else "FAILED on"} the installed macro (prefix left_)')
    return alone and expands


def report(counts: dict[str, dict[str, int]], selected: bool) -> bool:
    """Print the counts per package and the totals; True if every package ran clean."""
    clean = True
    for package in PACKAGES:
        c = counts.get(package)
        if c is None:
            if not selected:  # with --packages-select, only the selected ones have reports
                say(f'{package}: NO TEST REPORT')
                clean = False
            continue
        passed = c['tests'] - c['errors'] - c['failures'] - c['skipped']
        say(f'{package}: {c["tests"]} tests, {passed} passed, {c["errors"]} errors, '
            f'{c["failures"]} failures, {c["skipped"]} skipped, {c["time"]} s')
        clean &= c['tests'] > 0 and c['errors'] == 0 and c['failures'] == 0
    totals = {k: sum(c[k] for c in counts.values())
              for k in ('tests', 'errors', 'failures', 'skipped')}
    say(f'total: {totals["tests"]} tests, {totals["errors"]} errors, {totals["failures"]} '
        f'failures, {totals["skipped"]} skipped')
    return clean


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--launch-kit', type=Path,
                        default=ROOT.parent / 'shared' / 'ros2-launch-kit',
                        help='a copy of shared/ros2-launch-kit (default: ../shared/...)')
    parser.add_argument('--python', help='interpreter of the stand-in (default: python3.12, '
                                         'else python3.11)')
    parser.add_argument('--pytest-version', default='7.4.4', help="default: Ubuntu 24.04's")
    parser.add_argument('--work', type=Path, help='scratch folder to use and keep (the '
                                                  'stand-in is reused while its inputs match)')
    parser.add_argument('--keep', action='store_true', help='keep the temporary folder')
    parser.add_argument('colcon_test_args', nargs='*', help='after --: passed to colcon test')
    args = parser.parse_args(argv)
    kit = args.launch_kit.resolve()
    if not (kit / 'wheels').is_dir():
        sys.exit(f'[colcon-check] no launch kit at {kit} (--launch-kit DIR)')
    started = time.monotonic()
    work = (args.work.resolve() if args.work
            else Path(tempfile.mkdtemp(prefix='forte-colcon-check-')))
    logs = work / 'logs'
    logs.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(ROOT / 'forte_ros'))
    from forte_ros.isolation import isolate_ros_network
    domain = isolate_ros_network()  # this process and every child: loopback, own domain
    say(f'scratch folder {work}; ROS_DOMAIN_ID={domain}, discovery on localhost')
    clean = False
    try:
        keys = declared_keys()
        setup = build_stand_in(work / 'jazzy', find_python(args.python), kit,
                               args.pytest_version, keys, logs / 'stand_in.log')
        problems = check_keys(keys, setup)
        for problem in problems:
            say(f'ERROR: {problem}')
        if problems:
            return 1
        if not description_alone(work, setup, logs):
            return 1
        ws = work / 'ws'
        copy_clone(ws / 'src' / 'forte')
        say(f'stand-in ready after {time.monotonic() - started:.0f} s; workspace {ws}')
        colcon_clean = colcon_build_and_test(ws, setup, logs, args.colcon_test_args)
        packages_clean = report(junit_counts(ws / 'build'), bool(args.colcon_test_args))
        clean = colcon_clean and packages_clean
        say(f'{"clean" if clean else "FAILED"} after {time.monotonic() - started:.0f} s')
        return 0 if clean else 1
    finally:
        if clean and not (args.work or args.keep):
            shutil.rmtree(work, ignore_errors=True)
        elif not args.work:
            say(f'kept {work} (logs in {logs})')


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
