"""tools/setup.sh on the machines it promises to handle, run for real in a copy of the tree.

- A machine with ROS 2 Jazzy sourced, as Ubuntu 24.04 has it: Python 3.12, ROS's Python
  packages on PYTHONPATH, its libraries on LD_LIBRARY_PATH, ROS_DISTRO=jazzy. There is no
  ROS install here, so the test builds a stand-in: the ROS 2 Jazzy wheels for CPython 3.12
  installed with ``pip --prefix`` into ``<tmp>/opt/ros/jazzy`` and a ``setup.bash`` that
  sets what ``/opt/ros/jazzy/setup.bash`` sets. What it does not have (no apt packages, no
  launch stack, no rosdep) is said in the README.
- Wrong inputs: an unknown option, a launch kit folder without wheels, ROS_DISTRO set
  without an importable rclpy, a Python the wheels do not exist for. Each must stop with a
  clear message before touching anything.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CONSTRAINTS = ROOT / 'requirements' / 'constraints.txt'


def find_python(version: str) -> str | None:
    """An interpreter of ``version`` (e.g. '3.12') on PATH or in pyenv, or None."""
    found = shutil.which(f'python{version}')
    pyenv_root = Path(os.environ.get('PYENV_ROOT', Path.home() / '.pyenv')) / 'versions'
    candidates = [found] if found else []
    candidates += sorted(str(p) for p in pyenv_root.glob(f'{version}.*/bin/python{version}'))
    for candidate in candidates:
        if candidate and subprocess.run([candidate, '-c', 'import venv'],
                                        capture_output=True).returncode == 0:
            return candidate
    return None


def copy_tree(destination: Path) -> Path:
    """The files git tracks (as they are in the working tree) copied to ``destination``."""
    listed = subprocess.run(['git', 'ls-files', '-z'], cwd=ROOT, capture_output=True,
                            check=True).stdout.decode().split('\0')
    for name in filter(None, listed):
        source = ROOT / name
        if source.is_file():
            target = destination / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    return destination


def clean_environment(**extra: str) -> dict[str, str]:
    """A login-like environment: no venv, no ROS, no PYTHONPATH of this test run."""
    environment = {'HOME': os.environ.get('HOME', '/root'),
                   'PATH': '/usr/local/bin:/usr/bin:/bin', 'LANG': 'C.UTF-8'}
    for name in ('PIP_INDEX_URL', 'PIP_EXTRA_INDEX_URL', 'PIP_FIND_LINKS', 'PIP_CONFIG_FILE',
                 'PYENV_ROOT', 'TMPDIR'):
        if name in os.environ:
            environment[name] = os.environ[name]
    environment.update(extra)
    return environment


def run_setup(tree: Path, prelude: str = '', *arguments: str,
              **extra: str) -> subprocess.CompletedProcess:
    """``bash tools/setup.sh ARGUMENTS`` in ``tree`` after the shell lines ``prelude``."""
    quoted = ' '.join(f"'{argument}'" for argument in arguments)
    script = f'{prelude}\nbash tools/setup.sh {quoted}'
    return subprocess.run(['bash', '-c', script], cwd=tree, env=clean_environment(**extra),
                          capture_output=True, text=True, timeout=1200)


def make_standin_ros(prefix: Path, python: str) -> Path:
    """A stand-in for ``/opt/ros/jazzy`` built from the Jazzy wheels for ``python``.

    Returns the path of its ``setup.bash``.
    """
    subprocess.run([python, '-m', 'pip', 'install', '-q', '--disable-pip-version-check',
                    '--prefix', str(prefix), '-c', str(CONSTRAINTS),
                    '-r', str(ROOT / 'requirements' / 'ros.txt'), 'setuptools'],
                   check=True, capture_output=True, timeout=900)
    version = subprocess.run([python, '-c', 'import sys; print("%d.%d" % sys.version_info[:2])'],
                             capture_output=True, text=True, check=True).stdout.strip()
    include = subprocess.run(
        [python, '-c', 'import sysconfig; print(sysconfig.get_paths()["include"])'],
        capture_output=True, text=True, check=True).stdout.strip()
    site = prefix / 'lib' / f'python{version}' / 'site-packages'
    # the wheels' CMake exports name their build machine's paths (as on a bare machine)
    for export in prefix.glob('share/*/cmake/export_*__rosidl_generator_pyExport.cmake'):
        text = export.read_text()
        wheel_builder = f'/opt/python/cp3{version[2:]}-cp3{version[2:]}'
        text = text.replace(f'{wheel_builder}/include/python{version}', include)
        text = text.replace(f'{wheel_builder}/lib/python{version}/site-packages', str(site))
        export.write_text(text)
    python_bin = prefix / 'python_bin'
    python_bin.mkdir(exist_ok=True)
    (python_bin / 'python3').symlink_to(python)  # Ubuntu's python3 is ROS's Python
    libraries = ':'.join([str(prefix / 'lib'), *map(str, sorted(site.glob('ros_*.libs')))])
    setup = prefix / 'setup.bash'
    setup.write_text(
        '# stand-in for /opt/ros/jazzy/setup.bash (see test_setup_script.py)\n'
        'export ROS_DISTRO=jazzy ROS_VERSION=2 ROS_PYTHON_VERSION=3\n'
        f'export AMENT_PREFIX_PATH={prefix} CMAKE_PREFIX_PATH={prefix}\n'
        f'export PYTHONPATH={site}\n'
        f'export LD_LIBRARY_PATH={libraries}\n'
        f'export PATH={python_bin}:{prefix}/bin:$PATH\n')
    return setup


# --- wrong inputs: clear errors, nothing touched ---------------------------------------------
@pytest.mark.parametrize('arguments, message', [
    (('--frobnicate',), 'unknown argument: --frobnicate'),
    (('--launch-kit', '/nonexistent/kit'), 'no wheels/ folder there'),
])
def test_bad_arguments_stop_before_anything_is_made(tmp_path, arguments, message):
    tree = copy_tree(tmp_path / 'tree')
    result = run_setup(tree, '', *arguments)
    assert result.returncode == 1
    assert message in result.stderr
    assert not (tree / '.venv').exists()


def test_ros_sourced_without_rclpy_is_a_clear_error(tmp_path):
    tree = copy_tree(tmp_path / 'tree')
    result = run_setup(tree, '', ROS_DISTRO='jazzy')
    assert result.returncode == 1
    assert 'cannot import rclpy' in result.stderr
    assert not (tree / '.venv').exists()


def test_a_python_without_ros_wheels_is_refused(tmp_path):
    other = find_python('3.10') or find_python('3.13')
    if other is None:
        pytest.skip('no Python 3.10 or 3.13 on this machine to try (pyenv has both on the '
                    'project machines)')
    tree = copy_tree(tmp_path / 'tree')
    result = run_setup(tree, '', PYTHON=other)
    assert result.returncode == 1
    assert 'the ROS 2 Jazzy wheels exist for CPython 3.11 and 3.12' in result.stderr
    assert not (tree / '.venv').exists()


# --- a machine with ROS 2 Jazzy (Python 3.12) sourced ----------------------------------------
@pytest.mark.slow
def test_sourced_ros_with_python_312_is_used_and_not_reinstalled(tmp_path):
    python = find_python('3.12')
    assert python is not None, 'Python 3.12 is needed for this test (pyenv on the machines)'
    ros = make_standin_ros(tmp_path / 'opt' / 'ros' / 'jazzy', python)
    tree = copy_tree(tmp_path / 'tree')
    result = run_setup(tree, f'source {ros}')
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert 'using the sourced ROS 2 Jazzy (Python 3.12' in result.stdout
    venv_site = tree / '.venv' / 'lib' / 'python3.12' / 'site-packages'
    assert venv_site.is_dir(), 'the venv must use ROS\'s Python (3.12)'
    # nothing ROS provides is installed again into the venv
    reinstalled = sorted(p.name for p in venv_site.iterdir()
                         if p.name.startswith(('rclpy', 'ros_', 'rosidl', 'rmw')))
    assert reinstalled == [], reinstalled
    probe = ('import rclpy, forte_msgs.msg, forte_ros, forte_driver, forte_sim, forte_perception, '
             'forte_control, forte_bringup, sys; print(sys.version_info[:2]); '
             'print(rclpy.__file__); '
             'print(forte_msgs.__file__)')
    check = subprocess.run(
        ['bash', '-c', f'source {ros} && set +u && source install/setup.bash && '
                       f'python -c "{probe}"'],
        cwd=tree, env=clean_environment(), capture_output=True, text=True, timeout=120)
    assert check.returncode == 0, check.stderr[-3000:]
    version, rclpy_file, msgs_file = check.stdout.split('\n')[:3]
    assert version == '(3, 12)'
    assert rclpy_file.startswith(str(tmp_path / 'opt' / 'ros' / 'jazzy'))  # ROS's own rclpy
    assert msgs_file.startswith(str(tree / 'install' / 'forte_msgs'))  # built by colcon
    # a second run changes nothing and says so quickly
    again = run_setup(tree, f'source {ros}')
    assert again.returncode == 0, again.stderr[-3000:]
    assert 'installing' not in again.stdout and 'colcon build' not in again.stdout, again.stdout

