"""What forte_bringup's tests need from pytest, provided by the package itself.

``colcon test`` runs pytest in this package's folder. In a clone of the repository pytest
also finds the workspace's ``pytest.ini`` and ``conftest.py`` above it, but these tests do
not rely on them (pytest uses the first configuration file it meets going up, so a package
configuration or another layout hides them):

- DDS isolation before any test module imports rclpy (discovery on loopback, a domain id
  held by this process alone; :mod:`forte_ros.isolation`);
- the markers these tests use, ``slow`` and ``timeout`` of pytest-timeout (declared as
  ``<test_depend>python3-pytest-timeout</test_depend>``), registered by
  :func:`forte_ros.pytest_plugin.pytest_configure`.
"""
from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import (  # noqa: F401 (pytest hooks and fixtures, see that module)
    leak_guard,
    pytest_configure,
    pytest_pycollect_makemodule,
)

isolate_ros_network()
