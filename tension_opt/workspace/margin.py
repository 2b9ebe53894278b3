"""Capacity margin: how far the tensions that hold a wrench can stay from their bounds.

The capacity margin of a pose (N) under one wrench is::

    margin = max s  such that  A T = b,  t_min + s <= T <= t_max - s

the largest uniform distance that the tensions can keep from the nearest bound. It is
positive inside the wrench-feasible workspace, zero on its boundary, negative outside,
where ``-margin`` is the smallest largest bound violation of any tensions in
equilibrium (the infeasibility distance that :func:`tension_opt.distribute` reports
for the closed form), ``+inf`` when the tensions can grow without bound (no finite
``t_max`` and a strictly positive null vector of ``A``), and ``-inf`` when no tensions
at all satisfy ``A T = b`` (a singular pose whose structure matrix cannot produce the
wrench).

How it is computed
------------------
Tensions in equilibrium are ``T = T0 + Z z`` (minimum-norm particular solution and an
orthonormal null-space basis, from a batched SVD: :func:`tension_opt.problem.affine.solution_set`),
so the margin is the small linear program ``max s : a_l . z + s <= beta_l`` over the
bound lines ``l``. Its dual is ``min sum_l lambda_l beta_l`` over ``lambda >= 0``,
``sum lambda = 1``, ``sum lambda_l a_l = 0``, whose vertices have at most ``d + 1``
nonzeros (``d`` the null-space dimension). For ``d = 0, 1, 2`` all vertices are
enumerated at once for every pose (the minimum of a maximum of lines in 1-D,
triangles around the origin in 2-D): exact, no iteration. Otherwise, or when a backend
other than ``"closed_form"`` is named, the same LP with one extra variable goes to a
:mod:`tension_opt.backends` solver (:func:`margin_lp`).

:func:`margin_solve` takes general bounds ``lo_c + lo_g s <= T <= hi_c - hi_g s`` (the
capacity margin is ``lo_g = hi_g = 1``), which also serve linearised bounds such as
the sag-aware margin of :mod:`catenary.workspace`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend
from tension_opt.backends.lowdim import bound_lines, min_of_max_lines
from tension_opt.backends.registry import LP_ORDER, available_backends, choose_backend
from tension_opt.backends.settings import check_options
from tension_opt.checks import as_float_array
from tension_opt.errors import InvalidInputError, UnsupportedProblemError
from tension_opt.problem.affine import SolutionSet, solution_set
from tension_opt.problem.form import StandardForm, typical_tension
from tension_opt.robot import CableRobot
from tension_opt.status import STATUS_DTYPE, Status, status_array

__all__ = [
    "LP_CAP",
    "capacity_margin",
    "margin_lp",
    "margin_solve",
    "pose_margins",
    "robot_bounds",
]

#: Without a finite ``t_max`` the LP caps the margin at this many typical tensions.
LP_CAP = 1e6
#: Poses per block of the two-dimensional vertex enumeration (bounds its memory).
_BLOCK_2D = 1024
# A line whose slope is below this fraction of the largest is constant (flat).
_FLAT = 1e-14


# ------------------------------------------------------------------------ bounds
@dataclass(frozen=True)
class _Bounds:
    """Moving bounds ``lo_c + lo_g s <= T <= hi_c - hi_g s`` and a fixed ``floor <= T``,
    each (N, m) (see :func:`margin_solve`)."""

    lo_c: NDArray
    lo_g: NDArray
    hi_c: NDArray
    hi_g: NDArray
    floor: NDArray | None = None

    def take(self, index: NDArray) -> _Bounds:
        """The bounds of the poses ``index`` only."""
        floor = None if self.floor is None else self.floor[index]
        return _Bounds(self.lo_c[index], self.lo_g[index], self.hi_c[index],
                       self.hi_g[index], floor)


def _lines(T0: NDArray, Z: NDArray, bounds: _Bounds
           ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Bound lines ``a_l . z + gamma_l s <= beta_l`` of ``T = T0 + Z z`` (T0 (N, m), Z
    (N, m, d)): normals (N, L, d), gamma (N, L), beta (N, L) and validity (N, L).

    Infinite ``lo_c`` / ``hi_c`` give no line; lines absent for every pose are dropped.
    """
    a, beta, valid = bound_lines(T0, Z, bounds.lo_c, bounds.hi_c)
    gamma = np.concatenate([bounds.lo_g, bounds.hi_g], axis=1)
    keep = valid.any(axis=0)
    a, gamma, beta, valid = a[:, keep], gamma[:, keep], beta[:, keep], valid[:, keep]
    return a, np.where(valid, gamma, 1.0), beta, valid


