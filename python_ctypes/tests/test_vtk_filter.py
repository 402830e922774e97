"""BalloonSegmentationFilter in VTK pipelines: reader -> filter -> writer gives the CLI's mesh in
world coordinates (direction matrix included), parameters re-execute it, errors leave an empty
output and an ErrorEvent, the extent is honoured."""

import numpy as np
import pytest
from conftest import (
    AORTA_SEED,
    assert_same_mesh,
    cli_segment,
    polydata_arrays,
    read_image,
    read_vtp,
)
from vtkmodules.util.misc import calldata_type
from vtkmodules.vtkCommonCore import VTK_STRING, vtkCommand
from vtkmodules.vtkImagingCore import vtkImageChangeInformation, vtkImageClip
from vtkmodules.vtkIOImage import vtkMetaImageReader
from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

import balloonseg
from balloonseg.vtk import FILTER_PARAMETERS, BalloonSegmentationFilter


def reader_with_itk_direction(path):
    """vtkMetaImageReader, with the direction matrix set from SimpleITK's reading (VTK 9.7 reads
    TransformMatrix transposed, Debian's 9.1 ignores it)."""
    reader = vtkMetaImageReader()
    reader.SetFileName(str(path))
    fix = vtkImageChangeInformation()
    fix.SetInputConnection(reader.GetOutputPort())
    image, _, _ = read_image(path)
    fix.SetOutputDirection(image.GetDirection())
    return fix


@pytest.fixture(scope="module")
def oblique(phantom):
    return phantom("sphere", "--oblique", "--spacing=0.9,1.1,1.3")


def test_reader_filter_writer_equals_the_cli_in_world_coordinates(cli, oblique, tmp_path):
    path, seed = oblique
    source = reader_with_itk_direction(path)
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    balloon.SetSeed(*seed)
    writer = vtkXMLPolyDataWriter()
    writer.SetInputConnection(balloon.GetOutputPort())
    writer.SetFileName(str(tmp_path / "filter.vtp"))
    assert writer.Write() == 1
    assert balloon.GetErrorMessage() == ""
    points, triangles, states = read_vtp(tmp_path / "filter.vtp")
    expected = cli_segment(cli, path, seed, tmp_path / "cli.vtp")
    assert_same_mesh(balloonseg.Mesh(points, triangles, states), *expected)

    # World coordinates as ITK defines them: the surface's centre, mapped back to a continuous
    # index by SimpleITK, is the sphere's centre voxel, and its points lie about a radius away.
    image, _, _ = read_image(path)
    centre = points.mean(axis=0)
    centre_index = np.array(image.TransformPhysicalPointToContinuousIndex(centre))
    seed_index = np.array(image.TransformPhysicalPointToContinuousIndex(seed))
    assert np.abs(centre_index - seed_index).max() < 0.25
    back = [
        image.TransformContinuousIndexToPhysicalPoint(
            image.TransformPhysicalPointToContinuousIndex(p)
        )
        for p in points[:50]
    ]
    assert np.allclose(back, points[:50], atol=1e-9)


def test_the_direction_matrix_matters(cli, oblique, tmp_path):
    """Without the direction (identity), the mesh is elsewhere: the comparison above can fail."""
    path, seed = oblique
    reader = vtkMetaImageReader()
    reader.SetFileName(str(path))
    fix = vtkImageChangeInformation()
    fix.SetInputConnection(reader.GetOutputPort())
    fix.SetOutputDirection((1, 0, 0, 0, 1, 0, 0, 0, 1))
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(fix.GetOutputPort())
    image, _, _ = read_image(path)
    seed_index = image.TransformPhysicalPointToContinuousIndex(seed)
    balloon.SetSeed(
        *(o + s * i for o, s, i in zip(image.GetOrigin(), image.GetSpacing(), seed_index))
    )
    balloon.Update()
    points, _, _ = polydata_arrays(balloon.GetOutput())
    expected, _, _ = cli_segment(cli, path, seed, tmp_path / "cli.vtp")
    assert len(points) > 0
    assert np.abs(points.mean(axis=0) - expected.mean(axis=0)).max() > 1.0


