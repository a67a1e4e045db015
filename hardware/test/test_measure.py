"""Known-answer tests of the mesh measuring tools the finger checks rely on."""
import math

import numpy as np
import pytest
from forte_finger.measure import (
    chain_loops,
    fit_circle,
    loop_length,
    points_to_mesh_distance,
    read_stl,
    sample_polyline,
    section_segments,
)


def cylinder_mesh(radius: float, height: float, sides: int) -> np.ndarray:
    """Closed prism with a regular ``sides``-gon of circumradius ``radius`` (axis z)."""
    angles = np.linspace(0.0, 2 * math.pi, sides, endpoint=False)
    ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
    triangles = []
    for i in range(sides):
        a0 = np.array([*ring[i], 0.0])
        a1 = np.array([*ring[(i + 1) % sides], 0.0])
        b0, b1 = a0 + [0, 0, height], a1 + [0, 0, height]
        triangles += [[a0, a1, b1], [a0, b1, b0]]
        triangles += [[np.zeros(3), a1, a0], [np.array([0, 0, height]), b0, b1]]
    return np.array(triangles, dtype=float)


def cube_mesh(size: float) -> np.ndarray:
    """Axis-aligned cube [0, size]^3 as 12 triangles."""
    corners = np.array([[x, y, z] for x in (0, size) for y in (0, size) for z in (0, size)],
                       dtype=float)
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return corners[np.array(faces)]


def test_section_of_a_prism_is_one_closed_polygon_with_the_right_circle():
    sides, radius = 64, 1.0
    triangles = cylinder_mesh(radius, 5.0, sides)
    segments = section_segments(triangles, np.array([0, 0, 2.5]), np.array([0, 0, 1.0]))
    loops = chain_loops(segments)
    assert len(loops) == 1
    circle = fit_circle(loops[0], np.array([0, 0, 1.0]))
    # the section points lie on the polygon's sides, between the circumradius (vertices)
    # and the apothem radius * cos(pi / sides)
    apothem = radius * math.cos(math.pi / sides)
    assert apothem - 1e-9 <= circle.radius <= radius + 1e-9
    assert np.linalg.norm(circle.centre - [0, 0, 2.5]) < 1e-6
    perimeter = 2 * sides * radius * math.sin(math.pi / sides)
    assert loop_length(loops[0]) == pytest.approx(perimeter, rel=1e-6)


def test_plane_missing_the_mesh_gives_no_loops():
    triangles = cylinder_mesh(1.0, 5.0, 16)
    segments = section_segments(triangles, np.array([0, 0, 7.0]), np.array([0, 0, 1.0]))
    assert len(segments) == 0
    assert chain_loops(segments) == []


def test_open_chain_is_refused():
    segments = np.array([[[0, 0, 0], [1, 0, 0]], [[1, 0, 0], [1, 1, 0]]], dtype=float)
    with pytest.raises(ValueError, match='not a set of closed loops'):
        chain_loops(segments)


def test_two_separate_squares_give_two_loops():
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    segments = []
    for shift in (0.0, 5.0):
        shifted = square + [shift, 0, 0]
        segments += [[shifted[i], shifted[(i + 1) % 4]] for i in range(4)]
    loops = chain_loops(np.array(segments))
    assert sorted(len(loop) for loop in loops) == [4, 4]
    assert sorted(loop_length(loop) for loop in loops) == pytest.approx([4.0, 4.0])


def test_point_to_mesh_distance_known_answers():
    triangles = cube_mesh(2.0)
    points = np.array([
        [1.0, 1.0, 1.0],     # centre: 1 to every face
        [1.0, 1.0, 5.0],     # above the top face
        [3.0, 3.0, 3.0],     # beyond a corner: sqrt(3)
        [1.0, -1.0, -1.0],   # beyond an edge: sqrt(2)
        [0.5, 1.0, 1.0],     # inside, near the x=0 face
    ])
    expected = [1.0, 3.0, math.sqrt(3.0), math.sqrt(2.0), 0.5]
    assert points_to_mesh_distance(points, triangles) == pytest.approx(expected, abs=1e-12)


def test_sample_polyline_keeps_ends_and_spacing():
    path = np.array([[0, 0, 0], [3, 0, 0], [3, 4, 0]], dtype=float)
    samples = sample_polyline(path, 0.5)
    assert np.allclose(samples[0], path[0]) and np.allclose(samples[-1], path[-1])
    steps = np.linalg.norm(np.diff(samples, axis=0), axis=1)
    assert steps.max() <= 0.5 + 1e-12
    assert len(samples) == 6 + 8 + 1


def test_read_stl_rejects_truncated_file(tmp_path):
    path = tmp_path / 'bad.stl'
    path.write_bytes(b'x' * 80 + np.uint32(3).tobytes() + b'\0' * 50)
    with pytest.raises(ValueError, match='does not match'):
        read_stl(path)
