"""Wrench-space capacity margin by hyperplane shifting.

The wrenches that tensions within ``[t_min, t_max]`` apply at a pose form the zonotope
``{A T : t_min <= T <= t_max}`` (the *available wrench set*). Its facets are parallel
to the hyperplanes spanned by ``n - 1`` linearly independent columns of the structure
matrix ``A`` (Gouttefarde and Gosselin 2006; Bouchard, Moore and Gosselin 2010): with
``c`` a unit normal of such a hyperplane, the zonotope lies between the two planes of
normals ``+-c`` shifted to its supporting positions::

    h(c) = sum_j max(c . a_j t_min_j, c . a_j t_max_j)

and, for finite bounds with ``t_min < t_max``, each of these planes touches the
zonotope along a facet (the columns of the subset span an ``(n - 1)``-dimensional face),
so ``c . w <= h(c)`` over every subset is exactly the set. A subset whose columns are
dependent spans no hyperplane and is skipped; several subsets that span the same
hyperplane (more than ``n - 1`` columns in it) give the same facet, which changes
no minimum.

The margin of a pose against a polytope of required wrenches (Guay, Cardou,
Cruz-Ruiz and Caro 2014) is::

    margin = min over facets (h(c) - max over the polytope's vertices of c . b)

with ``b = -(w_gravity + w_external)`` the wrench the cables must apply (the
right-hand side of ``A T = b``). It is the distance (N, N m: the normals are unit
vectors of wrench coordinates) from the required set to the nearest facet, positive
when the whole set lies inside the available one: its sign is that of the
tension-space capacity margin (:mod:`tension_opt.workspace.margin`).
"""

from __future__ import annotations

import itertools
from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.kernels.first_use import announce
from tension_opt.kernels.launch import compiled_for
from tension_opt.robot import CableRobot
from tension_opt.workspace.wrench_set import WrenchPolytope, as_wrench_polytope

__all__ = [
    "DEPENDENT_TOL",
    "available_wrench_facets",
    "facet_margin",
    "has_finite_bounds",
    "normals_of",
    "pose_facet_margins",
    "subset_normals",
    "wrench_space_margin",
]

#: Columns whose normal is below this fraction of the product of their lengths are
#: dependent (the subset spans no hyperplane).
DEPENDENT_TOL = 1e-12
# Numbers held at once by one block of poses of the margin (a few of its arrays).
_BLOCK_ENTRIES = 1 << 22


def _subsets(m: int, n: int) -> NDArray:
    """Every subset of ``n - 1`` of the ``m`` columns, shape (C(m, n - 1), n - 1)."""
    return np.array(list(itertools.combinations(range(m), n - 1)), dtype=np.intp).reshape(
        comb(m, n - 1), n - 1)


def subset_normals(A: NDArray, subsets: NDArray) -> tuple[NDArray, NDArray]:
    """Unit normals of the hyperplanes spanned by subsets of columns, by cofactors.

    The normal of ``n - 1`` vectors ``B`` (n, n - 1) is the generalised cross product
    ``c_i = (-1)^i det(B without row i)``, orthogonal to every column of ``B``, of length
    the volume they span.

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
        Structure matrices.
    subsets : ndarray of int, shape (S, n - 1)
        Column indices.

    Returns
    -------
    normals : ndarray, shape (N, S, n)
        Unit normals; zero where the columns are dependent.
    independent : ndarray of bool, shape (N, S)
        Where the columns span a hyperplane (the normal's length above
        :data:`DEPENDENT_TOL` of the product of the columns' lengths).
    """
    n = A.shape[1]
    B = np.swapaxes(A[:, :, subsets], 1, 2)  # (N, S, n, n - 1)
    cof = np.empty((*B.shape[:2], n))
    for i in range(n):
        minor = np.delete(B, i, axis=2)
        cof[..., i] = (-1) ** i * np.linalg.det(minor)
    size = np.linalg.norm(cof, axis=2)
    volume = np.prod(np.linalg.norm(B, axis=2), axis=2)
    independent = size > DEPENDENT_TOL * volume
    with np.errstate(invalid="ignore", divide="ignore"):
        normals = np.where(independent[..., None], cof / size[..., None], 0.0)
    return normals, independent


