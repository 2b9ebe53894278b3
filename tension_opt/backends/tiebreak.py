"""The tie-break of non-unique LP optima, shared by every backend.

An LP optimum is tested for uniqueness through the cone of feasible directions at the
solution (:func:`lp_optimum_is_unique`). A tie is broken to the minimum 2-norm point
of the optimal face: by a second QP stage over :func:`optimal_face` where the backend
takes QPs, exactly otherwise (:func:`face_min_norm`): by enumeration on a face of at
most two dimensions (:func:`low_dim_face_solve`), as a least-distance program solved
by non-negative least squares on a larger one (:func:`least_distance_face`), so that
every backend breaks a tie to the same tensions, rank-deficient robots included.

Both the test and the face use the multipliers of the solution's certificate
(:mod:`tension_opt.certify.certificate`) where they are given: a bound whose multiplier is
clearly nonzero (:data:`MULTIPLIER_TOL`) holds on the whole optimal face, so the face
keeps that cable at its bound and the test allows it no move; the other active bounds
are judged from the tensions as before.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends import lowdim
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import StandardForm

#: Relative tolerance (of the typical tension) for "at a bound" in the uniqueness test.
ACTIVE_TOL = 1e-6
#: A bound multiplier (scaled problem, where costs are of order one) above this holds its
#: bound on the whole optimal face.
MULTIPLIER_TOL = 1e-6
#: Relative singular value below which the cone's rows leave a direction free (a ray).
RANK_TOL = 1e-10
#: Largest weight, and residual of ``R^T y = 0`` relative to it that counts as zero, in
#: the positive-span test of the cone of feasible directions (:func:`_cone_has_ray`).
SPAN_WEIGHT = 1e6
SPAN_TOL = 1e-8


def held_bounds(form: StandardForm, T: NDArray, multipliers: NDArray | None
                ) -> tuple[NDArray, NDArray]:
    """Bounds that hold on the whole optimal face by their multipliers: lower and upper
    masks (N, m), each where the tension is at that bound and its multiplier (of the
    scaled problem, (N, m); ``< 0`` lower, ``> 0`` upper) is beyond :data:`MULTIPLIER_TOL`.
    Both masks are False without multipliers."""
    if multipliers is None:
        none = np.zeros(T.shape, dtype=bool)
        return none, none.copy()
    tol = ACTIVE_TOL * form.typical_tension()[:, None]
    with np.errstate(invalid="ignore"):
        lower = np.isfinite(form.lb) & (T <= form.lb + tol) & (multipliers < -MULTIPLIER_TOL)
        upper = np.isfinite(form.ub) & (T >= form.ub - tol) & (multipliers > MULTIPLIER_TOL)
    return lower, upper


def lp_optimum_is_unique(form: StandardForm, T: NDArray, multipliers: NDArray | None = None,
                         _square: bool = True) -> NDArray:
    """Whether LP optima ``T`` (N, m) are the only optima of their problems, shape (N,).

    The optimum is unique iff no direction ``d != 0`` keeps equilibrium, the objective
    and the active constraints: ``A d = 0``, ``c.d = 0`` (or, for min-max, ``v_i d_i <= 0``
    for the cables at the maximum), ``d_i >= 0`` at a lower bound, ``d_i <= 0`` at an
    upper bound, and ``d_i = 0`` where a bound holds by its multiplier
    (:func:`held_bounds`; ``multipliers`` (N, m) of the bounds in the scaled problem,
    optional). That cone lives in a space of dimension ``m - rank``: tested by sign
    checks in dimension 1 and by a positive-span test beyond (:func:`_cone_has_ray`).
    """
    N, m = T.shape
    scale = form.typical_tension()
    tol = ACTIVE_TOL * scale[:, None]
    held = np.logical_or(*held_bounds(form, T, multipliers))
    at_lb = np.isfinite(form.lb) & (T <= form.lb + tol) | held
    at_ub = np.isfinite(form.ub) & (T >= form.ub - tol) | held
    if form.minmax is not None:
        vals = T * form.minmax
        at_ub |= vals >= vals.max(axis=1, keepdims=True) - tol
        E = form.A
    else:
        E = np.concatenate([form.A, form.c[:, None, :]], axis=1)
    if form.G is not None:  # rows of G at equality behave as upper bounds on G d
        raise InvalidInputError("the uniqueness test does not take extra inequality rows")
    unique = np.ones(N, dtype=bool)
    if _square and E.shape[1] == m:
        # Square: a determinant far from zero against the rows' lengths (Hadamard's
        # bound) settles most poses without a singular value decomposition.
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero row: in doubt
            ratio = np.abs(np.linalg.det(E)) / np.prod(np.linalg.norm(E, axis=2), axis=1)
        doubt = np.flatnonzero(~(ratio > 1e-8))
        if not len(doubt):
            return unique
        unique[doubt] = lp_optimum_is_unique(
            form.subset(doubt), T[doubt],
            None if multipliers is None else multipliers[doubt], _square=False)
        return unique
    s = np.linalg.svd(E, compute_uv=False)
    rank = (s > 1e-10 * s[:, :1]).sum(axis=1)
    for k in np.unique(rank):
        dim = m - int(k)
        if dim == 0:
            continue
        sel = np.flatnonzero(rank == k)
        vt = np.linalg.svd(E[sel], full_matrices=True)[2]
        basis = np.swapaxes(vt[:, int(k):, :], 1, 2)  # (s, m, dim)
        lower, upper = at_lb[sel], at_ub[sel]
        if dim == 1:
            v = basis[..., 0]
            big = np.abs(v) > 1e-9 * np.abs(v).max(axis=1, keepdims=True)
            plus = ~((lower & big & (v < 0)) | (upper & big & (v > 0))).any(axis=1)
            minus = ~((lower & big & (v > 0)) | (upper & big & (v < 0))).any(axis=1)
            unique[sel] = ~(plus | minus)
            continue
        for row, j in enumerate(sel):
            unique[j] = not _cone_has_ray(basis[row], lower[row], upper[row])
    return unique


def _cone_has_ray(basis: NDArray, lower: NDArray, upper: NDArray) -> bool:
    """Whether ``{z : (B z)_i >= 0 at lower, (B z)_i <= 0 at upper}`` contains ``z != 0``.

    With ``R`` the constraint rows (``R z <= 0``), the cone is ``{0}`` exactly when the
    rows positively span the space: ``R`` has full column rank and some ``y > 0`` has
    ``R^T y = 0`` (the polar of the cone they generate is the whole space). The second
    is one bounded least-squares problem, ``min ||R^T y||`` over ``1 <= y <= SPAN_WEIGHT``,
    where the 2 dim linear programs of :func:`_cone_has_ray_lp` cost ten times as much.
    The cap on the weights keeps two rows that are opposite up to rounding from
    cancelling the rest with weights of 1e15; a residual within :data:`SPAN_TOL` of the
    largest weight counts as zero. A cone thinner than that is taken for ``{0}``, and a
    set that spans only with weights beyond the cap for a ray, which costs the tie-break
    a stage and never the answer.
    """
    from scipy.optimize import lsq_linear

    rows = np.concatenate([-basis[lower], basis[upper]])  # rows . z <= 0
    dim = basis.shape[1]
    if len(rows) <= dim:  # fewer than dim + 1 vectors never positively span
        return True
    s = np.linalg.svd(rows, compute_uv=False)
    if not s[0] > 0 or s[dim - 1] <= RANK_TOL * s[0]:  # a direction every row ignores
        return True
    fit = lsq_linear(rows.T, np.zeros(dim), bounds=(1.0, SPAN_WEIGHT), method="bvls")
    if fit.status < 1:  # no convergence: the linear programs decide
        return _cone_has_ray_lp(basis, lower, upper)
    return bool(np.linalg.norm(rows.T @ fit.x) > SPAN_TOL * fit.x.max())


def _cone_has_ray_lp(basis: NDArray, lower: NDArray, upper: NDArray) -> bool:
    """:func:`_cone_has_ray` by linear programs: the largest ``+-z_j`` over the cone
    within the unit box, for each coordinate ``j`` (the reference of the tests)."""
    from scipy.optimize import linprog

    rows = np.concatenate([-basis[lower], basis[upper]])  # rows . z <= 0
    dim = basis.shape[1]
    if len(rows) == 0:
        return True
    for j in range(dim):
        for sign in (1.0, -1.0):
            cost = np.zeros(dim)
            cost[j] = -sign
            res = linprog(cost, A_ub=rows, b_ub=np.zeros(len(rows)),
                          bounds=[(-1.0, 1.0)] * dim, method="highs")
            if res.status == 0 and -res.fun > 1e-9:
                return True
    return False


def optimal_face(form: StandardForm, T: NDArray, multipliers: NDArray | None = None
                 ) -> StandardForm:
    """Stage-two problem: minimum 2-norm over the optimal set of an LP solved at ``T``.

    The optimal value is relaxed by a relative ``1e-9`` so that a solver's rounding
    cannot make the face empty. With the bound ``multipliers`` (N, m) of the scaled
    problem, bounds that hold on the whole face (:func:`held_bounds`) keep their cable
    within the same relaxation of the bound.
    """
    N, m = T.shape
    scale = form.typical_tension()
    lower, upper = held_bounds(form, T, multipliers)
    if lower.any() or upper.any():
        room = (1e-9 * np.abs(T) + 1e-12 * scale[:, None])
        ub = np.where(lower, np.minimum(form.ub, form.lb + room), form.ub)
        lb = np.where(upper, np.maximum(form.lb, form.ub - room), form.lb)
        form = StandardForm(form.A, form.b, lb, ub, form.q, form.c, form.minmax,
                            form.problem, form.previous, form.G, form.h, form.reference)
    if form.minmax is not None:
        fstar = (T * form.minmax).max(axis=1)
        cap = (fstar + 1e-9 * np.abs(fstar) + 1e-12 * scale)[:, None] / form.minmax
        ub = np.minimum(form.ub, cap)
        return StandardForm(form.A, form.b, form.lb, ub, np.ones((N, m)), np.zeros((N, m)),
                            None, form.problem, form.previous)
    fstar = np.einsum("nm,nm->n", form.c, T)
    slack = 1e-9 * np.abs(fstar) + 1e-12 * scale * np.linalg.norm(form.c, axis=1)
    return StandardForm(form.A, form.b, form.lb, form.ub, np.ones((N, m)), np.zeros((N, m)),
                        None, form.problem, form.previous, G=form.c[:, None, :],
                        h=(fstar + slack)[:, None])


def low_dim_face_solve(form: StandardForm, T: NDArray, multipliers: NDArray | None = None
                       ) -> NDArray | None:
    """Minimum-norm point of the optimal face exactly, when that face is at most 2-D.

    Used by LP-only backends for the tie-break. Returns None if some face is larger.
    ``multipliers`` (N, m) as for :func:`optimal_face`.
    """
    face = optimal_face(form, T, multipliers)
    _N, m = T.shape
    if face.G is not None:
        E = np.concatenate([face.A, face.G], axis=1)
        _, s, vt = np.linalg.svd(E, full_matrices=True)
    else:
        _, s, vt = np.linalg.svd(face.A, full_matrices=True)
    rank = (s > 1e-10 * s[:, :1]).sum(axis=1)
    dims = m - rank
    if dims.max() > 2:
        return None
    out = T.copy()
    scale = form.typical_tension()
    for dim in (1, 2):
        sel = np.flatnonzero(dims == dim)
        if not len(sel):
            continue
        Z = np.swapaxes(vt[sel, m - dim:, :], 1, 2)
        T0 = T[sel]
        lb, ub = face.lb[sel], face.ub[sel]
        if dim == 1:
            n = Z[..., 0]
            lo, hi = lowdim.interval(T0, n, lb, ub, scale[sel])
            lo, hi = lowdim.widen(lo, hi, n, scale[sel])
            t = np.clip(-np.einsum("nm,nm->n", T0, n) / np.einsum("nm,nm->n", n, n), lo, hi)
            out[sel] = T0 + t[:, None] * n
        else:
            z, feasible = lowdim.qp_2d(T0, Z, lb, ub, np.ones_like(T0), np.zeros_like(T0),
                                        scale[sel])
            good = sel[feasible]
            out[good] = T0[feasible] + np.einsum("nmi,ni->nm", Z[feasible], z[feasible])
    return out


def face_min_norm(form: StandardForm, T: NDArray, multipliers: NDArray | None = None
                  ) -> tuple[NDArray, NDArray]:
    """Minimum-norm points of the optimal faces of LP optima ``T`` (N, m), exactly.

    Faces of at most two dimensions are enumerated (:func:`low_dim_face_solve`), larger
    ones solved as least-distance programs (:func:`least_distance_face`); ``multipliers``
    (N, m) as for :func:`optimal_face`.

    Returns
    -------
    tensions : ndarray, shape (N, m)
        The tie-broken tensions (N); the vertex ``T`` where no point was found.
    found : ndarray of bool, shape (N,)
    """
    small = low_dim_face_solve(form, T, multipliers)
    if small is not None:
        return small, np.ones(len(T), dtype=bool)
    out, found = T.copy(), np.zeros(len(T), dtype=bool)
    for k in range(len(T)):
        point = least_distance_face(form.subset(slice(k, k + 1)), T[k:k + 1],
                                    None if multipliers is None else multipliers[k:k + 1])
        if point is not None:
            out[k], found[k] = point, True
    return out, found


def least_distance_face(form: StandardForm, T: NDArray, multipliers: NDArray | None = None
                        ) -> NDArray | None:
    """Minimum-norm point of the optimal face of one pose's LP optimum ``T`` (1, m).

    With ``Z`` an orthonormal basis of the null space of ``A`` (rank-revealing SVD, so
    a rank-deficient ``A`` is fine) and ``T0`` the component of ``T`` orthogonal to it,
    the face's points are ``T0 + Z z`` with ``||T||^2 = ||T0||^2 + ||z||^2``: a
    least-distance program ``min ||z||  s.t.  M z >= r`` (bounds and the optimal-value
    row), solved exactly by non-negative least squares (Lawson and Hanson, *Solving
    Least Squares Problems*, ch. 23). Returns the tensions (m,), or None if rounding
    left the face empty. ``multipliers`` (1, m) as for :func:`optimal_face`.
    """
    from scipy.optimize import nnls

    face = optimal_face(form, T, multipliers)
    s = float(form.typical_tension()[0])
    _, sv, vt = np.linalg.svd(face.A[0], full_matrices=True)
    rank = int((sv > 1e-10 * sv[0]).sum()) if sv.size and sv[0] > 0 else 0
    Z = vt[rank:].T  # (m, d)
    T0 = T[0] - Z @ (Z.T @ T[0])
    lb, ub = face.lb[0], face.ub[0]
    low, high = np.isfinite(lb), np.isfinite(ub)
    M = [Z[low], -Z[high]]
    r = [lb[low] - T0[low], T0[high] - ub[high]]
    if face.G is not None and face.h is not None:
        M.append(-(face.G[0] @ Z))
        r.append(face.G[0] @ T0 - face.h[0])
    Mz, rz = np.concatenate(M), np.concatenate(r) / s  # in units of the typical tension
    if not len(Mz):
        return T0
    E = np.vstack([Mz.T, rz[None, :]])
    f = np.zeros(Z.shape[1] + 1)
    f[-1] = 1.0
    u, _ = nnls(E, f, maxiter=50 * E.shape[1])
    residual = E @ u - f
    if not residual[-1] < -1e-12:  # incompatible constraints: the face is empty
        return None
    return T0 + Z @ (-residual[:-1] / residual[-1] * s)
