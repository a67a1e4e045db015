"""The default finger is generated here (STEP + STL) and measured on its mesh.

Tolerances: the STL is tessellated with a 0.01 mm chordal deflection, so a channel's
section polygon lies between its radius and radius - 0.01 mm; every diameter, wall and
position check below uses 0.02 mm (DIMENSION_TOLERANCE).
"""
import csv
import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pytest
import trimesh
from forte_finger import cad
from forte_finger.cli import generate, main, parse_overrides
from forte_finger.design import (
    LOCATIONS,
    SURFACES,
    FingerParameters,
    make_design,
    polyline_distance,
)
from forte_finger.measure import read_stl
from forte_finger.report import measure_finger
from OCP.STEPControl import STEPControl_Reader

DIMENSION_TOLERANCE = 0.02  # [mm]


@pytest.fixture(scope='module')
def default_finger():
    """Generate the default finger into hardware/out/ (the lab's copy; files are replaced
    atomically): (design, report, triangles read back from the STL, folder)."""
    out = Path(__file__).resolve().parents[1] / 'out'
    design = make_design()
    report = generate(design, out)
    triangles = read_stl(out / 'forte_finger.stl')
    return design, report, triangles, out


def expected_genus(design) -> int:
    """Through holes of the design: cavity cells, 2 mount holes, vented channels."""
    vented = sum(channel.vent is not None for channel in design.channels)
    return len(design.cells) + len(design.mount_holes) + vented


def test_default_design_matches_the_paper():
    p = FingerParameters()
    assert p.channel_diameter == 2.0
    assert p.channel_wall == 1.0
    design = make_design()
    names = [channel.name for channel in design.channels]
    assert names == [f'{loc}_{side}' for loc in LOCATIONS for side in SURFACES]


def test_files_written_and_step_reads_back_as_one_solid(default_finger):
    design, report, _, out = default_finger
    assert report['brep']['valid'] is True
    assert report['brep']['solids'] == 1
    reader = STEPControl_Reader()
    assert reader.ReadFile(str(out / 'forte_finger.step')) == 1  # IFSelect_RetDone
    reader.TransferRoots()
    shape = reader.OneShape()
    assert cad.solid_count(shape) == 1
    assert cad.volume(shape) == pytest.approx(report['brep']['volume_mm3'], rel=1e-6)
    # the channels remove their own volume: body - finger = sum of channel volumes
    removed = report['brep']['body_volume_mm3'] - report['brep']['volume_mm3']
    radius = design.parameters.channel_radius
    inside = 0.0
    for channel in design.channels:
        # centre-line length inside the finger; a closed end adds a hemisphere
        inside += channel.centreline_length * np.pi * radius ** 2
    assert removed == pytest.approx(inside, rel=0.02)


def test_mesh_is_watertight_single_body_with_expected_topology(default_finger):
    design, report, triangles, out = default_finger
    mesh = trimesh.load(out / 'forte_finger.stl')
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.body_count == 1
    assert mesh.volume == pytest.approx(report['brep']['volume_mm3'], rel=1e-3)
    # Euler characteristic 2 - 2 * genus: any channel touching another channel, a cavity
    # or the surface away from its port/vent would add a handle
    assert mesh.euler_number == 2 - 2 * expected_genus(design)
    assert len(triangles) == report['mesh']['triangles']


def test_channel_diameter_measured_in_sections(default_finger):
    design, report, _, _ = default_finger
    diameter = design.parameters.channel_diameter
    for kind in ('sensing', 'port_leg'):
        assert set(report['measured'][kind]) == {c.name for c in design.channels}
        for name, section in report['measured'][kind].items():
            assert section['diameter'] == pytest.approx(diameter, abs=DIMENSION_TOLERANCE), \
                (kind, name)
            assert section['roundness'] < DIMENSION_TOLERANCE, (kind, name)
            assert section['centre_offset'] < DIMENSION_TOLERANCE, (kind, name)


