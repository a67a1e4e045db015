"""Solid model of the finger with the OpenCascade kernel (OCP), STEP and STL export.

The body is the fin-ray profile extruded along ``y``, minus the cavity cells (through
holes along ``y``), the two mounting holes and the six channels. A channel is the union of
cylinders along its centre-line segments and spheres at its corners (and at a closed
distal end), i.e. exactly the set of points within ``channel_radius`` of the centre line;
segments that open on a side face run 1 mm past the face so the cut is clean.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepGProp import BRepGProp
from OCP.BRepMesh import BRepMesh_IncrementalMesh
from OCP.BRepPrimAPI import (
    BRepPrimAPI_MakeCylinder,
    BRepPrimAPI_MakePrism,
    BRepPrimAPI_MakeSphere,
)
from OCP.collections import List_TopoDS_Shape as TopTools_ListOfShape
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.IFSelect import IFSelect_RetDone
from OCP.Interface import Interface_Static
from OCP.Message import Message, Message_Gravity
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED, TopAbs_SOLID
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Shape

from forte_finger.design import Channel, FingerDesign

OVERSHOOT = 1.0  # [mm] how far cutting tools run past the faces they open


def _prism_xz(polygon: np.ndarray, y0: float, length: float) -> TopoDS_Shape:
    """Extrude a polygon of the x-z plane (placed at ``y = y0``) by ``length`` along +y."""
    maker = BRepBuilderAPI_MakePolygon()
    for x, z in polygon:
        maker.Add(gp_Pnt(float(x), float(y0), float(z)))
    maker.Close()
    face = BRepBuilderAPI_MakeFace(maker.Wire()).Face()
    return BRepPrimAPI_MakePrism(face, gp_Vec(0.0, float(length), 0.0)).Shape()


def _cylinder(start: np.ndarray, end: np.ndarray, radius: float) -> TopoDS_Shape:
    axis = end - start
    length = float(np.linalg.norm(axis))
    direction = gp_Dir(*(float(v) for v in axis / length))
    frame = gp_Ax2(gp_Pnt(*(float(v) for v in start)), direction)
    return BRepPrimAPI_MakeCylinder(frame, float(radius), length).Shape()


def _sphere(centre: np.ndarray, radius: float) -> TopoDS_Shape:
    return BRepPrimAPI_MakeSphere(gp_Pnt(*(float(v) for v in centre)), float(radius)).Shape()


def channel_tools(channel: Channel, radius: float) -> list[TopoDS_Shape]:
    """Solids whose union is the channel (cylinders + corner spheres), open ends extended."""
    path = [np.asarray(point, dtype=float) for point in channel.path]
    # open ends (port, vent) lie on a side face: push them outward by OVERSHOOT
    port_direction = path[-1] - path[-2]
    path[-1] = path[-1] + OVERSHOOT * port_direction / np.linalg.norm(port_direction)
    if channel.vent is not None:
        vent_direction = path[0] - path[1]
        path[0] = path[0] + OVERSHOOT * vent_direction / np.linalg.norm(vent_direction)
    tools = [_cylinder(a, b, radius) for a, b in zip(path[:-1], path[1:])]
    tools += [_sphere(corner, radius) for corner in path[1:-1]]
    if channel.vent is None:
        tools.append(_sphere(path[0], radius))  # closed, rounded distal end
    return tools


def build_body(design: FingerDesign) -> TopoDS_Shape:
    """Fin-ray body with cavities and mounting holes, without channels."""
    p = design.parameters
    body = _prism_xz(design.profile, -p.width / 2.0, p.width)
    tools = [_prism_xz(cell, -p.width / 2.0 - OVERSHOOT, p.width + 2 * OVERSHOOT)
             for cell in design.cells]
    for y, z in design.mount_holes:
        tools.append(_cylinder(np.array([-OVERSHOOT, y, z]),
                               np.array([p.base_depth + OVERSHOOT, y, z]),
                               p.mount_hole_diameter / 2.0))
    return _cut(body, tools)


def build_finger(design: FingerDesign, with_channels: bool = True) -> TopoDS_Shape:
    """The printable finger: body minus channels (``with_channels=False``: body only)."""
    body = build_body(design)
    if not with_channels:
        return body
    tools = []
    for channel in design.channels:
        tools += channel_tools(channel, design.parameters.channel_radius)
    return _cut(body, tools)


def _cut(argument: TopoDS_Shape, tools: list[TopoDS_Shape]) -> TopoDS_Shape:
    arguments = TopTools_ListOfShape()
    arguments.Append(argument)
    tool_list = TopTools_ListOfShape()
    for tool in tools:
        tool_list.Append(tool)
    cut = BRepAlgoAPI_Cut()
    cut.SetArguments(arguments)
    cut.SetTools(tool_list)
    cut.SetRunParallel(False)
    cut.Build()
    if not cut.IsDone():
        raise RuntimeError('OpenCascade boolean cut failed')
    return cut.Shape()


def is_valid(shape: TopoDS_Shape) -> bool:
    """OpenCascade's topological and geometric validity check of the B-rep."""
    return bool(BRepCheck_Analyzer(shape).IsValid())


