"""Wrench-feasible workspace with cable sag: the coupled catenary model.

:func:`sag_workspace` is the sag-aware counterpart of
:func:`tension_opt.workspace.wrench_feasible_workspace`. Every cable hangs as an
elastic catenary and the catenary end forces at the platform balance the load (the
``"coupled"`` model of :func:`catenary.inverse_kinematics`). As there, the tension
bounds apply along the whole cable: ``t_min`` to the lowest tension of each cable
(at its lowest point when it dips below both ends, else at an end) and ``t_max`` to
the highest (at the drawing point for a cable hanging from above).

Per pose:

``feasible``
    The coupled inverse kinematics with the minimum-sum objective converged with
    every cable's lowest tension >= ``t_min`` and highest <= ``t_max`` (for every
    wrench of the set). It starts from the straight-line distribution; where that is
    infeasible but the margin iteration below found balanced catenaries within the
    bounds, from those tensions (``initial_tensions``): sag makes some poses feasible
    that straight cables cannot hold (long cables dipping below the platform pull it
    down, so the others may pull harder), and the default start would miss them.
``margin``
    The **coupled capacity margin** (N): the largest ``s`` for which platform-end
    tensions exist whose catenaries balance the load with every cable's lowest tension
    ``>= t_min + s`` and highest ``<= t_max - s`` (the smallest over the wrenches): the
    straight-line margin of :mod:`tension_opt.workspace` with the straight cables
    replaced by catenaries. :func:`coupled_margin` finds it by sequential linear
    programming on the platform-end tensions ``t``, on the equilibrium manifold:

    1. start from the maximiser of the straight-line margin, balanced by minimum-norm
       Newton corrections (raised by multiples of ``t_min`` where that fails);
    2. linearise the catenary end forces in ``t`` (as the coupled inverse kinematics
       does) and the lowest and highest tension of each cable (forward differences),
       and solve the max-min LP in the null space exactly
       (:func:`tension_opt.workspace.margin_solve`), keeping every ``t_i`` 0.1 % above
       the smallest tension any catenary of its span can carry
       (:func:`min_end_tension`);
    3. line search along that step: each trial is balanced again and accepted when the
       true margin (evaluated on the balanced catenaries) does not drop.

    It stops when the LP step vanishes, or when no fraction of it changes the tensions
    or the margin (a kink of the margin: a cable whose lowest point leaves its platform
    end, or where two bounds meet). Every iterate is a catenary equilibrium, so the
    margin reported is attained (``margin_residual`` is the proof); it is a local
    maximum of a non-convex problem, started from the straight one (checked against
    SLSQP from other starts in the tests). NaN where no balanced
    start was found (far outside the workspace: some cable would need less tension
    than any taut catenary of its span).
``tensions``, ``lengths``, ``sag_correction``
    The coupled minimum-sum tensions at the drawing points (N), the unstretched
    lengths (m) and ``max_i |L_sag,i - L_straight,i|`` (m), the largest length
    correction the sag (and stretch) asks of any cable; NaN where infeasible.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.backends import Backend
from tension_opt.executors import Executor, chunk_slices, run_chunks
from tension_opt.solution import Status, status_array
from tension_opt.workspace import (
    FEAS_TOL,
    Grid,
    WorkspaceResult,
    _bounds,
    _margins,
    _merge,
    margin_solve,
    on_drawing_point,
    prepare,
)

from .kinematics import (
    _cable_data,
    _cable_wrench,
    _catenary,
    _extreme_tensions,
    _force_slope,
    _Geometry,
    _geometry,
    _platform_forces,
    _wrenches,
    inverse_kinematics,
)

__all__ = ["SagWorkspaceResult", "coupled_margin", "min_end_tension", "sag_workspace"]

#: Default poses per chunk (the coupled model costs more per pose than the straight one).
CHUNK_SIZE = 4096
#: Step halvings of the margin iteration's line search.
_HALVINGS = 12
#: Newton corrections that bring trial tensions back to equilibrium, and their tolerance
#: (relative to the load or the largest tension, as the catenaries are solved to 1e-9).
_RESTORE_ITER = 30
_RESTORE_TOL = 1e-10
#: The margin iteration keeps every platform-end tension this fraction above the
#: smallest that a catenary of the span can carry (:func:`min_end_tension`).
_FLOOR_GAP = 1e-3
#: Relative size below which a step's change of the tensions and of the margin counts
#: as none (the iteration has reached a kink of the margin).
_KINK_TOL = 1e-7


@dataclass(eq=False, repr=False)  # the parent's one-line repr, not every array
class SagWorkspaceResult(WorkspaceResult):
    """:class:`~tension_opt.workspace.WorkspaceResult` of the coupled sag model.

    Attributes (besides those of the parent)
    ----------------------------------------
    sag_correction : ndarray, shape (N,)
        ``max_i |L_sag,i - L_straight,i|`` (m) of the minimum-sum coupled solution under
        the critical wrench; NaN where infeasible.
    lengths : ndarray, shape (N, m)
        Unstretched cable lengths (m) of that solution.
    straight_lengths : ndarray, shape (N, m)
        Straight-line lengths (m); NaN for a pose on a drawing point.
    equilibrium_residual : ndarray, shape (N,)
        Wrench left on the platform by the catenary end forces of the minimum-sum
        solution (N, N m).
    straight_margin : ndarray, shape (N,)
        Capacity margin of the straight-line model (N), for comparison.
    margin_status : ndarray of str, shape (N,)
        How the coupled margin iteration ended (see :func:`coupled_margin`):
        ``"converged"``, ``"stalled"``, ``"max_iter"``, ``"catenary_failed"``,
        ``"singular"`` or ``"unbounded"``.
    margin_iterations : ndarray of int, shape (N,)
        Linearised LPs solved for the margin (summed over the wrenches).
    margin_residual : ndarray, shape (N,)
        Equilibrium residual of the catenaries at the margin's tensions (N, N m).
    """

    sag_correction: NDArray = None  # type: ignore[assignment]
    lengths: NDArray = None  # type: ignore[assignment]
    straight_lengths: NDArray = None  # type: ignore[assignment]
    equilibrium_residual: NDArray = None  # type: ignore[assignment]
    straight_margin: NDArray = None  # type: ignore[assignment]
    margin_status: NDArray = None  # type: ignore[assignment]
    margin_iterations: NDArray = None  # type: ignore[assignment]
    margin_residual: NDArray = None  # type: ignore[assignment]

    QUANTITIES: ClassVar[dict[str, str]] = {
        **WorkspaceResult.QUANTITIES,
        "margin": "coupled capacity margin (N)",
        "sag_correction": "largest sag length correction (m)",
        "straight_margin": "straight-line capacity margin (N)",
        "equilibrium_residual": "equilibrium residual (N)",
    }

    def _extra_columns(self, frame: pd.DataFrame) -> None:
        frame["sag_correction"] = self.sag_correction
        frame["straight_margin"] = self.straight_margin
        frame["equilibrium_residual"] = self.equilibrium_residual
        frame["margin_status"] = self.margin_status
        for i in range(self.lengths.shape[1]):
            frame[f"L{i + 1}"] = self.lengths[:, i]


# ------------------------------------------------------------------- coupled margin
def min_end_tension(x: NDArray, z: NDArray, w: float) -> NDArray:
    """Smallest tension at end A of any inextensible catenary from A to B (N).

    With ``a = H / w`` and the vertex at ``s0`` from A, ``z = 2 a sinh((x - 2 s0) / 2a)
    sinh(x / 2a)`` and ``T_A = w a cosh(s0 / a)``; ``T_A`` falls from infinity (very
    short ``a``, deep sag) to a minimum and grows again with ``a`` (taut), so a
    golden-section search over ``log a`` finds it. Below it no catenary carries the
    tension; the catenary solver then spends long in its bracketing fallback to say so.

    Parameters
    ----------
    x, z : ndarray
        Horizontal span (m) > 0 and rise of B over A (m), any shape.
    w : float
        Weight per length (N/m) > 0.

    Returns
    -------
    ndarray
        Same shape as ``x``; 0 where ``x == 0`` (vertical cables are not screened).
    """
    xs = np.where(x > 0, x, 1.0)

    def tension(log_a: NDArray) -> NDArray:
        a = np.exp(log_a)
        s0 = 0.5 * xs - a * np.arcsinh(z / (2.0 * a * np.sinh(xs / (2.0 * a))))
        return w * a * np.cosh(s0 / a)

    lo, hi = np.log(xs / 1400.0), np.log(xs * 1e6)
    ratio = 0.5 * (np.sqrt(5.0) - 1.0)
    c, d = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    with np.errstate(over="ignore", invalid="ignore"):
        fc, fd = tension(c), tension(d)
        for _ in range(90):
            left = fc < fd
            hi, lo = np.where(left, d, hi), np.where(left, lo, c)
            new = np.where(left, hi - ratio * (hi - lo), lo + ratio * (hi - lo))
            fnew = tension(new)
            c, d = np.where(left, new, d), np.where(left, c, new)
            fc, fd = np.where(left, fnew, fd), np.where(left, fc, fnew)
        best = np.fmin(fc, fd)
    return np.where(x > 0, best, 0.0)


def _subset(geo: _Geometry, idx: NDArray) -> _Geometry:
    return _Geometry(*(getattr(geo, f)[idx] for f in geo.__dataclass_fields__))


def coupled_margin(
    robot: CableRobot,
    poses: ArrayLike,
    wrench: ArrayLike | None = None,
    backend: str | Backend = "auto",
    *,
    start: ArrayLike | None = None,
    tol: float = 1e-9,
    max_iter: int = 60,
    **options: Any,
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """Coupled (catenary) capacity margin of each pose; see the module docstring.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable``.
    poses : array_like, shape (N, n) or (n,)
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    backend : str or Backend
        For the linearised max-min LPs: ``"auto"`` (closed form for a one-dimensional
        null space, else an LP solver) or an LP backend.
    start : array_like, shape (N, m), optional
        Platform-end tensions to start from (N); default: the maximiser of the
        straight-line margin.
    tol : float
        Stop when the tensions change less than ``tol`` relative to the largest.
    max_iter : int
        Iteration limit.
    **options
        Passed to the LP backend.

    Returns
    -------
    margin : ndarray, shape (N,)
        Coupled capacity margin (N); NaN where not found, ``-inf`` where no tensions are
        in equilibrium.
    tensions : ndarray, shape (N, m)
        Platform-end tensions at the margin (N).
    status : ndarray of str, shape (N,)
        ``"converged"``; ``"stalled"`` (the line search found no better point although
        the step was not small) and ``"max_iter"``: margin of the last (balanced)
        tensions, a lower bound; ``"catenary_failed"`` (no balanced start): NaN;
        ``"singular"`` (no straight-line tensions balance the load): ``-inf``;
        ``"unbounded"``: ``+inf``; ``"solver_error"``.
    iterations : ndarray of int, shape (N,)
    residual : ndarray, shape (N,)
        Equilibrium residual of the catenaries at the returned tensions (N, N m).
    """
    w, EA = _cable_data(robot)
    p = robot.as_poses(poses)
    N, m = p.shape[0], robot.m
    geo = _geometry(robot, p)
    b = robot.required_wrench(p, wrench)
    lb, ub = _bounds(robot, N)
    ones = np.ones_like(lb)
    rows = list(robot.wrench_rows)
    status = np.full(N, "max_iter", dtype="<U15")
    iterations = np.zeros(N, np.int64)
    # Tensions below these hold no catenary (inextensible cables; others not screened).
    floor = min_end_tension(geo.x, geo.z, w) if np.isinf(EA) and w > 0 else np.zeros((N, m))
    # The iteration keeps the tensions a little above, where the catenary still turns
    # smoothly with its tension.
    keep_above = floor * (1.0 + _FLOOR_GAP)
    if start is None:
        A0 = robot.structure_matrices(p)
        s0, T, st0, _ = margin_solve(A0, b, lb, ones, ub, ones, backend, argmax=True,
                                     **options)
        assert T is not None
        # Lifted above the catenary floors; the balance is restored below.
        T = np.maximum(T, floor * (1.0 + 10 * _FLOOR_GAP))
        status[s0 == -np.inf] = "singular"
        status[s0 == np.inf] = "unbounded"
        status[~(st0 == Status.OPTIMAL)] = "solver_error"
    else:
        T = np.array(np.broadcast_to(np.asarray(start, dtype=float), (N, m)))
    scale = np.maximum(np.linalg.norm(b, axis=1), robot.weight)
    cat = np.full((4, N, m), np.nan)  # H, V_A, V_B, L0 of the current tensions T

    def catenaries(sel: NDArray, tens: NDArray) -> tuple[NDArray, NDArray]:
        """Catenaries (4, k, m) of poses ``sel`` at platform tensions ``tens`` (k, m) and
        whether all of a pose's cables are taut (k,)."""
        out = np.full((4, len(sel), m), np.nan)
        good = (np.isfinite(tens).all(axis=1) & (tens > 0).all(axis=1)
                & (tens >= floor[sel] * (1.0 - 1e-9)).all(axis=1))
        if good.any():
            g = np.flatnonzero(good)
            h, va, vb, l0, _, conv = _catenary(geo.x[sel[g]], geo.z[sel[g]], tens[g], w, EA,
                                               "A")
            out[:, g] = np.stack([h, va, vb, l0])
            good[g] = conv.all(axis=1)
        return out, good

    def linearise(sel: NDArray, tens: NDArray, c: NDArray) -> tuple[NDArray, NDArray]:
        """Wrench matrix (k, n, m) of the force slopes and the residual wrench (k, n)."""
        sub = _subset(geo, sel)
        force = _platform_forces(sub, c[0], c[1])
        slope = _force_slope(sub, c[0], c[1], c[2], c[3], w, EA)
        A = np.ascontiguousarray(np.swapaxes(_wrenches(slope, sub.arm, rows), 1, 2))
        return A, _wrenches(force, sub.arm, rows).sum(axis=1) - b[sel]

    def restore(sel: NDArray, tens: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Tensions near ``tens`` whose catenaries balance the load (minimum-norm Newton
        corrections); returns them, their catenaries and success (k,)."""
        tens = tens.copy()
        c, ok = catenaries(sel, tens)
        done = np.zeros(len(sel), bool)
        for _ in range(_RESTORE_ITER):
            todo = np.flatnonzero(ok & ~done)
            if not len(todo):
                break
            A, r = linearise(sel[todo], tens[todo], c[:, todo])
            size = np.maximum(scale[sel[todo]], np.abs(tens[todo]).max(axis=1))
            close = np.linalg.norm(r, axis=1) <= _RESTORE_TOL * size
            done[todo[close]] = True
            move = todo[~close]
            if not len(move):
                break
            Am, rm = A[~close], r[~close]
            with np.errstate(all="ignore"):
                y = np.linalg.solve(np.einsum("kim,kjm->kij", Am, Am), rm[..., None])[..., 0]
            delta = -np.einsum("kim,ki->km", Am, y)
            # Damped where the full correction leaves a catenary without a taut shape.
            left = np.arange(len(move))
            for _half in range(6):
                c_try, ok_try = catenaries(sel[move[left]], tens[move[left]] + delta[left])
                good = left[ok_try]
                tens[move[good]] += delta[good]
                c[:, move[good]] = c_try[:, ok_try]
                left = left[~ok_try]
                if not len(left):
                    break
                delta[left] *= 0.5
            ok[move[left]] = False
        return tens, c, ok & done

    def value(c: NDArray, sel: NDArray) -> NDArray:
        """Margin of catenaries ``c`` (4, k, m): the smallest distance to a bound (k,)."""
        low, high = _extreme_tensions(c[0], c[1], c[2])
        with np.errstate(invalid="ignore"):
            return np.minimum(low - lb[sel], ub[sel] - high).min(axis=1)

    active = np.flatnonzero(status == "max_iter")
    # Balanced from the start; where that fails (far outside the workspace, slack
    # cables), from the start with every tension raised by 1, 3, 10 times the largest
    # lower bound (straighter cables), until one balances.
    raise_by = lb.max(axis=1) + 1e-3 * robot.weight
    good = np.zeros(len(active), bool)
    for k in (0.0, 1.0, 3.0, 10.0):
        todo = np.flatnonzero(~good)
        if not len(todo):
            break
        sel = active[todo]
        trial, c_new, ok = restore(sel, T[sel] + k * raise_by[sel][:, None])
        T[sel[ok]], cat[:, sel[ok]] = trial[ok], c_new[:, ok]
        good[todo[ok]] = True
    status[active[~good]] = "catenary_failed"
    active = active[good]
    phi = np.full(N, np.nan)
    phi[active] = value(cat[:, active], active)
    alpha = np.ones(N)
    for _ in range(max_iter):
        if not len(active):
            break
        t, c = T[active], cat[:, active]
        A, r = linearise(active, t, c)
        low, high = _extreme_tensions(c[0], c[1], c[2])
        # Slopes of the lowest and highest tension in t (a forward difference; 1 for a
        # cable without dip whose platform end is its lowest point).
        dt = 1e-7 * t
        near = _catenary(geo.x[active], geo.z[active], t + dt, w, EA, "A")
        low2, high2 = _extreme_tensions(near[0], near[1], near[2])
        with np.errstate(all="ignore"):
            g_lo = (low2 - low) / dt
            g_hi = (high2 - high) / dt
        g_lo = np.where(np.isfinite(g_lo) & (g_lo > 1e-3), g_lo, 1.0)
        g_hi = np.where(np.isfinite(g_hi) & (g_hi > 1e-3), g_hi, 1.0)
        with np.errstate(invalid="ignore"):
            lo_c = t + (lb[active] - low) / g_lo
            hi_c = t + (ub[active] - high) / g_hi
        # Linearised equilibrium A t' = A t - r; max-min LP in the null space.
        rhs = np.einsum("kim,km->ki", A, t) - r
        s, T_new, st, _ = margin_solve(A, rhs, lo_c, 1.0 / g_lo, hi_c, 1.0 / g_hi, backend,
                                       argmax=True, reference=t, floor=keep_above[active],
                                       **options)
        assert T_new is not None
        iterations[active] += 1
        bad = ~(st == Status.OPTIMAL) | ~np.isfinite(s) | ~np.isfinite(T_new).all(axis=1)
        status[active[bad]] = np.where(s[bad] == np.inf, "unbounded",
                                       np.where(s[bad] == -np.inf, "catenary_failed",
                                                "solver_error"))
        active, t, full = active[~bad], t[~bad], (T_new - t)[~bad]
        done = np.abs(full).max(axis=1) <= tol * np.abs(t).max(axis=1)
        status[active[done]] = "converged"
        active, t, full = active[~done], t[~done], full[~done]
        # Line search on the true margin along the step, each trial balanced again:
        # accept where the margin does not drop, else halve the step.
        before = phi[active].copy()
        moved = np.zeros(len(active))
        pending = np.arange(len(active))
        for _half in range(_HALVINGS):
            if not len(pending):
                break
            sel = active[pending]
            trial, c_new, ok = restore(sel, t[pending] + alpha[sel][:, None] * full[pending])
            v = value(c_new, sel)
            ok &= v >= phi[sel] - 1e-12 * scale[sel]
            acc = np.flatnonzero(ok)
            moved[pending[acc]] = np.abs(trial[acc] - t[pending[acc]]).max(axis=1)
            T[sel[acc]], cat[:, sel[acc]], phi[sel[acc]] = trial[acc], c_new[:, acc], v[acc]
            alpha[sel[acc]] = np.minimum(2.0 * alpha[sel[acc]], 1.0)
            alpha[sel[~ok]] *= 0.5
            pending = pending[~ok]
        # Where the linearisation keeps proposing a step but no fraction of it moves the
        # tensions or raises the margin, the margin has a kink there (a cable whose lowest
        # point leaves its platform end, or two bounds meeting): a local maximum the
        # linear model cannot see. Else the line search has stalled.
        gain = phi[active] - before
        flat = (gain <= _KINK_TOL * scale[active]) & (
            moved <= _KINK_TOL * np.abs(t).max(axis=1))
        stalled = np.zeros(len(active), bool)
        stalled[pending] = True
        status[active[flat]] = "converged"
        status[active[stalled & ~flat]] = "stalled"
        active = active[~flat & ~stalled]
    margin = np.full(N, np.nan)
    margin[status == "singular"] = -np.inf
    margin[status == "unbounded"] = np.inf
    solved = np.isin(status, ("converged", "stalled", "max_iter"))
    margin[solved] = phi[solved]
    forces = _platform_forces(geo, cat[0], cat[1])
    with np.errstate(invalid="ignore"):
        residual = np.linalg.norm(_cable_wrench(robot, forces, geo.arm) - b, axis=1)
    T[~solved] = np.nan
    return margin, T, status, iterations, residual


# ------------------------------------------------------------------------ workspace
@dataclass(frozen=True)
class _SagTask:
    robot: CableRobot
    poses: NDArray
    wrenches: NDArray
    backend: str | Backend
    tol: float
    max_iter: int
    options: dict[str, Any]


def _sag_chunk(task: _SagTask) -> dict[str, Any]:
    """Coupled margins, feasibility, tensions and sag of one chunk of poses.

    Poses on a drawing point (:func:`~tension_opt.workspace.on_drawing_point`) are not
    computed: infeasible, margins ``-inf`` (margin status ``"singular"``), NaN tensions,
    lengths and sag, status ``INFEASIBLE``; so are no poses at all.
    """
    robot, P, W = task.robot, task.poses, task.wrenches
    N, K, m = P.shape[0], W.shape[0], robot.m
    out: dict[str, Any] = {
        "margins": np.full((N, K), -np.inf), "margin": np.full(N, -np.inf),
        "crit": np.zeros(N, dtype=np.intp), "feasible": np.zeros(N, dtype=bool),
        "tensions": np.full((N, m), np.nan), "status": status_array(N, Status.INFEASIBLE),
        "lengths": np.full((N, m), np.nan), "chords": np.full((N, m), np.nan),
        "sag": np.full(N, np.nan), "residual": np.full(N, np.nan),
        "straight": np.full(N, -np.inf), "mstat": np.full(N, "singular", dtype="<U15"),
        "miters": np.zeros(N, np.int64), "mresid": np.full(N, np.nan)}
    ok = ~on_drawing_point(robot, P) if N else np.zeros(0, dtype=bool)
    if ok.any():
        for key, value in _sag_chunk_poses(task, P[ok]).items():
            out[key][ok] = value
    return out


def _sag_chunk_poses(task: _SagTask, P: NDArray) -> dict[str, Any]:
    """:func:`_sag_chunk` of poses ``P`` (N, n) that keep every cable off its drawing
    point."""
    robot, W = task.robot, task.wrenches
    N, K, m = P.shape[0], W.shape[0], robot.m
    margins = np.full((N, K), np.nan)
    straight = np.full((N, K), np.nan)
    feasible_k = np.zeros((N, K), bool)
    m_status = np.empty((N, K), dtype="<U15")
    m_iters = np.zeros(N, np.int64)
    m_resid = np.full((N, K), np.nan)
    T_k = np.full((K, N, m), np.nan)
    L_k = np.full((K, N, m), np.nan)
    res_k = np.full((N, K), np.nan)
    chords = np.full((N, m), np.nan)
    ik_status = np.full((N, K), "infeasible", dtype="<U15")
    for k in range(K):  # a handful of wrenches; every pose at once inside
        wk = W[k] if W[k].any() else None
        s0, st0, typical, _ = _margins(robot, P, wk, task.backend, task.options)
        straight[:, k] = s0
        margins[:, k], T_m, m_status[:, k], its, m_resid[:, k] = coupled_margin(
            robot, P, wk, task.backend, tol=task.tol, max_iter=task.max_iter, **task.options)
        m_iters += its
        tol_k = FEAS_TOL * typical
        # The coupled inverse kinematics starts from the straight-line distribution where
        # it exists; where only the margin iteration found catenaries in equilibrium
        # within the bounds (sag can widen the workspace), it starts from those.
        certified = (m_status[:, k] == "converged") & (margins[:, k] >= -tol_k)
        plain = (st0 == Status.OPTIMAL) & (s0 >= -tol_k)
        start = np.where((certified & ~plain)[:, None], T_m, np.nan)
        idx = np.flatnonzero(plain | certified)
        for attempt in range(2):
            if not len(idx):
                break
            ik = inverse_kinematics(robot, P[idx], model="coupled", objective="min_sum",
                                    backend=task.backend, wrench=wk, tol=task.tol,
                                    max_iter=task.max_iter, initial_tensions=start[idx],
                                    **task.options)
            ik_status[idx, k] = ik.status
            feasible_k[idx, k] = ik.success
            T_k[k, idx] = ik.tensions
            L_k[k, idx] = ik.lengths
            res_k[idx, k] = ik.equilibrium_residual
            chords[idx] = ik.straight_lengths
            if attempt == 0:  # certified poses the first start missed: from the margin's
                idx = idx[~ik.success & certified[idx]]
                start[idx] = T_m[idx]
    missing = ~np.isfinite(chords).all(axis=1)
    if missing.any():
        chords[missing] = robot.inverse_kinematics(P[missing])[0]
    with np.errstate(invalid="ignore"):
        crit = np.argmin(np.where(np.isnan(margins), -np.inf, margins), axis=1)
    rows = np.arange(N)
    feasible = feasible_k.all(axis=1)
    tensions = T_k[crit, rows]
    lengths = L_k[crit, rows]
    tensions[~feasible] = np.nan
    lengths[~feasible] = np.nan
    sag = np.abs(lengths - chords).max(axis=1)
    status = status_array(N, Status.INFEASIBLE)
    status[feasible] = Status.OPTIMAL
    solver_failed = (ik_status == "max_iter").any(axis=1) & ~feasible
    status[solver_failed] = Status.MAX_ITER
    # The margin status of the critical wrench (worst first among failures).
    mstat = m_status[rows, crit]
    return {
        "margins": margins, "margin": margins[rows, crit], "crit": crit,
        "feasible": feasible, "tensions": tensions, "status": status, "lengths": lengths,
        "chords": chords, "sag": sag, "residual": res_k[rows, crit],
        "straight": straight[rows, crit], "mstat": mstat, "miters": m_iters,
        "mresid": m_resid[rows, crit],
    }


def sag_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
    backend: str | Backend = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    tol: float = 1e-9,
    max_iter: int = 60,
    **options: Any,
) -> SagWorkspaceResult:
    """Wrench-feasible workspace of the coupled catenary model (cables with sag).

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (linear mass, ``EA``); bounds ``t_min`` / ``t_max`` (N).
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad); see :func:`tension_opt.workspace.workspace_grid`.
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches besides gravity (N, N m), each to be held on its own.
    backend : str or Backend
        For the straight-line start, the linearised LPs of the margin and the coupled
        inverse kinematics (as :func:`catenary.inverse_kinematics`).
    executor, chunk_size, progress
        As :func:`tension_opt.workspace.wrench_feasible_workspace`.
    bounds : (array_like, array_like), optional
        The sampled box, shape (n,) each, finite, ``lower <= upper`` (m, rad), for
        :meth:`~tension_opt.workspace.WorkspaceResult.volume`; default for a
        :class:`~tension_opt.workspace.Grid`: its box.
    tol, max_iter
        Convergence of the coupled iterations (relative change of the tensions) and
        their iteration limit.
    **options
        Passed to the backend.

    Returns
    -------
    SagWorkspaceResult
        ``feasible``, coupled ``margin`` (N), min-sum coupled ``tensions`` (N, m),
        ``sag_correction`` (m) per pose, and the straight-line margin for comparison.
        A pose that puts a cable on its drawing point (zero length) does not stop the
        batch: it is reported infeasible with margins ``-inf`` (margin status
        ``"singular"``), NaN tensions, lengths and sag, status ``INFEASIBLE``. No poses
        (N = 0) give an empty result.
    """
    _cable_data(robot)  # fail early without cable properties
    P, W, layout = prepare(robot, poses, wrenches, bounds)
    # No poses: one empty chunk, so that the result has the right (empty) shapes.
    tasks = [_SagTask(robot, P[sl], W, backend, tol, max_iter, dict(options))
             for sl in chunk_slices(len(P), chunk_size)] or [
                 _SagTask(robot, P, W, backend, tol, max_iter, dict(options))]
    parts = run_chunks(_sag_chunk, tasks, executor, progress=progress,
                       description="sag workspace")
    out = _merge(parts, ("margins", "margin", "crit", "feasible", "tensions", "status",
                         "lengths", "chords", "sag", "residual", "straight", "mstat",
                         "miters", "mresid"))
    return SagWorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["margin"], tensions=out["tensions"],
        status=out["status"], margins=out["margins"], critical_wrench=out["crit"],
        wrenches=W, robot=robot, backend="coupled catenary", **layout,
        sag_correction=out["sag"], lengths=out["lengths"],
        straight_lengths=out["chords"], equilibrium_residual=out["residual"],
        straight_margin=out["straight"], margin_status=out["mstat"],
        margin_iterations=out["miters"], margin_residual=out["mresid"])

