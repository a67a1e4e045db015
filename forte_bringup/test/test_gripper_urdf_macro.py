"""The gripper xacro macro: with and without a prefix, alone and on an arm's flange.

Pure (no ROS graph): xacro expands the files, ``xml.etree`` reads the URDF, and a small
forward kinematics of this file (origin, then rotation about the joint axis) moves the
fingers. Checked for each expansion: one root, every link reachable from it, the pads
reachable from the parent link, the movable joints exactly the joint names the gripper
driver and the simulator publish on ``joint_states`` (with the same prefix), and the pads
moving apart as theta opens, and the right finger joint the URDF mimic of the left (the
joint the driver's command bridge takes). Also :mod:`forte_bringup.robot_model` (URDF for a
prefix, robot_state_publisher detection). The macro's own checks (TCP, collision model,
SRDF, ros2_control tag) are forte_description's tests.
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from forte_bringup import robot_model
from forte_driver.ros import gripper_driver_parameters as driver_parameters
from forte_ros import contract

ROOT = Path(__file__).resolve().parents[2]
URDF_FOLDER = ROOT / 'forte_description' / 'urdf'
MACRO = URDF_FOLDER / robot_model.MACRO_XACRO

#: A minimal arm: base, one revolute wrist, a flange (tool0); two grippers on the flange.
ARM = """<?xml version="1.0"?>
<robot name="arm_with_two_fortes" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="{macro}"/>
  <link name="arm_base"/>
  <link name="tool0"/>
  <joint name="arm_wrist" type="revolute">
    <parent link="arm_base"/>
    <child link="tool0"/>
    <origin xyz="0 0 0.5" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="10" velocity="1"/>
  </joint>
  <xacro:forte_gripper prefix="left_" parent="tool0" xyz="0 0.1 0" rpy="0 0 ${{pi / 2}}"/>
  <xacro:forte_gripper prefix="right_" parent="tool0" xyz="0 -0.1 0"/>
