"""FORTE grasp state machine (FORTE, W/o-Slip and On-Off controllers) as a pure library, and the control node serving the Grasp action with a safety watchdog."""
