"""Dynamixel XM430-W350 gripper core: control table, units, protocol 2.0 codec, gripper logic.

Pure Python (no rclpy); the ROS shell is :mod:`forte_driver.gripper_driver_node`.
"""
