#!/usr/bin/env python3
"""Issue 18's reading speed: the full-size CT angiogram (``balloonseg phantom angiogram``, default
512x512x600 int16) written by SimpleITK as .nii.gz, .mha and .nrrd (both compressed) and .nii,
and by pydicom as a DICOM series (one uncompressed file per slice, stored as uint16 with a
RescaleIntercept of -1024, as scanners write CT), then read by SimpleITK (``sitk.ReadImage``;
``ImageSeriesReader`` on ``GetGDCMSeriesFileNames`` for the series) and by ``balloonseg info``
(its own ``read_seconds``, the read alone, and the whole process's wall clock), best of
``--repeat`` runs each, interleaved. Prints a Markdown table.

    .venv/bin/python scripts/read_speed.py [--binary target/release/balloonseg] [--dims 512,512,600]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import SimpleITK as sitk
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid


def best(runs):
    return min(runs)


def write_dicom_series(folder: Path, image) -> None:
    """`image` as a CT series, one file per slice, positions along the direction's third column."""
    folder.mkdir()
    hu = sitk.GetArrayFromImage(image)
    direction = np.asarray(image.GetDirection()).reshape(3, 3)
    spacing, origin = image.GetSpacing(), np.asarray(image.GetOrigin())
    series = generate_uid()
    for k in range(hu.shape[0]):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        path = folder / f"{k:04d}.dcm"
        d = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
        d.SOPClassUID = CTImageStorage
        d.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        d.StudyInstanceUID, d.SeriesInstanceUID = generate_uid(), series
        d.FrameOfReferenceUID = generate_uid()
        d.Modality, d.PatientName, d.PatientID = "CT", "Phantom^Angiogram", "0"
        d.InstanceNumber = k + 1
        position = origin + k * spacing[2] * direction[:, 2]
        d.ImagePositionPatient = [f"{v:.6f}" for v in position]
        d.ImageOrientationPatient = [f"{v:.6f}" for v in (*direction[:, 0], *direction[:, 1])]
        d.PixelSpacing = [f"{spacing[1]:.6f}", f"{spacing[0]:.6f}"]
        d.SliceThickness = f"{spacing[2]:.6f}"
        d.Rows, d.Columns = hu.shape[1], hu.shape[2]
        d.SamplesPerPixel, d.PhotometricInterpretation = 1, "MONOCHROME2"
        d.BitsAllocated, d.BitsStored, d.HighBit, d.PixelRepresentation = 16, 16, 15, 0
        d.RescaleIntercept, d.RescaleSlope, d.RescaleType = "-1024", "1", "HU"
        d.PixelData = (hu[k].astype(np.int32) + 1024).clip(0, 65535).astype(np.uint16).tobytes()
        d.save_as(path, enforce_file_format=True)


def read_with_sitk(path: Path) -> None:
    if path.is_dir():
        reader = sitk.ImageSeriesReader()
        reader.SetFileNames(sitk.ImageSeriesReader.GetGDCMSeriesFileNames(str(path)))
        reader.Execute()
    else:
        sitk.ReadImage(str(path))


def size_on_disk(path: Path) -> int:
    return sum(f.stat().st_size for f in path.iterdir()) if path.is_dir() else path.stat().st_size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="target/release/balloonseg")
    parser.add_argument("--dims", default="512,512,600")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    dims = tuple(int(v) for v in args.dims.split(","))
    with tempfile.TemporaryDirectory() as folder:
        generated = Path(folder) / "generated.mha"
        subprocess.run([args.binary, "phantom", "angiogram", "--dims", args.dims, "-o",
                        str(generated)], capture_output=True, check=True)
        image = sitk.ReadImage(str(generated))
        generated.unlink()
        files = []
        for suffix, compress in ((".nii.gz", True), (".mha", True), (".nrrd", True), (".nii", False)):
            # A stem of its own: given cta.nii.gz, ITK's NIfTI reader takes cta.nii when both
            # are there.
            path = Path(folder) / f"cta-{suffix.strip('.').replace('.', '-')}{suffix}"
            sitk.WriteImage(image, str(path), useCompression=compress)
            files.append(path)
        files.append(Path(folder) / "cta-dicom")
        write_dicom_series(files[-1], image)
        voxel_mb = np.prod(dims) * 2 / 1e6
        print(f"{dims[0]}x{dims[1]}x{dims[2]} int16 ({voxel_mb:.0f} MB of voxels), "
              f"best of {args.repeat}\n")
        print("| file | MB on disk | SimpleITK s | balloonseg read s | balloonseg process s "
              "| SimpleITK / balloonseg read |")
        print("|---|---|---|---|---|---|")
        for path in files:
            ours, process, theirs = [], [], []
            for _ in range(args.repeat):
                start = time.perf_counter()
                read_with_sitk(path)
                theirs.append(time.perf_counter() - start)
                start = time.perf_counter()
                out = subprocess.run([args.binary, "info", str(path)], capture_output=True,
                                     text=True, check=True)
                process.append(time.perf_counter() - start)
                ours.append(json.loads(out.stdout)["read_seconds"])
            print(f"| {path.name} | {size_on_disk(path) / 1e6:.0f} | {best(theirs):.3f} | "
                  f"{best(ours):.3f} | {best(process):.3f} | {best(theirs) / best(ours):.2f} |")


if __name__ == "__main__":
    main()
