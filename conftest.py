"""Test configuration shared by every package of the workspace.

1. Before any test imports rclpy, confine DDS discovery to loopback and give this pytest
   process a domain id of its own, so that tests never send multicast to the network and
   concurrent test runs on one machine never see each other's nodes.
2. Import the installed packages before collection. With ``--import-mode=importlib`` pytest
   names a test module after its path (``forte_msgs.test.test_x``) and would otherwise create
   a stand-in ``forte_msgs`` module for the source folder, hiding the generated interfaces.
"""
import importlib

from forte_bringup.ros_isolation import isolate_ros_network

isolate_ros_network()

for _package in ('forte_msgs', 'forte_driver', 'forte_perception', 'forte_control',
                 'forte_bringup'):
    importlib.import_module(_package)
