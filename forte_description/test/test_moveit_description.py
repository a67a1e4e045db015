"""The gripper's URDF and SRDF macros together, as MoveIt loads them, on a stand-in arm with two
grippers (``left_`` and ``right_``, test/arm_with_two_fortes.*.xacro) and alone.

Pure (xacro, numpy; no MoveIt here): the SRDF names only what the URDF has, with the
gripper's prefix; the right finger joint mimics the left; the TCP sits where the pads meet
(forward kinematics of description_model.py); a sweep of the joint range finds no colliding
pair of links that the SRDF leaves enabled, the fingers never touch the body or each other
(the geometry before the collision model was fixed did), and the SRDF's disabled pairs are
what sampling gives. Where python-fcl is installed, scripts/disabled_collisions.py (FCL, as
MoveIt) is run and must print the SRDF's pairs. Tolerances: 1e-6 m for poses; collision
margins in mm as stated.
"""
from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from itertools import combinations

import numpy as np
import pytest
from description_model import (
    ARM_SRDF,
    ARM_URDF,
    GRIPPERS,
    PACKAGE,
    Box,
    Robot,
    box_separation,
    expand,
    srdf_disabled,
)

STANDALONE_URDF = PACKAGE / 'urdf' / 'forte_gripper.urdf.xacro'
STANDALONE_SRDF = PACKAGE / 'srdf' / 'forte_gripper.srdf.xacro'
SCRIPT = PACKAGE / 'scripts' / 'disabled_collisions.py'
#: The macro's documented dimensions [m]: pivot offset and height, pad above the pivot.
PIVOT_Y, PIVOT_Z, PAD_ABOVE_PIVOT = 0.015, 0.070, 0.075
THETA_MAX = 1.0
#: Collision clearances of the macro's collision model [m]: closed fingers apart, finger to
#: body at theta_max.
FINGER_GAP, BODY_MARGIN = 0.001, 0.001


@pytest.fixture(scope='module')
def arm() -> Robot:
    return Robot(expand(ARM_URDF))


@pytest.fixture(scope='module')
def arm_srdf():
    return expand(ARM_SRDF)


def sweep(robot: Robot, count: int = 50, seed: int = 1) -> list[dict[str, float]]:
    """``count`` states: each gripper's theta on a grid over [0, THETA_MAX] (ends included,
    the two grippers in opposite order), other active joints uniform within their limits."""
    rng = np.random.default_rng(seed)
    thetas = np.linspace(0.0, THETA_MAX, count)
    states = []
    for index in range(count):
        state = {}
        for name in robot.active_joints:
            lower, upper = robot.limits(name)[:2]
            state[name] = float(rng.uniform(lower, upper))
        for prefix, theta in zip(GRIPPERS, (thetas[index], thetas[-1 - index])):
            if f'{prefix}forte_left_finger_joint' in state:
                state[f'{prefix}forte_left_finger_joint'] = float(theta)
        if 'forte_left_finger_joint' in state:
            state['forte_left_finger_joint'] = float(thetas[index])
        states.append(state)
    return states


def geometric_pairs(robot: Robot) -> list[tuple[str, str]]:
    return list(combinations([link for link in robot.links if robot.boxes[link]], 2))


# ---- names ------------------------------------------------------------------------------------
def test_every_srdf_name_is_in_the_urdf(arm, arm_srdf):
    links, joints = set(arm.links), set(arm.joints)
    for group in arm_srdf.findall('group'):
        assert {e.get('name') for e in group.findall('link')} <= links, group.get('name')
        assert {e.get('name') for e in group.findall('joint')} <= joints, group.get('name')
    for state in arm_srdf.findall('group_state'):
        assert {e.get('name') for e in state.findall('joint')} <= joints
    for effector in arm_srdf.findall('end_effector'):
        assert effector.get('parent_link') in links
    for pair in srdf_disabled(arm_srdf):
        assert pair <= links, pair


