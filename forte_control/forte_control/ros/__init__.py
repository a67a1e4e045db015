"""The grasp controller node's ROS shell: the node, its parameter declarations, message
conversions and the gripper position action servers (GripperCommand,
ParallelGripperCommand). Everything outside this folder is pure Python (no rclpy)."""
