"""Parametric FORTE fin-ray finger: parameters and the derived geometry (pure Python).

No CAD kernel here: this module turns :class:`FingerParameters` into plain numbers (the
2-D fin-ray profile, the cavity cells between the ribs, the channel centre-line paths and
the port table) that :mod:`forte_finger.cad` turns into a solid and the tests compare the
generated mesh against.

Finger frame (all lengths in mm, angles in degrees)
---------------------------------------------------
- ``x``: thickness direction. ``x = 0`` is the inner (contact) surface; ``+x`` points from
  the contact surface into the finger, toward the outer (back) surface.
- ``y``: width direction, ``-width/2 .. +width/2``. The side face ``y = +width/2`` is the
  *port side* (tubing); the side face ``y = -width/2`` is the *vent side* (clean-out vents,
  sealed with silicone epoxy after washing).
- ``z``: length direction. ``z = 0`` is the top of the base mount, ``z = length`` the tip;
  the base mount occupies ``-mount_height .. 0``.

Channels
--------
Each of the three sensing locations (distal, middle, root) has a pair of channels: one
under the inner (contact) surface and one under the outer surface. Every channel is an L:
a *sensing leg* parallel to its surface (axis at ``channel_wall + channel_diameter / 2``
below the surface, near the vent side) and a *port leg* running across the width to the
port on the port-side face. The distal end of the sensing leg is sealed: either closed in
the print (``distal_vent=False``) or, for resin printing where uncured resin must be
washed out, opened by a short vent to the vent-side face and sealed with silicone epoxy
after washing (``distal_vent=True``, the default, as in the paper).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

LOCATIONS = ('distal', 'middle', 'root')
SURFACES = ('inner', 'outer')


@dataclass(frozen=True)
class FingerParameters:
    """Design parameters of one finger (both fingers of the gripper are identical prints).

    Attributes
    ----------
    length : float
        Fin-ray length from the top of the base mount to the tip [mm].
    width : float
        Finger width along ``y`` (side face to side face) [mm].
    base_depth : float
        Thickness of the fin-ray at its root, contact surface to outer surface [mm].
    tip_depth : float
        Thickness at the tip (flat tip face) [mm].
    inner_wall : float
        Thickness of the inner (contact) beam [mm].
    outer_wall : float
        Thickness of the outer beam, measured normal to its surface [mm].
    rib_count : int
        Number of ribs between the beams (the floor above the mount is not counted).
    rib_angle : float
        Rib inclination from the ``x`` axis [deg]; positive tilts the outer end toward
        the tip.
    rib_thickness : float
        Rib thickness, normal to the rib [mm].
    floor_thickness : float
        Solid material between the base mount and the first cavity [mm].
    tip_cap : float
        Solid material below the tip face [mm].
    min_cell_area : float
        Cavity cells smaller than this (slivers near the tip) are left solid [mm^2].
    mount_height : float
        Height of the base mount block below ``z = 0`` [mm].
    mount_hole_diameter : float
        Diameter of the two mounting holes through the mount along ``x`` [mm].
    mount_hole_spacing : float
        Distance between the two mounting hole axes along ``y`` [mm].
    channel_diameter : float
        Air channel diameter [mm] (paper: 2).
    channel_wall : float
        Material between a channel and the adjacent inner/outer surface [mm] (paper: 1).
    side_wall : float
        Material between a sensing leg and the vent-side face [mm].
    sensing_length : float
        Length of each sensing leg along its surface [mm].
    location_fractions : tuple of 3 float
        Centre of the (distal, middle, root) sensing legs as a fraction of ``length``.
    distal_vent : bool
        Open the distal end of every channel to the vent-side face (for washing resin
        prints; seal with silicone epoxy afterwards). False: distal ends closed in print.
    min_internal_wall : float
        Smallest wall any check accepts between two channels or between a channel and a
        cavity [mm].
    """

    length: float = 90.0
    width: float = 22.0
    base_depth: float = 30.0
    tip_depth: float = 9.0
    inner_wall: float = 4.5
    outer_wall: float = 4.5
    rib_count: int = 6
    rib_angle: float = 10.0
    rib_thickness: float = 1.6
    floor_thickness: float = 3.0
    tip_cap: float = 3.0
    min_cell_area: float = 8.0
    mount_height: float = 10.0
    mount_hole_diameter: float = 4.4
    mount_hole_spacing: float = 12.0
    channel_diameter: float = 2.0
    channel_wall: float = 1.0
    side_wall: float = 2.0
    sensing_length: float = 14.0
    location_fractions: tuple[float, float, float] = (0.78, 0.5, 0.22)
    distal_vent: bool = True
    min_internal_wall: float = 1.0

    @property
    def channel_radius(self) -> float:
        """Channel radius [mm]."""
        return self.channel_diameter / 2.0

    @property
    def channel_depth(self) -> float:
        """Distance from a surface to the axis of the channel under it [mm]."""
        return self.channel_wall + self.channel_radius

    def validate(self) -> None:
        """Raise ValueError listing every reason the parameters cannot make a finger."""
        problems = []
        positive = ('length', 'width', 'base_depth', 'tip_depth', 'inner_wall', 'outer_wall',
                    'rib_thickness', 'floor_thickness', 'tip_cap', 'mount_height',
                    'mount_hole_diameter', 'channel_diameter', 'channel_wall', 'side_wall',
                    'sensing_length', 'min_internal_wall')
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                problems.append(f'{name} must be a finite number > 0 (got {value!r})')
        if problems:
            raise ValueError('; '.join(problems))
        if not isinstance(self.rib_count, int) or self.rib_count < 0:
            problems.append(f'rib_count must be an integer >= 0 (got {self.rib_count!r})')
        if not -45.0 < self.rib_angle < 45.0:
            problems.append(f'rib_angle {self.rib_angle} deg outside (-45, 45)')
        if self.tip_depth >= self.base_depth:
            problems.append('tip_depth must be smaller than base_depth (fin-ray taper)')
        needed = 2 * self.channel_wall + self.channel_diameter
        for name in ('inner_wall', 'outer_wall'):
            # the channel needs channel_wall to the surface and min_internal_wall inside
            need = self.channel_wall + self.channel_diameter + self.min_internal_wall
            if getattr(self, name) < need:
                problems.append(f'{name} {getattr(self, name)} mm < {need} mm needed to hold '
                                f'a {self.channel_diameter} mm channel with walls')
        if self.tip_depth < 2 * needed:
            problems.append(f'tip_depth {self.tip_depth} mm cannot hold two channels '
                            f'({2 * needed} mm needed)')
        fractions = self.location_fractions
        if len(fractions) != 3 or not all(0.0 < f < 1.0 for f in fractions):
            problems.append('location_fractions must be 3 values in (0, 1)')
        elif not fractions[0] > fractions[1] > fractions[2]:
            problems.append('location_fractions must be ordered distal > middle > root')
        else:
            half = self.sensing_length / 2.0
            centres = [f * self.length for f in fractions]
            gap_needed = self.channel_diameter + self.min_internal_wall
            # consecutive legs: distal end of the lower channel vs port leg of the upper one
            for upper, lower in zip(centres[:-1], centres[1:]):
                if (upper - half) - (lower + half) < gap_needed:
                    problems.append('sensing legs overlap: increase spacing of '
                                    'location_fractions or reduce sensing_length')
            if centres[2] - half < self.channel_radius + self.min_internal_wall:
                problems.append('root port leg too close to the base mount')
            if centres[0] + half > self.length - self.tip_cap - self.channel_radius:
                problems.append('distal sensing leg reaches the tip face')
        if self.width < 2 * (self.side_wall + self.channel_diameter) + self.channel_wall:
            problems.append(f'width {self.width} mm too small for the channel legs')
        if self.mount_hole_spacing + self.mount_hole_diameter >= self.width - 2.0:
            problems.append('mounting holes too close to the side faces')
        if self.mount_hole_diameter >= self.mount_height - 2.0:
            problems.append('mounting holes too large for mount_height')
        if problems:
            raise ValueError('; '.join(problems))

    def as_dict(self) -> dict:
        """Plain-dict copy (for JSON reports)."""
        return asdict(self)


@dataclass(frozen=True)
class Channel:
    """One air channel: centre-line path and where it opens.

    Attributes
    ----------
    name : str
        ``<location>_<surface>``, e.g. ``distal_inner``.
    location : str
        ``distal``, ``middle`` or ``root``.
    surface : str
        ``inner`` (contact side) or ``outer``.
    path : ndarray, shape (k, 3)
        Centre-line polyline [mm]: (vent end or sealed distal end), sensing leg,
        corner, port-leg end on the port-side face.
    port : ndarray, shape (3,)
        Port centre on the port-side face ``y = +width/2`` [mm].
    vent : ndarray or None, shape (3,)
        Vent centre on the vent-side face ``y = -width/2`` [mm], None if closed.
    surface_normal : ndarray, shape (3,)
        Unit outward normal of the surface the channel runs under.
    sensing_direction : ndarray, shape (3,)
        Unit direction of the sensing leg (from proximal to distal end).
    """

    name: str
    location: str
    surface: str
    path: np.ndarray
    port: np.ndarray
    vent: np.ndarray | None
    surface_normal: np.ndarray
    sensing_direction: np.ndarray

    @property
    def corner(self) -> np.ndarray:
        """Corner of the L (proximal end of the sensing leg) [mm], shape (3,)."""
        return self.path[-2]

    @property
    def distal_end(self) -> np.ndarray:
        """Distal end of the sensing leg [mm], shape (3,)."""
        return self.path[-3]

    @property
    def sensing_midpoint(self) -> np.ndarray:
        """Centre of the sensing leg [mm], shape (3,)."""
        return 0.5 * (self.corner + self.distal_end)

    @property
    def centreline_length(self) -> float:
        """Length of the centre line inside the finger [mm]."""
        return float(np.sum(np.linalg.norm(np.diff(self.path, axis=0), axis=1)))


@dataclass(frozen=True)
class FingerDesign:
    """Everything derived from the parameters (mm).

    Attributes
    ----------
    parameters : FingerParameters
    profile : ndarray, shape (5, 2)
        Outer profile polygon in the ``x``-``z`` plane, counter-clockwise.
    cells : list of ndarray, each shape (m, 2)
        Convex cavity cells (through holes along ``y``) in the ``x``-``z`` plane.
    channels : list of Channel
        Six channels, order: distal/middle/root x inner/outer.
    mount_holes : list of tuple (y, z)
        Mounting hole axes (along ``x``).
    """

    parameters: FingerParameters
    profile: np.ndarray
    cells: list[np.ndarray] = field(default_factory=list)
    channels: list[Channel] = field(default_factory=list)
    mount_holes: list[tuple[float, float]] = field(default_factory=list)

    def channel(self, name: str) -> Channel:
        """The channel called ``name`` (KeyError if none)."""
        for channel in self.channels:
            if channel.name == name:
                return channel
        raise KeyError(name)

    @property
    def outer_surface_normal(self) -> np.ndarray:
        """Unit outward normal of the outer surface in ``x``-``z``, shape (2,)."""
        return outer_normal(self.parameters)

    def port_table(self) -> list[dict]:
        """One row per channel: name, port and vent centres [mm] (for docs and CSV)."""
        rows = []
        for channel in self.channels:
            rows.append({
                'channel': channel.name,
                'port_x': round(float(channel.port[0]), 3),
                'port_y': round(float(channel.port[1]), 3),
                'port_z': round(float(channel.port[2]), 3),
                'vent_x': None if channel.vent is None else round(float(channel.vent[0]), 3),
                'vent_z': None if channel.vent is None else round(float(channel.vent[2]), 3),
                'centreline_length_mm': round(channel.centreline_length, 2),
                'volume_mm3': round(channel.centreline_length * math.pi
                                    * self.parameters.channel_radius ** 2, 1),
            })
        return rows


def outer_normal(p: FingerParameters) -> np.ndarray:
    """Unit outward normal (x, z) of the outer surface line (base_depth, 0)-(tip_depth, L)."""
    normal = np.array([p.length, p.base_depth - p.tip_depth], dtype=float)
    return normal / np.linalg.norm(normal)


def outer_surface_x(p: FingerParameters, z: float) -> float:
    """``x`` of the outer surface at height ``z`` [mm]."""
    return p.base_depth + (p.tip_depth - p.base_depth) * z / p.length


def clip_convex(polygon: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """Keep the part of a convex polygon where ``normal . p <= offset``.

    Parameters
    ----------
    polygon : ndarray, shape (m, 2)
        Convex polygon, vertices in order.
    normal : ndarray, shape (2,)
    offset : float

    Returns
    -------
    ndarray, shape (k, 2)
        Clipped polygon (k = 0 if nothing remains).
    """
    if len(polygon) == 0:
        return polygon
    result = []
    count = len(polygon)
    for i in range(count):
        a = polygon[i]
        b = polygon[(i + 1) % count]
        da = float(normal @ a) - offset
        db = float(normal @ b) - offset
        if da <= 0:
            result.append(a)
        if (da < 0 < db) or (db < 0 < da):
            t = da / (da - db)
            result.append(a + t * (b - a))
    return np.array(result, dtype=float).reshape(-1, 2)


def polygon_area(polygon: np.ndarray) -> float:
    """Signed area of a polygon [mm^2] (positive counter-clockwise in x-z)."""
    if len(polygon) < 3:
        return 0.0
    x, z = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def cavity_cells(p: FingerParameters) -> list[np.ndarray]:
    """Cavity cells between floor, ribs, beams and tip cap (convex, counter-clockwise)."""
    n_out = outer_normal(p)
    anchor = np.array([p.base_depth, 0.0])
    big = 10.0 * (p.length + p.base_depth)
    region = np.array([[p.inner_wall, p.floor_thickness], [big, p.floor_thickness],
                       [big, p.length - p.tip_cap], [p.inner_wall, p.length - p.tip_cap]])
    # inside the outer beam: n_out . (q - anchor) <= -outer_wall
    region = clip_convex(region, n_out, float(n_out @ anchor) - p.outer_wall)
    if len(region) < 3:
        return []
    angle = math.radians(p.rib_angle)
    rib_up = np.array([-math.sin(angle), math.cos(angle)])  # rib normal, pointing to the tip
    # rib centre lines cross the inner face at equally spaced heights between the floor and
    # the top of the cavity on the inner face
    top_inner = float(np.max(region[np.isclose(region[:, 0], p.inner_wall), 1]))
    span = top_inner - p.floor_thickness
    rib_z = [p.floor_thickness + span * (i + 1) / (p.rib_count + 1)
             for i in range(p.rib_count)]
    rib_offsets = [float(rib_up @ np.array([p.inner_wall, z])) for z in rib_z]
    half = p.rib_thickness / 2.0
    bounds = [-math.inf] + rib_offsets + [math.inf]
    cells = []
    for lower, upper in zip(bounds[:-1], bounds[1:]):
        cell = region
        if math.isfinite(lower):
            cell = clip_convex(cell, -rib_up, -(lower + half))
        if math.isfinite(upper):
            cell = clip_convex(cell, rib_up, upper - half)
        if len(cell) >= 3 and polygon_area(cell) >= p.min_cell_area:
            cells.append(cell)
    return cells


def _channel(p: FingerParameters, location: str, surface: str, centre_z: float) -> Channel:
    depth = p.channel_depth
    half = p.sensing_length / 2.0
    y_sense = -p.width / 2.0 + p.side_wall + p.channel_radius
    y_port = p.width / 2.0
    if surface == 'inner':
        normal2 = np.array([-1.0, 0.0])
        direction2 = np.array([0.0, 1.0])
        point2 = np.array([0.0, centre_z])  # on the contact surface
    else:
        normal2 = outer_normal(p)
        direction2 = np.array([-normal2[1], normal2[0]])  # along the surface, toward the tip
        point2 = np.array([outer_surface_x(p, centre_z), centre_z])
    axis_mid2 = point2 - depth * normal2
    proximal2 = axis_mid2 - half * direction2
    distal2 = axis_mid2 + half * direction2

    def lift(q: np.ndarray, y: float) -> np.ndarray:
        return np.array([q[0], y, q[1]])

    corner = lift(proximal2, y_sense)
    distal = lift(distal2, y_sense)
    port = lift(proximal2, y_port)
    if p.distal_vent:
        vent = lift(distal2, -p.width / 2.0)
        path = np.array([vent, distal, corner, port])
    else:
        vent = None
        path = np.array([distal, corner, port])
    return Channel(
        name=f'{location}_{surface}', location=location, surface=surface, path=path,
        port=port, vent=vent,
        surface_normal=np.array([normal2[0], 0.0, normal2[1]]),
        sensing_direction=np.array([direction2[0], 0.0, direction2[1]]))


def make_design(parameters: FingerParameters | None = None) -> FingerDesign:
    """Validate ``parameters`` (default design if None) and derive the geometry.

    Raises
    ------
    ValueError
        With every reason the parameters are unusable.
    """
    p = parameters or FingerParameters()
    p.validate()
    profile = np.array([[0.0, -p.mount_height], [p.base_depth, -p.mount_height],
                        [p.base_depth, 0.0], [p.tip_depth, p.length], [0.0, p.length]])
    channels = []
    for location, fraction in zip(LOCATIONS, p.location_fractions):
        for surface in SURFACES:
            channels.append(_channel(p, location, surface, fraction * p.length))
    holes = [(-p.mount_hole_spacing / 2.0, -p.mount_height / 2.0),
             (p.mount_hole_spacing / 2.0, -p.mount_height / 2.0)]
    return FingerDesign(parameters=p, profile=profile, cells=cavity_cells(p),
                        channels=channels, mount_holes=holes)


def segment_distance(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> float:
    """Smallest distance between segments a0-a1 and b0-b1 in 3-D [mm]."""
    d1, d2, r = a1 - a0, b1 - b0, a0 - b0
    aa, ee, ff = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    if aa <= 1e-15 and ee <= 1e-15:
        return float(np.linalg.norm(r))
    if aa <= 1e-15:
        s, t = 0.0, min(max(ff / ee, 0.0), 1.0)
    else:
        cc = float(d1 @ r)
        if ee <= 1e-15:
            t, s = 0.0, min(max(-cc / aa, 0.0), 1.0)
        else:
            bb = float(d1 @ d2)
            denom = aa * ee - bb * bb
            s = min(max((bb * ff - cc * ee) / denom, 0.0), 1.0) if denom > 1e-15 else 0.0
            t = (bb * s + ff) / ee
            if t < 0.0:
                t, s = 0.0, min(max(-cc / aa, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((bb - cc) / aa, 0.0), 1.0)
    return float(np.linalg.norm((a0 + s * d1) - (b0 + t * d2)))


def polyline_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest distance between two polylines (shapes (k, 3) and (m, 3)) [mm]."""
    return min(segment_distance(a[i], a[i + 1], b[j], b[j + 1])
               for i in range(len(a) - 1) for j in range(len(b) - 1))