def test_the_aorta_through_the_filter_equals_the_cli(aorta):
    path, expected = aorta
    source = reader_with_itk_direction(path)  # kept: VTK's ports do not own their algorithm
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    balloon.SetSeed(AORTA_SEED)
    progress = []
    balloon.AddObserver(vtkCommand.ProgressEvent, lambda o, e: progress.append(o.GetProgress()))
    balloon.Update()
    points, triangles, states = polydata_arrays(balloon.GetOutput())
    assert_same_mesh(
        balloonseg.Mesh(points, triangles, states),
        *expected,
    )
    assert progress and max(progress) == 1.0


def test_parameters_re_execute_and_an_unchanged_pipeline_does_not(oblique):
    path, seed = oblique
    source = reader_with_itk_direction(path)  # kept: VTK's ports do not own their algorithm
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    balloon.SetSeed(seed)
    balloon.Update()
    first = balloon.GetOutput().GetNumberOfPoints()
    assert balloon.ExecutionCount == 1 and first > 0
    balloon.Update()
    balloon.SetSeed(seed)
    balloon.SetTolerance(None)
    balloon.Update()
    assert balloon.ExecutionCount == 1, "re-executed without a change"
    balloon.SetEdgeLengthMm(2.5)
    assert balloon.GetEdgeLengthMm() == 2.5
    balloon.Update()
    assert balloon.ExecutionCount == 2
    assert balloon.GetOutput().GetNumberOfPoints() < first
    balloon.SetEdgeLengthMm(None)
    balloon.Update()
    assert balloon.ExecutionCount == 3 and balloon.GetOutput().GetNumberOfPoints() == first
    for name in FILTER_PARAMETERS:
        assert hasattr(balloon, f"Set{name}") and hasattr(balloon, f"Get{name}")


def test_simplification_error_gives_a_simplified_valid_surface(oblique):
    """SetSimplificationError (SetSimplifyErrorMm by its issue's name) re-executes the filter;
    the output has fewer triangles, stays a valid closed surface with its states, lies within
    the bound of the unsimplified output both ways and equals segment(..., simplify_mm=)."""
    from test_simplify import hausdorff_both_ways

    path, seed = oblique
    source = reader_with_itk_direction(path)  # kept: VTK's ports do not own their algorithm
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    balloon.SetSeed(seed)
    assert balloon.GetSimplificationError() is None
    balloon.Update()
    full = balloonseg.Mesh(*polydata_arrays(balloon.GetOutput()))
    balloon.SetSimplificationError(0.2)
    assert balloon.GetSimplificationError() == 0.2 == balloon.GetSimplifyErrorMm()
    balloon.Update()
    assert balloon.ExecutionCount == 2 and balloon.GetErrorMessage() == ""
    reduced = balloonseg.Mesh(*polydata_arrays(balloon.GetOutput()))
    assert 0 < len(reduced.triangles) < len(full.triangles)
    s = reduced.stats
    assert s["closed"] and s["manifold"] and s["outward"] and s["self_intersecting_pairs"] == 0
    assert s["genus"] == full.stats["genus"] and s["components"] == 1
    assert reduced.vertex_state is not None and len(reduced.vertex_state) == len(reduced.points)
    there, back = hausdorff_both_ways(reduced, full)
    assert there <= 0.2 + 1e-9 and back <= 0.2 + 1e-9, (there, back)
    image, voxels, geometry = read_image(path)  # image kept: voxels is a view of it
    direct = balloonseg.segment(voxels, seed, **geometry, simplify_mm=0.2)
    assert_same_mesh(reduced, direct.points, direct.triangles, direct.vertex_state)

    balloon.SetSimplificationError(-1.0)
    balloon.Update()
    assert "simplify_error_mm" in balloon.GetErrorMessage()
    assert balloon.GetOutput().GetNumberOfPoints() == 0
    balloon.SetSimplificationError(0.0)
    balloon.Update()
    unsimplified = polydata_arrays(balloon.GetOutput())
    np.testing.assert_array_equal(unsimplified[0], full.points)
    np.testing.assert_array_equal(unsimplified[1], full.triangles)


