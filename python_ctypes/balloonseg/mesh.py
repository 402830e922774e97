"""``Mesh``: a triangle mesh in world mm, owned by numpy arrays, with its statistics, its VTK
form and writers for the CLI's mesh formats (.vtp, .vtk, .stl, .ply, .obj)."""

from __future__ import annotations

import importlib.util
import struct
from pathlib import Path

import numpy as np

from . import kernels

MESH_FORMATS = (".vtp", ".vtk", ".stl", ".ply", ".obj", ".off")


class Mesh:
    """A triangle mesh: ``points`` (N, 3) float64 world mm, ``triangles`` (M, 3) uint32
    (counter-clockwise seen from outside), ``vertex_state`` (N,) uint8 (0 moving, 1 frozen at
    the border, 2 frozen by a self-intersection) or None for kernel meshes."""

    def __init__(self, points, triangles, vertex_state=None, run_stats: dict | None = None):
        self.points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(triangles, dtype=np.uint32).reshape(-1, 3)
        self.vertex_state = None if vertex_state is None else np.asarray(vertex_state, np.uint8)
        self._run_stats = run_stats or {}
        self._stats = None

    def __repr__(self) -> str:
        return f"<balloonseg.Mesh {len(self.points)} points, {len(self.triangles)} triangles>"

    @property
    def stats(self) -> dict:
        """The statistics of `balloonseg segment --stats`: the mesh check (vertices, triangles,
        euler_characteristic, genus, components, closed, manifold, oriented, outward,
        self_intersecting_pairs, volume_mm3, area_mm2) and, for a segmentation, the run
        (iterations, reparametrizations, reference_intensity, tolerance, edge_length_mm, seconds
        per phase and total)."""
        if self._stats is None:
            self._stats = {**kernels.check(self.points, self.triangles), **self._run_stats}
        return self._stats

    def simplify(self, max_error_mm: float, progress=None) -> Mesh:
        """A new mesh within ``max_error_mm`` of this one both ways (the two-sided Hausdorff
        distance), with as few triangles as the library reaches, still closed, 2-manifold,
        oriented as this one and free of self-intersections, with the same genus and components
        (see :func:`balloonseg.kernels.simplify`, which also gives the vertex map). Its
        ``vertex_state`` is None: ``segment(..., simplify_mm=...)`` carries the states over.
        ``progress(fraction, phase)`` reports and may cancel as in :func:`balloonseg.kernels.simplify`.
        Raises InvalidArgumentError for a bound that is not a positive finite number and
        InvalidMeshError for a mesh it cannot simplify (open, non-manifold, inconsistently
        oriented, self-intersecting)."""
        return kernels.simplify(self.points, self.triangles, max_error_mm, progress)[0]

    def to_vtk(self):
        """A ``vtkPolyData`` (double points, triangle polys, a "vertex_state" point array when
        the mesh has one). Needs the ``vtk`` package."""
        from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

        points = vtkPoints()
        points.SetData(numpy_to_vtk(self.points, deep=True))
        id_type = numpy_to_vtkIdTypeArray(np.zeros(0, dtype=np.int64)).GetDataTypeSize()
        ids = np.int64 if id_type == 8 else np.int32
        offsets = np.arange(0, 3 * len(self.triangles) + 1, 3, dtype=ids)
        cells = vtkCellArray()
        cells.SetData(
            numpy_to_vtkIdTypeArray(offsets, deep=True),
            numpy_to_vtkIdTypeArray(self.triangles.astype(ids).ravel(), deep=True),
        )
        poly = vtkPolyData()
        poly.SetPoints(points)
        poly.SetPolys(cells)
        if self.vertex_state is not None:
            states = numpy_to_vtk(self.vertex_state, deep=True)
            states.SetName("vertex_state")
            poly.GetPointData().AddArray(states)
        return poly

    def save(self, path) -> None:
        """Writes the mesh; the format follows the extension (.vtp, .vtk, .stl, .ply, .obj,
        .off). VTK's writers when ``vtk`` is importable, else (and for .off, which VTK does not
        write) the built-in ones."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in MESH_FORMATS:
            raise ValueError(
                f"{path}: cannot tell the mesh format from the extension; use one of "
                f"{', '.join(MESH_FORMATS)}"
            )
        if suffix == ".off" or importlib.util.find_spec("vtkmodules") is None:
            _NUMPY_WRITERS[suffix](self, path)
        else:
            _write_with_vtk(self, path, suffix)


def _write_with_vtk(mesh: Mesh, path: Path, suffix: str) -> None:
    from vtkmodules.vtkIOGeometry import vtkOBJWriter, vtkSTLWriter
    from vtkmodules.vtkIOLegacy import vtkPolyDataWriter
    from vtkmodules.vtkIOPLY import vtkPLYWriter
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    writer = {
        ".vtp": vtkXMLPolyDataWriter,
        ".vtk": vtkPolyDataWriter,
        ".stl": vtkSTLWriter,
        ".ply": vtkPLYWriter,
        ".obj": vtkOBJWriter,
    }[suffix]()
    if suffix in (".vtk", ".stl", ".ply"):
        writer.SetFileTypeToBinary()
    writer.SetFileName(str(path))
    writer.SetInputData(mesh.to_vtk())
    if not writer.Write():
        raise OSError(f"{path}: VTK could not write the mesh (check the folder and disk space)")


def _write_vtp(mesh: Mesh, path: Path) -> None:
    def ascii(values, fmt) -> str:
        return " ".join(fmt % v for v in np.asarray(values).ravel())

    m = len(mesh.triangles)
    point_data = ""
    if mesh.vertex_state is not None:
        point_data = (
            '<PointData><DataArray type="UInt8" Name="vertex_state" format="ascii">'
            f"{ascii(mesh.vertex_state, '%d')}</DataArray></PointData>"
        )
    text = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">\n<PolyData>\n'
        f'<Piece NumberOfPoints="{len(mesh.points)}" NumberOfPolys="{m}">\n{point_data}\n'
        '<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">'
        f"{ascii(mesh.points, '%.17g')}</DataArray></Points>\n"
        '<Polys><DataArray type="Int64" Name="connectivity" format="ascii">'
        f"{ascii(mesh.triangles, '%d')}</DataArray>\n"
        '<DataArray type="Int64" Name="offsets" format="ascii">'
        f"{ascii(np.arange(3, 3 * m + 1, 3), '%d')}</DataArray></Polys>\n"
        "</Piece>\n</PolyData>\n</VTKFile>\n"
    )
    path.write_text(text)


def _write_legacy_vtk(mesh: Mesh, path: Path) -> None:
    n, m = len(mesh.points), len(mesh.triangles)
    cells = np.empty((m, 4), dtype=">i4")
    cells[:, 0] = 3
    cells[:, 1:] = mesh.triangles
    parts = [
        b"# vtk DataFile Version 3.0\nballoonseg mesh\nBINARY\nDATASET POLYDATA\n",
        f"POINTS {n} double\n".encode(),
        mesh.points.astype(">f8").tobytes(),
        f"\nPOLYGONS {m} {4 * m}\n".encode(),
        cells.tobytes(),
    ]
    if mesh.vertex_state is not None:
        parts += [
            f"\nPOINT_DATA {n}\nSCALARS vertex_state unsigned_char 1\n".encode(),
            b"LOOKUP_TABLE default\n",
            mesh.vertex_state.tobytes(),
        ]
    path.write_bytes(b"".join(parts) + b"\n")


def _write_stl(mesh: Mesh, path: Path) -> None:
    corners = mesh.points[mesh.triangles.astype(np.int64)]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    record = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    records = np.zeros(len(corners), dtype=record)
    records["normal"] = normals
    records["corners"] = corners
    header = b"balloonseg mesh".ljust(80, b" ")
    path.write_bytes(header + struct.pack("<I", len(records)) + records.tobytes())


def _write_ply(mesh: Mesh, path: Path) -> None:
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    properties = "property double x\nproperty double y\nproperty double z\n"
    if mesh.vertex_state is not None:
        fields.append(("vertex_state", "u1"))
        properties += "property uchar vertex_state\n"
    vertices = np.zeros(len(mesh.points), dtype=fields)
    for axis, name in enumerate("xyz"):
        vertices[name] = mesh.points[:, axis]
    if mesh.vertex_state is not None:
        vertices["vertex_state"] = mesh.vertex_state
    faces = np.zeros(len(mesh.triangles), dtype=[("n", "u1"), ("v", "<i4", 3)])
    faces["n"] = 3
    faces["v"] = mesh.triangles
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment balloonseg mesh\n"
        f"element vertex {len(vertices)}\n{properties}"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    path.write_bytes(header.encode() + vertices.tobytes() + faces.tobytes())


def _write_obj(mesh: Mesh, path: Path) -> None:
    with open(path, "w") as f:
        f.write("# balloonseg mesh\n")
        np.savetxt(f, mesh.points, fmt="v %.17g %.17g %.17g")
        np.savetxt(f, mesh.triangles.astype(np.int64) + 1, fmt="f %d %d %d")


def _write_off(mesh: Mesh, path: Path) -> None:
    with open(path, "w") as f:
        f.write(f"OFF\n{len(mesh.points)} {len(mesh.triangles)} 0\n")
        np.savetxt(f, mesh.points, fmt="%.17g %.17g %.17g")
        np.savetxt(f, mesh.triangles.astype(np.int64), fmt="3 %d %d %d")


_NUMPY_WRITERS = {
    ".vtp": _write_vtp,
    ".vtk": _write_legacy_vtk,
    ".stl": _write_stl,
    ".ply": _write_ply,
    ".obj": _write_obj,
    ".off": _write_off,
}
