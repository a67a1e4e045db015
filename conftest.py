"""Test configuration shared by every package of the workspace.

Before any test imports rclpy, confine DDS discovery to loopback and give this pytest
process a domain id of its own, so that tests never send multicast to the network and
concurrent test runs on one machine never see each other's nodes.
"""
from forte_bringup.ros_isolation import isolate_ros_network

isolate_ros_network()
