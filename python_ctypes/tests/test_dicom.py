"""DICOM series: the CLI's reader (src/io/dicom.rs) against SimpleITK's ImageSeriesReader on
series these tests write with pydicom — axial, sagittal and oblique, 8-, 12- and 16-bit, signed
and unsigned, with and without a rescale, uncompressed, deflated, RLE and JPEG — and the errors a
broken series gives.

The CLI is $BALLOONSEG_CLI when set (a build in another target folder), else the one conftest
finds. Its geometry comes from `balloonseg info DIR`, its voxels from `info DIR --write F.nrrd`.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import CLI, assert_same_mesh, missing, read_vtp

pydicom = pytest.importorskip("pydicom")
sitk = pytest.importorskip("SimpleITK")

from pydicom.dataset import FileDataset, FileMetaDataset  # noqa: E402
from pydicom.encaps import encapsulate  # noqa: E402
from pydicom.uid import (  # noqa: E402
    CTImageStorage,
    DeflatedExplicitVRLittleEndian,
    ExplicitVRLittleEndian,
    JPEGBaseline8Bit,
    JPEGLosslessSV1,
    RLELossless,
    generate_uid,
)


@pytest.fixture(scope="module")
def cli() -> Path:
    path = Path(os.environ.get("BALLOONSEG_CLI", CLI))
    if not path.exists():
        missing(f"{path} is not built; run `cargo build --release --features cli`")
    return path


def ball(n: int = 24) -> np.ndarray:
    """Stored values of a bright ball (1124 in, 24 out) on an n³ grid, (k, j, i)."""
    k, j, i = np.mgrid[:n, :n, :n]
    return ((i - 11.5) ** 2 + (j - 12.2) ** 2 + (k - 11.8) ** 2 < 7.5**2) * 1100 + 24


def ds(x: float) -> str:
    """A decimal string DICOM accepts (at most 16 characters), read alike by both readers."""
    return f"{x:.10g}"


def rotation(a: float, b: float, c: float) -> np.ndarray:
    """A rotation matrix from three angles (radians) about z, y and x."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    return rz @ ry @ rx


