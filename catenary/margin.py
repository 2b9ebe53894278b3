"""The coupled (catenary) capacity margin of a pose.

The **coupled capacity margin** (N) is the largest ``s`` for which platform-end tensions
exist whose catenaries balance the load with every cable's lowest tension
``>= t_min + s`` and highest ``<= t_max - s``: the straight-line margin of
:mod:`tension_opt.workspace.margin` with the straight cables replaced by catenaries (the
``"coupled"`` model of :func:`catenary.inverse_kinematics`). :class:`CoupledMargin`
finds it by sequential linear programming on the platform-end tensions ``t``, on the
equilibrium manifold:

1. start from the maximiser of the straight-line margin, balanced by minimum-norm
   Newton corrections (raised by multiples of ``t_min`` where that fails);
2. linearise the catenary end forces in ``t`` (as the coupled inverse kinematics
   does) and the lowest and highest tension of each cable (forward differences), and
   solve the max-min LP in the null space exactly
   (:func:`tension_opt.workspace.margin.margin_solve`), keeping every ``t_i`` 0.1 % above the
   smallest tension any catenary of its span can carry (:func:`min_end_tension`);
3. line search along that step: each trial is balanced again and accepted when the
   true margin (evaluated on the balanced catenaries) does not drop.

It stops when the LP step vanishes, or when no fraction of it changes the tensions or
the margin (a kink of the margin: a cable whose lowest point leaves its platform end,
or where two bounds meet). Every iterate is a catenary equilibrium, so the margin
reported is attained (the residual is the proof); it is a local maximum of a
non-convex problem, started from the straight one. NaN where no balanced start was
found (far outside the workspace: some cable would need less tension than any taut
catenary of its span).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.backends import Backend
from tension_opt.status import Status, status_array
from tension_opt.workspace.margin import margin_solve, robot_bounds

from .geometry import (
    cable_data,
    cable_planes,
    equilibrium_residual,
    extreme_tensions,
    force_slope,
    platform_forces,
    taut_catenaries,
)

__all__ = ["CoupledMargin", "CoupledMarginResult", "coupled_margin", "min_end_tension"]

#: Step halvings of the margin iteration's line search.
HALVINGS = 12
#: Newton corrections that bring trial tensions back to equilibrium, and their tolerance
#: (relative to the load or the largest tension, as the catenaries are solved to 1e-9).
RESTORE_ITER = 30
RESTORE_TOL = 1e-10
#: The margin iteration keeps every platform-end tension this fraction above the
#: smallest that a catenary of the span can carry (:func:`min_end_tension`).
FLOOR_GAP = 1e-3
#: Relative size below which a step's change of the tensions and of the margin counts
#: as none (the iteration has reached a kink of the margin).
KINK_TOL = 1e-7


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


@dataclass(frozen=True, eq=False)
class CoupledMarginResult:
    """Coupled capacity margins of a batch of poses (:class:`CoupledMargin`).

    Attributes
    ----------
    margin : ndarray, shape (N,)
        Coupled capacity margin (N); NaN where not found, ``-inf`` where no tensions
        are in equilibrium, ``+inf`` where unbounded.
    tensions : ndarray, shape (N, m)
        Platform-end tensions at the margin (N); NaN where there is no margin.
    status : ndarray of str, shape (N,)
        ``Status.CONVERGED``; ``"stalled"`` (the line search found no better point
        although the step was not small) and ``Status.MAX_ITER``: margin of the last
        (balanced) tensions, a lower bound; ``"catenary_failed"`` (no balanced start):
        NaN; ``"singular"`` (no straight-line tensions balance the load): ``-inf``;
        ``Status.UNBOUNDED``: ``+inf``; ``Status.SOLVER_ERROR``.
    iterations : ndarray of int, shape (N,)
        Linearised LPs solved.
    residual : ndarray, shape (N,)
        Equilibrium residual of the catenaries at the returned tensions (N, N m).
    """

    margin: NDArray
    tensions: NDArray
    status: NDArray
    iterations: NDArray
    residual: NDArray

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: margin, status, iterations, residual, tensions."""
        frame = pd.DataFrame(self.tensions,
                             columns=[f"T{i + 1}" for i in range(self.tensions.shape[1])])
        frame.insert(0, "pose", np.arange(len(self.margin)))
        frame.insert(1, "status", self.status)
        frame.insert(2, "margin", self.margin)
        frame["iterations"] = self.iterations
        frame["residual"] = self.residual
        return frame


