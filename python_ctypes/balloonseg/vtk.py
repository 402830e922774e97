"""``BalloonSegmentationFilter``: the balloon as a VTK Python algorithm (vtkImageData in,
vtkPolyData out), usable in any VTK pipeline, 3D Slicer's included.

The voxels are read in place from the image's point scalars; the output points are in world
coordinates: ``origin + D · (spacing ⊙ index)`` with the image's direction matrix ``D`` and the
index counted from the extent's minimum corner, as ``vtkImageData::TransformIndexToPhysicalPoint``.
Seeds are world mm. Errors are reported like ``vtkErrorMacro`` (an ``ErrorEvent`` when someone
observes it, else the vtkOutputWindow) and leave the output empty; ``GetErrorMessage()`` keeps
the last one. ``AbortExecute`` (or ``CheckAbort``) cancels a running segmentation.
"""

from __future__ import annotations

import math

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
from vtkmodules.vtkCommonCore import vtkCommand, vtkOutputWindow
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPolyData

from .errors import BalloonError, CancelledError, InvalidArgumentError
from .segmenter import PARAMETERS, Segmenter

#: VTK-style parameter name -> BalloonParams field: ``Set``/``Get`` plus the field's name in
#: CamelCase, as the C++ vtkBalloonSegmentation names them.
FILTER_PARAMETERS = {
    "".join(part.capitalize() for part in field.split("_")): field for field in PARAMETERS
}


class BalloonSegmentationFilter(VTKPythonAlgorithmBase):
    """vtkImageData (one-component scalars of type u8…f64) in, the balloon's surface out (a
    vtkPolyData with a "vertex_state" point array). Parameters: ``Set<Name>(value)`` for each
    name in :data:`FILTER_PARAMETERS` (None restores the library's default or estimate)."""

    def __init__(self):
        VTKPythonAlgorithmBase.__init__(
            self,
            nInputPorts=1,
            inputType="vtkImageData",
            nOutputPorts=1,
            outputType="vtkPolyData",
        )
        self._seeds: list[tuple[float, float, float]] = []
        self._params: dict = {}
        self._error = ""
        #: How many times the filter ran (a pipeline test can see that it re-executed).
        self.ExecutionCount = 0

    # --- seeds ------------------------------------------------------------------------------
    def SetSeed(self, *point) -> None:
        """The only seed, world mm: ``SetSeed(x, y, z)`` or ``SetSeed((x, y, z))``."""
        seeds = [_point(point)]
        if seeds != self._seeds:
            self._seeds = seeds
            self.Modified()

    def AddSeed(self, *point) -> None:
        """One more seed, world mm."""
        self._seeds.append(_point(point))
        self.Modified()

    def RemoveAllSeeds(self) -> None:
        if self._seeds:
            self._seeds = []
            self.Modified()

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

    def GetErrorMessage(self) -> str:
        """The last error ("" after a successful run)."""
        return self._error

    # --- execution --------------------------------------------------------------------------
    def RequestData(self, request, in_info, out_info):
        self.ExecutionCount += 1
        self._error = ""
        image = vtkImageData.GetData(in_info[0])
        output = vtkPolyData.GetData(out_info)
        output.Initialize()
        try:
            output.ShallowCopy(self._segment(image).to_vtk())
        except CancelledError:
            self._error = "cancelled (AbortExecute)"
        except (BalloonError, OSError) as e:
            self._report_error(str(e))
        return 1

    def _segment(self, image: vtkImageData):
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
            return segmenter.segment()

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
