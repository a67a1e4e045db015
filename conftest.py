"""Test configuration shared by every package of the workspace.

Before any test imports rclpy, confine DDS discovery to loopback and give this pytest
process a domain id of its own, so that tests never send multicast to the network and
concurrent test runs on one machine never see each other's nodes.

The isolation module is loaded from its file, not imported as ``forte_bringup``: under
``colcon test`` each package's tests run with only that package's dependencies on the path,
and this file (the rootdir conftest of every package) must work for all of them.
"""
import importlib.util
from pathlib import Path

_SOURCE = Path(__file__).resolve().parent / 'forte_bringup' / 'forte_bringup' / 'ros_isolation.py'
_spec = importlib.util.spec_from_file_location('forte_test_ros_isolation', _SOURCE)
_module = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_module)
_module.isolate_ros_network()
