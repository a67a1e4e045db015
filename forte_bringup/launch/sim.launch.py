"""FORTE in simulation: the simulated scene (sensor, servo, arm, object), perception,
grasp control.

    ros2 launch forte_bringup sim.launch.py object:=soda_can record:=true
    ros2 launch forte_bringup sim.launch.py namespace:=right prefix:=right_   # a 2nd gripper

Without ``force_model:=`` perception gets the simulated rig's force model (made on the first
start, 6-13 s, and cached: ``python -m forte_evaluation.sim_force_model``).

Also started: forte_visualization (pad wrenches, markers; ``visualization:=false``: not)
and robot_state_publisher with the gripper's URDF for ``prefix`` where it is installed
(``robot_state_publisher:=false`` when the robot already publishes the gripper; not
installed: one line, and the graph without it).

``params_overlay:=FILE`` loads a second parameter YAML after the graph's own, for the
nodes it names (e.g. the slip setting of forte_tune_slip; forte_bringup.launch_support;
`forte_bringup sim params_overlay:=FILE` the same).
Nodes, parameter file and arguments come from forte_bringup.graph.GRAPHS['sim'], the same
description that `forte_bringup sim` starts on a machine without ros2 launch.
`ros2 launch forte_bringup sim.launch.py --show-args` lists the arguments.
"""
from forte_bringup.launch_support import graph_launch_description


def generate_launch_description():
    """Launch description of the sim graph."""
    return graph_launch_description('sim')
