"""balloonseg: seeded balloon segmentation of CT/MR volumes (Python bindings of libballoonseg).

>>> import SimpleITK as sitk, balloonseg
>>> image = sitk.ReadImage("aorta.mha")
>>> mesh = balloonseg.segment(sitk.GetArrayViewFromImage(image), seed=(-221.484, -156.445, 22.501),
...                           spacing=image.GetSpacing(), origin=image.GetOrigin(),
...                           direction=image.GetDirection())
>>> mesh.save("aorta.vtp")
"""

from ._library import version
from .errors import (
    BalloonError,
    BufferTooSmallError,
    CancelledError,
    InternalError,
    InvalidArgumentError,
    InvalidMeshError,
    InvalidVolumeError,
    LeakError,
    NullPointerError,
    OutOfMemoryError,
    PanicError,
    ParamsSizeMismatchError,
    UnknownParameterError,
    UnsupportedScalarTypeError,
)
from .kernels import check, marching_cubes, self_intersections, simplify
from .mesh import Mesh
from .segmenter import (
    PARAMETERS,
    ParameterInfo,
    Segmenter,
    default_params,
    parameter_info,
    segment,
    segment_objects,
)

__version__ = "0.3.0"

__all__ = [
    "BalloonError",
    "BufferTooSmallError",
    "CancelledError",
    "InternalError",
    "InvalidArgumentError",
    "InvalidMeshError",
    "InvalidVolumeError",
    "LeakError",
    "Mesh",
    "NullPointerError",
    "OutOfMemoryError",
    "PARAMETERS",
    "PanicError",
    "ParameterInfo",
    "ParamsSizeMismatchError",
    "Segmenter",
    "UnknownParameterError",
    "UnsupportedScalarTypeError",
    "check",
    "default_params",
    "marching_cubes",
    "parameter_info",
    "segment",
    "segment_objects",
    "self_intersections",
    "simplify",
    "version",
]
