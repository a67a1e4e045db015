"""What forte_sim's tests need from pytest, provided by the package itself.

- DDS isolation before any test module imports rclpy (discovery on loopback, a domain id
  held by this process alone; :mod:`forte_ros.isolation`). In a clone of the repository
  ``colcon test`` also finds the workspace's ``conftest.py`` above this package, but these
  tests do not rely on it (with a package configuration or another layout pytest would not
  load it).
- The simulated-servo fixtures of the bench twin's tests
  (:mod:`forte_driver.emulators.pytest_fixtures`: a slower peer's latency allowance, the
  servo pair's port).
"""
from forte_driver.emulators.pytest_fixtures import port, slow_peer_latency  # noqa: F401
from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()
