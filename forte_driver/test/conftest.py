"""DDS isolation for the forte_driver tests, provided by the package itself.

``colcon test`` runs this package's tests alone; in a clone of the repository pytest also
finds the workspace's ``conftest.py`` above it, but these tests do not rely on it (with a
package configuration or another layout pytest would not load it). Before any test module
imports rclpy: discovery on loopback and a domain id held by this process alone
(:mod:`forte_ros.isolation`, pure Python; calling it again keeps the id).
"""
from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()
