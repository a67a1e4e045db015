"""Every import of each FORTE package is declared in its package.xml.

``rosdep install --from-paths src`` installs what the package.xml files declare and nothing
else: an undeclared import works in the development venv and fails on a robot. For each
package this parses every ``.py`` file of its module folder, ``test/`` and ``launch/`` with
``ast`` (imports inside functions and ``try`` blocks included, and
``pytest.importorskip('name')``), maps each imported top-level module to the package.xml
key it needs (:data:`ROSDEP_KEYS`) and checks the declaration: runtime code needs
``<depend>``/``<exec_depend>``, test-only imports may be ``<test_depend>``. Libraries
without a rosdep key (:data:`PIP_ONLY`) must be in README's pip command instead; a test may
import what only an optional, undeclared package brings (:data:`OPTIONAL`). In reverse,
every ``<depend>``/``<exec_depend>`` must be imported by runtime code or be in
:data:`RUNTIME_ONLY` with its reason. An import in no table fails, naming file and module.
"""
from __future__ import annotations

import ast
import re
import sys
from collections import defaultdict
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ('forte_ros', 'forte_msgs', 'forte_description', 'forte_driver', 'forte_sim',
            'forte_perception', 'forte_control', 'forte_evaluation', 'forte_bringup',
            'forte_commissioning')

#: Imported top-level module -> the package.xml key it needs: Python libraries by their key
#: in ros/rosdistro rosdep/python.yaml, ROS 2 packages (and FORTE's own) by package name.
ROSDEP_KEYS: dict[str, str] = {
    'catkin_pkg': 'python3-catkin-pkg',
    'matplotlib': 'python3-matplotlib',
    'numpy': 'python3-numpy',
    'pytest': 'python3-pytest',
    'scipy': 'python3-scipy',
    'serial': 'python3-serial',  # pyserial
    'sklearn': 'python3-sklearn',  # scikit-learn
    'yaml': 'python3-yaml',  # PyYAML
    **{name: name for name in (
        'builtin_interfaces', 'control_msgs', 'diagnostic_msgs', 'dynamixel_sdk', 'geometry_msgs',
        'launch',
        'launch_pytest', 'launch_ros', 'lifecycle_msgs', 'rcl_interfaces', 'rclpy',
        'ros2action', 'ros2cli', 'ros2launch', 'ros2lifecycle', 'ros2topic',
        'rosgraph_msgs', 'sensor_msgs', 'std_msgs', 'std_srvs', 'visualization_msgs', 'xacro',
        *PACKAGES)},
}

#: Imported module -> pip distribution, for libraries that have no rosdep key (not
#: declared in package.xml; README's robot section installs them with pip).
PIP_ONLY: dict[str, str] = {
    'mcap': 'mcap',
    'mcap_ros2': 'mcap-ros2-support',
    'rosbags': 'rosbags',
}

#: Modules imported only where an optional package, deliberately not declared, is installed:
#: module -> why. robot_state_publisher is optional (a graph without it says so in one line
#: and goes on; the bare machine has no wheel of it), so it is no <exec_depend>.
OPTIONAL: dict[str, str] = {
    'tf2_msgs': 'test_visualization_live.py reads /tf only where robot_state_publisher runs '
                '(which depends on tf2_msgs)',
}

#: Modules of a package's own folder that only tests import (the test helpers shared across
#: packages, docs/testing.md): their imports are test imports, declared as <test_depend>.
TEST_SUPPORT: dict[str, str] = {
    'forte_ros/forte_ros/testing.py': 'helpers for the tests of every package',
    'forte_ros/forte_ros/pytest_plugin.py': 'the pytest hooks every conftest loads',
    'forte_perception/forte_perception/testing.py': 'synthetic signals of the perception and '
                                                    'slip-evaluation tests',
    'forte_driver/forte_driver/emulators/pytest_fixtures.py': 'the simulated-servo fixtures '
                                                              'of the driver and twin tests',
    'forte_driver/forte_driver/emulators/serial_host.py': 'a minimal sensor host of the '
                                                          'emulator and twin tests',
    'forte_bringup/forte_bringup/testing.py': 'the graph probe and test devices of the graph '
                                              'tests of every package',
}

