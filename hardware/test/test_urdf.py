"""The gripper URDF: names from docs/contracts.md, a connected tree, plausible kinematics,
the pre-expanded URDF equal to the xacro's expansion, and the finger mesh it shows."""
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
import xacro
from forte_finger import cad
from forte_finger.design import make_design

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / 'forte_description' / 'urdf' / 'forte_gripper.urdf'
XACRO = ROOT / 'forte_description' / 'urdf' / 'forte_gripper.urdf.xacro'
MESH = ROOT / 'forte_description' / 'meshes' / 'forte_finger.stl'

CONTRACT_LINKS = {'forte_base_link', 'forte_left_finger', 'forte_right_finger',
                  'forte_left_pad', 'forte_right_pad'}
CONTRACT_JOINTS = {'forte_left_finger_joint', 'forte_right_finger_joint'}


@pytest.fixture(scope='module')
def robot():
    return ET.parse(URDF).getroot()


def numbers(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def canonical(element: ET.Element):
    """Comparable form of an XML tree: tag, attributes (numbers parsed), children."""
    attributes = {}
    for key, value in sorted(element.attrib.items()):
        try:
            attributes[key] = tuple(round(float(v), 12) for v in value.split())
        except ValueError:
            attributes[key] = value
    children = [canonical(child) for child in element if isinstance(child.tag, str)]
    return element.tag, attributes, children


def test_urdf_is_the_expansion_of_the_xacro():
    expanded = ET.fromstring(xacro.process_file(str(XACRO)).toxml())
    committed = ET.parse(URDF).getroot()
    assert canonical(expanded) == canonical(committed), \
        'forte_gripper.urdf is out of date: run python hardware/expand_urdf.py'


def test_contract_links_and_joints_exist(robot):
    links = {link.get('name') for link in robot.findall('link')}
    joints = {joint.get('name'): joint for joint in robot.findall('joint')}
    assert CONTRACT_LINKS <= links
    assert CONTRACT_JOINTS <= set(joints)
    for side in ('left', 'right'):
        finger = joints[f'forte_{side}_finger_joint']
        assert finger.get('type') == 'revolute'
        assert finger.find('parent').get('link') == 'forte_base_link'
        assert finger.find('child').get('link') == f'forte_{side}_finger'
        limit = finger.find('limit')
        assert float(limit.get('lower')) == 0.0  # theta = 0: fully closed
        assert float(limit.get('upper')) > 0.6  # the paper grasps at 0.46..0.55 rad
        pads = [j for j in joints.values()
                if j.find('child').get('link') == f'forte_{side}_pad']
        assert len(pads) == 1 and pads[0].get('type') == 'fixed'
        assert pads[0].find('parent').get('link') == f'forte_{side}_finger'


def test_kinematic_tree_is_connected_with_one_root(robot):
    links = {link.get('name') for link in robot.findall('link')}
    children: dict[str, list[str]] = {}
    parents: dict[str, str] = {}
    for joint in robot.findall('joint'):
        parent = joint.find('parent').get('link')
        child = joint.find('child').get('link')
        assert parent in links and child in links
        assert child not in parents, f'{child} has two parents'
        parents[child] = parent
        children.setdefault(parent, []).append(child)
    roots = links - set(parents)
    assert roots == {'forte_base_link'}
    reached, stack = set(), ['forte_base_link']
    while stack:
        link = stack.pop()
        reached.add(link)
        stack += children.get(link, [])
    assert reached == links


def rotation(rpy: np.ndarray) -> np.ndarray:
    roll, pitch, yaw = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)],
                   [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0],
                   [-math.sin(pitch), 0, math.cos(pitch)]])
    rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                   [0, 0, 1]])
    return rz @ ry @ rx


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def joint_transform(joint: ET.Element, position: float) -> np.ndarray:
    origin = joint.find('origin')
    transform = np.eye(4)
    transform[:3, :3] = rotation(numbers(origin.get('rpy', '0 0 0')))
    transform[:3, 3] = numbers(origin.get('xyz', '0 0 0'))
    if joint.get('type') == 'revolute':
        motion = np.eye(4)
        motion[:3, :3] = axis_angle(numbers(joint.find('axis').get('xyz')), position)
        transform = transform @ motion
    return transform


