"""Test configuration shared by every package of the workspace.

Before any test imports rclpy, confine DDS discovery to loopback and give this pytest
process a domain id of its own, so that tests never send multicast to the network and
concurrent test runs on one machine never see each other's nodes.

:mod:`forte_ros.isolation` is pure Python and imports nothing of ROS; every package declares
forte_ros as a dependency (a test dependency for forte_msgs), so under ``colcon test``,
where each package's tests see only its own dependencies, this import works for all.
"""
from forte_ros.isolation import isolate_ros_network
from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401 (see that module)

isolate_ros_network()