def normals_of(A: NDArray, subsets: NDArray) -> tuple[NDArray, NDArray]:
    """:func:`subset_normals`, by its compiled twin for batches from ``COMPILED_MIN``
    poses (:func:`tension_opt.kernels.facets.subset_normals`, a Householder QR per
    subset: the same normals up to sign and rounding, dependent columns below ``1e-12``
    of the largest column on the triangular factor's diagonal)."""
    if not compiled_for(len(A)):
        return subset_normals(A, subsets)
    from tension_opt.kernels.facets import subset_normals as compiled  # loads numba

    announce("facet normals", compiled)
    normals = compiled(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(subsets))
    return normals, np.abs(normals).max(axis=2, initial=0.0) > 0


def _shifts(A: NDArray, lb: NDArray, ub: NDArray, normals: NDArray
            ) -> tuple[NDArray, NDArray]:
    """Supporting offsets ``h(+c)``, ``h(-c)`` (N, S) of normals (N, S, n) for the
    tension box ``[lb, ub]`` (N, m) each."""
    proj = normals @ A  # (N, S, m): c . a_j
    lo, hi = lb[:, None, :], ub[:, None, :]
    up = np.maximum(proj * lo, proj * hi).sum(axis=2)
    down = np.maximum(-proj * lo, -proj * hi).sum(axis=2)
    return up, down


def facet_margin(A: NDArray, lb: NDArray, ub: NDArray, B: NDArray) -> NDArray:
    """Hyperplane-shifting margin of required wrenches ``B`` against ``{A T : lb <= T <= ub}``.

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
        Structure matrices.
    lb, ub : ndarray, shape (N, m)
        Finite tension bounds (N).
    B : ndarray, shape (N, K, n)
        Vertices of each pose's required-wrench set ``b = -(w_gravity + w_external)``
        (N, N m).

    Returns
    -------
    ndarray, shape (N,)
        ``min over facets (h(c) - max_k c . B_k)`` (N, N m); ``-inf`` where ``A`` has rank
        below ``n - 1`` (no facet).
    """
    N, n, m = A.shape
    subsets = _subsets(m, n)
    out = np.empty(N)
    # Per pose: the subsets' columns (S n (n - 1)) and their products with B (S K).
    step = max(1, _BLOCK_ENTRIES // (len(subsets) * (n * n + B.shape[1])))
    for start in range(0, N, step):
        sl = slice(start, min(N, start + step))
        normals, independent = normals_of(A[sl], subsets)
        up, down = _shifts(A[sl], lb[sl], ub[sl], normals)
        cb = normals @ np.swapaxes(B[sl], 1, 2)  # (poses, S, K): c . b_k
        value = np.minimum(up - cb.max(axis=2), down + cb.min(axis=2))
        out[sl] = np.where(independent, value, np.inf).min(axis=1, initial=np.inf)
    out[np.isposinf(out)] = -np.inf  # no independent subset: rank below n - 1
    return out


def has_finite_bounds(robot: CableRobot) -> bool:
    """Whether every cable's ``t_max`` is finite (the available wrench set is bounded)."""
    return bool(np.isfinite(np.asarray(robot.t_max, dtype=float)).all())


def _finite_bounds(robot: CableRobot, N: int) -> tuple[NDArray, NDArray]:
    """The robot's bounds (N, m) each; raise unless every ``t_max`` is finite."""
    t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (robot.m,))
    if not np.isfinite(t_max).all():
        raise InvalidInputError(
            f"the wrench-space margin needs a finite t_max for every cable (the available "
            f"wrench set is unbounded otherwise), got t_max = {t_max.tolist()}; set one "
            "with robot.with_(t_max=...)")
    lb = np.broadcast_to(np.asarray(robot.t_min, dtype=float), (N, robot.m))
    return np.array(lb), np.array(np.broadcast_to(t_max, (N, robot.m)))


def required_vertices(robot: CableRobot, poses: NDArray, vertices: NDArray) -> NDArray:
    """Required wrenches ``b = -(w_gravity + v)`` of each vertex ``v`` (K, n) at validated
    poses (N, n): shape (N, K, n) (N, N m)."""
    b0 = robot.required_wrench(poses)
    return b0[:, None, :] - vertices[None]


