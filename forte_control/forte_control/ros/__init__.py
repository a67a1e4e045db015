"""The grasp controller node's ROS shell: the node, its parameter declarations, message
conversions and the GripperCommand action server. Everything outside this folder is pure
Python (no rclpy)."""