@pytest.mark.parametrize('prefix', GRIPPERS)
def test_the_gripper_semantics_carry_the_prefix(arm, arm_srdf, prefix):
    group_name = f'{prefix}forte_gripper'
    groups = {group.get('name'): group for group in arm_srdf.findall('group')}
    assert set(groups) == {'arm', 'left_forte_gripper', 'right_forte_gripper'}
    group = groups[group_name]
    names = [e.get('name') for e in (*group.findall('link'), *group.findall('joint'))]
    assert names and all(name.startswith(prefix + 'forte_') for name in names)
    assert {e.get('name') for e in group.findall('joint')} == {
        f'{prefix}forte_left_finger_joint', f'{prefix}forte_right_finger_joint'}
    # on an arm the body and the TCP belong to the end effector, its parent link does not
    assert {f'{prefix}forte_base_link', f'{prefix}forte_tcp'} <= set(names)
    effector = [e for e in arm_srdf.findall('end_effector') if e.get('group') == group_name]
    assert len(effector) == 1 and effector[0].get('name') == group_name
    assert effector[0].get('parent_link') == f'{prefix}tool0'
    assert effector[0].get('parent_link') not in names
    assert effector[0].get('parent_group') == ('arm' if prefix == 'left_' else None)
    for pair in srdf_disabled(arm_srdf):
        if any(link.startswith(prefix + 'forte_') for link in pair):
            assert pair <= {*names, f'{prefix}tool0'}, pair


@pytest.mark.parametrize('prefix', GRIPPERS)
def test_group_states_are_open_and_closed_within_the_limits(arm, arm_srdf, prefix):
    states = {state.get('name'): state for state in arm_srdf.findall('group_state')
              if state.get('group') == f'{prefix}forte_gripper'}
    assert set(states) == {'open', 'closed'}
    joint = f'{prefix}forte_left_finger_joint'
    lower, upper = arm.limits(joint)[:2]
    for name, theta in (('open', upper), ('closed', lower)):
        values = {e.get('name'): float(e.get('value')) for e in states[name].findall('joint')}
        # the one variable of the group (the mimic joint follows it)
        assert values == {joint: theta}
    assert (lower, upper) == (0.0, THETA_MAX)


def test_the_standalone_srdf_makes_the_body_the_parent():
    for prefix in ('', 'right_'):
        urdf, srdf = Robot(expand(STANDALONE_URDF, prefix=prefix)), \
            expand(STANDALONE_SRDF, prefix=prefix)
        effector = srdf.find('end_effector')
        assert effector.get('parent_link') == f'{prefix}forte_base_link'
        group = srdf.find('group')
        names = {e.get('name') for e in group.findall('link')}
        assert f'{prefix}forte_base_link' not in names and names <= set(urdf.links)
        assert all(pair <= set(urdf.links) for pair in srdf_disabled(srdf))


# ---- kinematics ----------------------------------------------------------------------------
@pytest.mark.parametrize('prefix', GRIPPERS)
def test_the_right_finger_joint_mimics_the_left(arm, prefix):
    left, right = f'{prefix}forte_left_finger_joint', f'{prefix}forte_right_finger_joint'
    assert arm.mimic(right) == (left, 1.0, 0.0)
    assert arm.mimic(left) is None
    assert left in arm.active_joints and right not in arm.active_joints
    assert arm.limits(right) == arm.limits(left)
    body = f'{prefix}forte_base_link'
    for theta in (0.0, 0.3, 1.0):
        state = {left: theta}
        in_body = {side: np.linalg.inv(arm.pose(body, state)) @ arm.pose(
            f'{prefix}forte_{side}_pad', state) for side in ('left', 'right')}
        # the right pad mirrors the left one about the centre plane y = 0
        assert in_body['right'][:3, 3] == pytest.approx(
            in_body['left'][:3, 3] * [1, -1, 1], abs=1e-9)
        gap = in_body['left'][1, 3] - in_body['right'][1, 3]
        expected = 2 * (PIVOT_Y * (1 - math.cos(theta)) + PAD_ABOVE_PIVOT * math.sin(theta))
        assert gap == pytest.approx(expected, abs=1e-9)


