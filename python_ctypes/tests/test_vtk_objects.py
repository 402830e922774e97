"""BalloonSegmentationFilter with several objects: labelled seeds, stop seeds and a region of
interest on a synthetic vtkImageData; the "object" cell array, the multiblock output (one block
per object, named by its label) and the equality with ``segment_objects``; one object without
stops or region is the single balloon as before."""

import numpy as np
import pytest
from conftest import assert_same_mesh, polydata_arrays
from vtkmodules.util.misc import calldata_type
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import VTK_STRING, vtkCommand
from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet, vtkImageData, vtkMultiBlockDataSet
from vtkmodules.vtkIOXML import vtkXMLMultiBlockDataReader, vtkXMLMultiBlockDataWriter

import balloonseg
from balloonseg.vtk import BalloonSegmentationFilter

WINDOW = dict(reference_intensity=200.0, tolerance=100.0)
SPACING = (1.0, 1.25, 0.8)
ORIGIN = (-10.0, 5.0, 2.5)


def world(i, j, k):
    return tuple(o + s * v for o, s, v in zip(ORIGIN, SPACING, (i, j, k)))


@pytest.fixture(scope="module")
def balls():
    """Two bright balls apart, as a (k, j, i) array and a vtkImageData, and their centres."""
    k, j, i = np.mgrid[:24, :24, :30]
    inside = lambda c: (i - c) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 <= 4.5**2  # noqa: E731
    volume = ((inside(8) | inside(21)) * 200).astype(np.int16)
    image = vtkImageData()
    image.SetDimensions(30, 24, 24)
    image.SetSpacing(SPACING)
    image.SetOrigin(ORIGIN)
    scalars = numpy_to_vtk(volume.ravel(), deep=True)
    image.GetPointData().SetScalars(scalars)
    return volume, image, world(8, 12, 12), world(21, 12, 12)


def run(image, configure):
    balloon = BalloonSegmentationFilter()
    balloon.SetInputData(image)
    balloon.SetReferenceIntensity(WINDOW["reference_intensity"])
    balloon.SetTolerance(WINDOW["tolerance"])
    configure(balloon)
    balloon.Update()
    assert balloon.GetErrorMessage() == ""
    return balloon


def labels_of(poly):
    array = poly.GetCellData().GetArray("object")
    assert array is not None and array.GetDataTypeAsString() == "int"
    assert array.GetNumberOfTuples() == poly.GetNumberOfPolys()
    return vtk_to_numpy(array)


def blocks_of(balloon):
    blocks = balloon.GetMultiBlockOutput()
    assert isinstance(blocks, vtkMultiBlockDataSet)
    names = [
        blocks.GetMetaData(b).Get(vtkCompositeDataSet.NAME())
        for b in range(blocks.GetNumberOfBlocks())
    ]
    return [blocks.GetBlock(b) for b in range(blocks.GetNumberOfBlocks())], names


def test_two_objects_give_the_object_array_and_named_blocks(balls, tmp_path):
    volume, image, a, b = balls

    def configure(f):
        f.AddLabelledSeed(7, b)
        f.AddLabelledSeed(3, *a)

    balloon = run(image, configure)
    assert balloon.GetNumberOfObjects() == 2 and balloon.GetSeedLabel(0) == 7
    expected = balloonseg.segment_objects(volume, {7: b, 3: a}, SPACING, ORIGIN, **WINDOW)
    assert list(expected) == [7, 3]

    blocks, names = blocks_of(balloon)
    assert names == ["7", "3"]
    for block, (label, mesh) in zip(blocks, expected.items()):
        assert_same_mesh(mesh, *polydata_arrays(block))
        assert (labels_of(block) == label).all()
        checked = balloonseg.check(*polydata_arrays(block)[:2])
        assert checked["closed"] and checked["manifold"] and checked["outward"], checked

    output = balloon.GetOutput()
    points, triangles, states = polydata_arrays(output)
    counts = [len(m.triangles) for m in expected.values()]
    assert labels_of(output).tolist() == [7] * counts[0] + [3] * counts[1]
    first = len(expected[7].points)
    assert np.array_equal(points, np.concatenate([expected[7].points, expected[3].points]))
    assert np.array_equal(triangles[: counts[0]], expected[7].triangles)
    assert np.array_equal(triangles[counts[0] :], expected[3].triangles + first)
    assert np.array_equal(states, np.concatenate([m.vertex_state for m in expected.values()]))

    # The multiblock port in a pipeline: a .vtm and one .vtp per object, read back by name.
    writer = vtkXMLMultiBlockDataWriter()
    writer.SetInputConnection(balloon.GetMultiBlockOutputPort())
    writer.SetFileName(str(tmp_path / "objects.vtm"))
    assert writer.Write() == 1
    reader = vtkXMLMultiBlockDataReader()
    reader.SetFileName(str(tmp_path / "objects.vtm"))
    reader.Update()
    back = reader.GetOutput()
    assert back.GetNumberOfBlocks() == 2
    assert [back.GetMetaData(i).Get(vtkCompositeDataSet.NAME()) for i in range(2)] == ["7", "3"]
    assert_same_mesh(expected[3], *polydata_arrays(back.GetBlock(1)))


