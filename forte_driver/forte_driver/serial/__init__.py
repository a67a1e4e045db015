"""The pressure-sensor board on a serial port: frame codec, stream assembly, device clock.

Pure core (no rclpy): :mod:`.protocol` (frames and commands of docs/firmware.md),
:mod:`.stream` and :mod:`.plausibility` (which frames are published, which are counted),
:mod:`.clock_sync` (device time to host time), :mod:`.sensor_stream` (one port's bytes to
stamped batches), :mod:`.reader_health`. The ROS shell is :mod:`.serial_sensor_node` with its
parameters in :mod:`.serial_sensor_parameters`.
"""
