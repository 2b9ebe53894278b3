"""Exception hierarchy of the :mod:`catenary` package.

Every exception raised on purpose by the package derives from
:class:`CatenaryError`. Argument errors also derive from :class:`ValueError`
so that callers catching the builtin keep working.
"""

from __future__ import annotations

__all__ = ["CatenaryError", "InvalidCableError"]


class CatenaryError(Exception):
    """Base class of all errors raised by :mod:`catenary`."""


class InvalidCableError(CatenaryError, ValueError):
    """An argument describing a cable is out of its domain (NaN, negative, ...).

    Per-cable numerical trouble (no solution, no convergence) is never raised;
    it is reported in the ``status`` field of the solver results instead.
    """