</robot>
"""


# ---- URDF reading and forward kinematics ------------------------------------------------
def numbers(text: str | None, default: str = '0 0 0') -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def rotation(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def about_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about the unit vector ``axis`` (Rodrigues)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def joint_transform(joint: ET.Element, position: float) -> np.ndarray:
    """4x4 pose of the child link in the parent link for a joint position [rad]."""
    origin = joint.find('origin')
    transform = np.eye(4)
    if origin is not None:
        transform[:3, :3] = rotation(numbers(origin.get('rpy')))
        transform[:3, 3] = numbers(origin.get('xyz'))
    if joint.get('type') in ('revolute', 'continuous'):
        motion = np.eye(4)
        axis = joint.find('axis')
        motion[:3, :3] = about_axis(numbers(None if axis is None else axis.get('xyz'), '1 0 0'),
                                    position)
        transform = transform @ motion
    return transform


class Tree:
    """Links and joints of a URDF as a tree (asserts it is one)."""

    def __init__(self, urdf: str) -> None:
        self.robot = ET.fromstring(urdf)
        self.links = [link.get('name') for link in self.robot.findall('link')]
        self.joints = {joint.get('name'): joint for joint in self.robot.findall('joint')}
        assert len(set(self.links)) == len(self.links), 'a link name is repeated'
        assert len(self.joints) == len(self.robot.findall('joint')), 'a joint name is repeated'
        self.parent_joint: dict[str, ET.Element] = {}
        for joint in self.joints.values():
            child = joint.find('child').get('link')
            assert joint.find('parent').get('link') in self.links and child in self.links
            assert child not in self.parent_joint, f'{child} has two parents'
            self.parent_joint[child] = joint

    @property
    def roots(self) -> set[str]:
        return set(self.links) - set(self.parent_joint)

    def reachable(self, start: str) -> set[str]:
        """Links reachable from ``start`` (itself included)."""
        children: dict[str, list[str]] = {}
        for child, joint in self.parent_joint.items():
            children.setdefault(joint.find('parent').get('link'), []).append(child)
        found, stack = set(), [start]
        while stack:
            link = stack.pop()
            found.add(link)
            stack += children.get(link, [])
        return found

    @property
    def movable(self) -> set[str]:
        return {name for name, joint in self.joints.items() if joint.get('type') != 'fixed'}

    def pose(self, link: str, positions: dict[str, float]) -> np.ndarray:
        """4x4 pose of ``link`` in the root for joint ``positions`` (missing ones 0)."""
        transform = np.eye(4)
        while link in self.parent_joint:
            joint = self.parent_joint[link]
            transform = joint_transform(joint, positions.get(joint.get('name'), 0.0)) @ transform
            link = joint.find('parent').get('link')
        return transform


def published_joint_names(prefix: str) -> set[str]:
    """Joint names on ``joint_states`` of the gripper driver and the simulator for
    ``prefix``: the driver's configuration and the sim node's (contract) names."""
    config = driver_parameters.gripper_config({'prefix': prefix})
    driver = {finger.joint_name for finger in config.fingers}
    sim = set(contract.joint_names(prefix))
    assert driver == sim, (driver, sim)
    assert {driver_parameters.LEFT_JOINT, driver_parameters.RIGHT_JOINT} == set(
        contract.JOINT_NAMES)
    return sim


def pads(prefix: str) -> list[str]:
    return [contract.prefixed(frame, prefix) for frame in contract.PAD_FRAMES]


def check_gripper(tree: Tree, prefix: str, parent: str | None) -> None:
    """The gripper of ``prefix`` in ``tree``: its links below ``parent`` (or the root), its
    finger joints those the drivers publish, its pads moving apart as theta opens."""
    base = contract.prefixed(contract.BASE_FRAME, prefix)
    top = base if parent is None else parent
    gripper_links = {name for name in tree.links if name.startswith(prefix + 'forte_')}
    assert {base, *pads(prefix), *(contract.prefixed(f, prefix) for f in
                                   contract.FINGER_FRAMES)} <= gripper_links
    assert gripper_links <= tree.reachable(top)
    fingers = published_joint_names(prefix)
    assert fingers <= tree.movable
    for name in fingers:
        assert tree.joints[name].find('parent').get('link') == base
    if parent is not None:
        mount = tree.parent_joint[base]
        assert mount.get('type') == 'fixed' and mount.find('parent').get('link') == parent
    left_name, right_name = contract.joint_names(prefix)
    gaps = []
    for theta in (0.0, 0.3, 0.6, 0.9):
        positions = {left_name: theta, right_name: theta}
        left, right = (tree.pose(pad, positions) for pad in pads(prefix))
        body = tree.pose(base, positions)
        # the pads' separation along the gripper's y axis, in the gripper's frame
        in_body = [np.linalg.inv(body) @ pose for pose in (left, right)]
        assert in_body[0][1, 3] == pytest.approx(-in_body[1][1, 3], abs=1e-12)
        gaps.append(in_body[0][1, 3] - in_body[1][1, 3])
    assert gaps[0] == pytest.approx(0.0, abs=1e-9)  # theta = 0: contact surfaces touch
    assert np.all(np.diff(gaps) > 0.005), gaps       # opening moves the pads apart


# ---- the standalone gripper ----------------------------------------------------------
@pytest.mark.parametrize('prefix', ['', 'left_', 'gripper2/'])
def test_standalone_gripper_for_a_prefix(prefix):
    tree = Tree(robot_model.expand_gripper(prefix))
    base = contract.prefixed(contract.BASE_FRAME, prefix)
    assert tree.roots == {base}
    assert tree.reachable(base) == set(tree.links)
    assert tree.movable == published_joint_names(prefix)
    assert all(name.startswith(prefix) for name in [*tree.links, *tree.joints])
    materials = {m.get('name') for m in tree.robot.findall('material')}
    assert materials and all(name.startswith(prefix + 'forte_') for name in materials)
    check_gripper(tree, prefix, parent=None)


@pytest.mark.parametrize('prefix', ['', 'left_'])
def test_the_mimic_joint_follows_the_joint_the_bridge_commands(prefix):
    """The URDF's right finger joint mimics the left one (multiplier 1): the joint MoveIt
    and ros2_control command is the driver's left finger, which moves both servos."""
    tree = Tree(robot_model.expand_gripper(prefix))
    left, right = contract.joint_names(prefix)
    assert (left, right) == tuple(contract.prefixed(name, prefix) for name in (
        driver_parameters.LEFT_JOINT, driver_parameters.RIGHT_JOINT))
    mimics = {name: joint.find('mimic') for name, joint in tree.joints.items()
              if joint.find('mimic') is not None}
    assert set(mimics) == {right}
    assert mimics[right].get('joint') == left
    assert float(mimics[right].get('multiplier')) == 1.0
    assert float(mimics[right].get('offset')) == 0.0


