"""FORTE on real devices and bags: serial sensor driver (binary and legacy ASCII protocol),
Dynamixel gripper driver, bag recording, reading and replay. The simulator and the bench
devices are the forte_sim package.
"""