def pad_pose(robot: ET.Element, side: str, theta: float) -> np.ndarray:
    joints = {joint.get('name'): joint for joint in robot.findall('joint')}
    finger = joint_transform(joints[f'forte_{side}_finger_joint'], theta)
    return finger @ joint_transform(joints[f'forte_{side}_pad_joint'], 0.0)


def test_pads_touch_when_closed_mirror_each_other_and_open_with_theta(robot):
    closed_left, closed_right = pad_pose(robot, 'left', 0.0), pad_pose(robot, 'right', 0.0)
    # theta = 0: contact surfaces meet on the centre plane y = 0
    assert closed_left[1, 3] == pytest.approx(0.0, abs=1e-9)
    assert closed_right[1, 3] == pytest.approx(0.0, abs=1e-9)
    # pad x axis = contact normal toward the object: left points -y, right +y
    assert np.allclose(closed_left[:3, 0], [0, -1, 0], atol=1e-9)
    assert np.allclose(closed_right[:3, 0], [0, 1, 0], atol=1e-9)
    gaps = []
    for theta in np.linspace(0.0, 1.0, 11):
        left, right = pad_pose(robot, 'left', theta), pad_pose(robot, 'right', theta)
        assert left[1, 3] == pytest.approx(-right[1, 3], abs=1e-12)  # symmetric
        assert left[2, 3] == pytest.approx(right[2, 3], abs=1e-12)
        # mirror images about the centre plane; each pad turns with its finger by theta
        assert left[:3, 0] * [1, -1, 1] == pytest.approx(right[:3, 0], abs=1e-12)
        assert np.dot(left[:3, 0], right[:3, 0]) == pytest.approx(-math.cos(2 * theta))
        gaps.append(left[1, 3] - right[1, 3])
    assert np.all(np.diff(gaps) > 0), 'opening (larger theta) must separate the pads'
    # the paper grasps an apple (~75 mm) around theta = 0.54 rad: same order of magnitude
    apple = pad_pose(robot, 'left', 0.54)[1, 3] - pad_pose(robot, 'right', 0.54)[1, 3]
    assert 0.04 < apple < 0.12


def test_finger_mesh_is_the_generated_default_finger(robot):
    filenames = {mesh.get('filename') for mesh in robot.iter('mesh')}
    assert filenames == {'package://forte_description/meshes/forte_finger.stl'}
    mesh = trimesh.load(MESH)
    assert mesh.is_watertight
    design = make_design()
    p = design.parameters
    low, high = mesh.bounds
    assert low == pytest.approx([0.0, -p.width / 2, -p.mount_height], abs=1e-3)
    assert high == pytest.approx([p.base_depth, p.width / 2, p.length], abs=1e-3)
    assert mesh.volume == pytest.approx(cad.volume(cad.build_finger(design)), rel=0.01)


def test_urdf_fin_ray_dimensions_follow_the_generator(robot):
    """The collision box and pad height use the generator's default dimensions (m)."""
    p = make_design().parameters
    joints = {joint.get('name'): joint for joint in robot.findall('joint')}
    finger_joint = joints['forte_left_finger_joint']
    pad_joint = joints['forte_left_pad_joint']
    link = next(link for link in robot.findall('link')
                if link.get('name') == 'forte_left_finger')
    box = numbers(link.find('collision/geometry/box').get('size'))
    mesh_origin = numbers(link.find('visual/origin').get('xyz'))
    assert box[0] == pytest.approx(p.width / 1000)
    assert box[1] == pytest.approx(p.base_depth / 1000)
    pad_z = numbers(pad_joint.find('origin').get('xyz'))[2]
    assert pad_z - mesh_origin[2] == pytest.approx(p.location_fractions[1] * p.length / 1000)
    assert finger_joint.find('limit').get('effort') is not None
