"""What forte_perception's tests need from pytest, provided by the package itself.

- DDS isolation before any test module imports rclpy (discovery on loopback, a domain id
  held by this process alone; :mod:`forte_ros.isolation`) and the ``slow`` marker. In a
  clone of the repository ``colcon test`` also finds the workspace's ``pytest.ini`` and
  ``conftest.py`` above this package, but these tests do not rely on them (with a package
  configuration or another layout pytest would not load them).
"""
import pytest

from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()


@pytest.hookimpl(trylast=True)  # after pytest.ini and the plugins have registered theirs
def pytest_configure(config):
    if not any(line.split(':')[0].strip() == 'slow' for line in config.getini('markers')):
        config.addinivalue_line('markers', 'slow: takes more than ~20 s')
