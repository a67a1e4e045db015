"""Procedures a lab runs on a gripper (sensor commissioning, force calibration, slip
characterisation): one module or a few per procedure; each module's docstring says what it
runs and whether it needs ROS."""