#: (package, key) declared as <depend>/<exec_depend> although no runtime code imports it.
RUNTIME_ONLY: dict[tuple[str, str], str] = {
    ('forte_msgs', 'rosidl_default_runtime'): 'the generated interfaces load it',
    ('forte_msgs', 'std_msgs'): 'the interface definitions use std_msgs/Header',
    ('forte_ros', 'lifecycle_msgs'): 'forte_ros.lifecycle drives lifecycle nodes through '
                                     'rclpy.lifecycle, which loads it',
    ('forte_driver', 'lifecycle_msgs'): 'services and transition events of its lifecycle '
                                        'nodes, used through rclpy.lifecycle',
    ('forte_sim', 'lifecycle_msgs'): 'services and transition events of the sim lifecycle '
                                     'node, used through rclpy.lifecycle',
    ('forte_bringup', 'xacro'): "expands forte_description's urdf/forte_gripper.urdf.xacro",
    ('forte_bringup', 'forte_description'): 'robot_model.py reads its urdf/ folder (share)',
    ('forte_bringup', 'robot_state_publisher'): 'the graphs start it (robot_state_publisher:='
                                                'true) where installed',
    ('forte_bringup', 'rviz2'): 'the graphs start it (rviz:=true) where installed',
    ('forte_bringup', 'diagnostic_aggregator'): 'config/diagnostics_aggregator.yaml is its '
                                                'parameter file (docs/visualization.md)',
    ('forte_bringup', 'forte_sim'): 'the sim graph and the bench twin graph start its nodes',
    ('forte_bringup', 'forte_control'): 'every graph starts its grasp controller node',
    ('forte_description', 'xacro'): 'view_gripper.launch.py runs the xacro command',
    ('forte_description', 'robot_state_publisher'): 'started by view_gripper.launch.py',
    ('forte_description', 'joint_state_publisher_gui'): 'started by view_gripper.launch.py',
    ('forte_description', 'rviz2'): 'started by view_gripper.launch.py',
}

#: Packages that import message classes by type name (importlib): forte_record records and
#: bag_replay_node replays the topics of forte_driver/forte_driver/replay/bags.py, so the
#: packages of the message types named there are runtime imports of both.
BY_TYPE_NAME = ('forte_driver', 'forte_bringup')
TOPIC_TYPES_FILE = ROOT / 'forte_driver' / 'forte_driver' / 'replay' / 'bags.py'


def imported_modules(path: Path) -> set[str]:
    """Top-level names of the modules ``path`` imports absolutely, anywhere in the file.

    Parameters
    ----------
    path : Path
        Python source file.

    Returns
    -------
    set of str
        E.g. ``{'numpy', 'rclpy', 'forte_msgs'}`` for ``from forte_msgs.msg import X``.
    """
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == 'importorskip' and node.args
              and isinstance(node.args[0], ast.Constant)):
            names.add(node.args[0].value)
    return {name.split('.')[0] for name in names}


def recorded_type_packages() -> set[str]:
    """Packages of the message types (``pkg/msg/Name`` literals) in replay/bags.py."""
    tree = ast.parse(TOPIC_TYPES_FILE.read_text())
    return {node.value.split('/')[0] for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and re.fullmatch(r'\w+/msg/\w+', node.value)}


def third_party_imports(package: str) -> dict[str, dict[str, set[str]]]:
    """Imports of ``package`` other than the standard library, itself and local helpers.

    Parameters
    ----------
    package : str
        One of :data:`PACKAGES`.

    Returns
    -------
    dict
        ``{'runtime': {module: files}, 'test': {module: files}}``; runtime = module folder(s)
        and ``launch/``, test = ``test/`` and :data:`TEST_SUPPORT` (modules runtime code
        imports are left out of it).
    """
    folder = ROOT / package
    support = {ROOT / name for name in TEST_SUPPORT}
    library = [*(folder / package).rglob('*.py'), *(folder / 'launch').rglob('*.py')]
    scopes = {'runtime': [path for path in library if path not in support],
              'test': [*(folder / 'test').rglob('*.py'),
                       *(path for path in library if path in support)]}
    # test helpers imported by their own name (perception_signals); a test subfolder's name
    # is not importable (prepend mode puts the subfolder itself on sys.path), and
    # forte_driver/test/serial must not hide pyserial's ``serial``
    local = {path.stem for path in scopes['test']} - set(PACKAGES)
    ignored = sys.stdlib_module_names | local | {package}
    found: dict[str, dict[str, set[str]]] = {'runtime': defaultdict(set), 'test': defaultdict(set)}
    for scope, paths in scopes.items():
        for path in paths:
            for module in imported_modules(path) - ignored:
                found[scope][module].add(str(path.relative_to(ROOT)))
    if package in BY_TYPE_NAME:
        for module in recorded_type_packages():
            found['runtime'][module].add(f'{TOPIC_TYPES_FILE.relative_to(ROOT)} (topic types)')
    for module in found['runtime']:
        found['test'].pop(module, None)
    return found


