"""Bags: writing rosbag2 MCAP bags and replaying them, damaged or not.

Pure core (no rclpy): :mod:`.bags` (writer, typestore, the recorded topics),
:mod:`.mcap_source` (tolerant reader) on :mod:`.mcap_records` and :mod:`.mcap_recovery`.
The ROS shell is :mod:`.bag_replay_node`.
"""
