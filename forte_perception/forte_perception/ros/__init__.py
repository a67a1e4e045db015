"""The perception node (the ROS shell). Everything outside this folder is pure Python."""