# ------------------------------------------------------------ exact: dimension 0-2
def _maxmin_0d(beta: NDArray, gamma: NDArray, valid: NDArray) -> NDArray:
    """Margin when the tensions are unique: the smallest ``beta / gamma``, shape (N,)."""
    return np.where(valid, beta / gamma, np.inf).min(axis=1, initial=np.inf)


def _maxmin_1d(a: NDArray, gamma: NDArray, beta: NDArray, valid: NDArray,
               z_ref: NDArray | None = None, z_box: tuple[NDArray, NDArray] | None = None
               ) -> tuple[NDArray, NDArray | None]:
    """``max s : a_l z + gamma_l s <= beta_l`` over scalar ``z``, for all poses at once.

    ``s(z) = min_l (beta_l - a_l z) / gamma_l`` is concave, so ``-s`` is the maximum of
    lines that :func:`tension_opt.problem.affine.min_of_max_lines` minimises exactly.

    Parameters
    ----------
    a, gamma, beta, valid : ndarray, shape (N, L)
        ``gamma > 0``.
    z_ref : ndarray, shape (N,), optional
        Also return the maximiser closest to ``z_ref`` (the maximisers form an interval).
    z_box : (ndarray, ndarray), each shape (N,), optional
        Keep ``z`` in ``[lower, upper]`` (non-empty).

    Returns
    -------
    s : ndarray, shape (N,)
        ``+inf`` where unbounded.
    z : ndarray, shape (N,) or None
    """
    amax = np.abs(np.where(valid, a, 0.0)).max(axis=1, keepdims=True)
    flat = valid & (np.abs(a) <= _FLAT * amax)
    a = np.where(flat | ~valid, 0.0, a)
    inf = np.full(len(a), np.inf)
    lo_box, hi_box = (-inf, inf) if z_box is None else z_box
    _, value = min_of_max_lines(a / gamma, np.where(valid, -beta / gamma, -np.inf),
                                lo_box, hi_box)
    s = -value
    if z_ref is None and z_box is None:
        return s, None
    # The maximisers: where every line keeps s, an interval (a point up to rounding).
    with np.errstate(divide="ignore", invalid="ignore"):
        rhs = beta - gamma * s[:, None]
        hi = np.where(valid & (a > 0), rhs / a, np.inf).min(axis=1, initial=np.inf)
        lo = np.where(valid & (a < 0), rhs / a, -np.inf).max(axis=1, initial=-np.inf)
    inverted = lo > hi
    mid = 0.5 * (lo + hi)
    lo, hi = np.where(inverted, mid, lo), np.where(inverted, mid, hi)
    ref = np.zeros(len(s)) if z_ref is None else z_ref
    z = np.where(np.isfinite(s), np.clip(ref, lo, hi), ref)
    return s, np.clip(z, lo_box, hi_box)