def pad_midpoint_in_body(robot: Robot, prefix: str, theta: float) -> np.ndarray:
    state = {f'{prefix}forte_left_finger_joint': theta}
    body = np.linalg.inv(robot.pose(f'{prefix}forte_base_link', state))
    pads = [body @ robot.pose(f'{prefix}forte_{side}_pad', state) for side in ('left', 'right')]
    return (pads[0][:3, 3] + pads[1][:3, 3]) / 2


@pytest.mark.parametrize('prefix', GRIPPERS)
def test_the_tcp_is_where_the_pads_meet(arm, prefix):
    tcp, body = f'{prefix}forte_tcp', f'{prefix}forte_base_link'
    assert arm.parent_joint[tcp].get('type') == 'fixed'
    assert arm.parent_joint[tcp].find('parent').get('link') == body
    for theta in (0.0, 0.5):
        state = {f'{prefix}forte_left_finger_joint': theta}
        tcp_pose, body_pose = arm.pose(tcp, state), arm.pose(body, state)
        assert tcp_pose[:3, :3] == pytest.approx(body_pose[:3, :3], abs=1e-12)  # +z approach
        in_body = (np.linalg.inv(body_pose) @ tcp_pose)[:3, 3]
        midpoint = pad_midpoint_in_body(arm, prefix, theta)
        # the pads' midpoint stays on the approach axis, between the fingers
        assert midpoint[:2] == pytest.approx([0.0, 0.0], abs=1e-6)
        assert in_body[:2] == pytest.approx(midpoint[:2], abs=1e-6)
        # closed, the pads meet at the TCP; opening swings them on arcs about the pivots
        drop = PAD_ABOVE_PIVOT - (PIVOT_Y * math.sin(theta) + PAD_ABOVE_PIVOT * math.cos(theta))
        assert in_body[2] - midpoint[2] == pytest.approx(drop, abs=1e-6)
        assert in_body[2] == pytest.approx(PIVOT_Z + PAD_ABOVE_PIVOT, abs=1e-6)
    assert drop == pytest.approx(1.99e-3, abs=1e-5)  # theta 0.5, as the macro documents


def test_the_tcp_is_at_the_pads_in_the_world_frame_too(arm):
    """On the yawed left gripper, turned by the arm: the world poses agree."""
    state = {'arm_shoulder': 0.7, 'arm_wrist': -0.4, 'left_forte_left_finger_joint': 0.0}
    pads = [arm.pose(f'left_forte_{side}_pad', state)[:3, 3] for side in ('left', 'right')]
    assert arm.pose('left_forte_tcp', state)[:3, 3] == pytest.approx(
        (pads[0] + pads[1]) / 2, abs=1e-6)


# ---- collision model ---------------------------------------------------------------------------
def test_box_separation_known_answers():
    unit = np.full(3, 0.5)
    a = Box(np.zeros(3), np.eye(3), unit)
    assert box_separation(a, Box(np.array([1.5, 0, 0]), np.eye(3), unit)) == pytest.approx(0.5)
    assert box_separation(a, Box(np.array([0.9, 0.2, 0]), np.eye(3), unit)) == \
        pytest.approx(-0.1)
    # a cube turned 45 deg about z: its edge reaches sqrt(2)/2 toward the first
    turned = np.array([[math.cos(math.pi / 4), -math.sin(math.pi / 4), 0],
                       [math.sin(math.pi / 4), math.cos(math.pi / 4), 0], [0, 0, 1]])
    b = Box(np.array([1.5, 0, 0]), turned, unit)
    assert box_separation(a, b) == pytest.approx(1.0 - math.sqrt(2) / 2)
    # two edges crossing above each other: only a cross-product axis separates them
    edge_a = Box(np.zeros(3), turned, np.array([0.5, 0.5, 0.5]))
    tilted = np.array([[1, 0, 0], [0, math.cos(math.pi / 4), -math.sin(math.pi / 4)],
                       [0, math.sin(math.pi / 4), math.cos(math.pi / 4)]])
    edge_b = Box(np.array([0, 0, 1.5]), tilted, np.array([0.5, 0.5, 0.5]))
    assert box_separation(edge_a, edge_b) == pytest.approx(1.5 - 0.5 - math.sqrt(2) / 2)