def test_the_pre_expanded_urdf_is_the_gripper_without_prefix():
    def canonical(element: ET.Element):
        attributes = {key: value for key, value in sorted(element.attrib.items())}
        return element.tag, attributes, [canonical(child) for child in element]

    expanded = ET.fromstring(robot_model.expand_gripper(''))
    committed = ET.parse(URDF_FOLDER / 'forte_gripper.urdf').getroot()
    assert canonical(expanded) == canonical(committed), \
        'forte_gripper.urdf is out of date: run python hardware/expand_urdf.py'


@pytest.mark.skipif(shutil.which('xacro') is None, reason='no xacro command on PATH')
def test_the_xacro_command_expands_the_wrapper_with_a_prefix():
    result = subprocess.run(['xacro', str(URDF_FOLDER / robot_model.GRIPPER_XACRO),
                             'prefix:=left_'], capture_output=True, text=True, timeout=60,
                            check=True)
    tree = Tree(result.stdout)
    assert tree.roots == {'left_forte_base_link'}
    assert tree.movable == {'left_forte_left_finger_joint', 'left_forte_right_finger_joint'}


# ---- the macro inside an arm's URDF ---------------------------------------------------------
@pytest.fixture(scope='module')
def arm(tmp_path_factory) -> Tree:
    path = tmp_path_factory.mktemp('arm') / 'arm.urdf.xacro'
    path.write_text(ARM.format(macro=MACRO))
    return Tree(robot_model.expand_gripper('', xacro_file=path))


def test_two_grippers_on_an_arm_make_one_tree(arm):
    assert arm.roots == {'arm_base'}
    assert arm.reachable('arm_base') == set(arm.links)
    assert arm.movable == {'arm_wrist'} | published_joint_names('left_') | \
        published_joint_names('right_')
    for prefix in ('left_', 'right_'):
        check_gripper(arm, prefix, parent='tool0')


def test_the_mount_pose_places_the_gripper_on_the_flange(arm):
    body = arm.pose('left_forte_base_link', {})
    assert body[:3, 3] == pytest.approx([0.0, 0.1, 0.5], abs=1e-12)
    assert body[:3, :3] @ [1, 0, 0] == pytest.approx([0, 1, 0], abs=1e-12)  # yaw pi/2
    # the wrist turns the gripper with the flange
    turned = arm.pose('left_forte_base_link', {'arm_wrist': math.pi / 2})
    assert turned[:3, 3] == pytest.approx([-0.1, 0.0, 0.5], abs=1e-12)


