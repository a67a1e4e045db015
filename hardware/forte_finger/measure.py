"""Measurements on a triangle mesh: planar sections, closed loops, circle fits, distances.

Pure numpy; used by the tests (hardware/test) and by the generation report to measure
the *generated* geometry (the STL a lab prints), independently of how it was built.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


def read_stl(path: Path) -> np.ndarray:
    """Triangles of a binary STL file, shape (n, 3, 3) [file units]."""
    data = Path(path).read_bytes()
    if len(data) < 84:
        raise ValueError(f'{path}: too short for a binary STL')
    count = int(np.frombuffer(data, dtype='<u4', count=1, offset=80)[0])
    if len(data) != 84 + 50 * count:
        raise ValueError(f'{path}: {count} facets announced, size {len(data)} does not match')
    record = np.dtype([('normal', '<f4', 3), ('corners', '<f4', (3, 3)), ('attr', '<u2')])
    facets = np.frombuffer(data, dtype=record, count=count, offset=84)
    return facets['corners'].astype(float)


def plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane with unit ``normal`` (right-handed with it)."""
    normal = np.asarray(normal, dtype=float)
    normal = normal / np.linalg.norm(normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def section_segments(triangles: np.ndarray, origin: np.ndarray,
                     normal: np.ndarray) -> np.ndarray:
    """Segments where the plane (``origin``, ``normal``) cuts the triangles, shape (m, 2, 3).

    Choose planes that do not pass exactly through mesh vertices (offset them by a few
    micrometres); a vertex exactly on the plane is treated as lying above it.
    """
    normal = np.asarray(normal, dtype=float)
    normal = normal / np.linalg.norm(normal)
    distance = (triangles - np.asarray(origin, dtype=float)) @ normal  # (n, 3)
    above = distance >= 0.0
    count_above = above.sum(axis=1)
    crossing = (count_above == 1) | (count_above == 2)
    tri = triangles[crossing]
    dist = distance[crossing]
    abv = above[crossing]
    # the odd vertex is the one on its own side of the plane
    lone_above = abv.sum(axis=1) == 1
    lone = np.where(lone_above, np.argmax(abv, axis=1), np.argmin(abv, axis=1))
    rows = np.arange(len(tri))
    others = np.stack([(lone + 1) % 3, (lone + 2) % 3], axis=1)
    p0 = tri[rows, lone]
    d0 = dist[rows, lone]
    points = []
    for k in range(2):
        q = tri[rows, others[:, k]]
        dq = dist[rows, others[:, k]]
        t = d0 / (d0 - dq)
        points.append(p0 + t[:, None] * (q - p0))
    return np.stack(points, axis=1)


def chain_loops(segments: np.ndarray, tolerance: float = 1e-6) -> list[np.ndarray]:
    """Join segments (shape (m, 2, 3)) into closed loops; raise ValueError on open chains.

    Returns
    -------
    list of ndarray, each shape (k, 3)
        Loop vertices in order (first vertex not repeated).
    """
    if len(segments) == 0:
        return []
    keys = np.round(segments.reshape(-1, 3) / tolerance).astype(np.int64)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 2)
    points = segments.reshape(-1, 3)
    neighbours: dict[int, list[int]] = {}
    position: dict[int, np.ndarray] = {}
    for index, (a, b) in enumerate(ids):
        if a == b:
            continue
        neighbours.setdefault(int(a), []).append(int(b))
        neighbours.setdefault(int(b), []).append(int(a))
        position[int(a)] = points[2 * index]
        position[int(b)] = points[2 * index + 1]
    bad = [node for node, near in neighbours.items() if len(near) != 2]
    if bad:
        raise ValueError(f'section is not a set of closed loops ({len(bad)} open/branch '
                         f'vertices, first at {position[bad[0]]})')
    loops = []
    unvisited = set(neighbours)
    while unvisited:
        start = unvisited.pop()
        loop = [start]
        previous, current = start, neighbours[start][0]
        while current != start:
            loop.append(current)
            unvisited.discard(current)
            a, b = neighbours[current]
            previous, current = current, (b if a == previous else a)
        loops.append(np.array([position[node] for node in loop]))
    return loops


@dataclass(frozen=True)
class Circle:
    """Least-squares circle of a planar loop (coordinates in 3-D, mm).

    Attributes
    ----------
    centre : ndarray, shape (3,)
    radius : float
    max_residual : float
        Largest |distance to centre - radius| over the loop vertices [mm].
    loop : ndarray, shape (k, 3)
    """

    centre: np.ndarray
    radius: float
    max_residual: float
    loop: np.ndarray


