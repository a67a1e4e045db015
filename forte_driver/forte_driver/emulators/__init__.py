"""Test and bench-top devices: stand-ins for hardware that is not on the desk.

Nothing here drives a robot. :mod:`.emulated_sensor` plays the sensor board on a
pseudo-terminal (with :mod:`.emulated_faults`); :mod:`.simulated_servo` plays a pair of
Dynamixel XM430 servos on a pseudo-terminal (with :mod:`.servo_faults`). Tests, benchmarks
and the hardware graph without hardware use them through the real drivers.
"""
