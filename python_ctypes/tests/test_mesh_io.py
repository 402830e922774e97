"""Mesh.to_vtk and Mesh.save in every format, through VTK's writers and the built-in ones, read
back by VTK."""

import numpy as np
import pytest
from conftest import polydata_arrays
from vtkmodules.vtkIOGeometry import vtkOBJReader, vtkSTLReader
from vtkmodules.vtkIOLegacy import vtkPolyDataReader
from vtkmodules.vtkIOPLY import vtkPLYReader
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

import balloonseg
from balloonseg import mesh as mesh_module

READERS = {
    ".vtp": vtkXMLPolyDataReader,
    ".vtk": vtkPolyDataReader,
    ".stl": vtkSTLReader,
    ".ply": vtkPLYReader,
    ".obj": vtkOBJReader,
}


@pytest.fixture(scope="module")
def mesh():
    z, y, x = np.mgrid[:12, :12, :12]
    d = 4.3 - np.sqrt((x - 5.5) ** 2 + (y - 5.7) ** 2 + (z - 5.2) ** 2)
    m = balloonseg.marching_cubes(d, 0.0, spacing=(0.3, 0.7, 1.1), origin=(-1.0, 2.5, 3.0))
    states = (np.arange(len(m.points)) % 3).astype(np.uint8)
    return balloonseg.Mesh(m.points, m.triangles, states)


def read_back(path):
    reader = READERS[path.suffix]()
    reader.SetFileName(str(path))
    reader.Update()
    return polydata_arrays(reader.GetOutput())


def test_to_vtk(mesh):
    points, triangles, states = polydata_arrays(mesh.to_vtk())
    assert points.dtype == np.float64
    assert np.array_equal(points, mesh.points)
    assert np.array_equal(triangles, mesh.triangles)
    assert np.array_equal(states, mesh.vertex_state)


@pytest.mark.parametrize("writer", ["vtk", "numpy"])
@pytest.mark.parametrize("suffix", list(READERS))
def test_save_and_read_back(mesh, suffix, writer, tmp_path, monkeypatch):
    if writer == "numpy":
        monkeypatch.setattr(
            mesh_module, "_write_with_vtk", lambda m, p, s: mesh_module._NUMPY_WRITERS[s](m, p)
        )
    path = tmp_path / f"mesh{suffix}"
    mesh.save(path)
    points, triangles, states = read_back(path)
    if suffix == ".stl":  # float32 by format; VTK's reader welds duplicate points
        assert len(triangles) == len(mesh.triangles)
        corners = points[triangles.astype(np.int64)]
        expected = mesh.points[mesh.triangles.astype(np.int64)].astype(np.float32)
        assert np.array_equal(corners.astype(np.float32), expected)
        return
    assert np.array_equal(triangles, mesh.triangles)
    if suffix == ".obj" and writer == "vtk":  # vtkOBJWriter writes points in %g precision
        assert np.allclose(points, mesh.points, atol=1e-4)
    elif suffix == ".ply":  # vtkPLYReader keeps float32 points
        assert np.array_equal(points.astype(np.float32), mesh.points.astype(np.float32))
    else:
        assert np.array_equal(points, mesh.points)
    if suffix in (".vtp", ".vtk"):
        assert np.array_equal(states, mesh.vertex_state)


def test_an_unknown_extension_is_refused(mesh, tmp_path):
    with pytest.raises(ValueError, match=r"\.vtp"):
        mesh.save(tmp_path / "mesh.xyz")


def test_off_is_written_without_vtk(mesh, tmp_path):
    path = tmp_path / "mesh.off"
    mesh.save(path)
    lines = path.read_text().splitlines()
    assert lines[0] == "OFF" and lines[1] == f"{len(mesh.points)} {len(mesh.triangles)} 0"
    body = np.array([line.split() for line in lines[2 : 2 + len(mesh.points)]], dtype=np.float64)
    assert np.array_equal(body, mesh.points)
    faces = np.array([line.split() for line in lines[2 + len(mesh.points) :]], dtype=np.int64)
    assert np.all(faces[:, 0] == 3) and np.array_equal(faces[:, 1:], mesh.triangles)
