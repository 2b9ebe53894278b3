"""Exception hierarchy of the :mod:`catenary` package.

Every exception raised on purpose by the package derives from
:class:`CatenaryError`. Argument errors also derive from :class:`ValueError`
so that callers catching the builtin keep working. The functions of a robot
(kinematics, stiffness, workspace) read its poses, wrenches and objective with
:mod:`tension_opt`'s own checks and so raise its
:class:`~tension_opt.errors.InvalidInputError` for those (a :class:`ValueError`
too, naming the argument): catch :class:`ValueError` to take both.
"""

from __future__ import annotations

__all__ = ["CatenaryError", "InvalidCableError", "InvalidDesignError", "OptionalDependencyError"]


class CatenaryError(Exception):
    """Base class of all errors raised by :mod:`catenary`."""


class InvalidCableError(CatenaryError, ValueError):
    """An argument describing a cable is out of its domain (NaN, negative, ...).

    Per-cable numerical trouble (no solution, no convergence) is never raised;
    it is reported in the ``status`` field of the solver results instead.
    """


class InvalidDesignError(CatenaryError, ValueError):
    """A design space, criterion or design optimisation is set up wrongly (a variable
    out of range, bounds the wrong way round, a criterion the robot cannot take); the
    message names the argument and the fix (:mod:`catenary.design`)."""


class OptionalDependencyError(CatenaryError, ImportError):
    """A feature needs a package of an optional extra that is not installed.

    The message names the package and the extra, e.g. ``pip install
    "tension-opt[viz]"`` for the interactive views (plotly).
    """
