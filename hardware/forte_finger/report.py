"""Measure a generated finger mesh against its design (diameters, walls, ports, clearances).

:func:`measure_finger` returns plain numbers; the tests assert them against the parameters
with stated tolerances and ``python -m forte_finger`` writes them to the JSON report.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from forte_finger.design import Channel, FingerDesign, polyline_distance
from forte_finger.measure import (
    Circle,
    chain_loops,
    fit_circle,
    loop_edges,
    loop_length,
    point_to_edges_distance,
    points_to_mesh_distance,
    sample_polyline,
    section_segments,
)

PLANE_NUDGE = 3.1e-6  # [mm] keeps section planes off exact vertex coordinates
FACE_INSET = 0.01  # [mm] depth below a side face where port/vent openings are looked for


@dataclass(frozen=True)
class CrossSection:
    """A channel seen in one planar section of the mesh.

    Attributes
    ----------
    diameter : float
        Fitted circle diameter [mm].
    centre_offset : float
        Distance between the fitted centre and the design's channel axis [mm].
    wall_adjacent : float
        Smallest distance from the channel to any other boundary in the section [mm].
    wall_direction : float
        Cosine between (nearest boundary point - centre) and the surface's outward normal;
        1 means the thinnest wall is the one to the adjacent inner/outer surface.
    wall_inward : float
        Smallest distance to boundaries on the far side of the channel (toward the cavity
        or the other beam) [mm].
    roundness : float
        Largest deviation of the section loop from the fitted circle [mm].
    """

    diameter: float
    centre_offset: float
    wall_adjacent: float
    wall_direction: float
    wall_inward: float
    roundness: float


def section_loops(triangles: np.ndarray, origin: np.ndarray, normal: np.ndarray
                  ) -> list[np.ndarray]:
    """Closed loops of the mesh's section by a plane (nudged off vertices)."""
    normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    return chain_loops(section_segments(triangles, origin + PLANE_NUDGE * normal, normal))


def small_circles(loops: list[np.ndarray], normal: np.ndarray, max_perimeter: float,
                  max_residual: float) -> list[Circle]:
    """Loops shorter than ``max_perimeter`` that are circles within ``max_residual``."""
    circles = []
    for loop in loops:
        if len(loop) >= 8 and loop_length(loop) < max_perimeter:
            circle = fit_circle(loop, normal)
            if circle.max_residual < max_residual:
                circles.append(circle)
    return circles


def measure_cross_section(loops: list[np.ndarray], normal: np.ndarray, expected: np.ndarray,
                          surface_normal: np.ndarray, max_perimeter: float) -> CrossSection:
    """Find the channel loop nearest to ``expected`` and measure it and its walls."""
    circles = small_circles(loops, normal, max_perimeter, max_residual=0.1)
    if not circles:
        raise ValueError(f'no channel found in the section near {expected}')
    circle = min(circles, key=lambda c: np.linalg.norm(c.centre - expected))
    starts, ends = loop_edges([loop for loop in loops if loop is not circle.loop])
    wall, nearest = point_to_edges_distance(circle.loop, starts, ends)
    direction = (nearest - circle.centre) / np.linalg.norm(nearest - circle.centre)
    # boundary on the far side of the channel: edges entirely beyond the channel's
    # centre plane parallel to the adjacent surface
    beyond = (np.maximum((starts - circle.centre) @ surface_normal,
                         (ends - circle.centre) @ surface_normal) < 0.0)
    wall_inward = point_to_edges_distance(circle.loop, starts[beyond], ends[beyond])[0]
    return CrossSection(
        diameter=2.0 * circle.radius,
        centre_offset=float(np.linalg.norm(circle.centre - expected)),
        wall_adjacent=wall,
        wall_direction=float(direction @ surface_normal),
        wall_inward=float(wall_inward),
        roundness=circle.max_residual)


@dataclass(frozen=True)
class Opening:
    """A circular opening found just inside a side face.

    Attributes
    ----------
    centre : ndarray, shape (3,)
    diameter : float
    """

    centre: np.ndarray
    diameter: float