AXIAL = (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
SAGITTAL = (np.array([0, 1.0, 0]), np.array([0, 0, -1.0]))
OBLIQUE = tuple(rotation(0.3, -0.2, 0.45).T[:2])


def stored_values(rng, shape, bits_stored: int, signed: bool) -> np.ndarray:
    half = 2 ** (bits_stored - 1)
    low, high = (-half, half) if signed else (0, 2 * half)
    return rng.integers(low, high, size=shape)


def write_series(
    folder: Path,
    stored: np.ndarray,
    *,
    spacing=(0.7, 0.8, 1.25),
    origin=(-120.5, 30.25, 17.0),
    orientation=AXIAL,
    bits_allocated: int = 16,
    bits_stored: int = 16,
    signed: bool = True,
    rescale: tuple[str, str] | None = None,
    uid: str | None = None,
    description: str = "test series",
    positions=None,
    seed: int = 0,
    transfer_syntax=ExplicitVRLittleEndian,
) -> list[Path]:
    """Writes `stored` (k, j, i) as one file per slice, in a shuffled file-name order so that
    only the positions can sort them. Returns the paths, slice order."""
    folder.mkdir(parents=True, exist_ok=True)
    uid = uid or generate_uid()
    row, column = (np.asarray(v, float) for v in orientation)
    normal = np.cross(row, column)
    sx, sy, sz = spacing
    nz, ny, nx = stored.shape
    names = np.random.default_rng(seed).permutation(nz)
    dtype = {(8, False): np.uint8, (8, True): np.int8, (16, False): np.uint16, (16, True): np.int16}
    paths = []
    for k in range(nz):
        position = (
            np.asarray(origin) + k * sz * normal if positions is None else np.asarray(positions[k])
        )
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = (
            ExplicitVRLittleEndian if transfer_syntax == RLELossless else transfer_syntax
        )
        path = folder / f"{uid[-6:]}_{names[k]:04d}.dcm"
        d = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
        d.SOPClassUID = CTImageStorage
        d.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        d.StudyInstanceUID = "1.2.826.0.1.3680043.8.498.1"
        d.SeriesInstanceUID = uid
        d.SeriesDescription = description
        d.FrameOfReferenceUID = "1.2.826.0.1.3680043.8.498.2"
        d.Modality = "CT"
        d.PatientName = "Phantom^Dicom"
        d.PatientID = "0"
        d.InstanceNumber = k + 1
        d.ImagePositionPatient = [ds(v) for v in position]
        d.ImageOrientationPatient = [ds(v) for v in (*row, *column)]
        d.PixelSpacing = [ds(sy), ds(sx)]
        d.SliceThickness = ds(sz)
        d.Rows, d.Columns = ny, nx
        d.SamplesPerPixel = 1
        d.PhotometricInterpretation = "MONOCHROME2"
        d.BitsAllocated = bits_allocated
        d.BitsStored = bits_stored
        d.HighBit = bits_stored - 1
        d.PixelRepresentation = int(signed)
        if rescale is not None:
            d.RescaleIntercept, d.RescaleSlope = rescale
            d.RescaleType = "HU"
        encode(d, stored[k].astype(dtype[bits_allocated, signed]), transfer_syntax)
        d.save_as(path, enforce_file_format=True)
        paths.append(path)
    return paths


def encode(d: FileDataset, pixels: np.ndarray, transfer_syntax) -> None:
    """Puts `pixels` (one slice) into `d` in `transfer_syntax`, each by another encoder than
    the reader's: pydicom's RLE, GDCM's JPEG lossless (through SimpleITK) and Pillow's (libjpeg)
    baseline JPEG."""
    if transfer_syntax == RLELossless:
        d.compress(RLELossless, pixels)
    elif transfer_syntax == JPEGLosslessSV1:
        with tempfile.TemporaryDirectory() as scratch:
            writer = sitk.ImageFileWriter()
            writer.SetImageIO("GDCMImageIO")
            writer.SetFileName(f"{scratch}/slice.dcm")
            writer.SetUseCompression(True)
            writer.SetCompressor("JPEG")
            writer.Execute(sitk.GetImageFromArray(pixels))
            by_gdcm = pydicom.dcmread(f"{scratch}/slice.dcm")
        assert by_gdcm.file_meta.TransferSyntaxUID == JPEGLosslessSV1
        d.PixelData = by_gdcm.PixelData
        d["PixelData"].VR = "OB"
    elif transfer_syntax == JPEGBaseline8Bit:
        image = pytest.importorskip("PIL.Image")
        stream = io.BytesIO()
        image.fromarray(pixels).save(stream, "JPEG", quality=90)
        d.PixelData = encapsulate([stream.getvalue()])
        d["PixelData"].VR = "OB"
    else:
        d.PixelData = pixels.tobytes()


def sitk_series(folder: Path, uid: str | None = None):
    reader = sitk.ImageSeriesReader()
    args = (str(folder),) if uid is None else (str(folder), uid)
    reader.SetFileNames(sitk.ImageSeriesReader.GetGDCMSeriesFileNames(*args))
    return reader.Execute()


def run(cli: Path, *args) -> subprocess.CompletedProcess:
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)


def cli_read(cli: Path, folder: Path, tmp_path: Path, *options):
    """The CLI's info JSON and its voxels (through `info --write`)."""
    written = tmp_path / f"{folder.name}_read.nrrd"
    done = run(cli, "info", folder, "--write", written, *options)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout), sitk.ReadImage(str(written))


def assert_same_as_sitk(info, voxels, expected):
    assert info["dims"] == list(expected.GetSize())
    for key, value in [
        ("spacing", expected.GetSpacing()),
        ("origin", expected.GetOrigin()),
        ("direction", expected.GetDirection()),
    ]:
        np.testing.assert_allclose(info[key], value, rtol=0, atol=1e-6, err_msg=key)
    np.testing.assert_array_equal(
        sitk.GetArrayFromImage(voxels).astype(np.float64),
        sitk.GetArrayFromImage(expected).astype(np.float64),
    )


