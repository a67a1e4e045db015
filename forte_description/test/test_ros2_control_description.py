"""The gripper's ros2_control tag (urdf/forte_gripper.ros2_control.xacro) and the YAML files
of config/, against the formats their consumers document (ROS 2 Jazzy).

Pure (xacro and PyYAML; no controller manager, MoveIt or hardware plugin here). Checked:
the mock and the real expansion (plugin names, hardware parameters, interfaces, the mimic
joint as ros2_control 4.x's URDF parser requires it), the controller manager's YAML
(controller types, parameters of parallel_gripper_action_controller/GripperActionController,
joint names and interfaces that the tag provides), MoveIt's controller YAML (both paths) and
joint_limits.yaml (MoveIt's format, the URDF's limits).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
import yaml
from description_model import ARM_URDF, PACKAGE, Robot, expand

CONFIG = PACKAGE / 'config'
STANDALONE_URDF = PACKAGE / 'urdf' / 'forte_gripper.urdf.xacro'
MOCK_PLUGIN = 'mock_components/GenericSystem'
REAL_PLUGIN = 'topic_based_ros2_control/TopicBasedSystem'
GRIPPER_CONTROLLER_TYPE = 'parallel_gripper_action_controller/GripperActionController'
#: Parameters of parallel_gripper_action_controller/GripperActionController (Jazzy,
#: gripper_action_controller_parameters.yaml of parallel_gripper_controller).
GRIPPER_CONTROLLER_PARAMETERS = {
    'action_monitor_rate', 'joint', 'state_interfaces', 'goal_tolerance', 'allow_stalling',
    'stall_velocity_threshold', 'stall_timeout', 'max_effort_interface', 'max_effort',
    'max_velocity_interface', 'max_velocity'}
#: MoveIt's simple controller manager: controller types and the keys of a controller block.
MOVEIT_TYPES = {'GripperCommand', 'ParallelGripperCommand', 'FollowJointTrajectory'}
MOVEIT_KEYS = {'type', 'action_ns', 'default', 'joints', 'command_joint', 'parallel',
               'max_effort', 'max_velocity', 'allow_failure'}
#: MoveIt's joint_limits.yaml keys of one joint.
JOINT_LIMIT_KEYS = {'has_position_limits', 'min_position', 'max_position',
                    'has_velocity_limits', 'max_velocity', 'has_acceleration_limits',
                    'max_acceleration', 'has_jerk_limits', 'max_jerk', 'has_effort_limits',
                    'max_effort'}
LEFT, RIGHT = 'forte_left_finger_joint', 'forte_right_finger_joint'


def load(name: str) -> dict:
    return yaml.safe_load((CONFIG / name).read_text())


def tags(robot: ET.Element) -> dict[str, ET.Element]:
    return {tag.get('name'): tag for tag in robot.findall('ros2_control')}


def hardware(tag: ET.Element) -> tuple[str, dict[str, str]]:
    """The tag's plugin and hardware parameters."""
    element = tag.find('hardware')
    return element.find('plugin').text, {p.get('name'): p.text for p in element.findall('param')}


def interfaces(joint: ET.Element, kind: str) -> list[str]:
    return [e.get('name') for e in joint.findall(f'{kind}_interface')]


def initial_values(joint: ET.Element) -> dict[str, float]:
    return {e.get('name'): float(e.find("param[@name='initial_value']").text)
            for e in joint.findall('state_interface')}


@pytest.fixture(scope='module')
def arm() -> ET.Element:
    return expand(ARM_URDF, ros2_control='true')


def check_jazzy_rules(robot: ET.Element) -> None:
    """What ros2_control 4.x's URDF parser requires: every joint of a tag is a non-fixed
    joint of the URDF; a URDF mimic joint not marked mimic="false" has no command interface
    and mimics a joint of the same tag."""
    urdf = Robot(robot)
    for tag in robot.findall('ros2_control'):
        assert tag.get('type') == 'system'
        names = [joint.get('name') for joint in tag.findall('joint')]
        for joint in tag.findall('joint'):
            name = joint.get('name')
            assert name in urdf.joints and urdf.joints[name].get('type') != 'fixed', name
            mimic = urdf.mimic(name)
            if joint.get('mimic') == 'true':
                assert mimic is not None, f'{name}: mimic="true" without a URDF <mimic>'
            if mimic is not None and joint.get('mimic') != 'false':
                assert not interfaces(joint, 'command'), name
                assert mimic[0] in names, name


