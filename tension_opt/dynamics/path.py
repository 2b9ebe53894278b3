"""A geometric path through poses, and its dynamics written in the path parameter.

The path is the cubic spline ``q(s)`` through the given poses (scipy
:class:`~scipy.interpolate.CubicSpline`, not-a-knot ends by default), ``s`` the
cumulative distance between consecutive poses in pose coordinates (m, with rad for
angles). Along it, with ``x = s'^2`` and ``u = s''``, the velocities and accelerations
(velocity coordinates of :mod:`tension_opt.dynamics.wrench`) are::

    vel = V(s) s',         acc = V(s) u + C(s) x

(``V = q'`` and ``C = q''`` except for a rotation vector, whose angular terms carry the
Jacobian of :mod:`tension_opt.dynamics.rotation`), and the wrench the cables must
supply is linear in ``(u, x)``::

    w = a(s) u + b(s) x + c(s),   a = M V,  b = M C + h(q, V),  c = static wrench.

:func:`path_stages` evaluates all of these on a grid of ``s``: the constraints of the
time-optimal timing (:mod:`tension_opt.dynamics.timing`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

from tension_opt.checks import as_finite, as_float_array
from tension_opt.dynamics.rotation import twist_rates
from tension_opt.dynamics.wrench import inertia_terms
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot

__all__ = ["MAX_GRID", "PathSpline", "PathStages", "path_stages"]

#: Most grid points of a timing: each is a linear program (one pass of the
#: reachability method takes about 1 ms a point), and the convex program holds them
#: all at once.
MAX_GRID = 100_000


@dataclass(frozen=True, eq=False)
class PathSpline:
    """The cubic spline through a robot's poses, parametrised by chord length.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        The poses (m, rad), N >= 2, consecutive ones distinct.
    s : ndarray, shape (N,)
        Their path parameter: cumulative distance in pose coordinates (m, rad).
    spline : scipy.interpolate.CubicSpline
        ``q(s)``.
    """

    poses: NDArray
    s: NDArray
    spline: CubicSpline

    @classmethod
    def through(cls, robot: CableRobot, path: ArrayLike, bc_type: str = "not-a-knot"
                ) -> PathSpline:
        """The spline through ``path`` (N, n) of ``robot``'s poses.

        Raises
        ------
        InvalidInputError
            If ``path`` is not (N, n) with N >= 2 finite poses, or repeats a pose.
        """
        q = robot.as_poses(path)
        if q.shape[0] < 2:
            raise InvalidInputError(f"path must hold at least 2 poses, got {q.shape[0]}")
        with np.errstate(over="ignore"):
            step = np.linalg.norm(np.diff(q, axis=0), axis=1)
        if not np.isfinite(step.sum()):
            raise InvalidInputError("path poses are too far apart to measure (the length "
                                    "overflows): give them in m and rad")
        if (step <= 1e-12 * max(1.0, float(np.abs(q).max()))).any():
            k = int(np.argmax(step <= 1e-12 * max(1.0, float(np.abs(q).max()))))
            raise InvalidInputError(
                f"path poses {k} and {k + 1} coincide ({q[k].tolist()}): drop the repeat")
        s = np.concatenate([[0.0], np.cumsum(step)])
        return cls(q, s, CubicSpline(s, q, axis=0, bc_type=bc_type))

    @property
    def length(self) -> float:
        """Total path parameter (m, rad)."""
        return float(self.s[-1])

    def grid(self, gridpoints: int | ArrayLike | None = None) -> NDArray:
        """Grid of ``s``: the poses' own (None; three evenly spaced values for a path of
        two poses), ``count`` evenly spaced values, or the given increasing values from
        0 to :attr:`length`; from 3 (at rest at both ends, a path of two grid points
        cannot move) to :data:`MAX_GRID` points.

        Raises
        ------
        InvalidInputError
            Naming ``gridpoints``.
        """
        if gridpoints is None:
            return self.s.copy() if len(self.s) > 2 else np.linspace(0.0, self.length, 3)
        if isinstance(gridpoints, int | np.integer) and not isinstance(gridpoints, bool):
            if not 3 <= gridpoints <= MAX_GRID:
                raise InvalidInputError(
                    f"gridpoints must be from 3 to {MAX_GRID}, got {gridpoints}: at rest at "
                    "both ends, two points cannot move, and every point is a linear program")
            return np.linspace(0.0, self.length, int(gridpoints))
        g = as_finite("gridpoints", gridpoints)
        if g.ndim != 1 or not 3 <= g.size <= MAX_GRID:
            raise InvalidInputError(f"gridpoints must be a count (an int) or 3 to {MAX_GRID} "
                                    f"values, got shape {g.shape}")
        if (np.diff(g) <= 0).any() or not (
                np.isclose(g[0], 0.0) and np.isclose(g[-1], self.length)):
            raise InvalidInputError(
                f"gridpoints must increase from 0 to the path length {self.length:g}")
        return g

    def __call__(self, s: ArrayLike, nu: int = 0) -> NDArray:
        """The ``nu``-th derivative of the poses at ``s``, shape (len(s), n)."""
        return np.asarray(self.spline(np.asarray(s, dtype=float), nu))


@dataclass(frozen=True, eq=False)
class PathStages:
    """A path's dynamics on a grid of ``s`` (see the module docstring), per grid point.

    Attributes
    ----------
    s : ndarray, shape (K,)
    poses, V, C : ndarray, shape (K, n)
    a, b, c : ndarray, shape (K, n)
        Wrench coefficients of ``u``, ``x`` and 1 (N, N m).
    A : ndarray, shape (K, n, m)
        Structure matrices: ``A T = w``.
    lb, ub : ndarray, shape (K, m)
        Tension bounds (N).
    """

    s: NDArray
    poses: NDArray
    V: NDArray
    C: NDArray
    a: NDArray
    b: NDArray
    c: NDArray
    A: NDArray
    lb: NDArray
    ub: NDArray

    @property
    def K(self) -> int:
        """Number of grid points."""
        return int(self.s.size)

    def wrenches(self, u: NDArray, x: NDArray) -> NDArray:
        """``a u + b x + c`` for per-point ``u, x`` (K,), shape (K, n)."""
        return self.a * u[:, None] + self.b * x[:, None] + self.c

    def motion(self, u: NDArray, x: NDArray) -> tuple[NDArray, NDArray]:
        """Velocities ``V sqrt(x)`` and accelerations ``V u + C x``, each (K, n)."""
        return (self.V * np.sqrt(np.maximum(x, 0.0))[:, None],
                self.V * u[:, None] + self.C * x[:, None])

    def take(self, index: NDArray) -> PathStages:
        """The stages at the points ``index`` (an index array or a boolean mask)."""
        return PathStages(*(getattr(self, f.name)[index] for f in fields(self)))

    @staticmethod
    def join(*parts: PathStages) -> PathStages:
        """The points of ``parts`` one after the other."""
        return PathStages(*(np.concatenate([getattr(p, f.name) for p in parts])
                            for f in fields(PathStages)))


def _per_point(name: str, value: ArrayLike, shape: tuple[int, ...]) -> NDArray:
    arr = as_float_array(name, value)
    try:
        return np.array(np.broadcast_to(arr, shape))
    except ValueError:
        raise InvalidInputError(f"{name} must have shape {shape} (one per grid point), got "
                                f"{arr.shape}") from None


def path_stages(robot: CableRobot, path: PathSpline, s: NDArray, *,
                structure: ArrayLike | None = None,
                bounds: tuple[ArrayLike, ArrayLike] | None = None,
                wrench: ArrayLike | None = None) -> PathStages:
    """The dynamics of ``path`` at the grid ``s`` (K,).

    Parameters
    ----------
    robot : CableRobot
    path : PathSpline
    s : ndarray, shape (K,)
    structure : array_like, shape (K, n, m), optional
        Structure matrices replacing the straight-cable ones (e.g. cable directions
        with sag at the platform).
    bounds : (array_like, array_like), each (m,) or (K, m), optional
        Tension bounds replacing the robot's (N).
    wrench : array_like, shape (n,) or (K, n), optional
        External wrench besides gravity (N, N m), added to ``c``.
    """
    q = robot.as_poses(path(s))
    V, C = twist_rates(robot.pattern, q, path(s, 1), path(s, 2))
    mass, _ = inertia_terms(robot, q)
    _, h = inertia_terms(robot, q, V)
    a = np.einsum("kij,kj->ki", mass, V)
    b = np.einsum("kij,kj->ki", mass, C) + h
    c = robot.required_wrench(q, wrench)
    K, n, m = len(s), robot.dof, robot.m
    A = robot.structure_matrices(q) if structure is None else as_finite("structure", structure)
    if A.shape != (K, n, m):
        raise InvalidInputError(f"structure must have shape {(K, n, m)}, got {A.shape}")
    if bounds is not None and not (isinstance(bounds, tuple | list) and len(bounds) == 2):
        raise InvalidInputError("bounds must be a pair (t_min, t_max), each (m,) or (K, m)")
    lo, hi = (robot.t_min, robot.t_max) if bounds is None else bounds
    lb, ub = _per_point("t_min", lo, (K, m)), _per_point("t_max", hi, (K, m))
    if not np.isfinite(lb).all() or np.isnan(ub).any() or (lb > ub).any():
        raise InvalidInputError("bounds must be finite lower bounds not above the upper "
                                "bounds (which may be +inf)")
    return PathStages(s, q, V, C, a, b, c, A, lb, ub)
