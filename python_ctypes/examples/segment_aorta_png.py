"""Segments the abdominal aorta of the shared vmtk scan from one seed and renders the surface
over three orthogonal slices of the scan, off-screen, into a PNG.

    python python_ctypes/examples/segment_aorta_png.py -o aorta.png

Needs SimpleITK (reading) and vtk (rendering); the scan is $BALLOONSEG_DATA/vmtk-aorta/aorta.mha
(default ../shared/data from the repository) unless given with --image.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import SimpleITK as sitk
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401 - the rendering backend
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkImagingColor import vtkImageMapToWindowLevelColors
from vtkmodules.vtkIOImage import vtkPNGWriter
from vtkmodules.vtkRenderingCore import (
    vtkActor,
    vtkImageActor,
    vtkPolyDataMapper,
    vtkRenderer,
    vtkRenderWindow,
    vtkWindowToImageFilter,
)

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python_ctypes"))
import balloonseg  # noqa: E402

#: The README's seed, deep inside the aortic trunk: voxel (74, 150, 15).
AORTA_SEED = (-221.484, -156.445, 22.501)


def vtk_image(image: sitk.Image) -> vtkImageData:
    """The SimpleITK image as vtkImageData with the same spacing, origin and direction."""
    voxels = sitk.GetArrayFromImage(image)
    out = vtkImageData()
    out.SetDimensions(image.GetSize())
    out.SetSpacing(image.GetSpacing())
    out.SetOrigin(image.GetOrigin())
    out.SetDirectionMatrix(image.GetDirection())
    out.GetPointData().SetScalars(numpy_to_vtk(voxels.ravel(), deep=True))
    return out


def slice_actor(image: vtkImageData, extent, window: float, level: float) -> vtkImageActor:
    colours = vtkImageMapToWindowLevelColors()
    colours.SetInputData(image)
    colours.SetWindow(window)
    colours.SetLevel(level)
    actor = vtkImageActor()
    actor.GetMapper().SetInputConnection(colours.GetOutputPort())
    actor.SetDisplayExtent(*extent)
    return actor


def render(mesh: balloonseg.Mesh, image: sitk.Image, path: Path, size=(1000, 1200)) -> None:
    """The mesh in front of three orthogonal slices of the scan: the far walls of its box as
    the camera sees it (each at index 0 of its axis), so that no slice hides the vessel."""
    volume = vtk_image(image)
    nx, ny, nz = image.GetSize()
    low, high = np.percentile(sitk.GetArrayViewFromImage(image), [1.0, 99.5])
    renderer = vtkRenderer()
    renderer.SetBackground(0.1, 0.1, 0.12)
    for extent in (
        (0, 0, 0, ny - 1, 0, nz - 1),
        (0, nx - 1, 0, 0, 0, nz - 1),
        (0, nx - 1, 0, ny - 1, 0, 0),
    ):
        renderer.AddActor(slice_actor(volume, extent, window=high - low, level=(high + low) / 2))
    mapper = vtkPolyDataMapper()
    mapper.SetInputData(mesh.to_vtk())
    mapper.ScalarVisibilityOff()
    surface = vtkActor()
    surface.SetMapper(mapper)
    surface.GetProperty().SetColor(0.9, 0.3, 0.25)
    surface.GetProperty().SetSpecular(0.3)
    renderer.AddActor(surface)

    # Look from the side of growing i, j, k (mostly k, the scan's thin axis) towards the
    # index-0 walls, with the vessel's long axis (j) upright on the picture.
    camera = renderer.GetActiveCamera()
    centre = mesh.points.mean(axis=0)
    along_i, along_j, along_k = np.reshape(image.GetDirection(), (3, 3)).T
    view = 0.75 * along_k + 0.45 * along_i + 0.35 * along_j
    camera.SetFocalPoint(*centre)
    camera.SetPosition(*(centre + 800.0 * view / np.linalg.norm(view)))
    camera.SetViewUp(*along_j)
    # The image's world box from its corners (image actors' own bounds ignore the direction).
    corners = np.array(
        [
            image.TransformIndexToPhysicalPoint((i, j, k))
            for i in (0, nx - 1)
            for j in (0, ny - 1)
            for k in (0, nz - 1)
        ]
    )
    renderer.ResetCamera(*np.ravel(np.column_stack([corners.min(0), corners.max(0)])))
    camera.Zoom(1.1)
    renderer.ResetCameraClippingRange()

    window = vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(*size)
    window.AddRenderer(renderer)
    window.Render()
    grab = vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.Update()
    writer = vtkPNGWriter()
    writer.SetFileName(str(path))
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()


def main() -> None:
    data = Path(os.environ.get("BALLOONSEG_DATA", REPO.parent / "shared" / "data"))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--image", type=Path, default=data / "vmtk-aorta" / "aorta.mha")
    parser.add_argument("--seed", type=float, nargs=3, default=AORTA_SEED, metavar=("X", "Y", "Z"))
    parser.add_argument("-o", "--output", type=Path, default=Path("aorta.png"))
    args = parser.parse_args()
    if not args.image.exists():
        parser.error(f"{args.image} does not exist: set BALLOONSEG_DATA or give --image")

    image = sitk.ReadImage(str(args.image))
    start = time.perf_counter()
    mesh = balloonseg.segment(
        sitk.GetArrayViewFromImage(image),
        args.seed,
        spacing=image.GetSpacing(),
        origin=image.GetOrigin(),
        direction=image.GetDirection(),
    )
    s = mesh.stats
    print(
        f"{len(mesh.points)} points, {len(mesh.triangles)} triangles, genus {s['genus']}, "
        f"{s['volume_mm3'] / 1000:.1f} ml, {time.perf_counter() - start:.1f} s"
    )
    render(mesh, image, args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
