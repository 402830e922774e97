"""``BalloonSegmentationFilter``: the balloon as a VTK Python algorithm (vtkImageData in,
vtkPolyData out), usable in any VTK pipeline, 3D Slicer's included.

The voxels are read in place from the image's point scalars; the output points are in world
coordinates: ``origin + D · (spacing ⊙ index)`` with the image's direction matrix ``D`` and the
index counted from the extent's minimum corner, as ``vtkImageData::TransformIndexToPhysicalPoint``.
Seeds are world mm. Errors are reported like ``vtkErrorMacro`` (an ``ErrorEvent`` when someone
observes it, else the vtkOutputWindow) and leave the output empty; ``GetErrorMessage()`` keeps
the last one. ``AbortExecute`` (or ``CheckAbort``) cancels a running segmentation.

Several objects (docs/interfaces.md, "Several objects"), as the C++ vtkBalloonSegmentation:
``AddLabelledSeed(label, x, y, z)`` adds a seed of object ``label`` (``SetSeed``/``AddSeed`` seeds
are object 1), ``AddStopSeed(x, y, z)`` a competitor left out of the output, and
``SetRegionOfInterest(xmin, xmax, ymin, ymax, zmin, zmax)`` (VTK bounds, world mm) a box no balloon
grows beyond. Output port 0 holds all objects in one vtkPolyData with the Int32 cell array
"object" (each triangle's label, also with one object); output port 1 a vtkMultiBlockDataSet with
one vtkPolyData block per object named by its label (``vtkCompositeDataSet.NAME()``, e.g. "2").
One object without stop seeds and region runs the single balloon exactly as before.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
from vtkmodules.vtkCommonCore import vtkCommand, vtkOutputWindow
from vtkmodules.vtkCommonDataModel import (
    vtkCompositeDataSet,
    vtkDataObject,
    vtkImageData,
    vtkMultiBlockDataSet,
    vtkPolyData,
)

from .errors import BalloonError, CancelledError, InvalidArgumentError
from .mesh import Mesh
from .segmenter import PARAMETERS, Segmenter, segment_objects

#: VTK-style parameter name -> BalloonParams field: ``Set``/``Get`` plus the field's name in
#: CamelCase, as the C++ vtkBalloonSegmentation names them.
FILTER_PARAMETERS = {
    "".join(part.capitalize() for part in field.split("_")): field for field in PARAMETERS
}


class BalloonSegmentationFilter(VTKPythonAlgorithmBase):
    """vtkImageData (one-component scalars of type u8…f64) in, the balloons' surfaces out: port 0
    a vtkPolyData with a "vertex_state" point array and an "object" cell array, port 1 a
    vtkMultiBlockDataSet with a block per object. Parameters: ``Set<Name>(value)`` for each name
    in :data:`FILTER_PARAMETERS` (None restores the library's default or estimate), and
    ``SetSimplificationError(mm)``, the same as ``SetSimplifyErrorMm``: the output simplified
    within that distance of the balloon's surface, both ways (0 or None: not simplified)."""

    def __init__(self):
        VTKPythonAlgorithmBase.__init__(
            self,
            nInputPorts=1,
            inputType="vtkImageData",
            nOutputPorts=2,
            outputType="vtkPolyData",
        )
        self._seeds: list[tuple[float, float, float]] = []
        self._labels: list[int] = []  # one per seed
        self._stops: list[tuple[float, float, float]] = []
        self._region: tuple[float, ...] | None = None  # VTK bounds
        self._params: dict = {}
        self._error = ""
        #: How many times the filter ran (a pipeline test can see that it re-executed).
        self.ExecutionCount = 0

    # --- seeds ------------------------------------------------------------------------------
    def SetSeed(self, *point) -> None:
        """The only seed, world mm: ``SetSeed(x, y, z)`` or ``SetSeed((x, y, z))``."""
        seeds = [_point(point)]
        if seeds != self._seeds or self._labels != [1]:
            self._seeds = seeds
            self._labels = [1]
            self.Modified()

    def AddSeed(self, *point) -> None:
        """One more seed of object 1, world mm."""
        self.AddLabelledSeed(1, *point)

    def AddLabelledSeed(self, label: int, *point) -> None:
        """A seed of object ``label`` (1 to 2**31 - 1), world mm: ``AddLabelledSeed(2, x, y, z)``
        or ``AddLabelledSeed(2, (x, y, z))``. Seeds of one label grow as one object. A label
        out of range is the library's error at execution."""
        if isinstance(label, bool) or not isinstance(label, numbers.Integral):
            raise TypeError(f"an object label is an integer from 1 to 2147483647, got {label!r}")
        self._seeds.append(_point(point))
        self._labels.append(int(label))
        self.Modified()

    def RemoveAllSeeds(self) -> None:
        if self._seeds:
            self._seeds = []
            self._labels = []
            self.Modified()

    def GetSeedLabel(self, index: int = 0) -> int:
        return self._labels[index]

    def GetNumberOfObjects(self) -> int:
        """The number of distinct labels among the seeds."""
        return len(set(self._labels))

    def AddStopSeed(self, *point) -> None:
        """A stop seed, world mm: a competitor that keeps the objects out of its structure and
        is not in the output."""
        self._stops.append(_point(point))
        self.Modified()

    def RemoveAllStopSeeds(self) -> None:
        if self._stops:
            self._stops = []
            self.Modified()

    def GetNumberOfStopSeeds(self) -> int:
        return len(self._stops)

    def GetStopSeed(self, index: int = 0) -> tuple[float, float, float]:
        return self._stops[index]

    # --- region of interest -------------------------------------------------------------------
    def SetRegionOfInterest(self, *bounds) -> None:
        """VTK bounds (xmin, xmax, ymin, ymax, zmin, zmax), world mm, as 6 numbers or one
        sequence: no balloon grows beyond the box. The library gets the corners (xmin, ymin,
        zmin) and (xmax, ymax, zmax)."""
        values = bounds[0] if len(bounds) == 1 else bounds
        values = tuple(float(v) for v in values)
        if len(values) != 6:
            raise ValueError(
                "a region of interest is 6 numbers xmin, xmax, ymin, ymax, zmin, zmax (VTK "
                f"bounds, world mm), got {bounds!r}"
            )
        if values != self._region:
            self._region = values
            self.Modified()

    def ClearRegionOfInterest(self) -> None:
        if self._region is not None:
            self._region = None
            self.Modified()

    def HasRegionOfInterest(self) -> bool:
        return self._region is not None

    def GetRegionOfInterest(self) -> tuple[float, ...] | None:
        """The bounds given to SetRegionOfInterest, or None."""
        return self._region

    def GetNumberOfSeeds(self) -> int:
        return len(self._seeds)

    def GetSeed(self, index: int = 0) -> tuple[float, float, float]:
        return self._seeds[index]

    # --- the vtkPolyDataAlgorithm habits ----------------------------------------------------
    def SetInputData(self, image: vtkImageData) -> None:
        """An image without a pipeline, as ``vtkAlgorithm::SetInputData``."""
        self.SetInputDataObject(0, image)

    def GetInput(self) -> vtkImageData | None:
        """The image on the input port, as ``vtkAlgorithm::GetInput``."""
        return self.GetInputDataObject(0, 0)

    def GetOutput(self) -> vtkPolyData:
        """The surface (after ``Update()``), as C++ filters' GetOutput."""
        return self.GetOutputDataObject(0)

    def GetMultiBlockOutput(self) -> vtkMultiBlockDataSet:
        """Output port 1: one vtkPolyData block per object, named by its label."""
        return self.GetOutputDataObject(1)

    def GetMultiBlockOutputPort(self):
        return self.GetOutputPort(1)

    def FillOutputPortInformation(self, port, info):
        info.Set(vtkDataObject.DATA_TYPE_NAME(), "vtkMultiBlockDataSet" if port else "vtkPolyData")
        return 1

    def GetErrorMessage(self) -> str:
        """The last error ("" after a successful run)."""
        return self._error

    # --- execution --------------------------------------------------------------------------
    def RequestData(self, request, in_info, out_info):
        self.ExecutionCount += 1
        self._error = ""
        image = vtkImageData.GetData(in_info[0])
        output = vtkPolyData.GetData(out_info, 0)
        blocks = vtkMultiBlockDataSet.GetData(out_info, 1)
        output.Initialize()
        blocks.Initialize()
        try:
            objects = self._segment(image)
            output.ShallowCopy(_with_labels(_appended(objects), objects))
            blocks.SetNumberOfBlocks(len(objects))
            for index, (label, mesh) in enumerate(objects):
                blocks.SetBlock(index, _with_labels(mesh, [(label, mesh)]))
                blocks.GetMetaData(index).Set(vtkCompositeDataSet.NAME(), str(label))
        except CancelledError:
            self._error = "cancelled (AbortExecute)"
        except (BalloonError, OSError) as e:
            self._report_error(str(e))
        return 1

    def _segment(self, image: vtkImageData) -> list[tuple[int, Mesh]]:
        """(label, mesh) per object, in the order the labels first appear among the seeds."""
        if not self._seeds:
            raise InvalidArgumentError("no seed: SetSeed(x, y, z) at a point inside the structure")
        scalars = image.GetPointData().GetScalars() if image else None
        if scalars is None:
            raise InvalidArgumentError("the input image has no point scalars to segment")
        if scalars.GetNumberOfComponents() != 1:
            raise InvalidArgumentError(
                f"the input scalars have {scalars.GetNumberOfComponents()} components; extract "
                "one (vtkImageExtractComponents) before segmenting"
            )
        nx, ny, nz = image.GetDimensions()
        voxels = vtk_to_numpy(scalars).reshape(nz, ny, nx)
        spacing = np.array(image.GetSpacing())
        direction = np.array(
            [image.GetDirectionMatrix().GetElement(r, c) for r in range(3) for c in range(3)]
        ).reshape(3, 3)
        corner = np.array(image.GetExtent()[0::2], dtype=np.float64)
        origin = np.array(image.GetOrigin()) + direction @ (spacing * corner)
        objects: dict = {}
        for label, point in zip(self._labels, self._seeds):
            objects.setdefault(label, []).append(point)
        (label, *others) = objects
        if (
            not others
            and not self._stops
            and self._region is None
            and 1 <= label < 2**31
        ):
            with Segmenter(
                voxels,
                self._seeds,
                spacing=spacing,
                origin=origin,
                direction=direction,
                axes="zyx",
                progress=self._progress,
                **self._params,
            ) as segmenter:
                return [(label, segmenter.segment())]
        region = None
        if self._region is not None:
            b = self._region  # VTK bounds -> two opposite corners
            region = (b[0], b[2], b[4], b[1], b[3], b[5])
        meshes = segment_objects(
            voxels,
            objects,
            spacing=spacing,
            origin=origin,
            direction=direction,
            axes="zyx",
            progress=self._progress,
            stop=self._stops or None,
            roi=region,
            **self._params,
        )
        return list(meshes.items())

    def _progress(self, fraction: float, _phase: str) -> bool:
        self.UpdateProgress(fraction)
        return bool(self.CheckAbort() if hasattr(self, "CheckAbort") else self.GetAbortExecute())

    def _report_error(self, message: str) -> None:
        self._error = message
        if self.HasObserver(vtkCommand.ErrorEvent):
            self.InvokeEvent(vtkCommand.ErrorEvent, message)
        else:
            vtkOutputWindow.GetInstance().DisplayErrorText(
                f"ERROR: In BalloonSegmentationFilter: {message}\n"
            )


def _appended(objects: list[tuple[int, Mesh]]) -> Mesh:
    """The objects' meshes one after the other (point ids shifted) in one Mesh."""
    if len(objects) == 1:
        return objects[0][1]
    meshes = [mesh for _, mesh in objects]
    firsts = np.cumsum([0] + [len(m.points) for m in meshes[:-1]])
    states = [
        m.vertex_state if m.vertex_state is not None else np.zeros(len(m.points), np.uint8)
        for m in meshes
    ]
    return Mesh(
        np.concatenate([m.points for m in meshes]),
        np.concatenate([m.triangles + np.uint32(f) for m, f in zip(meshes, firsts)]),
        np.concatenate(states),
    )


def _with_labels(mesh: Mesh, objects: list[tuple[int, Mesh]]) -> vtkPolyData:
    """``mesh.to_vtk()`` with the Int32 cell array "object": each object's label over as many
    triangles as it has, in order."""
    poly = mesh.to_vtk()
    labels = np.concatenate(
        [np.full(len(m.triangles), label, dtype=np.int32) for label, m in objects]
    )
    array = numpy_to_vtk(labels, deep=True)
    array.SetName("object")
    poly.GetCellData().AddArray(array)
    return poly


def _point(point) -> tuple[float, float, float]:
    values = point[0] if len(point) == 1 else point
    values = tuple(float(v) for v in values)
    if len(values) != 3:
        raise ValueError(f"a seed is three numbers (x, y, z) in world mm, got {point!r}")
    return values


def _parameter_accessors(field: str):
    def setter(self, value) -> None:
        if isinstance(value, float) and math.isnan(value):
            value = None
        if self._params.get(field) != value:
            if value is None:
                self._params.pop(field, None)
            else:
                self._params[field] = value
            self.Modified()

    def getter(self):
        return self._params.get(field)

    setter.__doc__ = f"Sets {field} (None: the library's default); re-executes the filter."
    getter.__doc__ = f"{field}, or None for the library's default."
    return setter, getter


for _vtk_name, _field in FILTER_PARAMETERS.items():
    _set, _get = _parameter_accessors(_field)
    setattr(BalloonSegmentationFilter, f"Set{_vtk_name}", _set)
    setattr(BalloonSegmentationFilter, f"Get{_vtk_name}", _get)

# SimplifyErrorMm under the name the issue and the docs give it, as in the C++ filter.
BalloonSegmentationFilter.SetSimplificationError = BalloonSegmentationFilter.SetSimplifyErrorMm
BalloonSegmentationFilter.GetSimplificationError = BalloonSegmentationFilter.GetSimplifyErrorMm
