"""Progress callbacks ``progress(fraction, phase)`` as the C ABI's ``BalloonProgressCallback``:
a true return value (or an exception) cancels the running call."""

from __future__ import annotations

from . import _library as L
from .errors import InvalidArgumentError


def check_progress(callback) -> None:
    if callback is not None and not callable(callback):
        raise InvalidArgumentError(f"progress must be callable or None, got {callback!r}")


class Progress:
    """The C progress callback of one call: a Python exception is kept (it must not unwind
    through the library), cancels the call, and is raised once the call has returned."""

    def __init__(self, callback):
        check_progress(callback)
        self.callback = callback
        self.error = None
        self.c = L.PROGRESS_CALLBACK(self._call) if callback else L.PROGRESS_CALLBACK()

    def _call(self, fraction: float, phase: bytes, _user_data) -> int:
        try:
            return 1 if self.callback(fraction, phase.decode()) else 0
        except BaseException as e:  # noqa: BLE001 - raised by check
            self.error = e
            return 1

    def check(self, status: int) -> None:
        error, self.error = self.error, None
        if error is not None:
            raise error
        L.check(status)