def _cross(u: NDArray, v: NDArray) -> NDArray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _maxmin_2d(a: NDArray, gamma: NDArray, beta: NDArray, valid: NDArray) -> NDArray:
    """``max s : a_l . z + gamma_l s <= beta_l`` over ``z`` in R^2, shape (N,).

    Dual vertices: triangles of normals around the origin (``lambda`` from the cross
    products), antiparallel pairs, and lines with zero normal. ``+inf`` if none. (One
    loop body over blocks of poses: split into functions it runs about 10 % slower.)
    """
    N, L, _ = a.shape
    out = np.empty(N)
    norm = np.linalg.norm(a, axis=2)
    nmax = np.where(valid, norm, 0.0).max(axis=1, keepdims=True)
    flat = valid & (norm <= _FLAT * nmax)
    moving = valid & ~flat
    tri = np.array(list(itertools.combinations(range(L), 3)), dtype=int).reshape(-1, 3)
    duo = np.array(list(itertools.combinations(range(L), 2)), dtype=int).reshape(-1, 2)
    for start in range(0, N, _BLOCK_2D):
        sl = slice(start, min(start + _BLOCK_2D, N))
        aa, gg, bb, mv, nn = a[sl], gamma[sl], beta[sl], moving[sl], norm[sl]
        best = np.where(flat[sl], bb / gg, np.inf).min(axis=1, initial=np.inf)
        if len(tri):  # triangles around the origin
            i, j, k = tri.T
            ai, aj, ak = aa[:, i], aa[:, j], aa[:, k]
            c = np.stack([_cross(aj, ak), _cross(ak, ai), _cross(ai, aj)], axis=-1)
            det = c.sum(axis=-1)
            size = nn[:, i] * nn[:, j] + nn[:, j] * nn[:, k] + nn[:, k] * nn[:, i]
            ok = mv[:, i] & mv[:, j] & mv[:, k] & (np.abs(det) > 1e-12 * size)
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = c / det[..., None]
                ok &= (lam >= -1e-12).all(axis=-1)
                g3 = np.stack([gg[:, i], gg[:, j], gg[:, k]], axis=-1)
                b3 = np.stack([bb[:, i], bb[:, j], bb[:, k]], axis=-1)
                val = (lam * b3).sum(axis=-1) / (lam * g3).sum(axis=-1)
            best = np.minimum(best, np.where(ok, val, np.inf).min(axis=1, initial=np.inf))
        if len(duo):  # antiparallel pairs
            i, j = duo.T
            ai, aj = aa[:, i], aa[:, j]
            ni, nj = nn[:, i], nn[:, j]
            anti = (mv[:, i] & mv[:, j] & (np.abs(_cross(ai, aj)) <= 1e-12 * ni * nj)
                    & ((ai * aj).sum(axis=-1) < 0))
            with np.errstate(divide="ignore", invalid="ignore"):
                val = (nj * bb[:, i] + ni * bb[:, j]) / (nj * gg[:, i] + ni * gg[:, j])
            best = np.minimum(best, np.where(anti, val, np.inf).min(axis=1, initial=np.inf))
        out[sl] = best
    return out


def _exact_0d(T0: NDArray, bounds: _Bounds) -> NDArray:
    """Margin (N,) of poses with unique tensions ``T0`` (N, m)."""
    Z = np.zeros((*T0.shape, 0))
    _, g, beta, valid = _lines(T0, Z, bounds)
    margin = _maxmin_0d(beta, g, valid)
    if bounds.floor is not None:
        margin[(T0 < bounds.floor).any(axis=1)] = -np.inf
    return margin


