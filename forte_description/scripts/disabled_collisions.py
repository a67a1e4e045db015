#!/usr/bin/env python3
"""The SRDF ``disable_collisions`` pairs of a URDF, by sampling as MoveIt's setup assistant.

Maintainer tool of forte_description (not run by any launch file): it computed the pairs in
``srdf/forte_gripper.macro.xacro``; run it again after changing the gripper's collision
geometry and paste its ``--srdf`` output into the macro. ``test/test_moveit_description.py``
runs it and fails while the macro disagrees::

    python forte_description/scripts/disabled_collisions.py              # the gripper
    python forte_description/scripts/disabled_collisions.py --srdf --xacro-prefix
    python forte_description/scripts/disabled_collisions.py robot.urdf.xacro --arg prefix:=l_

Needs numpy, xacro (for ``.xacro`` input) and python-fcl (the collision library MoveIt
uses; ``pip install python-fcl``, pinned in requirements/hardware.txt). None of them is a
run-time dependency of forte_description.

Classification of every pair of links with collision geometry, in MoveIt Setup Assistant's
order (a pair keeps the first reason that applies):

1. ``Adjacent``: the links are connected by a joint; a link without collision geometry is
   skipped over (its neighbours are adjacent to each other), to a fixed point.
2. ``Default``: in collision in the default state (each active joint at 0, or at the middle
   of its limits where 0 is outside them).
3. ``Always``: in collision in at least ``--always-fraction`` (0.95, the assistant's
   default) of the random states.
4. ``Never``: in collision in none of the random states (``--samples``, default 10000,
   uniform within the joint limits, mimic joints following the joint they mimic, fixed
   ``--seed``).
Other pairs stay enabled: MoveIt checks them.

Shapes: box, cylinder, sphere (URDF primitives); a mesh collision element is refused.
"""
from __future__ import annotations

import argparse
import math
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path

import numpy as np

PACKAGE = Path(__file__).resolve().parents[1]
DEFAULT_INPUT = PACKAGE / 'urdf' / 'forte_gripper.urdf.xacro'
#: Reasons in the order they are decided.
REASONS = ('Adjacent', 'Default', 'Always', 'Never')


# ---- URDF model ----------------------------------------------------------------------------
def _numbers(text: str | None, default: str = '0 0 0') -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def _rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes x, y, z): R = Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _origin(element: ET.Element | None) -> np.ndarray:
    """4x4 transform of an ``<origin>`` element (identity when absent)."""
    transform = np.eye(4)
    if element is not None:
        transform[:3, :3] = _rpy_matrix(_numbers(element.get('rpy')))
        transform[:3, 3] = _numbers(element.get('xyz'))
    return transform


@dataclass
class Joint:
    """One URDF joint: its parent/child links, origin, axis, limits and mimic."""

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float = 0.0
    upper: float = 0.0
    mimic: tuple[str, float, float] | None = None  # (joint, multiplier, offset)

    @property
    def active(self) -> bool:
        """A variable MoveIt samples: movable and no mimic."""
        return self.kind in ('revolute', 'continuous', 'prismatic') and self.mimic is None

    def motion(self, value: float) -> np.ndarray:
        """4x4 transform of the child in the parent at ``value`` [rad or m]."""
        transform = self.origin.copy()
        if self.kind in ('revolute', 'continuous'):
            x, y, z = self.axis / np.linalg.norm(self.axis)
            k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
            rotation = np.eye(3) + math.sin(value) * k + (1 - math.cos(value)) * k @ k
            step = np.eye(4)
            step[:3, :3] = rotation
            transform = transform @ step
        elif self.kind == 'prismatic':
            step = np.eye(4)
            step[:3, 3] = value * self.axis / np.linalg.norm(self.axis)
            transform = transform @ step
        return transform


@dataclass
class Shape:
    """One collision element: kind (box, cylinder, sphere), dimensions [m], pose in its link."""

    kind: str
    size: tuple[float, ...]
    pose: np.ndarray


