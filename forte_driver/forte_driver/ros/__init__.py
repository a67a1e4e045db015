"""The driver's ROS shell: the serial sensor, gripper driver and bag replay nodes and their
parameter tables. Everything outside this folder is pure Python (no rclpy)."""