def _floor_interval(T0: NDArray, n_vec: NDArray, floor: NDArray
                    ) -> tuple[tuple[NDArray, NDArray], NDArray]:
    """The interval of ``z`` with ``T0 + n z >= floor`` (each (N,)), and where it is empty."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (floor - T0) / n_vec
    z_lo = np.where(n_vec > 0, r, -np.inf).max(axis=1)
    z_hi = np.where(n_vec < 0, r, np.inf).min(axis=1)
    stuck = ((n_vec == 0) & (T0 < floor)).any(axis=1)
    empty = stuck | (z_lo > z_hi)
    return (np.where(empty, 0.0, z_lo), np.where(empty, 0.0, z_hi)), empty


def _exact_1d(T0: NDArray, n_vec: NDArray, bounds: _Bounds, argmax: bool,
              reference: NDArray | None) -> tuple[NDArray, NDArray | None]:
    """Margin (N,) and, with ``argmax``, a maximiser (N, m) along one null vector
    ``n_vec`` (N, m), the one closest to ``reference`` (default ``T0``)."""
    a, g, beta, valid = _lines(T0, n_vec[..., None], bounds)
    z_ref = z_box = empty = None
    if argmax:
        ref = T0 if reference is None else reference
        z_ref = np.einsum("nm,nm->n", ref - T0, n_vec)
    if bounds.floor is not None:
        z_box, empty = _floor_interval(T0, n_vec, bounds.floor)
    margin, z = _maxmin_1d(a[..., 0], g, beta, valid, z_ref, z_box)
    if empty is not None:  # no tensions above the floor
        margin[empty] = -np.inf
    T = T0 + z[:, None] * n_vec if argmax and z is not None else None
    return margin, T


def _exact_2d(T0: NDArray, Z: NDArray, bounds: _Bounds) -> NDArray:
    """Margin (N,) over a two-dimensional null space ``Z`` (N, m, 2)."""
    return _maxmin_2d(*_lines(T0, Z, bounds))


def _exact(solutions: SolutionSet, bounds: _Bounds, argmax: bool,
           reference: NDArray | None, margin: NDArray, T: NDArray | None) -> NDArray:
    """Fill ``margin`` (and ``T``) of the poses the closed form covers; return them
    as a mask (N,): null-space dimension 0, 1, or 2 without ``argmax`` or ``floor``."""
    handled = np.zeros(len(margin), dtype=bool)
    dim = solutions.dimension
    for d in (0, 1, 2):
        sel = np.flatnonzero(solutions.consistent & (dim == d))
        if not len(sel) or (d == 2 and (argmax or bounds.floor is not None)):
            continue
        T0, part = solutions.particular[sel], bounds.take(sel)
        if d == 0:
            margin[sel] = _exact_0d(T0, part)
            if T is not None:
                T[sel] = T0
        elif d == 1:
            ref = None if reference is None else reference[sel]
            margin[sel], T_sel = _exact_1d(T0, solutions.basis(sel, 1)[..., 0], part,
                                           argmax, ref)
            if T is not None and T_sel is not None:
                T[sel] = T_sel
        else:
            margin[sel] = _exact_2d(T0, solutions.basis(sel, 2), part)
        handled[sel] = True
    return handled


# --------------------------------------------------------------------- the LP path
def _lp_backend(backend: str | Backend, probe: StandardForm) -> Backend:
    """The backend for the LP path: the one named (checked), or the first installed of
    :data:`tension_opt.backends.registry.LP_ORDER` that can take ``probe``."""
    named = backend.name if isinstance(backend, Backend) else backend
    if named == "closed_form":
        raise UnsupportedProblemError(
            "the closed form covers null spaces of dimension 0, 1 and 2 only; name an LP "
            f"backend (installed: {[n for n in available_backends() if n != 'closed_form']})")
    return choose_backend(backend, probe, order=LP_ORDER, what="the margin LP")


def _margin_form(A: NDArray, b: NDArray, bounds: _Bounds
                 ) -> tuple[StandardForm, NDArray, NDArray]:
    """The margin LP as a :class:`StandardForm` in ``(y, s)``; the cap on ``s`` (N,) and
    whether each pose has a finite upper bound (N,). See :func:`margin_lp`."""
    N, _, m = A.shape
    lo_c, lo_g, hi_c, hi_g, floor = (bounds.lo_c, bounds.lo_g, bounds.hi_c, bounds.hi_g,
                                     bounds.floor)
    typical = typical_tension(A, b, lo_c)
    finite_hi = np.isfinite(hi_c)
    cols = np.flatnonzero(finite_hi.any(axis=0))
    big = lo_c + LP_CAP * typical[:, None]
    hi_fill = np.where(finite_hi, hi_c, big)
    A_aug = np.concatenate([A, np.einsum("nim,nm->ni", A, lo_g)[..., None]], axis=2)
    any_hi = finite_hi.any(axis=1)
    cap = np.where(any_hi, np.inf, LP_CAP * typical)
    lb = np.concatenate([lo_c, np.full((N, 1), -np.inf)], axis=1)
    ub = np.concatenate([np.full((N, m), np.inf), cap[:, None]], axis=1)
    c = np.zeros((N, m + 1))
    c[:, m] = -1.0
    G = h = None
    if len(cols):
        G = np.zeros((N, len(cols), m + 1))
        G[:, np.arange(len(cols)), cols] = 1.0
        G[:, :, m] = (lo_g + hi_g)[:, cols]
        h = hi_fill[:, cols]
    if floor is not None:  # T = y + lo_g s >= floor, whatever s
        F = np.zeros((N, m, m + 1))
        F[:, np.arange(m), np.arange(m)] = -1.0
        F[:, :, m] = -lo_g
        G = F if G is None else np.concatenate([G, F], axis=1)
        h = -floor if h is None else np.concatenate([h, -floor], axis=1)
    form = StandardForm(A_aug, b, lb, ub, np.zeros((N, m + 1)), c, G=G, h=h)
    return form, cap, any_hi


def _run_lp(solver: Backend, form: StandardForm, lo_g: NDArray, options: dict[str, Any]
            ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Solve a margin LP form: margin (N,), tensions (N, m), status (N,), solved (N,)."""
    m = lo_g.shape[1]
    raw = solver.solve_stage(form, **options)
    x = np.asarray(raw.tensions, dtype=float)
    status = np.asarray(raw.status).astype(STATUS_DTYPE)
    ok = (status == Status.OPTIMAL) | (status == Status.INACCURATE)
    s = np.where(ok, x[:, m], np.nan)
    T = x[:, :m] + lo_g * x[:, m:]
    T[~ok] = np.nan
    s[status == Status.INFEASIBLE] = -np.inf
    return s, T, status, ok


