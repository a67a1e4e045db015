"""Dynamixel XM430-W350 gripper core: control table, units, protocol 2.0 codec, gripper logic.

Pure core (no rclpy) in every module but :mod:`.gripper_driver_node`, the ROS shell.
"""
