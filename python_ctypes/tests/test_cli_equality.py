"""The Python package gives exactly the CLI's mesh (points written as Float64 in .vtp, compared
bit for bit) on every phantom and on the aorta, and the mesh is a valid closed surface."""

import numpy as np
import pytest
from conftest import (
    AORTA_SEED,
    PHANTOMS,
    assert_same_mesh,
    assert_valid_surface,
    cli_segment,
    read_image,
)

import balloonseg


@pytest.mark.parametrize("name", PHANTOMS)
def test_phantom_mesh_equals_cli(name, cli, phantom, tmp_path):
    path, seed = phantom(name)
    image, voxels, geometry = read_image(path)
    mesh = balloonseg.segment(voxels, seed, **geometry)
    assert_same_mesh(mesh, *cli_segment(cli, path, seed, tmp_path / "cli.vtp"))
    assert_valid_surface(mesh)


def test_oblique_anisotropic_phantom_equals_cli(cli, phantom, tmp_path):
    path, seed = phantom("y-vessel", "--oblique", "--spacing=0.8,1.1,1.4")
    image, voxels, geometry = read_image(path)
    assert not np.allclose(np.reshape(geometry["direction"], (3, 3)), np.eye(3))
    mesh = balloonseg.segment(voxels, seed, **geometry)
    assert_same_mesh(mesh, *cli_segment(cli, path, seed, tmp_path / "cli.vtp"))
    assert_valid_surface(mesh)


def test_parameters_reach_the_library_as_the_cli_flags(cli, phantom, tmp_path):
    path, seed = phantom("touching-tubes")
    image, voxels, geometry = read_image(path)
    mesh = balloonseg.segment(
        voxels, seed, edge_length_mm=1.7, max_iterations=60, bending_weight=0.3, **geometry
    )
    expected = cli_segment(
        cli,
        path,
        seed,
        tmp_path / "cli.vtp",
        "--edge-length=1.7",
        "--max-iterations=60",
        "--bending=0.3",
    )
    assert_same_mesh(mesh, *expected)
    default = balloonseg.segment(voxels, seed, **geometry)
    assert len(default.points) != len(mesh.points), "the parameters changed nothing"


def test_aorta_mesh_equals_cli(aorta):
    path, expected = aorta
    image, voxels, geometry = read_image(path)
    assert voxels.dtype == np.float32
    mesh = balloonseg.segment(voxels, AORTA_SEED, **geometry)
    assert_same_mesh(mesh, *expected)
    assert_valid_surface(mesh)
    stats = mesh.stats
    for key in (
        "vertices",
        "triangles",
        "euler_characteristic",
        "genus",
        "components",
        "closed",
        "manifold",
        "self_intersecting_pairs",
        "iterations",
        "reparametrizations",
        "volume_mm3",
        "area_mm2",
        "seconds",
        "reference_intensity",
        "tolerance",
    ):
        assert key in stats, key
    assert stats["vertices"] == len(mesh.points) and stats["iterations"] > 0
    assert stats["seconds"]["total"] > 0 and 1000 < stats["reference_intensity"] < 2500