def _positive_null_vector(solver: Backend, A: NDArray, options: dict[str, Any]) -> NDArray:
    """Whether ``A`` (N, n, m) has a strictly positive null vector, shape (N,) of bool.

    With ``b = 0`` and ``t_min = 1`` the margin is -1 (``T = 0``) unless a positive
    null vector lets it grow to the cap.
    """
    N, n, m = A.shape
    ones = np.ones((N, m))
    unbounded_above = _Bounds(ones, ones, np.full((N, m), np.inf), ones)
    form, _, _ = _margin_form(A, np.zeros((N, n)), unbounded_above)
    s, _, _, _ = _run_lp(solver, form, ones, options)
    return s > 0


def margin_lp(backend: str | Backend, A: NDArray, b: NDArray, lo_c: NDArray,
              lo_g: NDArray, hi_c: NDArray, hi_g: NDArray, *, floor: NDArray | None = None,
              **options: Any) -> tuple[NDArray, NDArray, NDArray]:
    """The margin LP ``max s : A T = b, lo_c + lo_g s <= T <= hi_c - hi_g s`` by a backend.

    Written for the backend with ``y = T - lo_g s`` (a box bound ``y >= lo_c``), one
    extra column ``A lo_g`` for ``s`` and rows ``y_i + (lo_g_i + hi_g_i) s <= hi_c_i``
    for finite upper bounds. Without any finite upper bound ``s`` is capped at
    ``LP_CAP`` typical tensions; a pose at the cap is reported ``+inf`` when ``A`` has
    a strictly positive null vector (then the margin is unbounded).

    Parameters
    ----------
    backend : str or Backend
        An LP-capable backend name or ``"auto"``.
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lo_c, lo_g, hi_c, hi_g : ndarray, shape (N, m)
        ``lo_c`` finite; ``lo_g, hi_g > 0`` (N/N).
    floor : ndarray, shape (N, m), optional
        Lower bounds on ``T`` that do not move with ``s`` (N).
    **options
        Passed to the backend's solve.

    Returns
    -------
    margin : ndarray, shape (N,)
        ``-inf`` where no tensions satisfy ``A T = b`` (and ``floor``); NaN where the
        solver failed.
    tensions : ndarray, shape (N, m)
        A maximiser (N).
    status : ndarray of Status values, shape (N,)

    Raises
    ------
    UnsupportedProblemError
        For ``"closed_form"`` or a backend that does not take LPs.
    """
    bounds = _Bounds(lo_c, lo_g, hi_c, hi_g, floor)
    form, cap, any_hi = _margin_form(A, b, bounds)
    solver = _lp_backend(backend, form)
    s, T, status, ok = _run_lp(solver, form, lo_g, options)
    capped = ok & ~any_hi & (s >= cap * (1 - 1e-6))
    if capped.any():
        idx = np.flatnonzero(capped)
        unbounded = _positive_null_vector(solver, A[idx], options)
        s[idx[unbounded]] = np.inf
        status[idx[~unbounded]] = Status.INACCURATE
    return s, T, status


