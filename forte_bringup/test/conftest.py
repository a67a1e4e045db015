"""What forte_bringup's tests need from pytest, provided by the package itself.

``colcon test`` runs pytest in this package's folder. In a clone of the repository pytest
also finds the workspace's ``pytest.ini`` and ``conftest.py`` above it, but these tests do
not rely on them (pytest uses the first configuration file it meets going up, so a package
configuration or another layout hides them):

- DDS isolation before any test module imports rclpy (discovery on loopback, a domain id
  held by this process alone; :mod:`forte_ros.isolation`);
- the markers these tests use: ``slow``, and ``timeout`` of pytest-timeout (declared as
  ``<test_depend>python3-pytest-timeout</test_depend>``). Both are registered here as well,
  so that the tests collect under ``--strict-markers`` whether the plugin is installed or
  not (without it, ``timeout`` sets no limit).
"""
import pytest

from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()

#: ``markers`` lines registered unless already known (pytest.ini or a plugin).
MARKERS = (
    'slow: takes more than ~20 s',
    'timeout(seconds): fail the test after this many seconds (pytest-timeout; inert without it)',
)


def _marker_name(line: str) -> str:
    return line.split(':')[0].split('(')[0].strip()


@pytest.hookimpl(trylast=True)  # after the plugins have registered theirs
def pytest_configure(config):
    known = {_marker_name(line) for line in config.getini('markers')}
    for line in MARKERS:
        if _marker_name(line) not in known:
            config.addinivalue_line('markers', line)