def openings_on_face(triangles: np.ndarray, design: FingerDesign, side: int
                     ) -> list[Opening]:
    """Circular holes in the section ``FACE_INSET`` inside the face ``y = side * width/2``."""
    p = design.parameters
    normal = np.array([0.0, 1.0, 0.0])
    origin = np.array([0.0, side * (p.width / 2.0 - FACE_INSET), 0.0])
    loops = section_loops(triangles, origin, normal)
    limit = 2.0 * np.pi * p.channel_radius * 1.5
    return [Opening(c.centre, 2.0 * c.radius)
            for c in small_circles(loops, normal, limit, max_residual=0.1)]


def measure_finger(design: FingerDesign, triangles: np.ndarray,
                   body_triangles: np.ndarray | None = None) -> dict:
    """Measure the finger mesh (mm) against ``design``.

    Parameters
    ----------
    design : FingerDesign
    triangles : ndarray, shape (n, 3, 3)
        The printable finger's mesh [mm].
    body_triangles : ndarray, shape (m, 3, 3), optional
        Mesh of the same finger without channels; when given, the clearance from every
        channel to the finger's other surfaces is measured along its whole centre line.

    Returns
    -------
    dict
        ``sensing`` and ``port_leg``: {channel name: CrossSection}; ``ports`` and ``vents``:
        {channel name: (centre offset [mm], diameter [mm])} of the opening nearest to the
        stated position; ``port_openings``/``vent_openings``: number of circular openings
        found on each face; ``channel_gaps``: smallest surface-to-surface distance between
        two channels [mm]; ``clearance``: {channel name: smallest clearance to the body
        surface along the centre line, openings excluded [mm]}.
    """
    p = design.parameters
    perimeter_limit = 2.0 * np.pi * p.channel_radius * 1.5
    result: dict = {'sensing': {}, 'port_leg': {}, 'ports': {}, 'vents': {}}
    for channel in design.channels:
        origin = channel.sensing_midpoint
        loops = section_loops(triangles, origin, channel.sensing_direction)
        result['sensing'][channel.name] = measure_cross_section(
            loops, channel.sensing_direction, origin, channel.surface_normal,
            perimeter_limit)
    y_normal = np.array([0.0, 1.0, 0.0])
    mid_loops = section_loops(triangles, np.zeros(3), y_normal)
    for channel in design.channels:
        expected = np.array([channel.corner[0], 0.0, channel.corner[2]])
        result['port_leg'][channel.name] = measure_cross_section(
            mid_loops, y_normal, expected, channel.surface_normal, perimeter_limit)
    port_openings = openings_on_face(triangles, design, +1)
    vent_openings = openings_on_face(triangles, design, -1)
    result['port_openings'] = len(port_openings)
    result['vent_openings'] = len(vent_openings)
    for channel in design.channels:
        result['ports'][channel.name] = _nearest_opening(port_openings, channel.port)
        if channel.vent is not None:
            result['vents'][channel.name] = _nearest_opening(vent_openings, channel.vent)
    result['channel_gaps'] = min(
        polyline_distance(a.path, b.path) - 2.0 * p.channel_radius
        for a, b in itertools.combinations(design.channels, 2))
    if body_triangles is not None:
        result['clearance'] = {
            channel.name: channel_clearance(channel, design, body_triangles)
            for channel in design.channels}
    return result


def _nearest_opening(openings: list[Opening], stated: np.ndarray) -> tuple[float, float]:
    if not openings:
        return (np.inf, 0.0)
    # compare in the face plane (x, z); the opening is FACE_INSET inside the face
    best = min(openings, key=lambda o: np.hypot(*(o.centre - stated)[[0, 2]]))
    return (float(np.hypot(*(best.centre - stated)[[0, 2]])), best.diameter)


def channel_clearance(channel: Channel, design: FingerDesign, body_triangles: np.ndarray,
                      step: float = 0.5) -> float:
    """Smallest distance from the channel wall to the body surface [mm], openings excluded.

    Samples the centre line every ``step`` mm, drops samples closer to an opening than
    ``channel_radius + channel_wall + 0.5`` mm (there the channel meets the face by
    design), and returns min(distance to body mesh) - channel_radius.
    """
    p = design.parameters
    samples = sample_polyline(channel.path, step)
    keep_out = p.channel_radius + p.channel_wall + 0.5
    keep = np.abs(samples[:, 1] - p.width / 2.0) > keep_out
    if channel.vent is not None:
        keep &= np.abs(samples[:, 1] + p.width / 2.0) > keep_out
    distances = points_to_mesh_distance(samples[keep], body_triangles)
    return float(distances.min() - p.channel_radius)