CASES = {
    # name: orientation, bits allocated, bits stored, signed, rescale (intercept, slope)[,
    # transfer syntax]
    "axial-int16-hu": (AXIAL, 16, 16, True, ("-1024", "1")),
    "axial-int16-hu-rle": (AXIAL, 16, 16, True, ("-1024", "1"), RLELossless),
    "axial-int16-hu-jpeg-lossless": (AXIAL, 16, 16, True, ("-1024", "1"), JPEGLosslessSV1),
    "oblique-uint12-jpeg-lossless": (OBLIQUE, 16, 12, False, ("-1024", "1"), JPEGLosslessSV1),
    "sagittal-int12-jpeg-lossless": (SAGITTAL, 16, 12, True, None, JPEGLosslessSV1),
    "sagittal-uint12-deflated": (SAGITTAL, 16, 12, False, ("-1024", "1"),
                                 DeflatedExplicitVRLittleEndian),
    "axial-uint12-hu": (AXIAL, 16, 12, False, ("-1024", "1")),
    "sagittal-uint16": (SAGITTAL, 16, 16, False, None),
    "oblique-int12-fractional": (OBLIQUE, 16, 12, True, ("-1024.25", "0.5")),
    "oblique-uint8": (OBLIQUE, 8, 8, False, None),
    "sagittal-int8-slope": (SAGITTAL, 8, 8, True, ("10", "3")),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_geometry_and_voxels_equal_simpleitk(cli, tmp_path, name):
    orientation, bits_allocated, bits_stored, signed, rescale, *syntax = CASES[name]
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    stored = stored_values(rng, (7, 9, 11), bits_stored, signed)
    folder = tmp_path / name
    write_series(
        folder,
        stored,
        orientation=orientation,
        bits_allocated=bits_allocated,
        bits_stored=bits_stored,
        signed=signed,
        rescale=rescale,
        transfer_syntax=syntax[0] if syntax else ExplicitVRLittleEndian,
    )
    if syntax:
        assert pydicom.dcmread(next(folder.iterdir())).file_meta.TransferSyntaxUID == syntax[0]
    expected = sitk_series(folder)
    info, voxels = cli_read(cli, folder, tmp_path)
    assert_same_as_sitk(info, voxels, expected)
    # Both equal the series as written, so neither reader is checked only against the other.
    slope, intercept = (1.0, 0.0) if rescale is None else (float(rescale[1]), float(rescale[0]))
    np.testing.assert_array_equal(sitk.GetArrayFromImage(voxels), stored * slope + intercept)
    np.testing.assert_allclose(info["spacing"], (0.7, 0.8, 1.25), atol=1e-6)
    # GDCM's voxel type where it is an integer; a fractional rescale is float32 here.
    itk_type = expected.GetPixelIDTypeAsString()
    ours = {"64-bit float": "float32"}.get(itk_type, info["scalar_type"])
    names = {
        "8-bit unsigned integer": "uint8",
        "8-bit signed integer": "int8",
        "16-bit unsigned integer": "uint16",
        "16-bit signed integer": "int16",
        "32-bit signed integer": "int32",
        "64-bit float": "float32",
    }
    assert names[itk_type] == ours == info["scalar_type"], (itk_type, info["scalar_type"])


def test_baseline_jpeg_equals_simpleitk_within_the_rounding_of_two_idcts(cli, tmp_path):
    # Lossy: the values are libjpeg's (Pillow) decoded, not the ones written, and jpeg-decoder's
    # integer IDCT rounds otherwise than GDCM's libjpeg in a few pixels.
    folder = tmp_path / "baseline"
    k, j, i = np.mgrid[:5, :16, :16]
    smooth = (40 + 5 * i + 4 * j + 3 * k).astype(np.uint8)
    write_series(folder, smooth, orientation=OBLIQUE, bits_allocated=8, bits_stored=8,
                 signed=False, transfer_syntax=JPEGBaseline8Bit)
    expected = sitk_series(folder)
    info, voxels = cli_read(cli, folder, tmp_path)
    assert info["dims"] == list(expected.GetSize()) and info["scalar_type"] == "uint8"
    np.testing.assert_allclose(info["direction"], expected.GetDirection(), atol=1e-6)
    ours = sitk.GetArrayFromImage(voxels).astype(int)
    theirs = sitk.GetArrayFromImage(expected).astype(int)
    assert np.abs(ours - theirs).max() <= 1, np.abs(ours - theirs).max()
    assert np.abs(ours - smooth).max() <= 4, np.abs(ours - smooth).max()


def test_a_jpeg_frame_other_than_rows_and_columns_is_refused_naming_the_file(cli, tmp_path):
    # jpeg-decoder allocates by the JPEG frame's size, so it must be the one the header bounds.
    folder = tmp_path / "mismatch"
    paths = write_series(folder, np.full((3, 16, 16), 90, np.uint8), bits_allocated=8,
                         bits_stored=8, signed=False, transfer_syntax=JPEGBaseline8Bit)
    for path in paths:
        d = pydicom.dcmread(path)
        d.Rows = 8
        d.save_as(path)
    done = run(cli, "info", folder, "--write", tmp_path / "never.nrrd")
    assert done.returncode != 0 and not (tmp_path / "never.nrrd").exists()
    assert ": its JPEG frame is 16×16 pixels of 1 components where Columns × Rows say 16×8" \
        in done.stderr and str(folder) in done.stderr, done.stderr


def test_a_folder_of_several_series_lists_them_and_series_chooses_one(cli, tmp_path):
    folder = tmp_path / "two"
    rng = np.random.default_rng(5)
    uids = ["1.2.826.0.1.3680043.8.498.11", "1.2.826.0.1.3680043.8.498.12"]
    write_series(folder, stored_values(rng, (4, 5, 6), 16, True), uid=uids[0],
                 description="arterial")
    write_series(folder, stored_values(rng, (6, 5, 6), 16, True), uid=uids[1],
                 description="venous", orientation=SAGITTAL)
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert "2 DICOM series" in done.stderr and "--series" in done.stderr, done.stderr
    assert f'{uids[0]} ("arterial", 4 files)' in done.stderr, done.stderr
    assert f'{uids[1]} ("venous", 6 files)' in done.stderr, done.stderr
    for uid in uids:
        info, voxels = cli_read(cli, folder, tmp_path, "--series", uid)
        assert_same_as_sitk(info, voxels, sitk_series(folder, uid))
    done = run(cli, "info", folder, "--series", "1.2.3")
    assert done.returncode != 0 and 'no DICOM series "1.2.3"' in done.stderr, done.stderr


def test_a_missing_slice_names_the_slices_around_the_gap(cli, tmp_path):
    folder = tmp_path / "gap"
    paths = write_series(folder, stored_values(np.random.default_rng(1), (6, 4, 4), 16, True))
    paths[3].unlink()
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert f"between {paths[2]} and {paths[4]}" in done.stderr, done.stderr
    assert "missing" in done.stderr, done.stderr


def test_a_tilted_gantry_is_refused_with_its_angle(cli, tmp_path):
    folder = tmp_path / "tilt"
    tilt = np.radians(12.0)
    positions = [(0.0, 2.0 * k * np.sin(tilt), 2.0 * k * np.cos(tilt)) for k in range(5)]
    write_series(folder, stored_values(np.random.default_rng(2), (5, 4, 4), 16, True),
                 positions=positions)
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert "tilt of about 12.00°" in done.stderr, done.stderr


def test_mixed_slice_sizes_name_the_odd_file(cli, tmp_path):
    folder = tmp_path / "mixed"
    uid = generate_uid()
    paths = write_series(folder, stored_values(np.random.default_rng(3), (5, 6, 6), 16, True),
                         uid=uid)
    odd = write_series(tmp_path / "odd", stored_values(np.random.default_rng(4), (5, 6, 7), 16,
                                                        True), uid=uid)
    odd[2].replace(paths[2])
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert f"{paths[2]}: its size is 7×6 pixels" in done.stderr, done.stderr


def test_a_truncated_file_is_named(cli, tmp_path):
    folder = tmp_path / "truncated"
    paths = write_series(folder, stored_values(np.random.default_rng(6), (4, 16, 16), 16, True))
    data = paths[1].read_bytes()
    paths[1].write_bytes(data[: len(data) - 200])
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert str(paths[1]) in done.stderr and "truncated" in done.stderr, done.stderr


def test_a_folder_without_dicom_files_says_so(cli, tmp_path):
    folder = tmp_path / "empty"
    folder.mkdir()
    (folder / "notes.txt").write_text("no images here")
    done = run(cli, "info", folder)
    assert done.returncode != 0 and "no DICOM files" in done.stderr, done.stderr


def test_segment_reads_the_folder_as_it_reads_the_converted_volume(cli, tmp_path):
    """The series of a bright ball: segmenting the folder gives the same mesh, byte for byte, as
    segmenting the volume `info --write` converted it to."""
    folder = tmp_path / "ball"
    write_series(folder, ball(), spacing=(1.0, 1.0, 1.0), orientation=OBLIQUE, signed=False,
                 bits_stored=12, rescale=("-1024", "1"))
    converted = tmp_path / "ball.mha"  # MetaImage keeps the geometry's every bit
    assert run(cli, "info", folder, "--write", converted).returncode == 0
    meshes = []
    for source in (folder, converted):
        out = tmp_path / f"{source.name}.vtp"
        done = run(cli, "segment", source, "--seed", "12,12,12", "--index", "-o", out)
        assert done.returncode == 0, done.stderr
        meshes.append(out.read_bytes())
    assert meshes[0] == meshes[1]
    done = run(cli, "segment", converted, "--series", "1.2", "--seed", "1,1,1", "-o",
               tmp_path / "x.vtp")
    assert done.returncode != 0 and "only be chosen in a folder" in done.stderr, done.stderr


def test_a_manifest_series_column_reads_alike_in_batch_and_the_python_cohort(cli, tmp_path):
    """A folder of two series, each a case chosen by the `series` column: the command line's
    batch and balloonseg.cohort (SimpleITK's ImageSeriesReader) give the same meshes."""
    from balloonseg import cohort

    folder = tmp_path / "study"
    uids = ["1.2.826.0.1.3680043.8.498.21", "1.2.826.0.1.3680043.8.498.22"]
    for uid, intercept in zip(uids, ("-1024", "-1000")):
        write_series(folder, ball(), spacing=(0.75, 0.75, 1.25), origin=(-9.0, -9.0, 0.0),
                     uid=uid, signed=False, bits_stored=12, rescale=(intercept, "1"))
    manifest = tmp_path / "cohort.csv"
    manifest.write_text(
        "id,image,seeds,coordinates,series\n"
        + "".join(f'case{n},study,"12,12,12",index,{uid}\n' for n, uid in enumerate(uids))
    )
    done = run(cli, "batch", manifest, "-o", tmp_path / "cli")
    assert done.returncode == 0, done.stderr
    results = cohort.run_manifest(manifest, tmp_path / "py")
    assert [r.status for r in results] == ["ok", "ok"], results
    for n, result in enumerate(results):
        points, triangles, states = read_vtp(tmp_path / "cli" / f"case{n}.vtp")
        assert_same_mesh(list(result.meshes.values())[0], points, triangles, states)
    manifest.write_text('id,image,seeds,coordinates\nboth,study,"12,12,12",index\n')
    failed = cohort.run_manifest(manifest, tmp_path / "py2")
    assert failed[0].status == "failed" and "2 DICOM series" in failed[0].error, failed


def test_8_bit_rle_which_dicom_rs_decodes_wrongly_is_refused(cli, tmp_path):
    folder = tmp_path / "rle8"
    paths = write_series(folder, stored_values(np.random.default_rng(7), (3, 5, 6), 8, False),
                         bits_allocated=8, bits_stored=8, signed=False,
                         transfer_syntax=RLELossless)
    done = run(cli, "info", folder)
    assert done.returncode != 0
    assert "8-bit RLE" in done.stderr and str(paths[0].parent) in done.stderr, done.stderr


def test_the_real_aorta_scan_as_a_series_reads_and_segments_as_its_volume_file(
    cli, data_dir, tmp_path
):
    """The vmtk aorta (float32, direction diag(-1,-1,1)) written as a 16-bit series with slope
    0.5: the CLI equals SimpleITK's series reader, the scan's own geometry and (to the rescale's
    step) its voxels, and the aorta segmented from the folder has the .mha's volume."""
    source = data_dir / "vmtk-aorta" / "aorta.mha"
    image = sitk.ReadImage(str(source))
    values = sitk.GetArrayFromImage(image).astype(np.float64)
    direction = np.reshape(image.GetDirection(), (3, 3))
    folder = tmp_path / "aorta"
    write_series(folder, np.round(values * 2), spacing=image.GetSpacing(),
                 origin=image.GetOrigin(), orientation=(direction[:, 0], direction[:, 1]),
                 bits_stored=16, signed=False, rescale=("0", "0.5"))
    info, voxels = cli_read(cli, folder, tmp_path)
    assert_same_as_sitk(info, voxels, sitk_series(folder))
    for key, value in [("spacing", image.GetSpacing()), ("origin", image.GetOrigin()),
                       ("direction", image.GetDirection())]:
        np.testing.assert_allclose(info[key], value, rtol=0, atol=1e-5, err_msg=key)
    assert np.abs(sitk.GetArrayFromImage(voxels) - values).max() <= 0.25
    volumes = []
    for source_path in (source, folder):
        stats = tmp_path / f"{source_path.name}.json"
        done = run(cli, "segment", source_path, "--seed", "-221.484,-156.445,22.501",
                   "-o", tmp_path / f"{source_path.name}.vtp", "--stats", stats)
        assert done.returncode == 0, done.stderr
        volumes.append(json.loads(stats.read_text())["volume_mm3"])
    assert volumes[1] == pytest.approx(volumes[0], rel=0.01), volumes