def test_no_enabled_pair_collides_over_the_joint_range(arm, arm_srdf):
    """50 states over the fingers' range (and the arm's): every pair of links with collision
    geometry that the SRDF leaves enabled is apart by more than 0.5 mm."""
    disabled = srdf_disabled(arm_srdf)
    enabled = [pair for pair in geometric_pairs(arm) if frozenset(pair) not in disabled]
    assert ('left_forte_left_finger', 'right_forte_right_finger') in enabled
    closest = {}
    for state in sweep(arm):
        for a, b in enabled:
            closest[a, b] = min(closest.get((a, b), math.inf), arm.separation(a, b, state))
    colliding = {pair: gap for pair, gap in closest.items() if gap <= 0.5e-3}
    assert not colliding, colliding


@pytest.mark.parametrize('prefix', GRIPPERS)
def test_the_fingers_never_touch_the_body_or_each_other(arm, prefix):
    """Across [0, theta_max], finger to body and finger to finger, disabled in the SRDF or
    not: the old boxes sank 4.4 to 12.6 mm into the body and touched when closed."""
    joint = f'{prefix}forte_left_finger_joint'
    body = f'{prefix}forte_base_link'
    fingers = [f'{prefix}forte_{side}_finger' for side in ('left', 'right')]
    to_body, between = [], []
    for theta in np.linspace(0.0, THETA_MAX, 101):
        state = {joint: float(theta)}
        to_body.append(min(arm.separation(body, finger, state) for finger in fingers))
        between.append(arm.separation(*fingers, state))
    assert min(to_body) > 0.99 * BODY_MARGIN, min(to_body)
    assert min(between) > 0.99 * FINGER_GAP, min(between)
    # known answers: the margins are reached exactly where the model is built to have them
    assert to_body[-1] == pytest.approx(BODY_MARGIN, abs=1e-9)  # theta_max
    assert between[0] == pytest.approx(FINGER_GAP, abs=1e-9)    # closed


#: The collision box of either finger before the collision model was fixed, in the finger's
#: frame: fin-ray width x base depth x (link + mount + fin-ray), from the pivot up, centred
#: on the pivot axis.
OLD_FINGER_BOX = Box(np.array([0.0, 0.0, 0.06]), np.eye(3), np.array([0.022, 0.030, 0.120]) / 2)


def test_the_checker_finds_the_old_geometry_in_the_body():
    """The same check on the old boxes: the body overlap the brief measured (4.4 mm at theta
    0.3, 12.6 mm at 1.0) and the closed fingers touching, so the tests above can fail."""
    robot = Robot(expand(STANDALONE_URDF))
    body = robot.boxes['forte_base_link'][0]
    gaps = {}
    for theta in (0.3, 1.0):
        finger = OLD_FINGER_BOX.moved(
            robot.pose('forte_left_finger', {'forte_left_finger_joint': theta}))
        gaps[theta] = box_separation(body, finger)
    assert gaps[0.3] == pytest.approx(-PIVOT_Y * math.sin(0.3), abs=1e-9)  # -4.4 mm
    assert gaps[1.0] == pytest.approx(-PIVOT_Y * math.sin(1.0), abs=1e-9)  # -12.6 mm
    closed = {'forte_left_finger_joint': 0.0}
    left, right = (OLD_FINGER_BOX.moved(robot.pose(f'forte_{side}_finger', closed))
                   for side in ('left', 'right'))
    assert box_separation(left, right) == pytest.approx(0.0, abs=1e-12)  # touching