def wrench_space_margin(robot: CableRobot, poses: ArrayLike,
                        wrench_set: WrenchPolytope | tuple[ArrayLike, ArrayLike] | ArrayLike
                        | None = None) -> NDArray:
    """Wrench-space capacity margin of each pose by hyperplane shifting (module docstring).

    Parameters
    ----------
    robot : CableRobot
        Every ``t_max`` finite.
    poses : array_like, shape (N, n) or (n,)
        Poses (m, rad).
    wrench_set : WrenchPolytope, (H, h) tuple or array_like of shape (K, n), optional
        External wrenches besides gravity (N, N m): a polytope, its inequalities
        ``H w <= h``, or vertices (a list of wrenches is its convex hull). Default: the
        weight alone.

    Returns
    -------
    ndarray, shape (N,)
        Distance (N, N m) from the required wrenches to the nearest facet of the
        available wrench set: positive inside, negative outside; ``-inf`` at a pose that
        puts a cable on its drawing point or whose structure matrix has rank below
        ``n - 1``.

    Raises
    ------
    InvalidInputError
        On bad poses or wrench set, or an infinite ``t_max``.
    """
    P = robot.as_poses(poses)
    V = (np.zeros((1, robot.dof)) if wrench_set is None
         else as_wrench_polytope(wrench_set, robot.dof).vertices)
    return pose_facet_margins(robot, P, V)


def pose_facet_margins(robot: CableRobot, P: NDArray, vertices: NDArray) -> NDArray:
    """:func:`wrench_space_margin` of validated poses ``P`` (N, n) against the wrench
    set of ``vertices`` (K, n); raises unless every ``t_max`` is finite."""
    lb, ub = _finite_bounds(robot, len(P))
    out = np.full(len(P), -np.inf)
    ok = (~robot.cable_geometry(P, check=False).degenerate if len(P)
          else np.zeros(0, dtype=bool))
    if ok.any():
        A = robot.structure_matrices(P[ok])
        out[ok] = facet_margin(A, lb[ok], ub[ok], required_vertices(robot, P[ok], vertices))
    return out


def available_wrench_facets(robot: CableRobot, poses: ArrayLike
                            ) -> tuple[NDArray, NDArray, NDArray]:
    """Facets ``H w <= h`` of the available wrench set ``{A T : t_min <= T <= t_max}``.

    Parameters
    ----------
    robot : CableRobot
        Every ``t_max`` finite.
    poses : array_like, shape (N, n) or (n,)
        Poses (m, rad) that keep every cable off its drawing point.

    Returns
    -------
    H : ndarray, shape (N, 2 S, n)
        Unit normals, ``S = C(m, n - 1)``: ``+c`` of each subset, then ``-c``.
    h : ndarray, shape (N, 2 S)
        Offsets (N, N m).
    facet : ndarray of bool, shape (N, 2 S)
        One true row per facet: false for dependent subsets (zero normal) and for the
        repeats of a hyperplane that several subsets span.
    """
    P = robot.as_poses(poses)
    lb, ub = _finite_bounds(robot, len(P))
    A = robot.structure_matrices(P)
    normals, independent = normals_of(A, _subsets(robot.m, robot.dof))
    up, down = _shifts(A, lb, ub, normals)
    H = np.concatenate([normals, -normals], axis=1)
    facet = np.concatenate([independent, independent], axis=1)
    # Repeats: sorted along a fixed generic direction, equal neighbours.
    key = H @ np.cos(np.arange(1, robot.dof + 1) * 0.7071)
    order = np.argsort(np.where(facet, key, np.inf), axis=1, kind="stable")
    Hs = np.take_along_axis(H, order[..., None], axis=1)
    same = np.linalg.norm(np.diff(Hs, axis=1), axis=2) <= 1e-9
    repeat = np.zeros_like(facet)
    np.put_along_axis(repeat, order[:, 1:], same, axis=1)
    return H, np.concatenate([up, down], axis=1), facet & ~repeat
