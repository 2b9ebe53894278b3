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
