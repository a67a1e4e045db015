"""FORTE on the real gripper: serial tactile sensor and Dynamixel gripper (lifecycle
nodes, configured and activated on start), perception, grasp control.

    ros2 launch forte_bringup hardware.launch.py sensor_port:=/dev/forte_sensor \\
        gripper_port:=/dev/forte_gripper arm_cmd_vel_topic:=/servo_node/delta_twist_cmds

Also started: forte_visualization (pad wrenches, markers; ``visualization:=false``: not).
This is the launch file a robot's launch includes (docs/bringup.md, "On a robot"): its
defaults add nothing the arm's bringup owns (``robot_state_publisher:=false``: the arm's
robot_state_publisher has the gripper in its URDF; no ``/robot_description``, no clock, no
RViz); ``robot_state_publisher:=true`` for the gripper alone, ``rviz:=true`` for RViz with
the view of ``namespace`` and ``prefix``, ``use_sim_time`` for every node.

``params_overlay:=FILE`` loads a second parameter YAML after the graph's own, for the
nodes it names (e.g. the slip setting of forte_tune_slip; forte_bringup.launch_support;
`forte_bringup hardware params_overlay:=FILE` the same).
Nodes, parameter file and arguments come from forte_bringup.graph.GRAPHS['hardware'], the same
description that `forte_bringup hardware` starts on a machine without ros2 launch.
`ros2 launch forte_bringup hardware.launch.py --show-args` lists the arguments.
"""
from forte_bringup.launch_support import graph_launch_description


def generate_launch_description():
    """Launch description of the hardware graph."""
    return graph_launch_description('hardware')