def test_topic_types_are_found():
    assert {'forte_msgs', 'sensor_msgs'} <= recorded_type_packages()


@pytest.mark.parametrize('package', PACKAGES)
def test_every_import_is_declared(package: str):
    manifest = parse_package(ROOT / package / 'package.xml')
    runtime_keys = {d.name for d in manifest.exec_depends}  # <depend> and <exec_depend>
    allowed = {'runtime': runtime_keys,
               'test': runtime_keys | {d.name for d in manifest.test_depends}}
    tags = {'runtime': '<depend> or <exec_depend>', 'test': '<test_depend> (or <depend>)'}
    problems = []
    for scope, modules in third_party_imports(package).items():
        for module, files in sorted(modules.items()):
            where = ', '.join(sorted(files))
            if module in PIP_ONLY or (scope == 'test' and module in OPTIONAL):
                continue
            if module not in ROSDEP_KEYS:
                problems.append(
                    f'{where}: imports {module!r}, which is in no table of {Path(__file__).name}:'
                    ' add its rosdep key to ROSDEP_KEYS and package.xml, or, if it has none,'
                    ' its pip distribution to PIP_ONLY and README')
            elif ROSDEP_KEYS[module] not in allowed[scope]:
                problems.append(f'{where}: imports {module!r}: declare {ROSDEP_KEYS[module]} '
                                f'as {tags[scope]} in {package}/package.xml')
    assert not problems, '\n'.join(problems)


@pytest.mark.parametrize('package', PACKAGES)
def test_every_runtime_dependency_is_used(package: str):
    manifest = parse_package(ROOT / package / 'package.xml')
    declared = {d.name for d in manifest.exec_depends}
    runtime = third_party_imports(package)['runtime']
    used = {ROSDEP_KEYS.get(module) for module in runtime}
    excused = {key for (owner, key) in RUNTIME_ONLY if owner == package}
    unused = declared - used - excused
    assert not unused, (
        f'{package}/package.xml declares {sorted(unused)} as <depend>/<exec_depend> but no '
        'runtime code imports them: remove them, make them <test_depend>, or add them to '
        'RUNTIME_ONLY with the reason')
    stale = excused - declared
    assert not stale, f'RUNTIME_ONLY names {sorted(stale)}, no longer declared by {package}'


def test_pip_only_dependencies_are_installed_by_readme_and_setup():
    readme_commands = [line for line in (ROOT / 'README.md').read_text().splitlines()
                       if 'pip install' in line]
    requirements = (ROOT / 'requirements' / 'python.txt').read_text().split()
    for distribution in PIP_ONLY.values():
        name = re.compile(rf'(?<![\w-]){re.escape(distribution)}(?![\w-])')
        assert any(name.search(line) for line in readme_commands), (
            f'README.md has no `pip install` line naming {distribution} (pip-only: no rosdep '
            'key, so rosdep leaves it out on a robot)')
        assert distribution in requirements, f'requirements/python.txt lacks {distribution}'


def test_test_module_basenames_are_unique():
    """Two test modules with one basename break pytest's default (prepend) import mode."""
    where = defaultdict(list)
    for top in (*PACKAGES, 'hardware'):
        for path in (ROOT / top / 'test').rglob('*.py'):
            if path.name not in ('conftest.py', '__init__.py'):
                where[path.name].append(str(path.relative_to(ROOT)))
    duplicates = {name: paths for name, paths in where.items() if len(paths) > 1}
    assert not duplicates, duplicates
