"""Test configuration shared by every package of the workspace.

Before any test imports rclpy, confine DDS discovery to loopback and give this pytest
process a domain id of its own, so that tests never send multicast to the network and
concurrent test runs on one machine never see each other's nodes.

:mod:`forte_ros.isolation` is pure Python and imports nothing of ROS; every package with ROS
tests declares forte_ros as a dependency (a test dependency for forte_msgs), so under
``colcon test``, where each package's tests see only its own dependencies, this import
works for them. forte_description's tests start no node and do not have forte_ros: for them
this file does nothing (its own tests check they import no ROS, tools/test/
test_pytest_config.py).
"""
try:
    from forte_ros.isolation import isolate_ros_network
    from forte_ros.pytest_plugin import leak_guard, pytest_pycollect_makemodule  # noqa: F401
except ModuleNotFoundError:  # colcon tests a package with its own dependencies only:
    pass                     # forte_description's tests (no ROS, no forte_ros) get here
else:
    isolate_ros_network()