def fit_circle(loop: np.ndarray, normal: np.ndarray) -> Circle:
    """Algebraic (Kasa) circle fit of a loop lying in a plane with ``normal``."""
    u, v = plane_basis(normal)
    origin = loop.mean(axis=0)
    a = (loop - origin) @ u
    b = (loop - origin) @ v
    design = np.column_stack([a, b, np.ones_like(a)])
    rhs = a * a + b * b
    (ca2, cb2, c), *_ = np.linalg.lstsq(design, rhs, rcond=None)
    ca, cb = ca2 / 2.0, cb2 / 2.0
    radius = float(np.sqrt(c + ca * ca + cb * cb))
    residual = np.abs(np.hypot(a - ca, b - cb) - radius)
    return Circle(origin + ca * u + cb * v, radius, float(residual.max()), loop)


def loop_length(loop: np.ndarray) -> float:
    """Perimeter of a closed loop [mm]."""
    return float(np.sum(np.linalg.norm(np.roll(loop, -1, axis=0) - loop, axis=1)))


def loop_edges(loops: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Edge start and end points of closed loops, each shape (e, 3)."""
    if not loops:
        return np.empty((0, 3)), np.empty((0, 3))
    starts = np.concatenate(list(loops))
    ends = np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
    return starts, ends


def point_to_edges_distance(points: np.ndarray, starts: np.ndarray, ends: np.ndarray
                            ) -> tuple[float, np.ndarray]:
    """Smallest distance from any of ``points`` (k, 3) to the segments starts-ends (e, 3).

    Returns
    -------
    distance : float
        [mm] (inf if there are no segments)
    nearest : ndarray, shape (3,)
        The closest point on the segments (NaN if none).
    """
    if len(starts) == 0:
        return np.inf, np.full(3, np.nan)
    edge = ends - starts
    length2 = np.maximum(np.einsum('ij,ij->i', edge, edge), 1e-30)
    best, best_point = np.inf, np.full(3, np.nan)
    for point in points:
        t = np.clip(np.einsum('ij,ij->i', point - starts, edge) / length2, 0.0, 1.0)
        closest = starts + t[:, None] * edge
        distance = np.linalg.norm(closest - point, axis=1)
        index = int(np.argmin(distance))
        if distance[index] < best:
            best, best_point = float(distance[index]), closest[index]
    return best, best_point


def points_to_mesh_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance from each point (k, 3) to the nearest triangle (n, 3, 3) [mm], shape (k,).

    Exact point-triangle distance (closest point by Voronoi regions), vectorised over the
    triangles.
    """
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, ac = b - a, c - a
    result = np.empty(len(points))
    for k, p in enumerate(points):
        ap = p - a
        d1 = np.einsum('ij,ij->i', ab, ap)
        d2 = np.einsum('ij,ij->i', ac, ap)
        bp = p - b
        d3 = np.einsum('ij,ij->i', ab, bp)
        d4 = np.einsum('ij,ij->i', ac, bp)
        cp = p - c
        d5 = np.einsum('ij,ij->i', ab, cp)
        d6 = np.einsum('ij,ij->i', ac, cp)
        va = d3 * d6 - d5 * d4
        vb = d5 * d2 - d1 * d6
        vc = d1 * d4 - d3 * d2
        denom = va + vb + vc
        denom = np.where(np.abs(denom) > 1e-30, denom, 1e-30)
        v = vb / denom
        w = vc / denom
        closest = a + ab * v[:, None] + ac * w[:, None]  # interior by default
        # vertex regions
        region_a = (d1 <= 0) & (d2 <= 0)
        region_b = (d3 >= 0) & (d4 <= d3)
        region_c = (d6 >= 0) & (d5 <= d6)
        # edge regions
        region_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        region_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        region_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
        with np.errstate(divide='ignore', invalid='ignore'):
            t_ab = np.where(region_ab, d1 / (d1 - d3), 0.0)
            t_ac = np.where(region_ac, d2 / (d2 - d6), 0.0)
            t_bc = np.where(region_bc, (d4 - d3) / ((d4 - d3) + (d5 - d6)), 0.0)
        closest = np.where(region_bc[:, None], b + t_bc[:, None] * (c - b), closest)
        closest = np.where(region_ac[:, None], a + t_ac[:, None] * ac, closest)
        closest = np.where(region_ab[:, None], a + t_ab[:, None] * ab, closest)
        closest = np.where(region_c[:, None], c, closest)
        closest = np.where(region_b[:, None], b, closest)
        closest = np.where(region_a[:, None], a, closest)
        result[k] = float(np.min(np.linalg.norm(closest - p, axis=1)))
    return result


def sample_polyline(path: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` mm along a polyline (k, 3), ends included."""
    samples = []
    for a, b in zip(path[:-1], path[1:]):
        count = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        t = np.linspace(0.0, 1.0, count + 1)[:-1]
        samples.append(a + t[:, None] * (b - a))
    samples.append(path[-1:])
    return np.concatenate(samples)