def _lp_part(A: NDArray, b: NDArray, bounds: _Bounds, backend: str | Backend, rest: NDArray,
             options: dict[str, Any], margin: NDArray, T: NDArray | None,
             status: NDArray) -> str:
    """Fill ``margin``, ``T`` and ``status`` of the poses ``rest`` by the margin LP;
    return the backend's name."""
    # The backend is chosen on one pose's form (without the floor rows).
    first = replace(bounds.take(rest[:1]), floor=None)
    solver = _lp_backend(backend, _margin_form(A[rest[:1]], b[rest[:1]], first)[0])
    part = bounds.take(rest)
    s, T_lp, st = margin_lp(solver, A[rest], b[rest], part.lo_c, part.lo_g, part.hi_c,
                            part.hi_g, floor=part.floor, **options)
    margin[rest] = s
    if T is not None:
        T[rest] = T_lp
    failed = ~((st == Status.OPTIMAL) | (st == Status.INACCURATE) | (st == Status.INFEASIBLE))
    status[rest[failed]] = st[failed]
    return solver.name


# ----------------------------------------------------------------------- entry points
def margin_solve(A: NDArray, b: NDArray, lo_c: NDArray, lo_g: NDArray, hi_c: NDArray,
                 hi_g: NDArray, backend: str | Backend = "auto", *, argmax: bool = False,
                 reference: NDArray | None = None, floor: NDArray | None = None,
                 **options: Any) -> tuple[NDArray, NDArray | None, NDArray, str]:
    """``max s : A T = b, lo_c + lo_g s <= T <= hi_c - hi_g s`` for a batch of poses.

    The capacity margin for ``lo_c = t_min, hi_c = t_max, lo_g = hi_g = 1``; other
    ``lo_g, hi_g`` serve linearised bounds (the sag-aware margin of
    :mod:`catenary.workspace`).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lo_c, hi_c : ndarray, shape (N, m)
        Bounds at ``s = 0`` (N); ``lo_c`` finite, ``hi_c`` may be ``inf``.
    lo_g, hi_g : ndarray, shape (N, m)
        Positive rates at which the bounds close in with ``s`` (N/N).
    backend : str or Backend
        ``"auto"``: closed form where the null space has dimension <= 2 (<= 1 with
        ``argmax``), the first installed LP solver elsewhere; ``"closed_form"``: closed
        form only; an LP backend name: that solver for every pose.
    argmax : bool
        Also return a maximiser.
    reference : ndarray, shape (N, m), optional
        With ``argmax``, where the maximisers form a set (null-space dimension 1): the
        one closest to ``reference`` (default: the minimum-norm solution ``T0``).
    floor : ndarray, shape (N, m), optional
        Lower bounds on ``T`` (N) that do not move with ``s`` (closed form for null
        spaces of dimension 0 and 1, LP otherwise).
    **options
        Passed to the LP backend.

    Returns
    -------
    margin : ndarray, shape (N,)
        ``+inf`` unbounded, ``-inf`` where ``A T = b`` has no solution, NaN where a
        solver failed.
    tensions : ndarray, shape (N, m), or None
        A maximiser (N) if ``argmax``.
    status : ndarray of Status values, shape (N,)
        ``OPTIMAL`` where the margin was found (also when negative or infinite), else
        the solver's status.
    method : str
        ``"closed_form"``, an LP backend name, or both joined by ``+``.
    """
    N, _, m = A.shape
    bounds = _Bounds(lo_c, lo_g, hi_c, hi_g, floor)
    solutions = solution_set(A, b)
    margin = np.full(N, np.nan)
    margin[~solutions.consistent] = -np.inf
    T = np.full((N, m), np.nan) if argmax else None
    status = status_array(N)
    used: list[str] = []
    handled = ~solutions.consistent
    if isinstance(backend, str) and backend in ("auto", "closed_form"):
        exact = _exact(solutions, bounds, argmax, reference, margin, T)
        if exact.any():
            used.append("closed_form")
        handled |= exact
    rest = np.flatnonzero(~handled)
    if len(rest):
        used.append(_lp_part(A, b, bounds, backend, rest, options, margin, T, status))
    return margin, T, status, "+".join(used)


