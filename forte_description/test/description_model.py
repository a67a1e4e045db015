"""Test helpers of forte_description: expand the xacro files, read a URDF and an SRDF, move
the links (forward kinematics of this file, mimic joints included) and separate boxes.

Independent of ``scripts/disabled_collisions.py`` on purpose (own kinematics, own collision
test), so that the tests cross-check the script instead of repeating it. Needs numpy and
xacro only.

Collision test: the separating axis theorem for oriented boxes (the gripper's collision
model and the stand-in arm are boxes only). :func:`box_separation` returns the largest gap
of the two boxes' projections over the 15 candidate axes: > 0 proves the boxes apart by at
least that much (a lower bound of their distance, exact when the closest features are
faces along one of the axes, as for parallel boxes); <= 0 means they intersect or touch.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import product
from pathlib import Path

import numpy as np
import pytest

PACKAGE = Path(__file__).resolve().parents[1]
TEST_FOLDER = Path(__file__).resolve().parent
ARM_URDF = TEST_FOLDER / 'arm_with_two_fortes.urdf.xacro'
ARM_SRDF = TEST_FOLDER / 'arm_with_two_fortes.srdf.xacro'
GRIPPERS = ('left_', 'right_')  # the prefixes of the stand-in arm's two grippers


def expand(path: Path, **mappings: str) -> ET.Element:
    """The ``<robot>`` element xacro makes of ``path`` with ``mappings`` (xacro arguments)."""
    xacro = pytest.importorskip('xacro')
    return ET.fromstring(xacro.process_file(str(path), mappings=mappings).toxml())


def numbers(text: str | None, default: str = '0 0 0') -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF roll, pitch, yaw about the fixed x, y, z axes: Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    roll, pitch, yaw = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)],
                   [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0],
                   [-math.sin(pitch), 0, math.cos(pitch)]])
    rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                   [0, 0, 1]])
    return rz @ ry @ rx


def origin(element: ET.Element | None) -> np.ndarray:
    """4x4 transform of an ``<origin>`` (identity when absent)."""
    transform = np.eye(4)
    if element is not None:
        transform[:3, :3] = rpy_matrix(numbers(element.get('rpy')))
        transform[:3, 3] = numbers(element.get('xyz'))
    return transform


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about ``axis`` (Rodrigues' formula)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


@dataclass(frozen=True)
class Box:
    """A box: center, rotation (columns = its axes), half extents [m], in one frame."""

    center: np.ndarray
    rotation: np.ndarray
    half: np.ndarray

    def moved(self, transform: np.ndarray) -> Box:
        """The box in the frame where ``transform`` gives its current frame."""
        return Box(transform[:3, :3] @ self.center + transform[:3, 3],
                   transform[:3, :3] @ self.rotation, self.half)


def box_separation(a: Box, b: Box) -> float:
    """Largest projection gap of boxes ``a`` and ``b`` over the 15 axes of the separating
    axis theorem [m] (module docstring)."""
    axes = [a.rotation[:, i] for i in range(3)] + [b.rotation[:, i] for i in range(3)]
    for i, j in product(range(3), range(3)):
        cross = np.cross(a.rotation[:, i], b.rotation[:, j])
        norm = np.linalg.norm(cross)
        if norm > 1e-9:
            axes.append(cross / norm)
    offset = b.center - a.center
    gaps = []
    for axis in axes:
        reach_a = np.sum(a.half * np.abs(a.rotation.T @ axis))
        reach_b = np.sum(b.half * np.abs(b.rotation.T @ axis))
        gaps.append(abs(offset @ axis) - reach_a - reach_b)
    return float(max(gaps))


class Robot:
    """A URDF: links, joints, collision boxes, and poses for joint positions."""

    def __init__(self, robot: ET.Element) -> None:
        self.element = robot
        self.links = [link.get('name') for link in robot.findall('link')]
        self.joints = {joint.get('name'): joint for joint in robot.findall('joint')}
        self.parent_joint = {joint.find('child').get('link'): joint
                             for joint in self.joints.values()}
        self.boxes: dict[str, list[Box]] = {}
        for link in robot.findall('link'):
            boxes = []
            for collision in link.findall('collision'):
                shape = collision.find('geometry')[0]
                assert shape.tag == 'box', f'{link.get("name")}: only boxes here, not {shape.tag}'
                pose = origin(collision.find('origin'))
                boxes.append(Box(pose[:3, 3], pose[:3, :3], numbers(shape.get('size')) / 2))
            self.boxes[link.get('name')] = boxes

    def mimic(self, name: str) -> tuple[str, float, float] | None:
        """(mimicked joint, multiplier, offset) of joint ``name``, or None."""
        element = self.joints[name].find('mimic')
        if element is None:
            return None
        return (element.get('joint'), float(element.get('multiplier', '1')),
                float(element.get('offset', '0')))

    @property
    def active_joints(self) -> list[str]:
        """Movable joints that mimic none (MoveIt's variables), in URDF order."""
        return [name for name, joint in self.joints.items()
                if joint.get('type') != 'fixed' and self.mimic(name) is None]

    def limits(self, name: str) -> tuple[float, float, float, float]:
        """(lower, upper, effort, velocity) of joint ``name``."""
        limit = self.joints[name].find('limit')
        return tuple(float(limit.get(key)) for key in ('lower', 'upper', 'effort', 'velocity'))

    def pose(self, link: str, positions: Mapping[str, float]) -> np.ndarray:
        """4x4 pose of ``link`` in the root; ``positions`` of the active joints (others 0),
        a mimic joint at multiplier * position + offset of the joint it mimics."""
        transform = np.eye(4)
        while link in self.parent_joint:
            joint = self.parent_joint[link]
            step = origin(joint.find('origin'))
            if joint.get('type') in ('revolute', 'continuous'):
                mimic = self.mimic(joint.get('name'))
                value = positions.get(joint.get('name'), 0.0) if mimic is None else \
                    mimic[1] * positions.get(mimic[0], 0.0) + mimic[2]
                motion = np.eye(4)
                axis = joint.find('axis')
                motion[:3, :3] = rotation_about(
                    numbers(None if axis is None else axis.get('xyz'), '1 0 0'), value)
                step = step @ motion
            transform = step @ transform
            link = joint.find('parent').get('link')
        return transform

    def placed_boxes(self, link: str, positions: Mapping[str, float]) -> list[Box]:
        pose = self.pose(link, positions)
        return [box.moved(pose) for box in self.boxes[link]]

    def separation(self, a: str, b: str, positions: Mapping[str, float]) -> float:
        """Smallest :func:`box_separation` of any box of link ``a`` and any of ``b`` [m]."""
        return min(box_separation(x, y) for x in self.placed_boxes(a, positions)
                   for y in self.placed_boxes(b, positions))


def srdf_disabled(srdf: ET.Element) -> dict[frozenset[str], str]:
    """The SRDF's disabled pairs: {link1, link2} -> reason."""
    return {frozenset((e.get('link1'), e.get('link2'))): e.get('reason')
            for e in srdf.findall('disable_collisions')}
