"""Sources of FORTE tactile frames and actuators: serial sensor driver (binary and legacy ASCII
protocol), Dynamixel gripper driver, simulated scene, bag replay.
"""