def test_the_real_path_talks_to_the_driver_topics():
    robot = expand(STANDALONE_URDF, ros2_control='true')
    check_jazzy_rules(robot)
    assert list(tags(robot)) == ['forte_gripper']
    tag = tags(robot)['forte_gripper']
    plugin, params = hardware(tag)
    assert plugin == REAL_PLUGIN
    assert params['joint_commands_topic'] == '/gripper/joint_commands'
    assert params['joint_states_topic'] == '/joint_states'
    assert 0.0 < float(params['trigger_joint_command_threshold']) < 1.534e-3  # one pulse
    assert params['use_initial_states_as_initial_commands'] == 'true'
    joints = tag.findall('joint')
    # the left finger only: TopicBasedSystem names every joint of its tag in a command, the
    # driver's bridge wants a position for each name
    assert [joint.get('name') for joint in joints] == [LEFT]
    assert interfaces(joints[0], 'command') == ['position']
    assert interfaces(joints[0], 'state') == ['position', 'velocity', 'effort']
    assert initial_values(joints[0]) == {'position': 0.0, 'velocity': 0.0, 'effort': 0.0}


def test_the_mock_path_mirrors_commands_with_the_mimic_joint():
    robot = expand(STANDALONE_URDF, ros2_control='true', use_mock_hardware='true',
                   initial_position='0.25')
    check_jazzy_rules(robot)
    tag = tags(robot)['forte_gripper']
    plugin, params = hardware(tag)
    assert plugin == MOCK_PLUGIN
    assert params['mock_sensor_commands'] == 'false'
    assert 'joint_commands_topic' not in params
    left, right = tag.findall('joint')
    assert (left.get('name'), right.get('name')) == (LEFT, RIGHT)
    assert interfaces(left, 'command') == ['position']
    assert right.get('mimic') == 'true' and interfaces(right, 'command') == []
    for joint in (left, right):
        assert interfaces(joint, 'state') == ['position', 'velocity', 'effort']
        assert initial_values(joint)['position'] == 0.25


def test_no_ros2_control_tag_unless_asked():
    assert tags(expand(STANDALONE_URDF)) == {}
    committed = ET.parse(PACKAGE / 'urdf' / 'forte_gripper.urdf').getroot()
    assert committed.find('ros2_control') is None


def test_two_grippers_on_an_arm_get_a_tag_each(arm):
    check_jazzy_rules(arm)
    found = tags(arm)
    assert set(found) == {'left_forte_gripper', 'right_gripper_io'}
    plugin, params = hardware(found['left_forte_gripper'])
    assert plugin == MOCK_PLUGIN and params['mock_sensor_commands'] == 'true'
    assert [j.get('name') for j in found['left_forte_gripper'].findall('joint')] == [
        'left_' + LEFT, 'left_' + RIGHT]
    assert initial_values(found['left_forte_gripper'].find('joint'))['position'] == 0.5
    plugin, params = hardware(found['right_gripper_io'])
    assert plugin == REAL_PLUGIN
    assert params['joint_commands_topic'] == '/right/gripper/joint_commands'
    assert params['joint_states_topic'] == '/right/forte/joint_states'
    assert [j.get('name') for j in found['right_gripper_io'].findall('joint')] == ['right_' + LEFT]
    every = [j.get('name') for tag in found.values() for j in tag.findall('joint')]
    assert len(every) == len(set(every)), 'a joint in two ros2_control tags'


# ---- controller manager ------------------------------------------------------------------
def test_the_controllers_are_the_documented_types():
    data = load('forte_controllers.yaml')
    manager = data['controller_manager']['ros__parameters']
    assert manager['update_rate'] > 0
    types = {name: block['type'] for name, block in manager.items() if isinstance(block, dict)}
    assert types == {'joint_state_broadcaster': 'joint_state_broadcaster/JointStateBroadcaster',
                     'forte_gripper_controller': GRIPPER_CONTROLLER_TYPE}
    assert set(data) == {'controller_manager', 'forte_gripper_controller'}


