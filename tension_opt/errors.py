"""Exception hierarchy of :mod:`tension_opt`.

Every error the package raises derives from :class:`TensionOptError`; errors of
third-party solvers are caught inside the backends and turned into a per-pose
status, so they never leak out of a batch.
"""

from __future__ import annotations


class TensionOptError(Exception):
    """Base class of every exception raised by :mod:`tension_opt`."""


class InvalidInputError(TensionOptError, ValueError):
    """An argument has the wrong shape, a non-finite value or an inconsistent value."""


class BackendNotAvailableError(TensionOptError, ImportError):
    """A backend or solver was requested that is not installed."""


class UnsupportedProblemError(TensionOptError):
    """The chosen backend cannot express the problem; the message names backends that can."""


class SolverError(TensionOptError):
    """A solver failed in a way that cannot be reported as a per-pose status."""


class RobotFileError(InvalidInputError):
    """A robot description file (YAML, JSON or a CASPR model) does not describe a robot.

    The message names the file, each bad field (e.g. ``cable.EA``), its line where known,
    and the fix. ``path`` is the file; ``problems`` holds ``(field, line, message)``
    tuples, ``line`` 0 where unknown.
    """

    def __init__(self, message: str, path: str = "",
                 problems: tuple[tuple[str, int, str], ...] = ()) -> None:
        super().__init__(message)
        self.path = path
        self.problems = problems
