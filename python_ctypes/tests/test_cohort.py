"""Cohorts from Python (balloonseg.cohort) and on Dask (balloonseg.dask): the manifest of
``balloonseg batch`` read the same way, each case's mesh bit for bit the command line's, failed
cases recorded without stopping the others, and everything a cluster sends back pickled."""

from __future__ import annotations

import json
import pickle
import subprocess

import numpy as np
import pytest
from conftest import assert_same_mesh, read_vtp

import balloonseg
from balloonseg import cohort


@pytest.fixture
def manifest(phantom, tmp_path):
    """A cohort: a sphere (world seed), a torus (voxel-index seed, a parameter), two objects in
    the touching tubes, and a seed outside its volume."""
    sphere, sphere_seed = phantom("sphere")
    torus, _ = phantom("torus")
    tubes, tubes_seed = phantom("touching-tubes")
    for path in (sphere, torus, tubes):
        (tmp_path / path.name).symlink_to(path)
    world = ",".join(map(repr, sphere_seed))
    tube = ",".join(map(repr, tubes_seed))
    other = ",".join(map(repr, (-tubes_seed[0], tubes_seed[1], tubes_seed[2])))
    path = tmp_path / "cohort.csv"
    path.write_text(
        "id,image,seeds,coordinates,edge-length\n"
        f'ball,{sphere.name},"{world}",,\n'
        f'ring,{torus.name},"30,30,12",index,1.5\n'
        f'pair,{tubes.name},"1:{tube};2:{other}",,\n'
        "# a seed far outside the volume\n"
        f'lost,{sphere.name},"900,900,900",,\n'
    )
    return path


def batch(cli, manifest, out, *options):
    return subprocess.run(
        [str(cli), "batch", str(manifest), "-o", str(out), *options],
        capture_output=True,
        text=True,
    )


def check_against_cli(results, cli_dir):
    """Every case's status as the command line's; each mesh its points and triangles."""
    table = json.loads((cli_dir / "results.json").read_text())["cases"]
    assert [r.status for r in results] == [row["status"] for row in table]
    assert [r.status for r in results] == ["ok", "ok", "ok", "failed"]
    for result, row in zip(results, table):
        if result.status != "ok":
            assert "outside" in result.error and "outside" in row["error"], (result, row)
            assert result.error_type == "InvalidArgumentError"
            continue
        assert result.triangles == row["triangles"] and result.genus == row["genus"]
        points, triangles, states = read_vtp(row["mesh"])
        merged = list(result.meshes.values())
        if len(merged) == 1:
            assert_same_mesh(merged[0], points, triangles, states)
        else:
            # The command line writes both objects into one file, label 1 first.
            assert sorted(result.meshes) == [1, 2]
            assert np.array_equal(
                np.concatenate([m.points for m in merged]), points
            ), "points differ"


def test_a_cohort_in_python_gives_the_command_lines_meshes(cli, manifest, tmp_path):
    cli_dir = tmp_path / "cli"
    done = batch(cli, manifest, cli_dir)
    assert done.returncode == 1, done.stderr  # the lost case
    results = cohort.run_manifest(manifest, tmp_path / "py")
    check_against_cli(results, cli_dir)
    assert results[1].genus == [1]
    assert (tmp_path / "py" / "pair_1.vtp").exists() and (tmp_path / "py" / "pair_2.vtp").exists()
    table = json.loads((tmp_path / "py" / "results.json").read_text())["cases"]
    assert [row["id"] for row in table] == ["ball", "ring", "pair", "lost"]
    header = (tmp_path / "py" / "results.csv").read_text().splitlines()[0]
    assert header == (cli_dir / "results.csv").read_text().splitlines()[0]