@pytest.mark.parametrize('mock', ['true', 'false'])
def test_the_gripper_controller_finds_its_interfaces(mock):
    params = load('forte_controllers.yaml')['forte_gripper_controller']['ros__parameters']
    assert set(params) <= GRIPPER_CONTROLLER_PARAMETERS
    robot = expand(STANDALONE_URDF, ros2_control='true', use_mock_hardware=mock)
    urdf = Robot(robot)
    joints = {j.get('name'): j for tag in robot.findall('ros2_control')
              for j in tag.findall('joint')}
    joint = joints[params['joint']]
    assert urdf.mimic(params['joint']) is None
    # claims <joint>/position as command, its state_interfaces as states; needs position
    # and velocity states (stall detection)
    assert 'position' in interfaces(joint, 'command')
    assert {'position', 'velocity'} <= set(params['state_interfaces']) <= set(
        interfaces(joint, 'state'))
    # no max-effort / max-velocity command interfaces on this hardware
    assert not params.get('max_effort_interface') and not params.get('max_velocity_interface')
    lower, upper, effort, velocity = urdf.limits(params['joint'])
    assert 0.0 < params['goal_tolerance'] < (upper - lower) / 10
    assert 0.0 <= params['max_effort'] <= effort and 0.0 <= params['max_velocity'] <= velocity
    assert params['stall_timeout'] > 0 and params['stall_velocity_threshold'] > 0
    assert isinstance(params['allow_stalling'], bool)


# ---- MoveIt ------------------------------------------------------------------------------------
def moveit() -> tuple[dict, dict]:
    data = load('moveit_controllers.yaml')
    return data, data['moveit_simple_controller_manager']


def test_moveit_controllers_have_the_documented_format():
    data, manager = moveit()
    assert data['moveit_controller_manager'] == \
        'moveit_simple_controller_manager/MoveItSimpleControllerManager'
    urdf = Robot(expand(STANDALONE_URDF))
    blocks = {name: block for name, block in manager.items() if name != 'controller_names'}
    assert set(manager['controller_names']) <= set(blocks)
    for name, block in blocks.items():
        assert set(block) <= MOVEIT_KEYS, name
        assert block['type'] in MOVEIT_TYPES and isinstance(block['action_ns'], str), name
        # MoveIt's trajectories carry the active joints only: not the mimic joint
        assert block['joints'] == [LEFT], name
        assert all(urdf.mimic(joint) is None and joint in urdf.joints for joint in block['joints'])
        assert block.get('max_effort', 0.0) >= 0.0 and block.get('max_velocity', 0.0) >= 0.0
        assert not block.get('parallel', False), name  # would send a sum of two joints
        if block['type'] == 'GripperCommand':
            assert block['command_joint'] == LEFT


def action_of(name: str, block: dict) -> str:
    """The action MoveIt calls for a controller block: <name>/<action_ns>, or <name>."""
    return f'{name}/{block["action_ns"]}' if block['action_ns'] else name


def test_forte_path_reaches_the_grasp_controller_actions():
    _, manager = moveit()
    named = {name: manager[name] for name in manager['controller_names']}
    assert {action_of(name, block): block['type'] for name, block in named.items()} == {
        'gripper_cmd': 'GripperCommand', 'parallel_gripper_cmd': 'ParallelGripperCommand'}
    assert sum(bool(block['default']) for block in named.values()) == 1


def test_ros2_control_path_reaches_the_gripper_controller_action():
    """forte_gripper_controller/gripper_cmd (ParallelGripperCommand), served by the
    controller of forte_controllers.yaml; one default once named alone."""
    _, manager = moveit()
    controllers = load('forte_controllers.yaml')['controller_manager']['ros__parameters']
    alternative = {name: block for name, block in manager.items()
                   if name not in (*manager['controller_names'], 'controller_names')}
    assert list(alternative) == ['forte_gripper_controller']
    block = alternative['forte_gripper_controller']
    assert action_of('forte_gripper_controller', block) == 'forte_gripper_controller/gripper_cmd'
    assert controllers['forte_gripper_controller']['type'] == GRIPPER_CONTROLLER_TYPE
    assert block['type'] == 'ParallelGripperCommand' and block['default'] is True
    params = load('forte_controllers.yaml')['forte_gripper_controller']['ros__parameters']
    assert block['joints'] == [params['joint']]
    # the controller takes no effort or velocity from a goal without those interfaces
    assert block['max_effort'] == 0.0 and block['max_velocity'] == 0.0


def test_joint_limits_are_the_urdf_limits():
    data = load('joint_limits.yaml')
    assert set(data) == {'default_velocity_scaling_factor',
                         'default_acceleration_scaling_factor', 'joint_limits'}
    assert 0 < data['default_velocity_scaling_factor'] <= 1
    assert 0 < data['default_acceleration_scaling_factor'] <= 1
    urdf = Robot(expand(STANDALONE_URDF))
    assert set(data['joint_limits']) == set(urdf.active_joints) == {LEFT}
    limits = data['joint_limits'][LEFT]
    assert set(limits) <= JOINT_LIMIT_KEYS
    assert limits['has_velocity_limits'] is True
    assert limits['max_velocity'] == urdf.limits(LEFT)[3]
    assert limits['has_acceleration_limits'] is True and limits['max_acceleration'] > 0
