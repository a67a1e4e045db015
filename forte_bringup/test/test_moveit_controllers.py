"""forte_description's MoveIt controller configuration (config/moveit_controllers.yaml) matches
the grasp controller: the controllers of FORTE's own path reach the node's gripper actions
and command its first finger joint.

Pure (the YAML and the node's names, no graph). MoveIt's simple controller manager calls
the action ``<controller name>/<action_ns>`` (the name alone when ``action_ns`` is empty),
resolved in move_group's namespace; the grasp controller serves ``gripper_cmd`` and
``parallel_gripper_cmd`` in its own (the root namespace in the shipped graphs). The file's
format and its ros2_control path are forte_description's tests
(test_ros2_control_description.py): this one needs forte_control, which forte_description
does not depend on.
"""
from __future__ import annotations

import yaml

from forte_bringup.robot_model import urdf_folder
from forte_control.parameters import NODE_PARAMETERS
from forte_control.ros.gripper_command_servers import (
    GRIPPER_COMMAND_ACTION,
    PARALLEL_GRIPPER_COMMAND_ACTION,
)

ACTION_OF_TYPE = {'GripperCommand': GRIPPER_COMMAND_ACTION,
                  'ParallelGripperCommand': PARALLEL_GRIPPER_COMMAND_ACTION}


def controllers() -> tuple[dict, dict]:
    """The YAML and the blocks of the controllers it names (FORTE's own path)."""
    path = urdf_folder().parent / 'config' / 'moveit_controllers.yaml'
    data = yaml.safe_load(path.read_text())
    manager = data['moveit_simple_controller_manager']
    return data, {name: manager[name] for name in manager['controller_names']}


def test_both_interfaces_reach_the_node_actions():
    data, named = controllers()
    assert data['moveit_controller_manager'] == \
        'moveit_simple_controller_manager/MoveItSimpleControllerManager'
    assert sorted(block['type'] for block in named.values()) == sorted(ACTION_OF_TYPE)
    for name, block in named.items():
        action = f'{name}/{block["action_ns"]}' if block['action_ns'] else name
        assert action == ACTION_OF_TYPE[block['type']], (name, action)


def test_joints_are_the_controller_first_joint_and_one_default():
    """MoveIt sends the left finger joint (the right one is its URDF mimic); the node's
    joint_names start with it and the node moves both fingers to its theta."""
    _, named = controllers()
    joints = list(NODE_PARAMETERS['joint_names'].default)
    for block in named.values():
        assert block['joints'] == joints[:1]
        assert block['max_effort'] >= 0.0
    assert sum(bool(block['default']) for block in named.values()) == 1
    gripper = next(b for b in named.values() if b['type'] == 'GripperCommand')
    # one joint's position is theta; `parallel: true` would send the sum of two
    assert gripper['command_joint'] == joints[0] and not gripper.get('parallel', False)