def test_the_pads_follow_their_finger_joint_only(arm):
    rest = {name: arm.pose(name, {}) for name in pads('right_') + pads('left_')}
    moved = {name: arm.pose(name, {'right_forte_left_finger_joint': 0.5})
             for name in rest}
    assert not np.allclose(moved['right_forte_left_pad'], rest['right_forte_left_pad'])
    for name in ('right_forte_right_pad', 'left_forte_left_pad', 'left_forte_right_pad'):
        assert np.allclose(moved[name], rest[name])
    # the pad turns with its finger by theta about the pivot; its normal (+x) tilts by theta
    before, after = rest['right_forte_left_pad'][:3, 0], moved['right_forte_left_pad'][:3, 0]
    assert math.acos(np.clip(before @ after, -1, 1)) == pytest.approx(0.5)


# ---- robot_model -----------------------------------------------------------------------------
@pytest.mark.parametrize('prefix', ['/left_', 'left gripper', 'a.b'])
def test_an_invalid_prefix_is_refused(prefix):
    with pytest.raises(ValueError, match='prefix'):
        robot_model.expand_gripper(prefix)


def test_robot_state_publisher_parameters_hold_the_urdf():
    parameters = robot_model.robot_state_publisher_parameters('right_')
    assert set(parameters) == {'robot_description'}
    assert Tree(parameters['robot_description']).roots == {'right_forte_base_link'}


def test_robot_state_publisher_is_found_through_the_ament_index(tmp_path):
    empty, ros = tmp_path / 'empty', tmp_path / 'ros'
    empty.mkdir()
    environ = {'AMENT_PREFIX_PATH': f'{empty}:{ros}'}
    assert robot_model.robot_state_publisher_executable(environ) is None
    assert robot_model.robot_state_publisher_message(environ) == \
        robot_model.ROBOT_STATE_PUBLISHER_MISSING
    assert '\n' not in robot_model.ROBOT_STATE_PUBLISHER_MISSING
    marker = ros / 'share' / 'ament_index' / 'resource_index' / 'packages'
    marker.mkdir(parents=True)
    (marker / 'robot_state_publisher').write_text('')
    assert not robot_model.robot_state_publisher_available(environ)  # no executable yet
    executable = ros / 'lib' / 'robot_state_publisher' / 'robot_state_publisher'
    executable.parent.mkdir(parents=True)
    executable.write_text('#!/bin/sh\n')
    executable.chmod(0o755)
    assert robot_model.robot_state_publisher_executable(environ) == executable
    assert robot_model.robot_state_publisher_available(environ)
    assert robot_model.robot_state_publisher_message(environ) is None


def test_the_urdf_folder_falls_back_to_the_installed_share(tmp_path, monkeypatch):
    share = tmp_path / 'share' / 'forte_description' / 'urdf'
    share.mkdir(parents=True)
    (share / robot_model.GRIPPER_XACRO).write_text('<robot/>')
    assert robot_model.urdf_folder() == URDF_FOLDER  # the source tree first
    monkeypatch.setattr(robot_model, '__file__', str(tmp_path / 'nowhere' / 'pkg' / 'x.py'))
    assert robot_model.urdf_folder({'AMENT_PREFIX_PATH': str(tmp_path)}) == share


def installed() -> bool:
    """forte_bringup is in the ament index of a prefix of ``AMENT_PREFIX_PATH``."""
    return any(prefix and (Path(prefix) / 'share' / 'ament_index' / 'resource_index' /
                           'packages' / 'forte_bringup').is_file()
               for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep))


@pytest.mark.skipif(not installed(), reason='forte_bringup is not installed (make setup)')
def test_an_arm_includes_the_installed_macro_with_find(tmp_path):
    """docs/visualization.md's include line: ``$(find forte_bringup)`` (the ament index)."""
    path = tmp_path / 'arm.urdf.xacro'
    path.write_text(ARM.format(macro='$(find forte_description)/urdf/' + robot_model.MACRO_XACRO))
    tree = Tree(robot_model.expand_gripper('', xacro_file=path))
    assert tree.roots == {'arm_base'}
    check_gripper(tree, 'right_', parent='tool0')
