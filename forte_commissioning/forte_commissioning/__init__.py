"""Putting a FORTE gripper into service: commissioning, force calibration, slip tuning."""
