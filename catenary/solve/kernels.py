"""Compiled (numba) kernels of the elastic catenary: the span equations of one cable,
the taut-branch Newton of :func:`catenary.solve.solve_length` and the Newton of
:func:`catenary.solve.solve_forces`, for one cable or many (in parallel).

The numpy implementations are the reference (:func:`catenary.elastic.evaluate`,
:mod:`catenary.solve.length_newton`, :mod:`catenary.solve.forces`): the same
nondimensional data (lengths over a power of two of the chord, forces over one of the
tension or force scale), formulas without cancellation, initial guess, Newton step,
safeguards, stopping rule and certificate (span residuals within ``RES_TOL`` of the
chord, end tension within ``T_TOL``). A cable the kernels do not settle that way
(vertical, weightless or zero-tension cables, a degenerate limit of the span formulas,
Newton not converging or leaving the taut branch, data beyond the double range) gets
the code :data:`FALLBACK`, and the caller solves it by the numpy path, whose closed
forms and bracketing searches cover every case; data the numpy path rejects get
:data:`INVALID`. Over a batch, :func:`solve_length_cables` also decides the cables
whose tension no catenary through both ends carries (:data:`INFEASIBLE`) and finds the
taut root of the ones Newton leaves, from the family of cables with that end tension
(:mod:`catenary.solve.kernels_bracket`); it runs groups of cables side by side in the
vector unit (:mod:`catenary.solve.kernels_lanes`), each cable getting the bits of the
one-at-a-time kernel (:func:`solve_length_cables_scalar`). These modules import numpy
and numba only; numba compiles them on first use and keeps the machine code on disk
(``cache=True``; numba checks a cached function against its own module only, so a
change to ``kernels_bracket`` alone needs this module's cache cleared).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from . import kernels_lanes as lanes
from .kernels_bracket import FEASIBLE, family_decision
from .kernels_bracket import INFEASIBLE as NO_MEMBER
from .kernels_spans import (
    EPS,
    RES_TOL,
    T_TOL,
    at,
    clip,
    hypot,
    nanmax,
    power_of_two,
    spans_call,
    spans_flex_call,
    spans_one,
    valid,
)

__all__ = ["CONVERGED", "FALLBACK", "INFEASIBLE", "INVALID", "PARALLEL_FROM", "hypot",
           "solve_forces_batch", "solve_forces_cables", "solve_forces_cables_parallel",
           "solve_forces_one", "solve_length_cables", "solve_length_cables_parallel",
           "solve_length_cables_scalar", "solve_length_one", "solve_length_serial",
           "spans_one"]

#: Codes of the solvers: certified, to be solved by the numpy path, invalid data, no
#: catenary through both ends carries the prescribed tension.
CONVERGED, FALLBACK, INVALID, INFEASIBLE = 0, 1, 2, 3
#: Cables from which a batch runs in parallel (below, waking threads costs more than
#: the work).
PARALLEL_FROM = 2048


@njit(cache=True, error_model="numpy")
def _initial(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float
             ) -> tuple[float, float, float]:
    """Near-straight guess ``(p, q, L0)`` (``_initial_length`` of
    :mod:`catenary.solve.length_newton`)."""
    c = hypot(x, z)
    cos_t, sin_t = x / c, z / c
    Tm = nanmax(T - 0.5 * w * z if at_b else T + 0.5 * w * z, 0.5 * T)
    t = 0.5 * w * x / Tm
    Ls = c + (t * t) * (c / 6.0)
    L0 = Ls / (1.0 + Tm * inv_EA)
    if not at_b:
        t = -t
    r = 1.0 / math.sqrt(1.0 + t * t)
    p = (cos_t - t * sin_t) * r
    q = (sin_t + t * cos_t) * r
    if p < 0.01:
        p, q = 0.01, math.copysign(math.sqrt(1.0 - 1e-4), q)
    return p, q, L0


#: Outcomes of one Newton step (:func:`_newton_step`): go on, converged on the taut
#: branch, stopped without (a small step off the fit or the branch, or a step to a
#: non-finite point), and a limit of the span formulas.
_GO_ON, _DONE, _STOPPED, _IRREGULAR = 0, 1, 2, 3
#: :func:`_length_start`'s code of data for Newton.
_NEWTON = -1
#: Cables per parallel task of :func:`solve_length_cables_parallel`.
_BLOCK = 256


@njit(cache=True, error_model="numpy")
def _newton_length(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                   rtol: float, max_iter: int
                   ) -> tuple[float, float, float, bool, int, bool]:
    """Newton in (end angle, ``L0``) on nondimensional data, as
    :func:`catenary.solve.length_newton.newton_length`: ``(p, q, L0, converged,
    iterations, regular)``; not converged, and not ``regular``, also where the span
    formulas reach a limit (which the numpy path's Newton passes)."""
    p, q, l0 = _initial(at_b, x, z, T, w, inv_EA)
    return _newton_from(at_b, x, z, T, w, inv_EA, p, q, l0, rtol, max_iter)


@njit(cache=True, error_model="numpy")
def _newton_from(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                 p: float, q: float, l0: float, rtol: float, max_iter: int
                 ) -> tuple[float, float, float, bool, int, bool]:
    """:func:`_newton_length` from the start ``(p, q, l0)``."""
    tol = RES_TOL * hypot(x, z)
    for its in range(1, max_iter + 1):
        p, q, l0, outcome = _newton_step(at_b, x, z, T, w, inv_EA, p, q, l0, rtol, tol)
        if outcome != _GO_ON:
            return p, q, l0, outcome == _DONE, its, outcome != _IRREGULAR
    return p, q, l0, False, max_iter, True


@njit(cache=True, error_model="numpy")
def _newton_step(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                 p: float, q: float, l0: float, rtol: float, tol: float
                 ) -> tuple[float, float, float, int]:
    """One step of :func:`_newton_from` from ``(p, q, l0)`` (``tol``: the span
    residual of a fit): the new point and the outcome (``_GO_ON``, ``_DONE``,
    ``_STOPPED``, ``_IRREGULAR``); the point stays where the step is not taken."""
    h = T * p
    v = T * q if at_b else T * q + w * l0
    va = v - w * l0 if at_b else T * q
    xs, zs, fxx, fxz, fzz, ta, tb, regular = spans_flex_call(h, v, l0, w, inv_EA, True)
    if not regular:
        return p, q, l0, _IRREGULAR
    rx, rz = xs - x, zs - z
    if at_b:
        xp, zp = h * fxz - v * fxx, h * fzz - v * fxz
        kk = 1.0 / ta + inv_EA
        xl, zl = h * kk, (v - w * l0) * kk
    else:
        xp, zp = h * fxz - va * fxx, h * fzz - va * fxz
        kk = 1.0 / tb + inv_EA
        xl, zl = h * kk, v * kk
    det = xp * zl - xl * zp
    dp = (xl * rz - zl * rx) / det
    dl = (zp * rx - xp * rz) / det
    ln = clip(l0 + dl, 0.5 * l0, 2.0 * l0)
    if dp * q > 0.9 * p:  # keep H > 0
        dp = 0.9 * p / q
    r = 1.0 / math.sqrt(1.0 + dp * dp)
    pn, qn = (p - dp * q) * r, (q + dp * p) * r
    if not (math.isfinite(pn) and math.isfinite(qn) and math.isfinite(ln)):
        return p, q, l0, _STOPPED
    if abs(dp) <= rtol and abs(dl) <= rtol * l0:
        # The taut branch has det < 0 at its root.
        fit = abs(rx) <= tol and abs(rz) <= tol
        return pn, qn, ln, _DONE if fit and det < 0.0 else _STOPPED
    return pn, qn, ln, _GO_ON


@njit(cache=True, error_model="numpy")
def solve_length_one(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                     rtol: float, max_iter: int, out: NDArray) -> int:
    """Taut catenary of one cable with tension ``T`` (N) at end B (``at_b``) or A.

    In units of the chord and of ``T`` (powers of two, as the numpy path), Newton from
    the near-straight guess, then the certificate. ``out`` (5,) gets ``(H, V_B, V_A,
    L0, iterations)`` (N, N, N, m) where solved. Returns :data:`CONVERGED` (certified)
    or :data:`FALLBACK`.
    """
    code, H, V_B, V_A, L0, its = _length_values(at_b, x, z, T, w, inv_EA, rtol, max_iter,
                                                False)
    if code == CONVERGED:
        out[0], out[1], out[2], out[3], out[4] = H, V_B, V_A, L0, its
    return code


@njit(cache=True, error_model="numpy")
def _length_values(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                   rtol: float, max_iter: int, decide: bool
                   ) -> tuple[int, float, float, float, float, int]:
    """:func:`solve_length_one` as ``(code, H, V_B, V_A, L0, iterations)``; with
    ``decide`` the family of the cable decides (:mod:`catenary.solve.kernels_bracket`)
    the data too light to be held, before Newton, and the cables Newton leaves:
    :data:`INFEASIBLE` (0 iterations, as the numpy path), or the taut member polished
    by the same Newton (its iterations added), the numpy path's bracketing search and
    polish."""
    code, ell, F, xs, zs, Ts, ws, ies, decide = _length_start(at_b, x, z, T, w, inv_EA,
                                                              decide)
    if code != _NEWTON:
        return code, np.nan, np.nan, np.nan, np.nan, 0
    p, q, l0, converged, its, regular = _newton_length(at_b, xs, zs, Ts, ws, ies, rtol,
                                                      max_iter)
    return _length_finish(at_b, xs, zs, Ts, ws, ies, ell, F, p, q, l0, converged, its,
                          regular, decide, rtol, max_iter)


@njit(cache=True, error_model="numpy")
def _length_start(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                  decide: bool) -> tuple[int, float, float, float, float, float, float,
                                         float, bool]:
    """The part of :func:`_length_values` before Newton: ``(code, ell, F, x, z, T, w,
    inv_EA, decide)``, the data in units of ``ell`` (m) and ``F`` (N); the code is
    ``_NEWTON`` for data Newton takes on, else :data:`FALLBACK` or :data:`INFEASIBLE`."""
    nan = np.nan
    if not (x > 0.0 and T > 0.0 and 0.0 <= w < np.inf and 0.0 <= inv_EA < np.inf
            and math.isfinite(x) and math.isfinite(z) and math.isfinite(T)):
        return FALLBACK, nan, nan, nan, nan, nan, nan, nan, False  # the numpy path decides
    ell, F = power_of_two(hypot(x, z)), power_of_two(T)
    xs, zs, Ts = x / ell, z / ell, T / F
    ws, ies = (w / F) * ell, inv_EA * F
    if not math.isfinite(ws * ies):
        return FALLBACK, nan, nan, nan, nan, nan, nan, nan, False
    decide = decide and ws > 0.0
    if decide and family_decision(at_b, xs, zs, Ts, ws, ies, False)[0] == NO_MEMBER:
        return INFEASIBLE, nan, nan, nan, nan, nan, nan, nan, False
    return _NEWTON, ell, F, xs, zs, Ts, ws, ies, decide


@njit(cache=True, error_model="numpy")
def _length_finish(at_b: bool, xs: float, zs: float, Ts: float, ws: float, ies: float,
                   ell: float, F: float, p: float, q: float, l0: float, converged: bool,
                   its: int, regular: bool, decide: bool, rtol: float, max_iter: int
                   ) -> tuple[int, float, float, float, float, int]:
    """The part of :func:`_length_values` after Newton (which ended at ``(p, q, l0)``):
    the family's decision where Newton did not settle the cable, the certificate, and
    the values in newtons and metres."""
    nan = np.nan
    if not converged and decide and regular:  # where the numpy path brackets
        outcome, p, q, l0 = family_decision(at_b, xs, zs, Ts, ws, ies, True)
        if outcome == NO_MEMBER:
            return INFEASIBLE, nan, nan, nan, nan, 0
        if outcome == FEASIBLE:  # polished as the numpy path's bracketed roots
            start = l0
            p, q, l0, converged, polish, _ = _newton_from(at_b, xs, zs, Ts, ws, ies, p,
                                                          q, l0, rtol, max_iter)
            its += polish
            converged = converged and abs(l0 - start) <= 1e-6 * start
    if not converged:
        return FALLBACK, nan, nan, nan, nan, its
    H = Ts * p
    V_A = Ts * q if not at_b else Ts * q - ws * l0
    V_B = Ts * q if at_b else V_A + ws * l0
    if not _certified(at_b, xs, zs, Ts, ws, ies, H, V_B, V_A, l0):
        return FALLBACK, nan, nan, nan, nan, its
    H, V_B, V_A, l0 = H * F, V_B * F, V_A * F, l0 * ell
    if not (math.isfinite(H) and math.isfinite(V_B) and math.isfinite(V_A)
            and math.isfinite(l0) and l0 > 0.0):
        return FALLBACK, nan, nan, nan, nan, its
    return CONVERGED, H, V_B, V_A, l0, its


@njit(cache=True, error_model="numpy")
def _certified(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
               H: float, V_B: float, V_A: float, L0: float) -> bool:
    """The certificate of ``_certify_length`` (:mod:`catenary.solve.length`), in the
    nondimensional units of the solve (the same test: the units are powers of two)."""
    got = hypot(H, V_B) if at_b else hypot(H, V_A)
    if not (abs(got - T) <= T_TOL * T and math.isfinite(V_A)):
        return False
    if not (math.isfinite(H) and math.isfinite(V_B) and math.isfinite(L0) and H >= 0
            and L0 > 0):
        return False
    xs, zs = spans_call(H, V_B, L0, w, inv_EA, True)[:2]
    tol = RES_TOL * hypot(x, z)
    return abs(xs - x) <= tol and abs(zs - z) <= tol


@njit(cache=True, error_model="numpy")
def solve_length_cables(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                       EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                       ints: NDArray) -> int:
    """:func:`solve_length_one` over ``n = out.shape[1]`` cables in the calling thread.

    ``x, z, T, w, EA`` have ``n`` entries or one (the same for every cable; ``w`` and
    ``EA`` may also be numbers, which compiles another variant). ``out``
    (4, n) gets rows ``(H, V_B, V_A, L0)``; ``ints`` (2, n) the code
    (:data:`CONVERGED`, :data:`INFEASIBLE`, :data:`FALLBACK`, or :data:`INVALID` for
    data the numpy path rejects) and the iterations. Beyond :func:`solve_length_one`,
    the family of each cable decides infeasible data (before Newton where a bound
    shows it) and the taut root of cables Newton does not settle. Returns the number
    of cables not :data:`CONVERGED`.
    """
    return _length_block(at_b, x, z, T, w, EA, rtol, max_iter, out, ints, 0,
                         out.shape[1])


@njit(cache=True, error_model="numpy")
def solve_length_cables_scalar(at_b: bool, x: NDArray, z: NDArray, T: NDArray,
                               w: NDArray, EA: NDArray, rtol: float, max_iter: int,
                               out: NDArray, ints: NDArray) -> int:
    """:func:`solve_length_cables` one cable at a time, without the vector unit's
    lockstep (the reference its side-by-side steps are tested against, bit for bit)."""
    unsettled = 0
    for k in range(out.shape[1]):
        xk, zk, Tk, wk, EAk = at(x, k), at(z, k), at(T, k), at(w, k), at(EA, k)
        if not valid(xk, zk, Tk, wk, EAk, True):
            ints[0, k], ints[1, k] = INVALID, 0
            unsettled += 1
            continue
        code, H, V_B, V_A, L0, its = _length_values(at_b, xk, zk, Tk, wk, 1.0 / EAk, rtol,
                                                    max_iter, True)
        ints[0, k], ints[1, k] = code, its
        out[0, k], out[1, k], out[2, k], out[3, k] = H, V_B, V_A, L0
        unsettled += 0 if code == CONVERGED else 1
    return unsettled


@njit(cache=True, error_model="numpy", parallel=True)
def solve_length_cables_parallel(at_b: bool, x: NDArray, z: NDArray, T: NDArray,
                                 w: NDArray, EA: NDArray, rtol: float, max_iter: int,
                                 out: NDArray, ints: NDArray) -> int:
    """:func:`solve_length_cables` over threads (a separate kernel: calling one compiled
    with ``parallel=True`` starts numba's threading layer, which a forked child of the
    process could not use), in blocks of ``_BLOCK`` cables."""
    n = out.shape[1]
    unsettled = 0
    for b in prange((n + _BLOCK - 1) // _BLOCK):
        # int64 bounds: the serial kernel's compiled _length_block serves (a prange
        # index is unsigned, and compiling another costs seconds).
        j = np.int64(b)
        unsettled += _length_block(at_b, x, z, T, w, EA, rtol, max_iter, out, ints,
                                   j * _BLOCK, min(n, (j + 1) * _BLOCK))
    return unsettled


@njit(cache=True, error_model="numpy")
def _length_block(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                  EA: NDArray, rtol: float, max_iter: int, out: NDArray, ints: NDArray,
                  start: int | np.int64, stop: int | np.int64) -> int:
    """Cables ``start .. stop - 1`` of :func:`solve_length_cables`, in groups of
    :data:`~catenary.solve.kernels_lanes.LANES` side by side in the vector unit
    (:mod:`catenary.solve.kernels_lanes`: start, Newton, certificate); returns how many
    are not :data:`CONVERGED`.

    Each cable gets the results and iterations of :func:`_length_values`, bit for bit:
    a lane the vector steps leave is finished, or solved from its start, by the scalar
    code here."""
    unsettled = 0
    W = np.zeros(lanes.FIELDS * lanes.LANES)
    for g in range(start, stop, lanes.LANES):
        count = min(lanes.LANES, stop - g)
        for j in range(lanes.LANES):
            k = g + min(j, count - 1)  # a short last group repeats its last cable
            W[lanes.at(lanes.F_RX, j)], W[lanes.at(lanes.F_RZ, j)], W[lanes.at(lanes.F_RT, j)] = (
                at(x, k), at(z, k), at(T, k))
            W[lanes.at(lanes.F_RW, j)], W[lanes.at(lanes.F_REA, j)] = at(w, k), at(EA, k)
        lanes.start_lanes(at_b, W)
        for j in range(count):
            if W[lanes.at(lanes.F_CODE, j)] == lanes.SCREEN:
                screen = family_decision(at_b, W[lanes.at(lanes.F_X, j)], W[lanes.at(lanes.F_Z, j)],
                                         W[lanes.at(lanes.F_T, j)], W[lanes.at(lanes.F_W, j)],
                                         W[lanes.at(lanes.F_IE, j)], False)[0]
                infeasible = screen == NO_MEMBER
                W[lanes.at(lanes.F_CODE, j)] = lanes.INFEASIBLE if infeasible else lanes.NEWTON
        lanes.newton_lanes(at_b, W, rtol, max_iter)
        lanes.finish_lanes(at_b, W)
        for j in range(count):
            unsettled += _lane_out(at_b, W, j, g + j, rtol, max_iter, out, ints)
    return unsettled


@njit(cache=True, error_model="numpy", inline="always")
def _lane_out(at_b: bool, W: NDArray, j: int, k: int, rtol: float, max_iter: int,
              out: NDArray, ints: NDArray) -> int:
    """Write the results of lane ``j`` of :func:`_length_block` (cable ``k``), solving
    it by the scalar code where the lane says so; 1 if not :data:`CONVERGED`."""
    code = W[lanes.at(lanes.F_CODE, j)]
    if code == lanes.INVALID:
        ints[0, k], ints[1, k] = INVALID, 0
        return 1
    if code == lanes.SCALAR:
        icode, H, V_B, V_A, L0, its = _length_values(
            at_b, W[lanes.at(lanes.F_RX, j)], W[lanes.at(lanes.F_RZ, j)],
            W[lanes.at(lanes.F_RT, j)], W[lanes.at(lanes.F_RW, j)],
            1.0 / W[lanes.at(lanes.F_REA, j)], rtol, max_iter, True)
    elif code == lanes.FINISH:
        outcome = W[lanes.at(lanes.F_OUT, j)]
        icode, H, V_B, V_A, L0, its = _length_finish(
            at_b, W[lanes.at(lanes.F_X, j)], W[lanes.at(lanes.F_Z, j)], W[lanes.at(lanes.F_T, j)],
            W[lanes.at(lanes.F_W, j)], W[lanes.at(lanes.F_IE, j)], W[lanes.at(lanes.F_ELL, j)],
            W[lanes.at(lanes.F_F, j)], W[lanes.at(lanes.F_P, j)], W[lanes.at(lanes.F_Q, j)],
            W[lanes.at(lanes.F_L0, j)], outcome == lanes.DONE, int(W[lanes.at(lanes.F_ITS, j)]),
            outcome != lanes.IRREGULAR, W[lanes.at(lanes.F_DECIDE, j)] != 0.0, rtol, max_iter)
    elif code == lanes.CONVERGED:
        icode, its = CONVERGED, int(W[lanes.at(lanes.F_ITS, j)])
        H, V_B = W[lanes.at(lanes.F_H, j)], W[lanes.at(lanes.F_VB, j)]
        V_A = W[lanes.at(lanes.F_VA, j)]
        L0 = W[lanes.at(lanes.F_LEN, j)]
    else:  # no certificate after Newton, data the kernel leaves, or infeasible
        icode = FALLBACK if code == lanes.FALLBACK else INFEASIBLE
        ran = code == lanes.FALLBACK and W[lanes.at(lanes.F_OUT, j)] != lanes.IDLE
        its = int(W[lanes.at(lanes.F_ITS, j)]) if ran else 0
        H = V_B = V_A = L0 = np.nan
    ints[0, k], ints[1, k] = icode, its
    out[0, k], out[1, k], out[2, k], out[3, k] = H, V_B, V_A, L0
    return 0 if icode == CONVERGED else 1


@njit(cache=True, error_model="numpy")
def _initial_forces(x: float, z: float, L0: float, w: float, inv_EA: float
                    ) -> tuple[float, float]:
    """Closed-form guess of ``(H, V_B)`` (:func:`catenary.solve.forces._initial_forces`):
    a parabolic cable along the chord, or the inextensible catenary of this length
    where the cable is well longer than its chord."""
    c = math.hypot(x, z)
    cos_t, sin_t = x / c, z / c
    e = L0 - c
    k = (w * cos_t) ** 2 * c ** 3 / 24.0
    a = L0 * inv_EA
    t_up = max(-e, 0.0) / a + np.cbrt(k / a)
    t_inext = math.sqrt(k / e) if e > 0 else np.nan
    T = t_up
    if e > 0:  # numpy.fmin: the other one where one is NaN
        T = t_inext if t_up != t_up else (t_up if t_inext != t_inext else min(t_up, t_inext))
    for _ in range(12):
        p = a * T ** 3 + e * T ** 2 - k
        dp = 3 * a * T ** 2 + 2 * e * T
        if dp > 0:
            T = T - p / dp
    H = T * cos_t
    V = T * sin_t + 0.5 * w * L0
    if e > 1e-3 * c:  # deeper sag: the inextensible catenary with this length
        R = math.sqrt(L0 - z) * math.sqrt(L0 + z) / x
        logR = math.log(R)
        lam = nanmax(math.sqrt(6.0 * (R - 1.0)), logR + math.log(2.0 * logR + 2.0))
        if R < 1.2:
            lam = math.sqrt(6.0 * (R - 1.0))
        for _ in range(30):
            lsh = lam + math.log1p(-math.exp(-2.0 * lam)) - math.log(2.0) - math.log(lam)
            d = 1.0 / math.tanh(lam) - 1.0 / lam
            lam = nanmax(lam - (lsh - logR) / d, 0.5 * lam)
        Hs = w * x / (2.0 * lam)
        Vs = 0.5 * w * (z / math.tanh(lam) + L0)
        if math.isfinite(Hs):
            H = Hs
        if math.isfinite(Vs):
            V = Vs
    return H, V


@njit(cache=True, error_model="numpy")
def _newton_forces(x: float, z: float, L0: float, w: float, inv_EA: float, H: float,
                   V: float, rtol: float, max_iter: int) -> tuple[float, float, bool, int]:
    """Safeguarded Newton on the span equations of one cable
    (:func:`catenary.solve.forces._newton_forces`): ``(H, V_B, converged, iterations)``;
    iterations -1 where the span formulas reach a limit the numpy path handles."""
    its = 0
    tol = RES_TOL * math.hypot(x, z)
    for _ in range(max_iter):
        xs, zs, fxx, fxz, fzz, _, _, regular = spans_flex_call(H, V, L0, w, inv_EA, False)
        if not regular:
            return H, V, False, -1
        rx, rz = xs - x, zs - z
        det = fxx * fzz - fxz * fxz
        dh = -(fzz * rx - fxz * rz) / det
        dv = -(fxx * rz - fxz * rx) / det
        its += 1
        hn = clip(H + dh, 0.1 * H, 10.0 * H)
        fscale = math.hypot(H, V) + w * L0
        vn = V + clip(dv, -10 * fscale, 10 * fscale)
        ok = math.isfinite(hn) and math.isfinite(vn)
        small_step = abs(dh) <= rtol * H and abs(dv) <= rtol * fscale
        tiny_res = (abs(rx) <= 2 * EPS * (x + L0)) and (abs(rz) <= 2 * EPS * (abs(z) + L0))
        if ok:
            H, V = hn, vn
        fit = abs(rx) <= tol and abs(rz) <= tol
        if ok and fit and (small_step or tiny_res):
            return H, V, True, its
        if not ok or (small_step and not fit):
            return H, V, False, its
    return H, V, False, its


@njit(cache=True, error_model="numpy")
def solve_forces_one(x: float, z: float, L0: float, w: float, inv_EA: float, rtol: float,
                     max_iter: int, out: NDArray) -> int:
    """End forces of one cable of unstretched length ``L0`` (m) (forward problem).

    The general case of :func:`catenary.solve.forces.solve_forces_flat` (``x > 0``,
    ``w > 0``, a feasible length): nondimensional data (lengths over a power of two of
    the chord, forces over one of the force scale), closed-form guess, Newton,
    certificate. ``out`` (4,) gets ``(H, V_B, V_A, iterations)`` (N) where solved.
    Returns :data:`CONVERGED` (certified) or :data:`FALLBACK` (the numpy path decides:
    weightless, vertical, infeasible, invalid data, Newton not converging).
    """
    code, H, V, its = _forces_values(x, z, L0, w, inv_EA, rtol, max_iter)
    if code == CONVERGED:
        out[0], out[1], out[2], out[3] = H, V, V - w * L0, its
    return code


@njit(cache=True, error_model="numpy")
def _forces_values(x: float, z: float, L0: float, w: float, inv_EA: float, rtol: float,
                   max_iter: int) -> tuple[int, float, float, int]:
    """:func:`solve_forces_one` as ``(code, H, V_B, iterations)``."""
    nan = np.nan
    if not (math.isfinite(x) and math.isfinite(z) and math.isfinite(L0) and L0 > 0.0
            and 0.0 < w < np.inf and 0.0 <= inv_EA < np.inf):
        return FALLBACK, nan, nan, 0
    c = math.hypot(x, z)
    if not x > 1e-15 * c or (inv_EA == 0.0 and L0 <= c):
        return FALLBACK, nan, nan, 0
    stretching = (c - L0) / (L0 * inv_EA) if c > L0 else 0.0
    force_scale = nanmax(w * max(c, L0), stretching)
    ell, F = power_of_two(c), power_of_two(force_scale)
    ws, ies = (w / F) * ell, inv_EA * F
    if not (math.isfinite(force_scale) and math.isfinite(ws * ies)):
        return FALLBACK, nan, nan, 0
    xs, zs, Ls = x / ell, z / ell, L0 / ell
    H0, V0 = _initial_forces(xs, zs, Ls, ws, ies)
    H, V, converged, its = _newton_forces(xs, zs, Ls, ws, ies, H0, V0, rtol, max_iter)
    if not converged:
        return FALLBACK, nan, nan, max(its, 0)
    H, V = H * F, V * F
    if not (math.isfinite(H) and math.isfinite(V) and H >= 0.0):
        return FALLBACK, nan, nan, its
    xc, zc = spans_call(H, V, L0, w, inv_EA, False)[:2]
    tol = RES_TOL * c
    if not (abs(xc - x) <= tol and abs(zc - z) <= tol):
        return FALLBACK, nan, nan, its
    return CONVERGED, H, V, its


@njit(cache=True, error_model="numpy")
def solve_forces_cables(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, EA: NDArray,
                       rtol: float, max_iter: int, out: NDArray, ints: NDArray) -> int:
    """:func:`solve_forces_one` over ``n = out.shape[1]`` cables in the calling thread.

    ``x, z, L0, w, EA`` have ``n`` entries or one. ``out`` (3, n) gets rows ``(H, V_B,
    V_A)``; ``ints`` (2, n) the code (:data:`CONVERGED`, :data:`FALLBACK`,
    :data:`INVALID`) and the iterations. Returns the number of cables not
    :data:`CONVERGED`.
    """
    unsettled = 0
    for i in range(out.shape[1]):
        unsettled += _forces_entry(x, z, L0, w, EA, rtol, max_iter, out, ints, i)
    return unsettled


@njit(cache=True, error_model="numpy", parallel=True)
def solve_forces_cables_parallel(x: NDArray, z: NDArray, L0: NDArray, w: NDArray,
                                 EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                                 ints: NDArray) -> int:
    """:func:`solve_forces_cables` over threads (see :func:`solve_length_cables_parallel`)."""
    unsettled = 0
    for k in prange(out.shape[1]):
        unsettled += _forces_entry(x, z, L0, w, EA, rtol, max_iter, out, ints, np.int64(k))
    return unsettled


@njit(cache=True, error_model="numpy")
def _forces_entry(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, EA: NDArray,
                  rtol: float, max_iter: int, out: NDArray, ints: NDArray,
                  k: int | np.int64) -> int:
    """Cable ``k`` of :func:`solve_forces_cables`; 1 if not :data:`CONVERGED`, else 0."""
    j = np.int64(k)  # a prange index is unsigned: mixed with 0 it would become a float
    xk, zk, Lk = x[j if x.size > 1 else 0], z[j if z.size > 1 else 0], L0[j if L0.size > 1 else 0]
    wk, EAk = w[j if w.size > 1 else 0], EA[j if EA.size > 1 else 0]
    if not valid(xk, zk, Lk, wk, EAk, False):
        ints[0, k], ints[1, k] = INVALID, 0
        return 1
    code, H, V, its = _forces_values(xk, zk, Lk, wk, 1.0 / EAk, rtol, max_iter)
    ints[0, k], ints[1, k] = code, its
    out[0, k], out[1, k], out[2, k] = H, V, V - wk * Lk
    return 0 if code == CONVERGED else 1


@njit(cache=True, error_model="numpy")
def solve_length_serial(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                        inv_EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                        codes: NDArray) -> None:
    """:func:`solve_length_one` over flat cables (K,) given their compliance, in the
    calling thread; ``out`` (K, 5), ``codes`` (K,) (the kernel alone, for timings)."""
    for k in range(x.size):
        codes[k] = solve_length_one(at_b, x[k], z[k], T[k], w[k], inv_EA[k], rtol,
                                    max_iter, out[k])


@njit(cache=True, error_model="numpy")
def solve_forces_batch(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, inv_EA: NDArray,
                       rtol: float, max_iter: int, out: NDArray, codes: NDArray,
                       parallel: bool) -> None:
    """:func:`solve_forces_one` over flat cables (K,) given their compliance, in the
    calling thread; ``out`` (K, 4), ``codes`` (K,) (the kernel alone, for timings;
    ``parallel`` is ignored)."""
    for k in range(x.size):
        codes[k] = solve_forces_one(x[k], z[k], L0[k], w[k], inv_EA[k], rtol, max_iter,
                                    out[k])
