"""What forte_driver's tests need from pytest, provided by the package itself.

``colcon test`` runs this package's tests alone; in a clone of the repository pytest also
finds the workspace's ``conftest.py`` above it, but these tests do not rely on it (with a
package configuration or another layout pytest would not load it).

- Before any test module imports rclpy: discovery on loopback and a domain id held by this
  process alone (:mod:`forte_ros.isolation`, pure Python; calling it again keeps the id).
- The fixtures of the tests against the fake hardware's simulated servos
  (:mod:`forte_driver.emulators.pytest_fixtures`).
"""
from forte_driver.emulators.pytest_fixtures import port, slow_peer_latency  # noqa: F401
from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()
