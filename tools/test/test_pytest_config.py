"""Each FORTE package's tests carry the pytest configuration they need.

``colcon test`` runs each package's tests in that package's folder with whatever pytest
plugins ``rosdep install`` put there (Ubuntu 24.04: pytest 7.4.4). So, per package:

- a marker that a pytest plugin provides is only used if the plugin's rosdep key is a
  ``<test_depend>`` (or ``<depend>``) of the package (:data:`PLUGIN_MARKERS`);
- every other marker beyond pytest's own is registered by the package's ``test/conftest.py``
  (``markers`` lines), so that the tests collect under ``--strict-markers`` without the
  workspace's ``pytest.ini`` and without the plugin;
- ``test/conftest.py`` isolates DDS (:mod:`forte_ros.isolation`) itself, before any test
  module imports rclpy, rather than relying on the workspace's ``conftest.py``.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

from forte_ros.pytest_plugin import MARKERS

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ('forte_ros', 'forte_msgs', 'forte_description', 'forte_driver', 'forte_sim',
            'forte_perception', 'forte_control', 'forte_evaluation', 'forte_bringup',
            'forte_commissioning')

#: Markers of pytest itself.
BUILTIN_MARKERS = {'parametrize', 'skip', 'skipif', 'xfail', 'usefixtures', 'filterwarnings'}

#: Marker -> rosdep key of the pytest plugin that provides it.
PLUGIN_MARKERS = {
    'timeout': 'python3-pytest-timeout',
    # launch_pytest's plugin registers it; its test modules importorskip launch_pytest first
    'launch': 'launch_pytest',
}

#: Plugin markers the package's conftest need not register (the module skips without them).
SKIPPED_WITHOUT_PLUGIN = {'launch'}


def markers_used(package: str) -> dict[str, set[str]]:
    """``pytest.mark.<name>`` names in the package's tests -> the files using them."""
    used: dict[str, set[str]] = {}
    for path in sorted((ROOT / package / 'test').rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute)
                    and node.value.attr == 'mark' and isinstance(node.value.value, ast.Name)
                    and node.value.value.id == 'pytest'):
                used.setdefault(node.attr, set()).add(str(path.relative_to(ROOT)))
    return used


def test_packages_without_dds_import_no_ros():
    for package in WITHOUT_DDS:
        files = list((ROOT / package / 'test').glob('*.py'))
        assert files and not any('rclpy' in path.read_text() or 'forte_ros' in path.read_text()
                                 for path in files), package


def test_markers_are_found():
    assert {'timeout', 'slow'} <= set(markers_used('forte_bringup'))


@pytest.mark.parametrize('package', PACKAGES)
def test_plugin_markers_are_declared_test_dependencies(package: str):
    manifest = parse_package(ROOT / package / 'package.xml')
    declared = {d.name for d in (*manifest.exec_depends, *manifest.test_depends)}
    missing = {f'{name} ({", ".join(sorted(files))})': PLUGIN_MARKERS[name]
               for name, files in markers_used(package).items()
               if name in PLUGIN_MARKERS and PLUGIN_MARKERS[name] not in declared}
    assert not missing, (f'{package}: markers of pytest plugins without the plugin as '
                         f'<test_depend> in package.xml: {missing}')


@pytest.mark.parametrize('package', PACKAGES)
def test_custom_markers_are_registered_by_the_package(package: str):
    conftest = ROOT / package / 'test' / 'conftest.py'
    text = conftest.read_text() if conftest.exists() else ''
    if 'pytest_configure,' in text and 'from forte_ros.pytest_plugin import' in text:
        text += '\n'.join(f"'{line}" for line in MARKERS)  # registered by the shared hook
    unregistered = sorted(
        name for name in markers_used(package)
        if name not in BUILTIN_MARKERS | SKIPPED_WITHOUT_PLUGIN
        and f"'{name}:" not in text and f"'{name}(" not in text)
    assert not unregistered, (
        f'{package}/test/conftest.py does not register the markers {unregistered} (a '
        "'markers' line in pytest_configure): without the workspace's pytest.ini or the "
        'plugin, --strict-markers stops the collection')


#: Packages whose tests start no ROS node (no rclpy, no DDS): package -> why.
WITHOUT_DDS = {'forte_description': 'xacro and file checks only (the package has no Python '
                                    'and no Python test dependency on forte_ros)'}


@pytest.mark.parametrize('package', [name for name in PACKAGES if name not in WITHOUT_DDS])
def test_package_conftest_isolates_dds(package: str):
    conftest = ROOT / package / 'test' / 'conftest.py'
    assert conftest.exists(), f'{package}/test/conftest.py is missing'
    calls = [node for node in ast.parse(conftest.read_text()).body
             if isinstance(node, ast.Expr) and isinstance(node.value, ast.Call)
             and getattr(node.value.func, 'id', None) == 'isolate_ros_network']
    assert calls, (f'{package}/test/conftest.py must call isolate_ros_network() at import, '
                   'before any test module imports rclpy')
