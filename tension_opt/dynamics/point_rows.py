"""The wrench-feasible set of points along a path as rows in their grid point's ``(u, x)``.

A point ``p`` of the interval of grid point ``k``, at ``d = s - s_k``, needs the wrench
``w = au_p u + b_p x + c_p`` (``au = a + 2 d b``,
:mod:`tension_opt.dynamics.intervals`), which tensions within its bounds hold if and
only if ``H w <= h`` for the facets ``(H, h)`` of its wrench-feasible set
(:func:`~tension_opt.dynamics.facets.facets_of`, exact for a structure matrix of full
rank): rows ``G (u, x) <= g`` with ``G = (H au, H b)``, ``g = h - H c``. With every
bound moved in by ``s``, row ``r`` moves in by ``s sum_j |H_r a_j|``, so the capacity
margin of ``w`` is ``min_r (g_r - G_r (u, x)) / sum_j |H_r a_j|``: the margins of a
timing along the path are a few products, and the same rows, moved in by the tension
slack, are the constraints of the compiled reachability passes
(:mod:`tension_opt.kernels.reachability`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, fields
from math import comb

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.facets import facet_data, subset_normals_reference
from tension_opt.dynamics.path import PathStages
from tension_opt.problem.form import safe_norm, typical_tension
from tension_opt.tolerances import UB_SHARE

__all__ = ["FACET_CAP", "PointRows", "facets_fit", "point_rows", "point_rows_reference",
           "tension_gap", "tension_scale"]

#: Most facets per point (``2 C(m, n - 1)``) for rows; beyond, the LPs over the tensions.
FACET_CAP = 2000


def tension_scale(points: PathStages) -> NDArray:
    """The tension scale of each point (N), shape (P,): the typical tension of its
    static wrench (:func:`~tension_opt.problem.form.typical_tension`), floored by
    :data:`~tension_opt.tolerances.UB_SHARE` of its largest finite upper bound (the
    reference tension of a tension solve), so that a robot's mass and bounds scaled
    together leave a timing as it is."""
    top = np.where(np.isfinite(points.ub), points.ub, 0.0).max(axis=1, initial=0.0)
    return np.maximum(typical_tension(points.A, points.c, points.lb), UB_SHARE * top)


def tension_gap(points: PathStages, slack: float) -> NDArray:
    """How far each tension stays inside its bounds, ``slack`` times the tension scale
    (at most half its range), shape (P, m)."""
    return np.minimum(slack * tension_scale(points)[:, None], 0.5 * (points.ub - points.lb))


def facets_fit(A: NDArray) -> bool:
    """Whether structure matrices ``A`` (P, n, m) are written by rows: few enough
    facets, and full rank (else the facets miss an equation)."""
    _, n, m = A.shape
    if 2 * comb(m, n - 1) > FACET_CAP:
        return False
    sv = np.linalg.svd(A, compute_uv=False)
    return bool((sv[:, -1] > 1e-10 * np.maximum(sv[:, 0], 1e-300)).all())


@dataclass(frozen=True, eq=False)
class PointRows:
    """Rows of points along a path (module docstring).

    Attributes
    ----------
    G : ndarray, shape (P, F, 2)
    g : ndarray, shape (P, F)
        ``+inf`` where the row holds for any wrench (an absent upper bound).
    weight : ndarray, shape (P, F)
        ``sum_j |H_r a_j|``: how far the row moves per unit of margin.
    moved : ndarray, shape (P, F), or None
        ``sum_j |H_r a_j| gap_j``: how far the row moves for the tension slack.
    half : ndarray, shape (P,)
        Half the narrowest tension range (N): the margin can be no larger.
    au, b, c : ndarray, shape (P, n)
        The wrench's coefficients of ``u``, ``x`` and 1.
    column, low : ndarray, shape (P,)
        The longest column of the structure matrix and the largest finite lower bound:
        the typical tension of a wrench (:func:`~tension_opt.problem.form.typical_tension`).
    """

    G: NDArray
    g: NDArray
    weight: NDArray
    moved: NDArray | None
    half: NDArray
    au: NDArray
    b: NDArray
    c: NDArray
    column: NDArray
    low: NDArray

    def take(self, index: NDArray) -> PointRows:
        """The rows of the points ``index``."""
        return PointRows(*(None if getattr(self, f.name) is None  # type: ignore[arg-type]
                           else getattr(self, f.name)[index] for f in fields(self)))

    @staticmethod
    def join(*parts: PointRows) -> PointRows:
        """The points of ``parts`` one after the other."""
        def stack(name: str) -> NDArray | None:
            values = [getattr(p, name) for p in parts]
            return None if any(v is None for v in values) else np.concatenate(values)
        return PointRows(*(stack(f.name) for f in fields(PointRows)))  # type: ignore[arg-type]

    def margin(self, u: NDArray, x: NDArray) -> NDArray:
        """Capacity margin (N) of the wrench of ``u, x`` (P,) at every point."""
        room = self.g - self.G[..., 0] * u[:, None] - self.G[..., 1] * x[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(self.weight > 0, room / self.weight,
                             np.where(room >= 0, np.inf, -np.inf))
        ratio = np.where(np.isfinite(self.g), ratio, np.inf)
        return np.minimum(ratio.min(axis=1, initial=np.inf), self.half)

    def typical(self, u: NDArray, x: NDArray) -> NDArray:
        """Typical tension (N) of the wrench of ``u, x`` (P,) at every point."""
        W = self.au * u[:, None] + self.b * x[:, None] + self.c
        with np.errstate(over="ignore"):
            s = safe_norm(W, axis=1) / np.maximum(self.column, 1e-300)
        return np.maximum(np.maximum(s, self.low), 1e-12)


def _compiled_facets(A: NDArray, lb: NDArray, ub: NDArray, coef: NDArray, gap: NDArray
                     ) -> tuple[NDArray, NDArray, NDArray, NDArray] | None:
    """``G, g, weight, moved`` of :func:`point_rows` by
    :func:`tension_opt.kernels.point_rows.point_rows_into`; None for a structure matrix
    of lower rank (or fewer than two rows), which the reference handles."""
    P, n, m = A.shape
    if n < 2 or m < n:
        return None
    from tension_opt.kernels.point_rows import point_rows_into  # loads numba

    subsets = itertools.combinations(range(m), n - 1)
    complements = np.array([[j for j in range(m) if j not in sub] for sub in subsets],
                           dtype=np.int64).reshape(-1, m - n + 1)
    F = 2 * len(complements)
    G, g = np.empty((P, F, 2)), np.empty((P, F))
    weight, moved = np.empty((P, F)), np.empty((P, F))
    ok = point_rows_into(np.ascontiguousarray(A), np.ascontiguousarray(lb),
                         np.ascontiguousarray(ub, dtype=float), np.ascontiguousarray(coef),
                         np.ascontiguousarray(gap), complements, G, g, weight, moved)
    return (G, g, weight, moved) if ok else None


def point_rows(points: PathStages, offset: NDArray, gap: NDArray | None = None,
               compiled: bool = True) -> PointRows:
    """The rows of ``points`` at ``offset`` from their grid points; ``gap`` (P, m): the
    tension slack of each cable (``moved``). ``compiled``: the facets by
    :mod:`tension_opt.kernels.point_rows` (the reference: False, or a structure matrix
    of lower rank)."""
    A, lb, ub = points.A, points.lb, points.ub
    au = points.a + 2.0 * offset[:, None] * points.b
    coef = np.stack([au, points.b, points.c], axis=2)  # (P, n, 3)
    fast = None
    if compiled:
        fast = _compiled_facets(A, lb, ub, coef, np.zeros_like(lb) if gap is None else gap)
    if fast is not None:
        G, g, weight, moved_all = fast
        moved = None if gap is None else moved_all
    else:
        G, g, weight, moved = _reference_facets(A, lb, ub, coef, gap)
    with np.errstate(invalid="ignore"):
        half = np.where(np.isfinite(ub), 0.5 * (ub - lb), np.inf).min(axis=1)
    low = np.where(np.isfinite(lb), np.abs(lb), 0.0).max(axis=1)
    return PointRows(G, g, weight, moved, half, au, points.b, points.c,
                     safe_norm(A, axis=1).max(axis=1), low)


def point_rows_reference(points: PathStages, offset: NDArray, gap: NDArray | None = None
                         ) -> PointRows:
    """:func:`point_rows` by numpy alone (the normals by singular value decompositions):
    the reference of the compiled facets."""
    return point_rows(points, offset, gap, compiled=False)


def _reference_facets(A: NDArray, lb: NDArray, ub: NDArray, coef: NDArray,
                      gap: NDArray | None
                      ) -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
    """``G, g, weight, moved`` by :func:`~tension_opt.dynamics.facets.facet_data`."""
    _, n, m = A.shape
    subsets = np.array(list(itertools.combinations(range(m), n - 1)), dtype=np.int64)
    H, h, size = facet_data(A, lb, ub,
                            subset_normals_reference(A, subsets.reshape(len(subsets), n - 1)))
    prod = H @ coef  # (P, F, 3)
    moved = None if gap is None else (size @ gap[:, :, None])[..., 0]
    return np.ascontiguousarray(prod[..., :2]), h - prod[..., 2], size.sum(axis=2), moved
