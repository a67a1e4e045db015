"""FORTE grasp control.

The grasp state machine (FORTE, W/o-Slip and On-Off controllers) as a pure library
(:mod:`forte_control.state_machine`) and the control node serving the Grasp action with a
safety watchdog (:mod:`forte_control.ros.grasp_controller_node`).
"""