def test_one_object_is_the_single_balloon_with_its_label(balls):
    _, image, a, _ = balls
    plain = run(image, lambda f: f.SetSeed(a))
    labelled = run(image, lambda f: f.AddLabelledSeed(4, a))
    same = polydata_arrays(plain.GetOutput())
    assert_same_mesh(balloonseg.Mesh(*polydata_arrays(labelled.GetOutput())), *same)
    assert (labels_of(plain.GetOutput()) == 1).all()
    assert (labels_of(labelled.GetOutput()) == 4).all()
    blocks, names = blocks_of(labelled)
    assert names == ["4"]
    assert_same_mesh(balloonseg.Mesh(*polydata_arrays(blocks[0])), *same)


def test_stop_seeds_and_the_region_of_interest(balls):
    volume, image, a, b = balls
    stopped = run(image, lambda f: (f.SetSeed(a), f.AddStopSeed(b)))
    assert stopped.GetNumberOfStopSeeds() == 1 and stopped.GetStopSeed(0) == b
    expected = balloonseg.segment_objects(volume, a, SPACING, ORIGIN, stop=b, **WINDOW)
    assert_same_mesh(expected[1], *polydata_arrays(stopped.GetOutput()))
    assert blocks_of(stopped)[1] == ["1"]

    end = a[0] + 1.0
    bounds = (ORIGIN[0], end, ORIGIN[1], ORIGIN[1] + 30, ORIGIN[2], ORIGIN[2] + 20)
    cut = run(image, lambda f: (f.SetSeed(a), f.SetRegionOfInterest(bounds)))
    assert cut.HasRegionOfInterest() and cut.GetRegionOfInterest() == bounds
    corners = (bounds[0], bounds[2], bounds[4], bounds[1], bounds[3], bounds[5])
    expected = balloonseg.segment(volume, a, SPACING, ORIGIN, roi=corners, **WINDOW)
    points = polydata_arrays(cut.GetOutput())[0]
    assert_same_mesh(expected, *polydata_arrays(cut.GetOutput()))
    assert points[:, 0].max() < end + 0.6

    executions = cut.ExecutionCount
    cut.SetRegionOfInterest(*bounds)
    cut.Update()
    assert cut.ExecutionCount == executions, "an unchanged region re-executed"
    cut.ClearRegionOfInterest()
    cut.Update()
    assert cut.ExecutionCount == executions + 1 and cut.GetRegionOfInterest() is None
    assert points[:, 0].max() < polydata_arrays(cut.GetOutput())[0][:, 0].max()


def test_errors_leave_both_outputs_empty(balls):
    _, image, a, b = balls
    balloon = BalloonSegmentationFilter()
    balloon.SetInputData(image)
    messages = []

    @calldata_type(VTK_STRING)
    def on_error(obj, event, message):
        messages.append(message)

    balloon.AddObserver(vtkCommand.ErrorEvent, on_error)
    balloon.AddLabelledSeed(1, a)
    balloon.AddLabelledSeed(2, a)  # two objects in one voxel
    balloon.Update()
    assert "voxel" in messages[-1], messages
    assert balloon.GetOutput().GetNumberOfPoints() == 0
    assert balloon.GetMultiBlockOutput().GetNumberOfBlocks() == 0
    balloon.RemoveAllSeeds()
    balloon.AddLabelledSeed(0, a)
    balloon.Update()
    assert "label" in messages[-1] and balloon.GetOutput().GetNumberOfPoints() == 0
    balloon.RemoveAllSeeds()
    balloon.SetSeed(a)
    balloon.SetRegionOfInterest(b[0] - 3, b[0] + 3, 0, 40, 0, 30)  # the seed is outside
    balloon.Update()
    assert len(messages) == 3 and balloon.GetOutput().GetNumberOfPoints() == 0
    with pytest.raises(ValueError, match="bounds"):
        balloon.SetRegionOfInterest(0, 1, 2)
    with pytest.raises(TypeError, match="label"):
        balloon.AddLabelledSeed(1.5, a)
