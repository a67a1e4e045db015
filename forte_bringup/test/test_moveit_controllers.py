"""The shipped MoveIt controller configuration (config/moveit_controllers.yaml) matches the
grasp controller: its controllers reach the node's gripper actions and name its joints.

Pure (the YAML and the node's names, no graph). MoveIt's simple controller manager calls
the action ``<controller name>/<action_ns>`` (the name alone when ``action_ns`` is empty),
resolved in move_group's namespace; the grasp controller serves ``gripper_cmd`` and
``parallel_gripper_cmd`` in its own (the root namespace in the shipped graphs).
"""
from __future__ import annotations

import yaml

from forte_bringup.graph import config_folder
from forte_control.parameters import NODE_PARAMETERS
from forte_control.ros.gripper_command_servers import (
    GRIPPER_COMMAND_ACTION,
    PARALLEL_GRIPPER_COMMAND_ACTION,
)

ACTION_OF_TYPE = {'GripperCommand': GRIPPER_COMMAND_ACTION,
                  'ParallelGripperCommand': PARALLEL_GRIPPER_COMMAND_ACTION}


def controllers() -> tuple[dict, dict]:
    data = yaml.safe_load((config_folder() / 'moveit_controllers.yaml').read_text())
    return data, data['moveit_simple_controller_manager']


def test_both_interfaces_reach_the_node_actions():
    data, manager = controllers()
    assert data['moveit_controller_manager'] == \
        'moveit_simple_controller_manager/MoveItSimpleControllerManager'
    names = manager['controller_names']
    assert sorted(manager[name]['type'] for name in names) == sorted(ACTION_OF_TYPE)
    for name in names:
        block = manager[name]
        action = f'{name}/{block["action_ns"]}' if block['action_ns'] else name
        assert action == ACTION_OF_TYPE[block['type']], (name, action)


def test_joints_are_the_controller_joints_and_one_default():
    _, manager = controllers()
    joints = list(NODE_PARAMETERS['joint_names'].default)
    blocks = [manager[name] for name in manager['controller_names']]
    for block in blocks:
        assert block['joints'] == joints
        assert block['max_effort'] >= 0.0
    assert sum(bool(block['default']) for block in blocks) == 1
    gripper = next(b for b in blocks if b['type'] == 'GripperCommand')
    # one joint's position is theta; `parallel: true` would send the sum of both
    assert gripper['command_joint'] == joints[0] and not gripper.get('parallel', False)
