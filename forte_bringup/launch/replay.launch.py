"""FORTE on a recorded bag: bag replay drives perception and control; the controller runs
with dry_run:=true so that no servo or arm command moves anything.

    ros2 launch forte_bringup replay.launch.py bag:=out/bags/run1 rate:=1.0

Also started: forte_visualization (pad wrenches, markers; ``visualization:=false``: not)
and robot_state_publisher with the gripper's URDF for ``prefix`` where it is installed
(``robot_state_publisher:=false`` when the robot already publishes the gripper; not
installed: one line, and the graph without it).

``params_overlay:=FILE`` loads a second parameter YAML after the graph's own, for the
nodes it names (e.g. the slip setting of forte_tune_slip; forte_bringup.launch_support;
`forte_bringup replay params_overlay:=FILE` the same).
Nodes, parameter file and arguments come from forte_bringup.graph.GRAPHS['replay'], the same
description that `forte_bringup replay` starts on a machine without ros2 launch.
`ros2 launch forte_bringup replay.launch.py --show-args` lists the arguments.
"""
from forte_bringup.launch_support import graph_launch_description


def generate_launch_description():
    """Launch description of the replay graph."""
    return graph_launch_description('replay')