def test_set_input_data_gives_the_pipeline_s_surface(oblique):
    """An image handed over with SetInputData, as to any vtkPolyDataAlgorithm, gives the same
    surface as the same image through a connection."""
    path, seed = oblique
    source = reader_with_itk_direction(path)
    source.Update()
    image = source.GetOutput()
    connected, handed = BalloonSegmentationFilter(), BalloonSegmentationFilter()
    connected.SetInputConnection(source.GetOutputPort())
    handed.SetInputData(image)
    assert handed.GetInput() is image
    for f in (connected, handed):
        f.SetSeed(seed)
        f.Update()
    a = polydata_arrays(connected.GetOutput())
    b = polydata_arrays(handed.GetOutput())
    assert len(b[0]) > 0
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_the_extent_is_honoured(oblique):
    """A cropped image (extent not starting at 0) gives the surface of the same sphere."""
    path, seed = oblique
    source = reader_with_itk_direction(path)
    crop = vtkImageClip()  # keeps origin and direction, moves the extent's corner
    crop.SetInputConnection(source.GetOutputPort())
    crop.SetOutputWholeExtent(3, 50, 4, 38, 2, 31)
    crop.ClipDataOn()
    whole, cropped = BalloonSegmentationFilter(), BalloonSegmentationFilter()
    whole.SetInputConnection(source.GetOutputPort())
    cropped.SetInputConnection(crop.GetOutputPort())
    for f in (whole, cropped):
        f.SetSeed(seed)
        f.Update()
    crop.Update()
    assert crop.GetOutput().GetExtent()[0] == 3
    a, _, _ = polydata_arrays(whole.GetOutput())
    b, _, _ = polydata_arrays(cropped.GetOutput())
    assert len(b) > 0
    assert np.allclose(a.mean(axis=0), b.mean(axis=0), atol=0.05)
    assert np.allclose(np.ptp(a, axis=0), np.ptp(b, axis=0), atol=0.1)


def test_errors_leave_an_empty_output_and_an_error_event(oblique):
    path, _ = oblique
    source = reader_with_itk_direction(path)  # kept: VTK's ports do not own their algorithm
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    messages = []

    @calldata_type(VTK_STRING)
    def on_error(obj, event, message):
        messages.append(message)

    balloon.AddObserver(vtkCommand.ErrorEvent, on_error)
    balloon.Update()
    assert "seed" in messages[-1] and balloon.GetOutput().GetNumberOfPoints() == 0
    balloon.SetSeed(1000.0, 0.0, 0.0)
    balloon.Update()
    assert "seed" in messages[-1].lower() and balloon.GetOutput().GetNumberOfPoints() == 0
    assert balloon.GetErrorMessage() == messages[-1]
    balloon.SetSeed(oblique[1])
    balloon.SetMaxIterations(-3)
    balloon.Update()
    assert "max_iterations" in messages[-1] and balloon.GetOutput().GetNumberOfPoints() == 0
    balloon.SetMaxIterations(None)
    balloon.Update()
    assert balloon.GetOutput().GetNumberOfPoints() > 0 and balloon.GetErrorMessage() == ""
    assert len(messages) == 3


def test_abort_execute_cancels(oblique):
    path, seed = oblique
    source = reader_with_itk_direction(path)  # kept: VTK's ports do not own their algorithm
    balloon = BalloonSegmentationFilter()
    balloon.SetInputConnection(source.GetOutputPort())
    balloon.SetSeed(seed)
    balloon.AddObserver(vtkCommand.ProgressEvent, lambda o, e: o.SetAbortExecute(1))
    balloon.Update()
    assert balloon.GetOutput().GetNumberOfPoints() == 0
    assert "cancel" in balloon.GetErrorMessage()