def solid_count(shape: TopoDS_Shape) -> int:
    """Number of solids in ``shape`` (a printable finger is exactly one)."""
    explorer = TopExp_Explorer(shape, TopAbs_SOLID)
    count = 0
    while explorer.More():
        count += 1
        explorer.Next()
    return count


def volume(shape: TopoDS_Shape) -> float:
    """Exact B-rep volume [mm^3]."""
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def export_step(shape: TopoDS_Shape, path: Path) -> None:
    """Write ``shape`` as STEP AP214 (millimetres)."""
    # OpenCascade prints transfer statistics to stdout; keep only failures
    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    Interface_Static.SetCVal_s('write.step.schema', 'AP214IS')
    Interface_Static.SetCVal_s('write.step.unit', 'MM')
    writer = STEPControl_Writer()
    writer.Transfer(shape, STEPControl_AsIs)
    if writer.Write(str(path)) != IFSelect_RetDone:
        raise OSError(f'STEP export to {path} failed')


def triangulate(shape: TopoDS_Shape, linear_deflection: float = 0.01,
                angular_deflection: float = 0.2) -> np.ndarray:
    """Tessellate ``shape``; triangles with outward winding, degenerate ones dropped.

    Parameters
    ----------
    linear_deflection : float
        Largest distance between the mesh and the exact surface [mm].
    angular_deflection : float
        Largest angle between neighbouring facets' normals [rad].

    Returns
    -------
    ndarray, shape (n, 3, 3)
        Triangle corner coordinates [mm]. Zero-area triangles (OpenCascade emits them at
        sphere poles) are removed; they carry no surface.
    """
    mesher = BRepMesh_IncrementalMesh(shape, linear_deflection, False, angular_deflection,
                                      False)
    mesher.Perform()
    if not mesher.IsDone():
        raise RuntimeError('OpenCascade tessellation failed')
    triangles = []
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        location = TopLoc_Location()
        triangulation = BRep_Tool.Triangulation_s(face, location)
        if triangulation is None:
            raise RuntimeError('a face has no triangulation')
        transform = location.Transformation()
        nodes = np.array([
            triangulation.Node(i).Transformed(transform).Coord()
            for i in range(1, triangulation.NbNodes() + 1)])
        indices = np.array([triangulation.Triangle(i).Get()
                            for i in range(1, triangulation.NbTriangles() + 1)]) - 1
        if face.Orientation() == TopAbs_REVERSED:
            indices = indices[:, ::-1]
        triangles.append(nodes[indices])
        explorer.Next()
    corners = np.concatenate(triangles, axis=0)
    area2 = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                    corners[:, 2] - corners[:, 0]), axis=1)
    return corners[area2 > 1e-12]


def write_stl(triangles: np.ndarray, path: Path, header: str = 'FORTE finger, mm') -> None:
    """Write triangles (shape (n, 3, 3), mm) as a binary STL with facet normals."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(lengths > 0, lengths, 1.0)
    record = np.dtype([('normal', '<f4', 3), ('corners', '<f4', (3, 3)), ('attr', '<u2')])
    data = np.zeros(len(triangles), dtype=record)
    data['normal'] = normals
    data['corners'] = triangles
    with open(path, 'wb') as stream:
        stream.write(header.encode('ascii')[:80].ljust(80, b' '))
        stream.write(np.uint32(len(triangles)).tobytes())
        stream.write(data.tobytes())


def export_stl(shape: TopoDS_Shape, path: Path, linear_deflection: float = 0.01,
               angular_deflection: float = 0.2) -> np.ndarray:
    """Tessellate (see :func:`triangulate`), write a binary STL, return the triangles."""
    triangles = triangulate(shape, linear_deflection, angular_deflection)
    write_stl(triangles, path)
    return triangles