def test_a_cohort_on_a_dask_cluster_gives_the_same_meshes(cli, manifest, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    from balloonseg import dask as balloon_dask

    cli_dir = tmp_path / "cli"
    batch(cli, manifest, cli_dir)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        results = balloon_dask.run_manifest(manifest, tmp_path / "dask", client)
    check_against_cli(results, cli_dir)


def test_cases_results_meshes_and_errors_pickle(manifest, tmp_path):
    cases = cohort.read_manifest(manifest)
    assert pickle.loads(pickle.dumps(cases)) == cases
    result = cohort.run_case(cases[0], tmp_path)
    back = pickle.loads(pickle.dumps(result))
    assert_same_mesh(back.meshes[1], result.meshes[1].points, result.meshes[1].triangles)
    failed = cohort.run_case(cases[3], tmp_path)
    assert pickle.loads(pickle.dumps(failed)) == failed
    for error in (balloonseg.LeakError("leaked"), balloonseg.InvalidArgumentError("bad", 2)):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and again.message == error.message
        assert again.status == error.status


@pytest.mark.parametrize(
    "text, expected",
    [
        ('id,image,seeds,tolerence\na,sphere.mha,"1,2,3",5\n', "unknown column 'tolerence'"),
        ("id,image\na,sphere.mha\n", "no 'seeds' column"),
        ('id,image,seeds\na,sphere.mha,"1,2,3"\na,sphere.mha,"1,2,3"\n', "line 3"),
        ('id,image,seeds\na,nothing.mha,"1,2,3"\n', "line 2: the image"),
        ('id,image,seeds,tolerance\na,sphere.mha,"1,2,3",-4\n', "line 2"),
        ('id,image,seeds\na,sphere.mha,"1,2"\n', "line 2"),
        ('id,image,seeds\n../a,sphere.mha,"1,2,3"\n', "line 2"),
        ("id,image,seeds\n", "no cases"),
    ],
)
def test_a_manifest_the_command_line_refuses_is_refused(cli, phantom, tmp_path, text, expected):
    sphere, _ = phantom("sphere")
    (tmp_path / "sphere.mha").symlink_to(sphere)
    path = tmp_path / "m.csv"
    path.write_text(text)
    with pytest.raises(balloonseg.InvalidArgumentError, match=expected):
        cohort.read_manifest(path)
    done = batch(cli, path, tmp_path / "out")
    assert done.returncode != 0 and expected.split(":")[0] in done.stderr, done.stderr


def test_a_case_written_beside_its_image_removes_only_its_own_old_meshes(phantom, tmp_path):
    sphere, seed = phantom("sphere")
    image = tmp_path / "scan.mha"
    image.write_bytes(sphere.read_bytes())
    (tmp_path / "scan_2.vtp").write_text("an old second object")
    (tmp_path / "scan_notes.vtp").write_text("not the case's")
    manifest = tmp_path / "m.csv"
    manifest.write_text(f'id,image,seeds\nscan,scan.mha,"{",".join(map(repr, seed))}"\n')
    (result,) = cohort.run_manifest(manifest, tmp_path)
    assert result.status == "ok", result
    assert image.read_bytes() == sphere.read_bytes()
    assert not (tmp_path / "scan_2.vtp").exists()
    assert (tmp_path / "scan_notes.vtp").exists()
    assert (tmp_path / "scan.vtp").exists()


def test_a_mesh_that_would_replace_its_own_image_is_refused(phantom, tmp_path):
    sphere, seed = phantom("sphere")
    image = tmp_path / "scan.vtk"  # a legacy VTK volume, and a mesh format
    image.write_bytes(sphere.read_bytes())
    manifest = tmp_path / "m.csv"
    manifest.write_text(f'id,image,seeds\nscan,scan.vtk,"{",".join(map(repr, seed))}"\n')
    with pytest.raises(balloonseg.InvalidArgumentError, match="over its own image"):
        cohort.run_manifest(manifest, tmp_path, format="vtk")
    (case,) = cohort.read_manifest(manifest)
    result = cohort.run_case(case, tmp_path, format="vtk")
    assert result.status == "failed" and "over its own image" in result.error
    assert image.read_bytes() == sphere.read_bytes()