class CoupledMargin:
    """Sequential linear programming of the coupled margin for one batch of poses.

    Built once per batch; :meth:`solve` runs the iteration (see the module docstring)
    and keeps its state: the current platform-end tensions ``tensions`` (N, m), their
    catenaries ``cables`` (4, N, m) (``H, V_A, V_B, L0``), the true margin of those
    ``value`` (N,), the line-search step fraction ``step_size`` (N,), ``status`` and
    ``iterations`` (N,).

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
    tol : float
        Stop when the tensions change less than ``tol`` relative to the largest.
    max_iter : int
        Iteration limit.
    **options
        Passed to the LP backend.

    Attributes
    ----------
    floor : ndarray, shape (N, m)
        Tensions below which no catenary exists (inextensible cables; 0 otherwise).
    """

    def __init__(self, robot: CableRobot, poses: ArrayLike, wrench: ArrayLike | None = None,
                 backend: str | Backend = "auto", *, tol: float = 1e-9, max_iter: int = 60,
                 **options: Any) -> None:
        self.w, self.EA = cable_data(robot)
        self.robot = robot
        self.poses = robot.as_poses(poses)
        self.planes = cable_planes(robot, self.poses)
        self.required = robot.required_wrench(self.poses, wrench)
        self.backend, self.tol, self.max_iter, self.options = backend, tol, max_iter, options
        N, m = self.poses.shape[0], robot.m
        self.lb, self.ub = robot_bounds(robot, N)
        screened = np.isinf(self.EA) and self.w > 0
        self.floor = (min_end_tension(self.planes.x, self.planes.z, self.w) if screened
                      else np.zeros((N, m)))
        # The iteration keeps the tensions a little above, where the catenary still turns
        # smoothly with its tension.
        self.keep_above = self.floor * (1.0 + FLOOR_GAP)
        self.scale = np.maximum(np.linalg.norm(self.required, axis=1), robot.weight)
        self._reset()

    def _reset(self) -> None:
        N, m = self.poses.shape[0], self.robot.m
        self.tensions = np.full((N, m), np.nan)
        self.cables = np.full((4, N, m), np.nan)
        self.value = np.full(N, np.nan)
        self.step_size = np.ones(N)
        self.status = status_array(N, Status.MAX_ITER)
        self.iterations = np.zeros(N, np.int64)

    def solve(self, start: ArrayLike | None = None) -> CoupledMarginResult:
        """Run the iteration.

        Parameters
        ----------
        start : array_like, shape (N, m), optional
            Platform-end tensions to start from (N); default: the maximiser of the
            straight-line margin.
        """
        self._reset()
        if start is None:
            self._straight_start()
        else:
            self.tensions = np.array(np.broadcast_to(np.asarray(start, dtype=float),
                                                     self.tensions.shape))
        active = self._balanced_start(np.flatnonzero(self.status == Status.MAX_ITER))
        self.value[active] = self._value(self.cables[:, active], active)
        for _ in range(self.max_iter):
            if not len(active):
                break
            active, t, full = self._lp_step(active)
            if len(active):
                active = self._line_search(active, t, full)
        return self._result()

    # ------------------------------------------------------------------- start
    def _straight_start(self) -> None:
        """The maximiser of the straight-line margin, lifted above the catenary floors
        (the balance is restored by :meth:`_balanced_start`)."""
        ones = np.ones_like(self.lb)
        A0 = self.robot.structure_matrices(self.poses)
        s0, T, st0, _ = margin_solve(A0, self.required, self.lb, ones, self.ub, ones,
                                     self.backend, argmax=True, **self.options)
        assert T is not None  # argmax=True
        self.tensions = np.maximum(T, self.floor * (1.0 + 10 * FLOOR_GAP))
        self.status[s0 == -np.inf] = Status.SINGULAR
        self.status[s0 == np.inf] = Status.UNBOUNDED
        self.status[~(st0 == Status.OPTIMAL)] = Status.SOLVER_ERROR

    def _balanced_start(self, active: NDArray[np.intp]) -> NDArray[np.intp]:
        """Balance the start tensions of poses ``active``; returns those balanced.

        Where that fails (far outside the workspace, slack cables), from the start with
        every tension raised by 1, 3, 10 times the largest lower bound (straighter
        cables), until one balances.
        """
        raise_by = self.lb.max(axis=1) + 1e-3 * self.robot.weight
        good = np.zeros(len(active), bool)
        for k in (0.0, 1.0, 3.0, 10.0):
            todo = np.flatnonzero(~good)
            if not len(todo):
                break
            sel = active[todo]
            trial, c_new, ok = self._restore(sel, self.tensions[sel]
                                             + k * raise_by[sel][:, None])
            self.tensions[sel[ok]], self.cables[:, sel[ok]] = trial[ok], c_new[:, ok]
            good[todo[ok]] = True
        self.status[active[~good]] = Status.CATENARY_FAILED
        return active[good]

    # --------------------------------------------------------------- iteration
    def _lp_step(self, active: NDArray[np.intp]
                 ) -> tuple[NDArray[np.intp], NDArray, NDArray]:
        """The max-min LP linearised at the current tensions of poses ``active``.

        Returns the poses still iterating, their tensions (k, m) and full LP steps
        (k, m); marks the others converged or failed.
        """
        t, c = self.tensions[active], self.cables[:, active]
        A, r = self._linearise(active, c)
        lo_c, g_lo, hi_c, g_hi = self._linear_bounds(active, t, c)
        # Linearised equilibrium A t' = A t - r; max-min LP in the null space.
        rhs = np.einsum("kim,km->ki", A, t) - r
        s, T_new, st, _ = margin_solve(A, rhs, lo_c, 1.0 / g_lo, hi_c, 1.0 / g_hi,
                                       self.backend, argmax=True, reference=t,
                                       floor=self.keep_above[active], **self.options)
        assert T_new is not None  # argmax=True
        self.iterations[active] += 1
        bad = ~(st == Status.OPTIMAL) | ~np.isfinite(s) | ~np.isfinite(T_new).all(axis=1)
        self.status[active[bad]] = np.where(
            s[bad] == np.inf, Status.UNBOUNDED,
            np.where(s[bad] == -np.inf, Status.CATENARY_FAILED, Status.SOLVER_ERROR))
        active, t, full = active[~bad], t[~bad], (T_new - t)[~bad]
        done = np.abs(full).max(axis=1) <= self.tol * np.abs(t).max(axis=1)
        self.status[active[done]] = Status.CONVERGED
        return active[~done], t[~done], full[~done]

    def _linear_bounds(self, active: NDArray[np.intp], t: NDArray, c: NDArray
                       ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Bounds on the platform-end tensions ``t`` (k, m) from the linearised lowest and
        highest tension of each cable: ``lo_c, g_lo, hi_c, g_hi`` (k, m) each, the bounds
        at ``s = 0`` and the slopes of the extreme tensions in ``t``."""
        low, high = extreme_tensions(c[0], c[1], c[2])
        # Slopes of the lowest and highest tension in t (a forward difference; 1 for a
        # cable without dip whose platform end is its lowest point).
        dt = 1e-7 * t
        near = taut_catenaries(self.planes.x[active], self.planes.z[active], t + dt,
                               self.w, self.EA, "A")
        low2, high2 = extreme_tensions(near[0], near[1], near[2])
        with np.errstate(all="ignore"):
            g_lo = (low2 - low) / dt
            g_hi = (high2 - high) / dt
        g_lo = np.where(np.isfinite(g_lo) & (g_lo > 1e-3), g_lo, 1.0)
        g_hi = np.where(np.isfinite(g_hi) & (g_hi > 1e-3), g_hi, 1.0)
        with np.errstate(invalid="ignore"):
            lo_c = t + (self.lb[active] - low) / g_lo
            hi_c = t + (self.ub[active] - high) / g_hi
        return lo_c, g_lo, hi_c, g_hi

    def _line_search(self, active: NDArray[np.intp], t: NDArray, full: NDArray
                     ) -> NDArray[np.intp]:
        """Line search on the true margin along the steps ``full`` (k, m) from ``t``,
        each trial balanced again: accept where the margin does not drop, else halve the
        step. Returns the poses still iterating."""
        before = self.value[active].copy()
        moved = np.zeros(len(active))
        pending = np.arange(len(active))
        for _ in range(HALVINGS):
            if not len(pending):
                break
            sel = active[pending]
            trial, c_new, ok = self._restore(
                sel, t[pending] + self.step_size[sel][:, None] * full[pending])
            v = self._value(c_new, sel)
            ok &= v >= self.value[sel] - 1e-12 * self.scale[sel]
            acc = np.flatnonzero(ok)
            moved[pending[acc]] = np.abs(trial[acc] - t[pending[acc]]).max(axis=1)
            self.tensions[sel[acc]], self.cables[:, sel[acc]] = trial[acc], c_new[:, acc]
            self.value[sel[acc]] = v[acc]
            self.step_size[sel[acc]] = np.minimum(2.0 * self.step_size[sel[acc]], 1.0)
            self.step_size[sel[~ok]] *= 0.5
            pending = pending[~ok]
        # Where the linearisation keeps proposing a step but no fraction of it moves the
        # tensions or raises the margin, the margin has a kink there (a cable whose lowest
        # point leaves its platform end, or two bounds meeting): a local maximum the
        # linear model cannot see. Else the line search has stalled.
        gain = self.value[active] - before
        flat = (gain <= KINK_TOL * self.scale[active]) & (
            moved <= KINK_TOL * np.abs(t).max(axis=1))
        stalled = np.zeros(len(active), bool)
        stalled[pending] = True
        self.status[active[flat]] = Status.CONVERGED
        self.status[active[stalled & ~flat]] = Status.STALLED
        return active[~flat & ~stalled]

    # ------------------------------------------------------------- catenaries
    def _catenaries(self, sel: NDArray[np.intp], tens: NDArray) -> tuple[NDArray, NDArray]:
        """Catenaries (4, k, m) of poses ``sel`` at platform tensions ``tens`` (k, m) and
        whether all of a pose's cables are taut (k,)."""
        out = np.full((4, len(sel), self.robot.m), np.nan)
        good = (np.isfinite(tens).all(axis=1) & (tens > 0).all(axis=1)
                & (tens >= self.floor[sel] * (1.0 - 1e-9)).all(axis=1))
        if good.any():
            g = np.flatnonzero(good)
            c = taut_catenaries(self.planes.x[sel[g]], self.planes.z[sel[g]], tens[g],
                                self.w, self.EA, "A")
            out[:, g] = np.stack([c.H, c.V_A, c.V_B, c.L0])
            good[g] = c.converged.all(axis=1)
        return out, good

    def _linearise(self, sel: NDArray[np.intp], c: NDArray) -> tuple[NDArray, NDArray]:
        """Wrench matrix (k, n, m) of the force slopes of catenaries ``c`` (4, k, m) and
        the residual wrench (k, n)."""
        sub = self.planes.subset(sel)
        force = platform_forces(sub, c[0], c[1])
        slope = force_slope(sub, c[0], c[1], c[2], c[3], self.w, self.EA)
        A = np.ascontiguousarray(np.swapaxes(self.robot.cable_wrenches(slope, sub.arms), 1, 2))
        return A, self.robot.cable_wrenches(force, sub.arms).sum(axis=1) - self.required[sel]

    def _restore(self, sel: NDArray[np.intp], tens: NDArray
                 ) -> tuple[NDArray, NDArray, NDArray]:
        """Tensions near ``tens`` (k, m) whose catenaries balance the load (minimum-norm
        Newton corrections); returns them, their catenaries and success (k,)."""
        tens = tens.copy()
        c, ok = self._catenaries(sel, tens)
        done = np.zeros(len(sel), bool)
        for _ in range(RESTORE_ITER):
            todo = np.flatnonzero(ok & ~done)
            if not len(todo):
                break
            A, r = self._linearise(sel[todo], c[:, todo])
            size = np.maximum(self.scale[sel[todo]], np.abs(tens[todo]).max(axis=1))
            close = np.linalg.norm(r, axis=1) <= RESTORE_TOL * size
            done[todo[close]] = True
            move = todo[~close]
            if not len(move):
                break
            Am, rm = A[~close], r[~close]
            with np.errstate(all="ignore"):
                y = np.linalg.solve(np.einsum("kim,kjm->kij", Am, Am), rm[..., None])[..., 0]
            delta = -np.einsum("kim,ki->km", Am, y)
            ok[move[self._damped(sel, move, tens, c, delta)]] = False
        return tens, c, ok & done

    def _damped(self, sel: NDArray[np.intp], move: NDArray[np.intp], tens: NDArray,
                c: NDArray, delta: NDArray) -> NDArray[np.intp]:
        """Apply the corrections ``delta`` to ``tens[move]`` (and ``c``) in place, halved
        where the full one leaves a catenary without a taut shape; returns the indices
        into ``move`` where six halvings did not help."""
        left = np.arange(len(move))
        for _ in range(6):
            c_try, ok_try = self._catenaries(sel[move[left]], tens[move[left]] + delta[left])
            good = left[ok_try]
            tens[move[good]] += delta[good]
            c[:, move[good]] = c_try[:, ok_try]
            left = left[~ok_try]
            if not len(left):
                break
            delta[left] *= 0.5
        return left

    def _value(self, c: NDArray, sel: NDArray[np.intp]) -> NDArray:
        """Margin of catenaries ``c`` (4, k, m): the smallest distance to a bound (k,)."""
        low, high = extreme_tensions(c[0], c[1], c[2])
        with np.errstate(invalid="ignore"):
            return np.minimum(low - self.lb[sel], self.ub[sel] - high).min(axis=1)

    def _result(self) -> CoupledMarginResult:
        margin = np.full(len(self.status), np.nan)
        margin[self.status == Status.SINGULAR] = -np.inf
        margin[self.status == Status.UNBOUNDED] = np.inf
        solved = np.isin(self.status, (Status.CONVERGED, Status.STALLED, Status.MAX_ITER))
        margin[solved] = self.value[solved]
        forces = platform_forces(self.planes, self.cables[0], self.cables[1])
        with np.errstate(invalid="ignore"):
            residual = equilibrium_residual(self.robot, forces, self.planes.arms,
                                            self.required)
        tensions = self.tensions.copy()
        tensions[~solved] = np.nan
        return CoupledMarginResult(margin, tensions, self.status.copy(),
                                   self.iterations.copy(), residual)


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

    A thin wrapper over :class:`CoupledMargin`.

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
        See :class:`CoupledMarginResult`.
    iterations : ndarray of int, shape (N,)
    residual : ndarray, shape (N,)
        Equilibrium residual of the catenaries at the returned tensions (N, N m).
    """
    result = CoupledMargin(robot, poses, wrench, backend, tol=tol, max_iter=max_iter,
                           **options).solve(start)
    return result.margin, result.tensions, result.status, result.iterations, result.residual