@dataclass
class Model:
    """Links with their collision shapes and the joints of a URDF."""

    shapes: dict[str, list[Shape]] = field(default_factory=dict)
    joints: dict[str, Joint] = field(default_factory=dict)

    @classmethod
    def from_urdf(cls, robot: ET.Element) -> Model:
        """Read a URDF ``<robot>`` element (refuses mesh collision geometry)."""
        model = cls()
        for link in robot.findall('link'):
            shapes = []
            for collision in link.findall('collision'):
                geometry = collision.find('geometry')
                element = geometry[0]
                if element.tag == 'box':
                    size = tuple(_numbers(element.get('size')))
                elif element.tag == 'cylinder':
                    size = (float(element.get('radius')), float(element.get('length')))
                elif element.tag == 'sphere':
                    size = (float(element.get('radius')),)
                else:
                    raise ValueError(f'link {link.get("name")}: {element.tag} collision geometry '
                                     'is not supported (box, cylinder, sphere)')
                shapes.append(Shape(element.tag, size, _origin(collision.find('origin'))))
            model.shapes[link.get('name')] = shapes
        for element in robot.findall('joint'):
            limit, mimic = element.find('limit'), element.find('mimic')
            axis = element.find('axis')
            joint = Joint(element.get('name'), element.get('type'),
                          element.find('parent').get('link'), element.find('child').get('link'),
                          _origin(element.find('origin')),
                          _numbers(None if axis is None else axis.get('xyz'), '1 0 0'))
            if limit is not None:
                joint.lower = float(limit.get('lower', 0.0))
                joint.upper = float(limit.get('upper', 0.0))
            if joint.kind == 'continuous':
                joint.lower, joint.upper = -math.pi, math.pi
            if mimic is not None:
                joint.mimic = (mimic.get('joint'), float(mimic.get('multiplier', 1.0)),
                               float(mimic.get('offset', 0.0)))
            model.joints[joint.name] = joint
        return model

    @property
    def active_joints(self) -> list[Joint]:
        return [joint for joint in self.joints.values() if joint.active]

    @property
    def geometric_links(self) -> list[str]:
        """Links with collision geometry, in URDF order."""
        return [name for name, shapes in self.shapes.items() if shapes]

    def positions(self, values: Mapping[str, float]) -> dict[str, float]:
        """Every movable joint's value: ``values`` of the active joints, mimics following."""
        result = dict(values)
        for joint in self.joints.values():
            if joint.mimic is not None:
                source, multiplier, offset = joint.mimic
                result[joint.name] = multiplier * result[source] + offset
        return result

    def link_poses(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """4x4 pose of every link in the root for the active joints' ``values``."""
        positions = self.positions(values)
        parent_joint = {joint.child: joint for joint in self.joints.values()}
        poses: dict[str, np.ndarray] = {}

        def pose(link: str) -> np.ndarray:
            if link not in poses:
                joint = parent_joint.get(link)
                poses[link] = np.eye(4) if joint is None else \
                    pose(joint.parent) @ joint.motion(positions.get(joint.name, 0.0))
            return poses[link]

        for link in self.shapes:
            pose(link)
        return poses

    def default_values(self) -> dict[str, float]:
        """MoveIt's default state: 0, or the middle of the limits where 0 is outside."""
        return {joint.name: 0.0 if joint.lower <= 0.0 <= joint.upper
                else (joint.lower + joint.upper) / 2 for joint in self.active_joints}

    def random_values(self, count: int, seed: int) -> list[dict[str, float]]:
        """``count`` states uniform within the active joints' limits."""
        rng = np.random.default_rng(seed)
        joints = self.active_joints
        draws = rng.uniform([j.lower for j in joints], [j.upper for j in joints],
                            size=(count, len(joints)))
        return [{joint.name: float(value) for joint, value in zip(joints, row)}
                for row in draws]


def adjacent_pairs(model: Model) -> set[frozenset[str]]:
    """Pairs of links connected by a joint, links without geometry skipped over."""
    neighbours: dict[str, set[str]] = {link: set() for link in model.shapes}
    for joint in model.joints.values():
        neighbours[joint.parent].add(joint.child)
        neighbours[joint.child].add(joint.parent)
    changed = True
    while changed:
        changed = False
        for link in model.shapes:
            if model.shapes[link]:
                continue
            for a, b in combinations(sorted(neighbours[link]), 2):
                if b not in neighbours[a]:
                    neighbours[a].add(b)
                    neighbours[b].add(a)
                    changed = True
    geometric = set(model.geometric_links)
    return {frozenset((a, b)) for a in geometric for b in neighbours[a] & geometric}


# ---- collision checking (python-fcl) ----------------------------------------------------------
class Checker:
    """Collision and distance queries between links of a :class:`Model` with python-fcl."""

    def __init__(self, model: Model) -> None:
        import fcl  # the only use: the module loads without python-fcl (for --help)

        self.fcl = fcl
        self.model = model
        self.objects: dict[str, list[tuple[object, np.ndarray]]] = {}
        for link, shapes in model.shapes.items():
            self.objects[link] = [(fcl.CollisionObject(self._geometry(shape)), shape.pose)
                                  for shape in shapes]

    def _geometry(self, shape: Shape) -> object:
        if shape.kind == 'box':
            return self.fcl.Box(*shape.size)
        if shape.kind == 'cylinder':
            return self.fcl.Cylinder(*shape.size)
        return self.fcl.Sphere(*shape.size)

    def place(self, values: Mapping[str, float]) -> None:
        """Move every collision object to the state of the active joints' ``values``."""
        for link, pose in self.model.link_poses(values).items():
            for obj, local in self.objects[link]:
                world = pose @ local
                obj.setTransform(self.fcl.Transform(world[:3, :3], world[:3, 3]))

    def colliding(self, a: str, b: str) -> bool:
        """True if any shape of link ``a`` intersects any of link ``b`` (placed state)."""
        return any(self.fcl.collide(x, y, self.fcl.CollisionRequest(), self.fcl.CollisionResult())
                   for x, _ in self.objects[a] for y, _ in self.objects[b])

    def distance(self, a: str, b: str) -> float:
        """Smallest signed distance between the shapes of links ``a`` and ``b`` [m] (placed
        state; 0 when touching, minus the penetration depth when they intersect)."""
        request = self.fcl.DistanceRequest(enable_signed_distance=True)
        return min(self.fcl.distance(x, y, request, self.fcl.DistanceResult())
                   for x, _ in self.objects[a] for y, _ in self.objects[b])


@dataclass
class PairReport:
    """What sampling found for one pair of links."""

    links: tuple[str, str]
    reason: str | None  # one of REASONS, or None: MoveIt checks the pair
    collisions: int = 0  # random states in collision
    samples: int = 0  # random states checked
    min_distance: float = math.nan  # smallest distance over the distance states [m]


def classify(model: Model, samples: int = 10000, seed: int = 0,
             always_fraction: float = 0.95, distance_states: int = 101) -> list[PairReport]:
    """Every pair of links with collision geometry, classified as the module docstring says.

    Parameters
    ----------
    model : Model
        The robot.
    samples : int
        Random states for ``Always`` and ``Never``.
    seed : int
        Seed of the random states.
    always_fraction : float
        Smallest fraction of colliding states for ``Always``.
    distance_states : int
        States over which the minimum distance of each pair is measured (the default state,
        every active joint at its lower and at its upper limit, then the first random ones);
        0 skips the measurement.

    Returns
    -------
    list of PairReport
        Sorted by link names (each pair's names sorted).
    """
    checker = Checker(model)
    adjacent = adjacent_pairs(model)
    pairs = sorted(tuple(sorted(pair)) for pair in combinations(model.geometric_links, 2))
    reports = {pair: PairReport(pair, 'Adjacent' if frozenset(pair) in adjacent else None)
               for pair in pairs}
    checker.place(model.default_values())
    for pair, report in reports.items():
        if report.reason is None and checker.colliding(*pair):
            report.reason = 'Default'
    undecided = [pair for pair, report in reports.items() if report.reason is None]
    states = model.random_values(samples, seed)
    for state in states:
        checker.place(state)
        for pair in undecided:
            reports[pair].collisions += checker.colliding(*pair)
    for pair in undecided:
        report = reports[pair]
        report.samples = samples
        if samples and report.collisions >= always_fraction * samples:
            report.reason = 'Always'
        elif report.collisions == 0:
            report.reason = 'Never'
    if distance_states:
        bounds = [{joint.name: getattr(joint, end) for joint in model.active_joints}
                  for end in ('lower', 'upper')]
        for state in [model.default_values(), *bounds, *states][:distance_states]:
            checker.place(state)
            for pair, report in reports.items():
                distance = checker.distance(*pair)
                if not distance >= report.min_distance:  # NaN at first
                    report.min_distance = distance
    return [reports[pair] for pair in pairs]


# ---- input and output -----------------------------------------------------------------------
def load_robot(path: Path, mappings: Mapping[str, str] | None = None) -> ET.Element:
    """The URDF ``<robot>`` element of ``path`` (a ``.xacro`` file is expanded)."""
    if path.suffix == '.xacro':
        import xacro  # only for xacro input

        return ET.fromstring(xacro.process_file(str(path), mappings=dict(mappings or {}))
                             .toxml())
    return ET.parse(path).getroot()


def srdf_lines(reports: Iterable[PairReport], prefix: str = '') -> list[str]:
    """``<disable_collisions>`` elements of the disabled pairs, ``prefix`` before each link
    name (``${prefix}`` for the xacro macro)."""
    return [f'<disable_collisions link1="{prefix}{r.links[0]}" link2="{prefix}{r.links[1]}" '
            f'reason="{r.reason}"/>' for r in reports if r.reason is not None]


def parse_mappings(items: Sequence[str]) -> dict[str, str]:
    """``name:=value`` arguments as a dict."""
    mappings = {}
    for item in items:
        key, sep, value = item.partition(':=')
        if not sep or not key:
            raise argparse.ArgumentTypeError(f'expected name:=value, got {item!r}')
        mappings[key] = value
    return mappings


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('input', nargs='?', type=Path, default=DEFAULT_INPUT,
                        help='URDF or xacro file (default: the standalone gripper)')
    parser.add_argument('--arg', action='append', default=[], metavar='NAME:=VALUE',
                        help='xacro argument (repeatable)')
    parser.add_argument('--samples', type=int, default=10000, help='random states')
    parser.add_argument('--seed', type=int, default=0, help='seed of the random states')
    parser.add_argument('--always-fraction', type=float, default=0.95,
                        help="fraction of colliding states that makes a pair 'Always'")
    parser.add_argument('--srdf', action='store_true',
                        help='print the SRDF lines of the disabled pairs only')
    parser.add_argument('--xacro-prefix', action='store_true',
                        help='write link names as ${prefix}<name> (for the xacro macro)')
    args = parser.parse_args(argv)
    model = Model.from_urdf(load_robot(args.input, parse_mappings(args.arg)))
    reports = classify(model, args.samples, args.seed, args.always_fraction,
                       distance_states=0 if args.srdf else 101)
    prefix = '${prefix}' if args.xacro_prefix else ''
    if args.srdf:
        print('\n'.join(srdf_lines(reports, prefix)))
        return 0
    print(f'{args.input}: {len(model.geometric_links)} links with collision geometry, '
          f'{len(reports)} pairs, {args.samples} random states (seed {args.seed})')
    for report in reports:
        print(f'  {report.links[0]:32s} {report.links[1]:32s} '
              f'{report.reason or "CHECKED":9s} collisions {report.collisions}/{report.samples}'
              f'  min distance {1000 * report.min_distance:.3f} mm')
    counts = {reason: sum(r.reason == reason for r in reports) for reason in REASONS}
    print('disabled: ' + ', '.join(f'{count} {reason}' for reason, count in counts.items()))
    print('\n'.join(srdf_lines(reports, prefix)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