#: Poses per chunk of :func:`capacity_margin` (peak memory is bounded by a chunk).
MARGIN_CHUNK = 4096


def robot_bounds(robot: CableRobot, N: int) -> tuple[NDArray, NDArray]:
    """The robot's tension bounds ``t_min``, ``t_max`` per pose, each (N, m) (N)."""
    lb = np.broadcast_to(np.asarray(robot.t_min, dtype=float), (N, robot.m))
    ub = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (N, robot.m))
    return np.array(lb), np.array(ub)


def pose_margins(robot: CableRobot, poses: NDArray, wrench: ArrayLike | None,
                 backend: str | Backend, options: dict[str, Any]
                 ) -> tuple[NDArray, NDArray, NDArray, str]:
    """Capacity margin of validated poses under one wrench.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Validated poses (m, rad) that keep every cable off its drawing point.
    wrench : array_like, shape (n,) or (N, n), or None
        External wrench besides gravity (N, N m).
    backend : str or Backend
        As in :func:`margin_solve`.
    options : dict
        Passed to the LP backend.

    Returns
    -------
    margin : ndarray, shape (N,)
        Capacity margin (N).
    status : ndarray of Status values, shape (N,)
    typical : ndarray, shape (N,)
        Typical tension of each pose (N), the scale of the feasibility tolerance.
    method : str
        How the margins were computed (see :func:`margin_solve`).
    """
    N = poses.shape[0]
    A = robot.structure_matrices(poses)
    b = robot.required_wrench(poses, wrench)
    lb, ub = robot_bounds(robot, N)
    ones = np.ones_like(lb)
    margin, _, status, method = margin_solve(A, b, lb, ones, ub, ones, backend, **options)
    return margin, status, typical_tension(A, b, lb), method


def capacity_margin(robot: CableRobot, poses: ArrayLike, wrench: ArrayLike | None = None,
                    backend: str | Backend = "auto", **options: Any) -> NDArray:
    """Capacity margin of each pose under one wrench (see the module docstring).

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    backend : str or Backend
        ``"auto"``/``"closed_form"``: exact enumeration where the null space has
        dimension <= 2 (LP elsewhere, for ``"auto"``); an LP backend name: that solver.
    **options
        Passed to the LP backend.

    Returns
    -------
    ndarray, shape (N,)
        Margin (N): positive inside, negative outside, ``+inf`` unbounded, ``-inf`` where
        no tensions are in equilibrium, NaN where a solver failed.
    """
    check_options(options)
    p = robot.as_poses(poses)
    N = len(p)
    w = None if wrench is None else as_float_array("wrench", wrench)
    per_pose = w is not None and w.ndim == 2 and w.shape[0] == N and N > 1
    if N <= MARGIN_CHUNK:
        return pose_margins(robot, p, wrench, backend, options)[0]
    # Chunks bound the working set (the 2-D enumeration holds ~20 kB per pose).
    margin = np.empty(N)
    for start in range(0, N, MARGIN_CHUNK):
        chunk = slice(start, start + MARGIN_CHUNK)
        try:
            margin[chunk] = pose_margins(robot, p[chunk],
                                         w[chunk] if per_pose and w is not None else w,
                                         backend, options)[0]
        except InvalidInputError as error:
            raise InvalidInputError(f"poses[{start}:{min(N, start + MARGIN_CHUNK)}]: "
                                    f"{error}") from None
    return margin
