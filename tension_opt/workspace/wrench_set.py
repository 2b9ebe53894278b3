"""Polytopes of external wrenches: :class:`WrenchPolytope`.

A wrench set is the convex hull of finitely many wrenches, given by its vertices or by
inequalities ``H w <= h``. The workspace criteria need its vertices only: the capacity
margin of a pose is concave in the wrench (the largest ``s`` of a linear program whose
right-hand side is the wrench), so its smallest value over the polytope is taken at a
vertex, and a pose holds every wrench of the set if and only if it holds every vertex.

The ``(H, h)`` form is turned into vertices once, when the polytope is made: an
interior point from a Chebyshev-centre linear program, then
:class:`scipy.spatial.HalfspaceIntersection`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection

from tension_opt.errors import InvalidInputError

__all__ = ["WrenchPolytope", "as_wrench_polytope"]

#: A Chebyshev radius below this fraction of the set's size means it has no interior.
FLAT_TOL = 1e-9


def _finite_matrix(name: str, value: ArrayLike, columns: int | None = None) -> NDArray:
    """``value`` as a finite 2-D float array (rows of ``columns`` entries if given)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be an array of numbers, got "
                                f"{type(value).__name__}") from None
    if arr.ndim == 1 and columns is not None and arr.shape[0] == columns:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[0] < 1 or (columns is not None and arr.shape[1] != columns):
        want = f"(K, {columns})" if columns is not None else "(K, n)"
        raise InvalidInputError(f"{name} must have shape {want}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidInputError(f"{name} must be finite")
    return arr


def _chebyshev_centre(H: NDArray, h: NDArray) -> tuple[NDArray, float]:
    """Centre and radius of the largest ball inside ``H w <= h`` (one LP).

    Raises
    ------
    InvalidInputError
        If the set is empty.
    """
    n = H.shape[1]
    norms = np.linalg.norm(H, axis=1)
    cost = np.zeros(n + 1)
    cost[n] = -1.0
    # The radius is capped, so that an unbounded set still has an optimum.
    cap = 1.0 + float(np.abs(h).max() / max(norms.min(initial=np.inf), 1e-300))
    res = linprog(cost, A_ub=np.column_stack([H, norms]), b_ub=h,
                  bounds=[(None, None)] * n + [(0.0, cap)], method="highs")
    if res.status == 2:
        raise InvalidInputError("(H, h) describes an empty set: no wrench satisfies H w <= h")
    if res.status != 0:
        raise InvalidInputError(f"(H, h): the Chebyshev-centre LP failed ({res.message})")
    return np.asarray(res.x[:n]), float(res.x[n])


def _bounded(H: NDArray) -> bool:
    """Whether ``{w : H w <= h}`` is bounded: no direction ``d != 0`` with ``H d <= 0``,
    that is, the rows of ``H`` have full rank and positively span (``H^T lambda = 0``
    with every ``lambda >= 1``)."""
    n = H.shape[1]
    if np.linalg.matrix_rank(H) < n:
        return False
    res = linprog(np.zeros(len(H)), A_eq=H.T, b_eq=np.zeros(n),
                  bounds=[(1.0, None)] * len(H), method="highs")
    return bool(res.status == 0)


def _unique_rows(V: NDArray) -> NDArray:
    """Rows of ``V`` without repeats (closer than ``1e-12`` of the set's size)."""
    scale = max(float(np.abs(V).max()), 1e-300)
    _, first = np.unique(np.round(V / (1e-12 * scale)), axis=0, return_index=True)
    return V[np.sort(first)]


@dataclass(frozen=True, eq=False)
class WrenchPolytope:
    """A convex polytope of external wrenches (N, N m), by its vertices.

    Make one with :meth:`from_vertices`, :meth:`from_inequalities` or :meth:`box`.

    Attributes
    ----------
    vertices : ndarray, shape (K, n)
        Wrenches whose convex hull is the set (N, N m); read-only. From inequalities:
        exactly the vertices of the set; from vertices: the rows given, repeats
        removed (a row inside the hull changes no result).
    inequalities : (ndarray, ndarray) or None
        ``(H, h)``, shapes (r, n) and (r,), when the set was given that way.
    """

    vertices: NDArray
    inequalities: tuple[NDArray, NDArray] | None = None

    @property
    def dim(self) -> int:
        """Size ``n`` of a wrench."""
        return int(self.vertices.shape[1])

    @classmethod
    def from_vertices(cls, vertices: ArrayLike) -> WrenchPolytope:
        """The convex hull of wrenches ``vertices``, shape (K, n) or (n,) (N, N m)."""
        V = _unique_rows(_finite_matrix("vertices", vertices))
        V.setflags(write=False)
        return cls(V)

    @classmethod
    def from_inequalities(cls, H: ArrayLike, h: ArrayLike) -> WrenchPolytope:
        """The set ``{w : H w <= h}``: ``H`` shape (r, n) (1/N, 1/(N m) or scaled alike),
        ``h`` shape (r,). It must be bounded and have an interior.

        Raises
        ------
        InvalidInputError
            On wrong shapes or non-finite values, an empty set, an unbounded set, or a
            set without interior (give such a flat set by its vertices).
        """
        Hm = _finite_matrix("H", H)
        hv = np.array(h, dtype=float) if np.ndim(h) else np.array([h], dtype=float)
        if hv.shape != (Hm.shape[0],) or not np.isfinite(hv).all():
            raise InvalidInputError(f"h must be finite with shape ({Hm.shape[0]},) to match "
                                    f"H {Hm.shape}, got {np.shape(h)}")
        n = Hm.shape[1]
        if n < 2:
            raise InvalidInputError(f"H must have at least 2 columns (one per wrench "
                                    f"coordinate), got {n}")
        if (np.linalg.norm(Hm, axis=1) == 0).any():
            raise InvalidInputError("H has a zero row; remove it (0 <= h_i holds or fails "
                                    "for every wrench)")
        centre, radius = _chebyshev_centre(Hm, hv)
        if not _bounded(Hm):
            raise InvalidInputError("(H, h) describes an unbounded set: add rows that bound "
                                    "every direction (the rows of H must positively span R^n)")
        size = max(float(np.abs(hv / np.linalg.norm(Hm, axis=1)).max()), 1e-300)
        if radius <= FLAT_TOL * size:
            raise InvalidInputError("(H, h) describes a set without interior (flat or a single "
                                    "point); give it by its vertices with from_vertices")
        hs = HalfspaceIntersection(np.column_stack([Hm, -hv]), centre)
        points = _unique_rows(hs.intersections)
        V = points[np.sort(ConvexHull(points).vertices)]
        V.setflags(write=False)
        Hm.setflags(write=False)
        hv.setflags(write=False)
        return cls(V, (Hm, hv))

    @classmethod
    def box(cls, lower: ArrayLike, upper: ArrayLike) -> WrenchPolytope:
        """The box ``lower <= w <= upper`` (N, N m), shape (n,) each, by its ``2^k``
        corners (``k`` the coordinates with ``lower < upper``)."""
        lo = _finite_matrix("lower", np.atleast_2d(np.asarray(lower, dtype=float)))[0]
        hi = _finite_matrix("upper", upper, len(lo))[0]
        if (lo > hi).any():
            i = int(np.argmax(lo > hi))
            raise InvalidInputError(f"lower[{i}] = {lo[i]} exceeds upper[{i}] = {hi[i]}")
        grids = np.meshgrid(*[[a, b] if a < b else [a] for a, b in zip(lo, hi, strict=True)],
                            indexing="ij")
        return cls.from_vertices(np.stack([g.ravel() for g in grids], axis=1))

    def contains(self, wrenches: ArrayLike, tol: float = 1e-9) -> NDArray:
        """Whether each wrench (K, n) satisfies the inequalities (to ``tol`` of their
        size); only for a polytope given by inequalities."""
        if self.inequalities is None:
            raise InvalidInputError("contains() needs a polytope made by from_inequalities")
        H, h = self.inequalities
        W = _finite_matrix("wrenches", wrenches, self.dim)
        scale = np.abs(h) + np.linalg.norm(H, axis=1) * np.abs(W).max()
        return np.all(W @ H.T <= h + tol * scale, axis=1)

    def __repr__(self) -> str:
        form = "inequalities" if self.inequalities is not None else "vertices"
        return f"WrenchPolytope(n={self.dim}, vertices={len(self.vertices)}, from {form})"


def as_wrench_polytope(value: Any, dof: int, name: str = "wrench_set") -> WrenchPolytope:
    """A :class:`WrenchPolytope` of ``dof`` coordinates from what a caller gave.

    Parameters
    ----------
    value : WrenchPolytope, (H, h) tuple, or array_like of shape (K, dof)
        The set itself, its inequalities ``H w <= h`` (a tuple of two arrays), or its
        vertices (N, N m).
    dof : int
        The robot's number of wrench coordinates ``n``.
    name : str
        The argument's name, for error messages.

    Raises
    ------
    InvalidInputError
        On a set of the wrong size, or anything :meth:`WrenchPolytope.from_inequalities`
        refuses.
    """
    if isinstance(value, WrenchPolytope):
        poly = value
    elif isinstance(value, tuple) and len(value) == 2 and np.ndim(value[0]) == 2:
        try:
            poly = WrenchPolytope.from_inequalities(*value)
        except InvalidInputError as error:
            raise InvalidInputError(f"{name}: {error}") from None
    else:
        try:
            poly = WrenchPolytope.from_vertices(value)
        except InvalidInputError as error:
            raise InvalidInputError(f"{name} must be a WrenchPolytope, an (H, h) tuple or "
                                    f"vertices of shape (K, {dof}): {error}") from None
    if poly.dim != dof:
        raise InvalidInputError(f"{name} has wrenches of {poly.dim} coordinates; this robot "
                                f"needs {dof}")
    return poly
