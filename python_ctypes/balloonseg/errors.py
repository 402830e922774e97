"""The exceptions of balloonseg: one hierarchy rooted at :class:`BalloonError`.

Every failing library call raises the subclass that matches its ``BalloonStatus``; the message is
the library's own (what is wrong and what to change), and ``.status`` keeps the numeric status.
Errors about arguments are also ``ValueError`` (bad values) or ``TypeError`` (bad types), so code
that expects the built-in exceptions keeps working.
"""

from __future__ import annotations


class BalloonError(Exception):
    """Any error reported by libballoonseg or by the Python checks in front of it."""

    #: The ``BalloonStatus`` value this class stands for.
    default_status = 0

    def __init__(self, message: str, status: int | None = None):
        super().__init__(message)
        self.message = message
        self.status = self.default_status if status is None else status


class NullPointerError(BalloonError, ValueError):
    """A required pointer was NULL (a bug in the bindings, never the user's)."""

    default_status = 1


class InvalidArgumentError(BalloonError, ValueError):
    """A parameter, seed or argument is out of range or has the wrong shape."""

    default_status = 2


class InvalidVolumeError(InvalidArgumentError):
    """The volume is unusable: dims, strides, spacing, direction or scalar type."""

    default_status = 3


class InvalidMeshError(InvalidArgumentError):
    """A mesh given to a kernel is malformed."""

    default_status = 4


class ParamsSizeMismatchError(BalloonError):
    """The library was built with a different ``BalloonParams`` layout (version mismatch)."""

    default_status = 5


class BufferTooSmallError(BalloonError):
    """An output buffer was too small (handled inside the bindings)."""

    default_status = 6


class CancelledError(BalloonError):
    """The progress callback asked to stop."""

    default_status = 7


class LeakError(BalloonError):
    """The balloon grew past ``max_vertices``: it probably leaked out of the structure."""

    default_status = 8


class InternalError(BalloonError):
    """A result failed the library's own guarantees: a bug, please report it."""

    default_status = 9


class PanicError(InternalError):
    """A Rust panic was caught at the library boundary: a bug, please report it."""

    default_status = 10


class OutOfMemoryError(BalloonError, MemoryError):
    """A buffer the volume, the mesh or the parameters call for could not be allocated; the
    segmenter keeps the state of its last completed step and stays usable."""

    default_status = 11


class UnsupportedScalarTypeError(InvalidVolumeError, TypeError):
    """The numpy dtype is not one of the scalar types the library reads."""


class UnknownParameterError(InvalidArgumentError, TypeError):
    """A keyword argument is not a balloon parameter."""


_BY_STATUS = {
    cls.default_status: cls
    for cls in (
        NullPointerError,
        InvalidArgumentError,
        InvalidVolumeError,
        InvalidMeshError,
        ParamsSizeMismatchError,
        BufferTooSmallError,
        CancelledError,
        LeakError,
        InternalError,
        PanicError,
        OutOfMemoryError,
    )
}


def error_for_status(status: int, message: str) -> BalloonError:
    """The exception for a failing status (unknown statuses become a plain BalloonError)."""
    return _BY_STATUS.get(status, BalloonError)(message, status)