def test_wall_to_adjacent_surface_measured_in_sections(default_finger):
    design, report, _, _ = default_finger
    p = design.parameters
    for kind in ('sensing', 'port_leg'):
        for name, section in report['measured'][kind].items():
            assert section['wall_adjacent'] == pytest.approx(p.channel_wall,
                                                             abs=DIMENSION_TOLERANCE), name
            # the thinnest wall is the one toward the channel's own (inner/outer) surface
            assert section['wall_direction'] > 0.99, (kind, name)
            assert section['wall_inward'] >= p.min_internal_wall - DIMENSION_TOLERANCE


def test_channels_clear_of_each_other_and_of_the_surface(default_finger):
    design, report, _, _ = default_finger
    p = design.parameters
    measured = report['measured']
    assert measured['channel_gaps'] >= p.min_internal_wall
    for a, b in itertools.combinations(design.channels, 2):
        gap = polyline_distance(a.path, b.path) - p.channel_diameter
        assert gap >= p.min_internal_wall, (a.name, b.name, gap)
    # along each whole centre line (openings excluded) the nearest body surface is the
    # designed wall away, never closer
    for name, clearance in measured['clearance'].items():
        assert clearance == pytest.approx(p.channel_wall, abs=DIMENSION_TOLERANCE), name


def test_ports_and_vents_exit_where_stated(default_finger):
    design, report, _, out = default_finger
    p = design.parameters
    measured = report['measured']
    assert measured['port_openings'] == 6
    assert measured['vent_openings'] == 6
    for channel in design.channels:
        assert channel.port[1] == pytest.approx(p.width / 2.0)
        assert channel.vent[1] == pytest.approx(-p.width / 2.0)
        for table in ('ports', 'vents'):
            offset, diameter = measured[table][channel.name]
            assert offset < DIMENSION_TOLERANCE, (table, channel.name)
            assert diameter == pytest.approx(p.channel_diameter, abs=DIMENSION_TOLERANCE)
    assert (out / 'forte_finger_openings.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    with open(out / 'forte_finger_ports.csv') as stream:
        rows = list(csv.DictReader(stream))
    assert [row['channel'] for row in rows] == [c.name for c in design.channels]
    for row, channel in zip(rows, design.channels):
        assert float(row['port_x']) == pytest.approx(channel.port[0], abs=1e-3)
        assert float(row['port_z']) == pytest.approx(channel.port[2], abs=1e-3)


def test_inner_channels_lie_under_the_contact_surface(default_finger):
    design, _, _, _ = default_finger
    p = design.parameters
    for channel in design.channels:
        if channel.surface == 'inner':
            assert np.allclose(channel.path[:, 0], p.channel_depth)
        else:
            assert np.all(channel.path[:, 0] > p.base_depth / 4)
    # distal above middle above root
    heights = [design.channel(f'{loc}_inner').sensing_midpoint[2] for loc in LOCATIONS]
    assert heights[0] > heights[1] > heights[2]


def test_a_variant_design_measures_as_its_parameters():
    """Not tuned to the defaults: other diameter, wall, ribs, width; closed distal ends."""
    parameters = FingerParameters(channel_diameter=1.6, channel_wall=1.2, rib_count=4,
                                  rib_angle=-5.0, width=20.0, distal_vent=False,
                                  inner_wall=5.0, outer_wall=5.0)
    design = make_design(parameters)
    triangles = cad.triangulate(cad.build_finger(design), 0.01)
    body = cad.triangulate(cad.build_finger(design, with_channels=False), 0.01)
    measured = measure_finger(design, triangles, body)
    for name, section in measured['sensing'].items():
        assert section.diameter == pytest.approx(1.6, abs=DIMENSION_TOLERANCE), name
        assert section.wall_adjacent == pytest.approx(1.2, abs=DIMENSION_TOLERANCE), name
    for name, clearance in measured['clearance'].items():
        assert clearance == pytest.approx(1.2, abs=DIMENSION_TOLERANCE), name
    assert measured['port_openings'] == 6
    assert measured['vent_openings'] == 0
    mesh = trimesh.Trimesh(vertices=triangles.reshape(-1, 3),
                           faces=np.arange(3 * len(triangles)).reshape(-1, 3))
    mesh.merge_vertices()
    assert mesh.is_watertight
    assert mesh.euler_number == 2 - 2 * expected_genus(design)


def test_measurement_catches_a_channel_too_close_to_the_surface():
    """Negative control: shift one channel 0.5 mm toward the contact surface."""
    design = make_design()
    shifted = dataclasses.replace(
        design.channels[2], path=design.channels[2].path + [-0.5, 0.0, 0.0],
        port=design.channels[2].port + [-0.5, 0.0, 0.0])
    channels = list(design.channels)
    channels[2] = shifted
    moved = dataclasses.replace(design, channels=channels)
    triangles = cad.triangulate(cad.build_finger(moved), 0.01)
    section = measure_finger(design, triangles)['sensing'][shifted.name]
    assert section.wall_adjacent == pytest.approx(0.5, abs=DIMENSION_TOLERANCE)
    assert section.centre_offset == pytest.approx(0.5, abs=DIMENSION_TOLERANCE)


@pytest.mark.parametrize('overrides, reason', [
    ({'inner_wall': 3.0}, 'inner_wall'),
    ({'channel_diameter': -2.0}, 'channel_diameter must be'),
    ({'location_fractions': (0.6, 0.5, 0.2)}, 'overlap'),
    ({'tip_depth': 40.0}, 'tip_depth'),
    ({'width': 8.0}, 'width'),
    ({'channel_wall': float('nan')}, 'channel_wall must be'),
])
def test_unusable_parameters_are_refused_with_a_reason(overrides, reason):
    with pytest.raises(ValueError, match=reason):
        make_design(FingerParameters(**overrides))


def test_cli_overrides_and_errors(tmp_path, capsys):
    assert parse_overrides(['rib_count=5', 'width=20', 'distal_vent=false',
                            'location_fractions=0.8,0.5,0.2']) == {
        'rib_count': 5, 'width': 20.0, 'distal_vent': False,
        'location_fractions': (0.8, 0.5, 0.2)}
    with pytest.raises(ValueError, match='expected name=value'):
        parse_overrides(['no_such_field=1'])
    with pytest.raises(ValueError, match='cannot read'):
        parse_overrides(['rib_count=many'])
    assert main(['--out', str(tmp_path), '--set', 'inner_wall=2']) == 2
    assert 'inner_wall' in capsys.readouterr().err
    assert not (tmp_path / 'forte_finger.stl').exists()


@pytest.mark.parametrize('overrides', [
    {'rib_count': 0},
    {'rib_count': 10, 'rib_angle': -20.0},
    {'length': 120.0, 'base_depth': 35.0, 'width': 26.0, 'location_fractions': (0.8, 0.5, 0.2)},
])
def test_other_shapes_stay_valid_watertight_and_open_only_at_ports_and_vents(overrides):
    design = make_design(FingerParameters(**overrides))
    shape = cad.build_finger(design)
    assert cad.is_valid(shape) and cad.solid_count(shape) == 1
    triangles = cad.triangulate(shape, 0.01)
    mesh = trimesh.Trimesh(vertices=triangles.reshape(-1, 3),
                           faces=np.arange(3 * len(triangles)).reshape(-1, 3))
    mesh.merge_vertices()
    assert mesh.is_watertight
    assert mesh.euler_number == 2 - 2 * expected_genus(design)
    measured = measure_finger(design, triangles)
    assert (measured['port_openings'], measured['vent_openings']) == (6, 6)
    for name, section in measured['sensing'].items():
        assert section.diameter == pytest.approx(2.0, abs=DIMENSION_TOLERANCE), name
        assert section.wall_adjacent == pytest.approx(1.0, abs=DIMENSION_TOLERANCE), name