def sampled_pairs(robot: Robot, states: list[dict[str, float]]) -> dict[frozenset[str], str]:
    """Disabled pairs by sampling, with this file's kinematics and box test: Adjacent (a
    joint between, links without geometry skipped), Never (apart in every state, by more
    than 0.5 mm). The gripper has no pair in collision in the default state or always."""
    geometric = {link for link in robot.links if robot.boxes[link]}
    neighbours = {link: set() for link in robot.links}
    for joint in robot.joints.values():
        parent, child = joint.find('parent').get('link'), joint.find('child').get('link')
        neighbours[parent].add(child)
        neighbours[child].add(parent)
    for link in robot.links:  # through a link without geometry (the pads, the TCP)
        if not robot.boxes[link]:
            for a, b in combinations(neighbours[link], 2):
                neighbours[a].add(b)
                neighbours[b].add(a)
    result = {frozenset((a, b)): 'Adjacent' for a in geometric for b in neighbours[a] & geometric}
    for a, b in combinations(sorted(geometric), 2):
        if frozenset((a, b)) not in result and all(
                robot.separation(a, b, state) > 0.5e-3 for state in states):
            result[frozenset((a, b))] = 'Never'
    return result


@pytest.mark.parametrize('prefix', ['', 'left_'])
def test_the_srdf_holds_what_sampling_gives(prefix):
    robot = Robot(expand(STANDALONE_URDF, prefix=prefix))
    srdf = srdf_disabled(expand(STANDALONE_SRDF, prefix=prefix))
    expected = sampled_pairs(robot, sweep(robot, count=200))
    assert srdf == expected
    assert sorted(srdf.values()) == ['Adjacent', 'Adjacent', 'Never']


def test_the_mount_joint_pair_is_disabled_on_the_arm(arm_srdf):
    disabled = srdf_disabled(arm_srdf)
    for prefix in GRIPPERS:
        assert disabled[frozenset((f'{prefix}tool0', f'{prefix}forte_base_link'))] == 'Adjacent'


def test_the_fcl_script_prints_the_srdf_pairs():
    """scripts/disabled_collisions.py samples with FCL, as MoveIt's setup assistant: its
    output is the macro's pairs; on the old geometry it finds the fingers in collision."""
    result = subprocess.run([sys.executable, str(SCRIPT), '--srdf', '--samples', '2000'],
                            capture_output=True, text=True, timeout=120, check=True)
    printed = {line.strip() for line in result.stdout.splitlines() if line.strip()}
    srdf = expand(STANDALONE_SRDF)
    assert printed == {f'<disable_collisions link1="{e.get("link1")}" link2="{e.get("link2")}" '
                       f'reason="{e.get("reason")}"/>' for e in srdf.findall('disable_collisions')}
    report = subprocess.run([sys.executable, str(SCRIPT), '--samples', '2000'],
                            capture_output=True, text=True, timeout=120, check=True).stdout
    assert 'disabled: 2 Adjacent, 0 Default, 0 Always, 1 Never' in report
    distances = [float(line.split('min distance')[1].split()[0]) for line in report.splitlines()
                 if 'min distance' in line]
    assert distances == pytest.approx([1.0, 1.0, 1.0], abs=1e-6)  # [mm]


def test_the_fcl_script_flags_touching_fingers(tmp_path):
    """Fingers whose collision boxes touch when closed (the old model) are 'Default' pairs."""
    robot = expand(STANDALONE_URDF)
    for link in robot.findall('link'):
        if link.get('name').endswith('_finger'):
            for collision in link.findall('collision'):
                link.remove(collision)
            collision = link.makeelement('collision', {})
            collision.append(collision.makeelement('origin', {'xyz': '0 0 0.06', 'rpy': '0 0 0'}))
            geometry = collision.makeelement('geometry', {})
            geometry.append(geometry.makeelement('box', {'size': '0.022 0.03 0.12'}))
            collision.append(geometry)
            link.append(collision)
    path = tmp_path / 'old.urdf'
    path.write_bytes(ET.tostring(robot))
    result = subprocess.run([sys.executable, str(SCRIPT), str(path), '--srdf', '--samples',
                             '200'], capture_output=True, text=True, timeout=120, check=True)
    assert 'link1="forte_left_finger" link2="forte_right_finger" reason="Default"' in \
        result.stdout
