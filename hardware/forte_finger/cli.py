"""Command line: generate a finger (STEP, STL, port table, measured report).

Usage (from the repository root, environment sourced)::

    python hardware/generate_finger.py                      # default design -> hardware/out
    python hardware/generate_finger.py --set width=20 --set rib_count=5 --out /tmp/f
    python hardware/generate_finger.py --visual-mesh forte_description/meshes/forte_finger.stl
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from forte_finger import cad
from forte_finger.design import FingerDesign, FingerParameters, make_design
from forte_finger.drawing import draw
from forte_finger.report import measure_finger

DEFAULT_OUT = Path(__file__).resolve().parents[1] / 'out'
PRINT_DEFLECTION = 0.01  # [mm] STL for printing and for the measurements
VISUAL_DEFLECTION = 0.15  # [mm] light STL for RViz


def parse_overrides(items: list[str]) -> dict:
    """``name=value`` strings -> typed keyword arguments of FingerParameters."""
    fields = {f.name: f for f in dataclasses.fields(FingerParameters)}
    defaults = FingerParameters()
    overrides = {}
    for item in items:
        name, sep, text = item.partition('=')
        if not sep or name not in fields:
            raise ValueError(f'--set {item!r}: expected name=value with name one of '
                             f'{sorted(fields)}')
        default = getattr(defaults, name)
        try:
            if isinstance(default, bool):
                if text.lower() not in ('true', 'false', '1', '0'):
                    raise ValueError(text)
                value = text.lower() in ('true', '1')
            elif isinstance(default, int):
                value = int(text)
            elif isinstance(default, tuple):
                value = tuple(float(v) for v in text.split(','))
            else:
                value = float(text)
        except ValueError:
            raise ValueError(f'--set {item!r}: cannot read {text!r} as '
                             f'{type(default).__name__}') from None
        overrides[name] = value
    return overrides


def _jsonable(value):
    if isinstance(value, dict):
        return {key: _jsonable(item) for key, item in value.items()}
    if dataclasses.is_dataclass(value):
        return _jsonable(dataclasses.asdict(value))
    if isinstance(value, (list, tuple)):
        return [_jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float | np.floating):
        value = float(value)
        return round(value, 6) if math.isfinite(value) else None
    return value


@contextlib.contextmanager
def _replaced_atomically(path: Path):
    """Yield a temporary path next to ``path``; on success move it onto ``path``.

    Readers (another test run, a slicer) never see a half-written file.
    """
    temporary = path.with_name(f'.{path.name}.{os.getpid()}.tmp')
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def generate(design: FingerDesign, out: Path, stem: str = 'forte_finger') -> dict:
    """Build the finger; write ``<stem>.step``, ``.stl``, ``_ports.csv``, ``_openings.png``
    (labelled port and vent faces) and ``_report.json`` (each file replaced atomically).

    Returns
    -------
    dict
        The report (also written as JSON): parameters, B-rep and mesh facts, measured
        channel geometry, port table, file paths, timings [s].
    """
    out.mkdir(parents=True, exist_ok=True)
    paths = {kind: out / f'{stem}{suffix}' for kind, suffix in (
        ('step', '.step'), ('stl', '.stl'), ('ports', '_ports.csv'),
        ('drawing', '_openings.png'), ('report', '_report.json'))}
    started = time.perf_counter()
    shape = cad.build_finger(design)
    body = cad.build_finger(design, with_channels=False)
    built = time.perf_counter()
    with _replaced_atomically(paths['step']) as temporary:
        cad.export_step(shape, temporary)
    with _replaced_atomically(paths['stl']) as temporary:
        triangles = cad.export_stl(shape, temporary, PRINT_DEFLECTION)
    body_triangles = cad.triangulate(body, PRINT_DEFLECTION)
    exported = time.perf_counter()
    measured = measure_finger(design, triangles, body_triangles)
    finished = time.perf_counter()
    rows = design.port_table()
    with _replaced_atomically(paths['ports']) as temporary:
        with open(temporary, 'w', newline='') as stream:
            writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    with _replaced_atomically(paths['drawing']) as temporary:
        draw(design, temporary)
    report = {
        'parameters': design.parameters.as_dict(),
        'brep': {'valid': cad.is_valid(shape), 'solids': cad.solid_count(shape),
                 'volume_mm3': cad.volume(shape), 'body_volume_mm3': cad.volume(body)},
        'mesh': {'triangles': len(triangles), 'linear_deflection_mm': PRINT_DEFLECTION},
        'cavity_cells': len(design.cells),
        'measured': measured,
        'ports': rows,
        'files': {kind: str(path) for kind, path in paths.items()},
        'seconds': {'build': built - started, 'export': exported - built,
                    'measure': finished - exported},
    }
    report = _jsonable(report)
    with _replaced_atomically(paths['report']) as temporary:
        with open(temporary, 'w') as stream:
            json.dump(report, stream, indent=1)
    return report


def write_visual_mesh(design: FingerDesign, path: Path) -> int:
    """Write a light STL of the finger for RViz; returns the triangle count."""
    triangles = cad.triangulate(cad.build_finger(design), VISUAL_DEFLECTION, 0.5)
    path.parent.mkdir(parents=True, exist_ok=True)
    cad.write_stl(triangles, path, header='FORTE finger visual mesh, mm')
    return len(triangles)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', type=Path, default=DEFAULT_OUT,
                        help=f'output folder (default {DEFAULT_OUT})')
    parser.add_argument('--set', action='append', default=[], metavar='NAME=VALUE',
                        help='override a FingerParameters field (repeatable)')
    parser.add_argument('--visual-mesh', type=Path, default=None,
                        help='also write a light STL for the URDF to this path')
    args = parser.parse_args(argv)
    try:
        design = make_design(FingerParameters(**parse_overrides(args.set)))
    except ValueError as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    report = generate(design, args.out)
    measured = report['measured']
    print(f"finger: {report['files']['stl']} ({report['mesh']['triangles']} triangles), "
          f"{report['files']['step']}")
    print(f"volume {report['brep']['volume_mm3']:.0f} mm^3, {report['cavity_cells']} cavity "
          f"cells, B-rep valid: {report['brep']['valid']}")
    for name, section in measured['sensing'].items():
        print(f"  {name:13s} diameter {section['diameter']:.3f} mm, wall to surface "
              f"{section['wall_adjacent']:.3f} mm, inner wall {section['wall_inward']:.3f} mm"
              f", clearance {measured['clearance'][name]:.3f} mm")
    print(f"  ports found {measured['port_openings']}, vents found "
          f"{measured['vent_openings']}, smallest gap between channels "
          f"{measured['channel_gaps']:.2f} mm")
    if args.visual_mesh is not None:
        count = write_visual_mesh(design, args.visual_mesh)
        print(f'visual mesh: {args.visual_mesh} ({count} triangles)')
    return 0
