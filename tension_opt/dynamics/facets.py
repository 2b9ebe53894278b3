"""The wrench-feasible set of a pose as linear inequalities on the wrench.

The wrenches that tensions within ``[t_min, t_max]`` can apply at a pose are the
zonotope ``{A T : t_min <= T <= t_max}`` (a shifted polyhedral cone when ``t_max`` is
infinite). The hyperplane shifting method (Bouchard, Moore and Gosselin 2010;
Gouttefarde and Krut 2010) writes it as ``H w <= h``: every ``n - 1`` columns of ``A``
span a hyperplane with normal ``c``; the set lies between the two planes of normal
``+-c`` shifted to the largest value of ``c . A T`` over the tension box,

    h(c) = sum_j max(c . a_j t_min_j, c . a_j t_max_j),

which is ``+inf`` when an unbounded tension can raise it. For columns in general
position (no ``n`` of them linearly dependent) these planes are exactly the facets of
the set, so the inequalities are exact; extra planes are redundant but valid.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot

__all__ = ["facet_data", "facets_of", "subset_normals_reference", "wrench_facets"]


def wrench_facets(robot: CableRobot, poses: ArrayLike | None = None, *,
                  structure: ArrayLike | None = None,
                  bounds: tuple[ArrayLike, ArrayLike] | None = None
                  ) -> tuple[NDArray, NDArray]:
    """Inequalities ``H w <= h`` of the wrench-feasible set of each pose.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n), optional
        Poses (m, rad); not needed with ``structure``.
    structure : array_like, shape (N, n, m), optional
        Structure matrices to use instead of the poses' own.
    bounds : (array_like, array_like), each (m,) or (N, m), optional
        Tension bounds (N) replacing the robot's.

    Returns
    -------
    H : ndarray, shape (N, k, n)
        Unit normals, ``k = 2 C(m, n - 1)`` (a zero row where ``n - 1`` columns are
        dependent).
    h : ndarray, shape (N, k)
        Offsets (N, N m); ``+inf`` where the set is unbounded along the normal.
    """
    if structure is not None:
        A = np.asarray(structure, dtype=float)
        if A.ndim != 3 or A.shape[1:] != (robot.dof, robot.m) or not np.isfinite(A).all():
            raise InvalidInputError(
                f"structure must be finite with shape (N, {robot.dof}, {robot.m}), got "
                f"{A.shape}")
    elif poses is not None:
        A = robot.structure_matrices(poses)
    else:
        raise InvalidInputError("give poses or structure")
    N, _, m = A.shape
    lo, hi = (robot.t_min, robot.t_max) if bounds is None else bounds
    lb = np.broadcast_to(np.asarray(lo, dtype=float), (N, m))
    ub = np.broadcast_to(np.asarray(hi, dtype=float), (N, m))
    return facets_of(A, lb, ub)


def subset_normals_reference(A: NDArray, subsets: NDArray) -> NDArray:
    """Unit normals (N, S, n) of the hyperplanes spanned by the columns ``subsets``
    (S, n - 1) of each ``A`` (N, n, m); zero where those columns are dependent (the
    reference of :func:`tension_opt.kernels.facets.subset_normals`)."""
    N, n, _ = A.shape
    if n == 1:
        return np.ones((N, 1, 1))
    cols = np.swapaxes(A[:, :, subsets], 1, 2)  # (N, S, n, n-1)
    if n == 3:  # the cross product of the two columns
        c, d = cols[..., 0], cols[..., 1]
        normals = np.cross(c, d)
        size = np.linalg.norm(normals, axis=2)
        scale = np.linalg.norm(c, axis=2) * np.linalg.norm(d, axis=2)
        dependent = size <= 1e-12 * np.maximum(scale, 1e-300)
        with np.errstate(invalid="ignore", divide="ignore"):
            normals = normals / size[..., None]
        return np.where(dependent[..., None], 0.0, normals)
    _, sv, vt = np.linalg.svd(np.swapaxes(cols, 2, 3))  # rows: the n-1 columns
    normals = vt[..., -1, :]  # (N, S, n): orthogonal to the subset's columns
    dependent = sv[..., -1] <= 1e-12 * np.maximum(sv[..., 0], 1e-300)
    return np.where(dependent[..., None], 0.0, normals)


def facets_of(A: NDArray, lb: NDArray, ub: NDArray, normals: NDArray | None = None
              ) -> tuple[NDArray, NDArray]:
    """:func:`wrench_facets` of structure matrices ``A`` (N, n, m) and bounds ``lb, ub``
    (N, m) each; ``normals`` (N, S, n), if given, those of every ``n - 1`` columns."""
    H, h, _ = facet_data(A, lb, ub, normals)
    return H, h


def facet_data(A: NDArray, lb: NDArray, ub: NDArray, normals: NDArray | None = None
               ) -> tuple[NDArray, NDArray, NDArray]:
    """:func:`facets_of` and ``|H_r . a_j|`` (N, k, m), from one product of the normals
    and the columns (the facets come in pairs ``+-c``)."""
    _, n, m = A.shape
    if normals is None:
        subsets = np.array(list(itertools.combinations(range(m), n - 1)), dtype=int)
        normals = subset_normals_reference(A, subsets.reshape(len(subsets), n - 1))
    proj = normals @ A  # (N, S, m): c . a_j
    # The plane's own columns give c . a_j = 0 up to rounding, which an infinite t_max
    # must not turn into +inf.
    length = np.linalg.norm(A, axis=1)[:, None, :]
    proj[np.abs(proj) <= 1e-12 * np.maximum(length, 1e-300)] = 0.0
    lo, hi = lb[:, None, :], ub[:, None, :]
    with np.errstate(invalid="ignore"):
        up = np.where(proj > 0, proj * hi, proj * lo)  # the facet of normal +c
        down = np.where(proj < 0, -proj * hi, -proj * lo)  # and of -c
    zero = proj == 0  # 0 * inf
    h = np.concatenate([np.where(zero, 0.0, up).sum(axis=2),
                        np.where(zero, 0.0, down).sum(axis=2)], axis=1)
    size = np.abs(proj)
    return (np.concatenate([normals, -normals], axis=1), h,
            np.concatenate([size, size], axis=1))
