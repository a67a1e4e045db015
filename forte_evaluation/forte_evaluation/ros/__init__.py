"""The evaluation's ROS shell: bags of the slip set (rclpy serialization)."""
