"""The procedures' nodes: commissioning, force calibration rig, slip lifts."""
