"""The certified closed form of the real-time path, compiled: one pose, a batch of
independent poses (each with its own previous tensions), or a stream in order.

Each pose runs the steps of the plain :func:`tension_opt.distribute` on the compiled
closed form (:mod:`tension_opt.kernels.certified`: geometry, the pose's form, the exact
closed form, and the certificate of
:meth:`TensionSolution.from_form <tension_opt.distribution.solution.TensionSolution.from_form>`:
the pose's scaled problem, its multipliers by the cheap dual solve, the primal
residual, dual residual and duality gap) and also the smoothing and rate limit of a
stream (:func:`~tension_opt.kernels.closed_form.form_terms`), so that
:class:`tension_opt.Distributor` labels a pose optimal only where its certificate
meets the accuracy target and its equilibrium and bounds hold, exactly as the plain
call does; the measures agree with the plain call's to rounding.

Codes: 0-4 the status (optimal, infeasible, unbounded, inaccurate, solver error),
:data:`~tension_opt.kernels.closed_form.CODE_FALLBACK` for a pose the caller solves by
the numpy path (a degenerate structure matrix, a cable on its drawing point, data
beyond the kernels' range, tensions that are not finite, or a certificate whose
sign-constrained refit (:func:`tension_opt.kernels.refit.pose_refit`, as
:func:`tension_opt.certify.certificate.certify` refits) is singular), and
:data:`~tension_opt.kernels.closed_form.CODE_BAD_INPUT` for a pose or wrench that is
not finite.

The packed problem is :func:`tension_opt.distribution.packing.pack_certified`'s
layout (:func:`tension_opt.kernels.closed_form.pack`, then the accuracy target, the
objective's code, the largest min-max weight, and the objective's weights and target
tensions, which these kernels do not read).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import carray, njit, prange, types
from numba.extending import intrinsic
from numpy.typing import NDArray

from tension_opt.kernels.certificate import pose_estimate, pose_measures
from tension_opt.kernels.closed_form import (
    CHUNK,
    CODE_BAD_INPUT,
    CODE_FALLBACK,
    HEADER,
    form_terms,
    plain,
    point4,
    point4_distance,
    pose_scales,
    solve_form,
    work_size,
)
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into
from tension_opt.kernels.refit import pose_refit, refit_work_size
from tension_opt.kernels.scaling import pose_scaled
from tension_opt.tolerances import FEASIBILITY_TOL, RIDGE, ROW_FLOOR, UB_SHARE

__all__ = [
    "INFO",
    "certified_batch",
    "certified_batch_serial",
    "certified_one",
    "certified_sequence",
    "certified_work_size",
    "matrix_at",
    "multipliers_offset",
    "vector_at",
]

#: Codes of :func:`_pose` for a pose whose certificate needs the refit (its equilibrium
#: and bounds held, or not), which :func:`certified_one` settles.
_REFIT, _REFIT_HELD = 10, 11
#: Columns of a batch's ``info`` array: unique, equilibrium residual, infeasibility,
#: primal residual, dual residual, duality gap.
INFO = 6


def multipliers_offset(m: int, n: int) -> int:
    """Where :func:`certified_one` leaves the certificate's scaled bound multipliers
    ``z`` (m,) of a problem without min-max term in its work array (the layout of
    :func:`_views`), for the Jacobian of the pose it solved."""
    return n * m + n + 4 * m + work_size(m, n) + 4 * n + 5 * m


@njit(cache=True)
def certified_work_size(m: int, n: int) -> int:
    """Floats of work space one pose of :func:`certified_one` needs, for ``m`` cables
    and ``n`` degrees of freedom (room for a min-max term's epigraph variable and rows
    whatever the problem)."""
    k, g = m + 1, m
    r = n + g
    form = n * m + n + 4 * m + work_size(m, n)
    certificate = 3 * n + 9 * k + n * k + 2 * g + g * k + k * r + r * r + r + n
    return form + certificate + refit_work_size(n, g, k)


@intrinsic
def _pointer(typingctx: Any, address: Any) -> Any:
    """``(double *) address``: an address (an integer) as a pointer, for
    :func:`numba.carray` (so the compiled caller holds no address of its own and numba
    can cache it)."""
    sig = types.CPointer(types.float64)(address)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        kind = context.get_value_type(types.CPointer(types.float64))
        return builder.inttoptr(args[0], kind)

    return sig, codegen


@njit(cache=True, error_model="numpy", inline="always")
def vector_at(address: int, offset: int, size: int) -> NDArray:
    """``size`` floats from float ``offset`` of the buffer at ``address``, as an array
    that owns nothing (no reference count: numba's views of an owned array count theirs
    with two atomic operations each, 280 ns for a pose's twenty-eight)."""
    return carray(_pointer(address + 8 * offset), size)  # type: ignore[call-arg]


@njit(cache=True, error_model="numpy", inline="always")
def matrix_at(address: int, offset: int, rows: int, cols: int) -> NDArray:
    """A C-ordered (rows, cols) array over the buffer at ``address`` (see :func:`vector_at`)."""
    return carray(_pointer(address + 8 * offset), (rows, cols))  # type: ignore[call-arg]


@njit(cache=True, error_model="numpy")
def _constants(data: NDArray) -> tuple[NDArray, ...]:
    """The problem's arrays over ``data`` (owning nothing, see :func:`vector_at`): anchors
    and attachments (m, 3), centre of mass (3,), and ``q0, c0, v, lb0, ub0, rate``
    (m,) (:func:`tension_opt.kernels.closed_form.pack`)."""
    m = int(data[1])
    a, o = data.ctypes.data, HEADER + 6 * m
    return (
        matrix_at(a, HEADER, m, 3),
        matrix_at(a, HEADER + 3 * m, m, 3),
        vector_at(a, 8, 3),
        vector_at(a, o, m),
        vector_at(a, o + m, m),
        vector_at(a, o + 2 * m, m),
        vector_at(a, o + 3 * m, m),
        vector_at(a, o + 4 * m, m),
        vector_at(a, o + 5 * m, m),
    )


@njit(cache=True, error_model="numpy")
def _views(data: NDArray, work: NDArray) -> tuple[tuple[NDArray, ...], tuple[NDArray, ...]]:
    """The pose's form arrays ``A, b, q, c, lb, ub, rest`` and the certificate's work
    arrays, over ``work`` (:func:`certified_work_size`); the certificate's are shaped
    for the problem (``k = m + 1`` variables and ``g = m`` rows with a min-max term,
    else ``k = m``, ``g = 0``). They own nothing: the caller keeps ``work`` alive
    while it uses them (it reads ``work`` once more at its end)."""
    m, n = int(data[1]), int(data[2])
    minmax = data[7] != 0.0
    k = m + 1 if minmax else m
    g = m if minmax else 0
    r = n + g
    a = work.ctypes.data
    o = 0
    A = matrix_at(a, o, n, m)
    o += n * m
    b = vector_at(a, o, n)
    o += n
    q, c, lb, ub = (
        vector_at(a, o, m),
        vector_at(a, o + m, m),
        vector_at(a, o + 2 * m, m),
        vector_at(a, o + 3 * m, m),
    )
    o += 4 * m
    rest = vector_at(a, o, work_size(m, n))
    o += work_size(m, n)
    rows, e, beq, y = (
        vector_at(a, o, n),
        vector_at(a, o + n, n),
        vector_at(a, o + 2 * n, n),
        vector_at(a, o + 3 * n, n),
    )
    o += 4 * n
    P, cs, lbs, ubs, x, z = (
        vector_at(a, o, k),
        vector_at(a, o + k, k),
        vector_at(a, o + 2 * k, k),
        vector_at(a, o + 3 * k, k),
        vector_at(a, o + 4 * k, k),
        vector_at(a, o + 5 * k, k),
    )
    o += 6 * k
    grad, shrink, station = vector_at(a, o, k), vector_at(a, o + k, k), vector_at(a, o + 2 * k, k)
    o += 3 * k
    Aeq = matrix_at(a, o, n, k)
    o += n * k
    G = matrix_at(a, o, g, k)
    o += g * k
    h, mu = vector_at(a, o, g), vector_at(a, o + g, g)
    o += 2 * g
    B = matrix_at(a, o, k, r)
    o += k * r
    H = matrix_at(a, o, r, r)
    o += r * r
    u = vector_at(a, o, r)
    o += r
    refit = vector_at(a, o, refit_work_size(n, g, k))
    return (
        (A, b, q, c, lb, ub, rest),
        (rows, P, cs, Aeq, beq, G, h, lbs, ubs, x, y, mu, z, B, H, u, grad, shrink, station, e,
         refit),
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _pose(
    data: NDArray,
    consts: tuple[NDArray, ...],
    pose: NDArray,
    wrench: NDArray,
    prev: NDArray,
    has_prev: bool,
    form: tuple[NDArray, ...],
    cert: tuple[NDArray, ...],
    T: NDArray,
) -> tuple[int, bool, float, float, float, float, float]:
    """One pose: geometry, its (smoothed) form, the closed form, the equilibrium
    residual and bound violation, the certificate and the status; ``consts`` the
    problem's arrays (:func:`_constants`), ``form`` and ``cert`` the views of
    :func:`_views`. Returns ``(code, unique, residual, infeasibility, primal, dual,
    gap)`` (NaN where unknown) and writes the tensions ``T`` (m,) (NaN where the pose
    has none).

    A hot numerical kernel: every step of a pose in one pass (inlined into
    :func:`certified_one`, the one caller, so that no array crosses a call), on the
    caller's work arrays.
    """
    anchors, attachments, com, q0, c0, v, lb0, ub0, rate = consts
    A, b, q, c, lb, ub, rest = form
    rows, P, cs, Aeq, beq, G, h, lbs, ubs, x, y, mu, z, B, H, u, grad, shrink, station, e, \
        _ = cert
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    o = HEADER + 12 * m
    target, vmax = data[o], data[o + 2]
    minmax, tol_factor = data[7] != 0.0, data[6]
    nan = np.nan
    finite = True
    for i in range(n):
        finite = finite and math.isfinite(pose[i]) and math.isfinite(wrench[i])
    if not finite:
        return CODE_BAD_INPUT, True, nan, nan, nan, nan, nan
    if (
        geometry_into(kind, anchors, attachments, com, data[3], data[4], pose, wrench, A, b)
        != GEOMETRY_OK
    ):
        return CODE_FALLBACK, True, nan, nan, nan, nan, nan
    form_terms(q0, c0, lb0, ub0, data[5], rate, prev, has_prev, q, c, lb, ub)
    quadratic = False
    for i in range(m):
        quadratic = quadratic or q[i] != 0.0
    # The closed form as the plain path solves the form (form_pose, its calls made here).
    status, once, infeas, settled, off = CODE_FALLBACK, True, nan, False, False
    ok = plain(A, b, lb, ub, q, c)
    if ok and n == 3 and m == 4 and not minmax:  # the four-cable shortcut first
        settled, once, off = point4(A, b, lb, ub, q, c, quadratic, T, rest)
    if off:
        infeas = point4_distance(lb, ub, rest)
    if settled:
        status = 0 if math.isnan(infeas) else 1
    elif ok:
        status, once, _, infeas = solve_form(
            A, b, lb, ub, q, c, v, minmax, FEASIBILITY_TOL, T, rest
        )
    solved = status == 0 or status == 3
    for i in range(m):  # a "solution" that is not finite goes to the numpy path
        if solved and not math.isfinite(T[i]):
            status = CODE_FALLBACK
    if status > 3:
        return CODE_FALLBACK, True, nan, nan, nan, nan, nan
    if not solved:  # infeasible or unbounded: no tensions, nothing to measure
        T[:] = nan
        return status, once, nan, infeas, nan, nan, nan
    # Equilibrium residual and bound violation (StandardForm's measures).
    total = 0.0
    for r in range(n):
        d = -b[r]
        for i in range(m):
            d += A[r, i] * T[i]
        e[r] = d
        total += d * d
    residual = math.sqrt(total)
    violation = 0.0
    for i in range(m):
        violation = max(violation, max(lb[i] - T[i], T[i] - ub[i]))
    # The certificate (certify_form): the pose's scaled problem, its multipliers by the
    # cheap dual solve, the three measures.
    s = pose_scaled(
        A,
        b,
        lb,
        ub,
        q,
        c,
        v,
        vmax,
        UB_SHARE,
        ROW_FLOOR,
        rows,
        P,
        cs,
        Aeq,
        beq,
        G,
        h,
        lbs,
        ubs,
        False,
    )
    lifted = True
    for i in range(m):
        x[i] = T[i] / s
        lifted = lifted and math.isfinite(x[i])
    if minmax:  # the epigraph variable: the smallest that holds
        top = -np.inf
        for i in range(m):
            top = max(top, x[i] * G[i, i])
        x[m] = top
    if not (lifted and math.isfinite(residual)):  # beyond the float range: numpy's
        return CODE_FALLBACK, True, nan, nan, nan, nan, nan
    pose_estimate(P, cs, Aeq, G, h, lbs, ubs, x, RIDGE, y, mu, z, B, H, u, grad, shrink)
    first, second, third = pose_measures(P, cs, Aeq, beq, G, h, lbs, ubs, x, y, mu, z, station)
    met = first <= target and second <= target and third <= target
    tol = tol_factor * pose_scales(A, b, lb)[1]
    held = residual <= tol and violation <= tol
    if first <= target and not met:  # the refit of certify, by the caller (not inlined)
        return _REFIT_HELD if held else _REFIT, once, residual, infeas, first, second, third
    code = 0 if met and held else 3
    return code, once, residual, infeas, first, second, third


@njit(cache=True, nogil=True, error_model="numpy")
def certified_one(
    data: NDArray,
    pose: NDArray,
    wrench: NDArray,
    prev: NDArray,
    has_prev: bool,
    work: NDArray,
    T: NDArray,
) -> tuple[int, bool, float, float, float, float, float]:
    """One pose, certified, allocating nothing.

    Parameters
    ----------
    data : ndarray
        The packed problem (see the module docstring).
    pose : ndarray, shape (n,)
    wrench : ndarray, shape (n,)
        External wrench besides gravity (N, N m); zeros for none.
    prev : ndarray, shape (m,)
        Previous tensions (N), read where ``has_prev`` (smoothing, rate limit).
    work : ndarray
        At least :func:`certified_work_size` floats, owned by the calling thread.
    T : ndarray, shape (m,)
        Tensions (N), written (NaN where the pose has none).

    Returns
    -------
    tuple
        ``(code, unique, residual, infeasibility, primal, dual, gap)``: the code (see
        the module docstring), whether the optimum is unique, the equilibrium residual
        (N, N m), the distance to feasibility of an infeasible pose (N), and the
        certificate's primal residual, dual residual and relative duality gap (NaN
        where unknown).
    """
    consts = _constants(data)
    form, cert = _views(data, work)
    result = _pose(data, consts, pose, wrench, prev, has_prev, form, cert, T)
    if result[0] == _REFIT or result[0] == _REFIT_HELD:
        result = _refitted(data, cert, result)
    if work.size < 0:  # never: work read after the views' last use (they own nothing)
        result = (CODE_FALLBACK, True, np.nan, np.nan, np.nan, np.nan, np.nan)
    return result


@njit(cache=True, nogil=True, error_model="numpy")
def _refitted(data: NDArray, cert: tuple[NDArray, ...],
              result: tuple[int, bool, float, float, float, float, float]
              ) -> tuple[int, bool, float, float, float, float, float]:
    """A pose :func:`_pose` left uncertified though primal feasible (codes
    :data:`_REFIT`, :data:`_REFIT_HELD`: its equilibrium and bounds held), after the
    sign-constrained refit of its multipliers (:func:`tension_opt.kernels.refit.pose_refit`,
    as :func:`tension_opt.certify.certificate.certify` refits)."""
    P, cs, Aeq, beq, G, h, lbs, ubs, x, y, mu, z = cert[1:13]
    station, refit = cert[18], cert[20]
    code, once, residual, infeas, first, second, third = result
    first, second, third, kept = pose_refit(P, cs, Aeq, beq, G, h, lbs, ubs, x, y, mu, z,
                                            (first, second, third), station, refit)
    if kept < 0:  # a singular fit: the numpy path's
        return CODE_FALLBACK, True, np.nan, np.nan, np.nan, np.nan, np.nan
    target = data[HEADER + 12 * int(data[1])]
    met = first <= target and second <= target and third <= target
    return 0 if met and code == _REFIT_HELD else 3, once, residual, infeas, first, second, third


@njit(cache=True, nogil=True, error_model="numpy")
def _batch_chunk(
    j: int | np.int64,
    data: NDArray,
    poses: NDArray,
    wrenches: NDArray,
    prev: NDArray,
    has_prev: bool,
    T: NDArray,
    info: NDArray,
    codes: NDArray,
) -> None:
    """Poses ``j * CHUNK ...`` of :func:`certified_batch`, with one work space; each
    pose by :func:`certified_one` (a call, not an inlined copy of every step: a third
    of the distributor's compile time, and measured no slower per pose)."""
    N, m, n = poses.shape[0], int(data[1]), int(data[2])
    work = np.empty(certified_work_size(m, n))
    for p in range(j * CHUNK, min(N, (j + 1) * CHUNK)):
        w = wrenches[p] if wrenches.shape[0] > 1 else wrenches[0]
        last = prev[p] if prev.shape[0] > 1 else prev[0]
        code, unique, res, infeas, first, second, third = certified_one(
            data, poses[p], w, last, has_prev, work, T[p]
        )
        codes[p] = code
        info[p, 0], info[p, 1], info[p, 2] = 1.0 if unique else 0.0, res, infeas
        info[p, 3], info[p, 4], info[p, 5] = first, second, third


@njit(cache=True, error_model="numpy", parallel=True)
def certified_batch(
    data: NDArray,
    poses: NDArray,
    wrenches: NDArray,
    prev: NDArray,
    has_prev: bool,
    T: NDArray,
    info: NDArray,
    codes: NDArray,
) -> None:
    """:func:`certified_one` over independent poses (N, n), in parallel over chunks of
    :data:`~tension_opt.kernels.closed_form.CHUNK` poses (one work space per chunk).

    ``wrenches`` (N, n) or (1, n) (one for every pose), ``prev`` (N, m) or (1, m);
    ``T`` (N, m), ``info`` (N, :data:`INFO`) and ``codes`` (N,) written.
    """
    for j in prange((poses.shape[0] + CHUNK - 1) // CHUNK):
        # An int64 index, as the serial kernel's: one compiled chunk serves both.
        _batch_chunk(np.int64(j), data, poses, wrenches, prev, has_prev, T, info, codes)


@njit(cache=True, nogil=True, error_model="numpy")
def certified_batch_serial(
    data: NDArray,
    poses: NDArray,
    wrenches: NDArray,
    prev: NDArray,
    has_prev: bool,
    T: NDArray,
    info: NDArray,
    codes: NDArray,
) -> None:
    """:func:`certified_batch` in the calling thread (the same arithmetic per pose)."""
    for j in range((poses.shape[0] + CHUNK - 1) // CHUNK):
        _batch_chunk(j, data, poses, wrenches, prev, has_prev, T, info, codes)


@njit(cache=True, nogil=True, error_model="numpy")
def certified_sequence(
    data: NDArray,
    poses: NDArray,
    wrenches: NDArray,
    last: NDArray,
    has_last: bool,
    T: NDArray,
    info: NDArray,
    codes: NDArray,
    start: int,
    work: NDArray,
) -> int:
    """Poses ``start, start + 1, ...`` in order, each smoothed against the last solved
    tensions (``last`` (m,), updated in place with those of every pose the closed form
    solves, optimal or inaccurate, as the plain sequence does; unsmoothed while there
    are none), as
    :func:`certified_one` answers each. Stops at a pose that needs the numpy path
    (codes from :data:`~tension_opt.kernels.closed_form.CODE_BAD_INPUT`) and returns its
    index (N when done). ``wrenches`` (N, n) or (1, n); ``T`` (N, m), ``info`` (N,
    :data:`INFO`) and ``codes`` (N,) written; ``work`` :func:`certified_work_size`
    floats. Each pose by :func:`certified_one`, as :func:`_batch_chunk` does."""
    for p in range(start, poses.shape[0]):
        w = wrenches[p] if wrenches.shape[0] > 1 else wrenches[0]
        code, unique, res, infeas, first, second, third = certified_one(
            data, poses[p], w, last, has_last, work, T[p]
        )
        codes[p] = code
        info[p, 0], info[p, 1], info[p, 2] = 1.0 if unique else 0.0, res, infeas
        info[p, 3], info[p, 4], info[p, 5] = first, second, third
        if code >= CODE_BAD_INPUT:
            return p
        if code == 0 or code == 3:  # solved: the plain sequence goes on from it too
            last[:] = T[p]
            has_last = True
    return poses.shape[0]
