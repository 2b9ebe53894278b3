"""Exact closed-form backend for null-space dimension 1 and 2 (``m = n + 1``, ``m = n + 2``).

Tensions are written ``T = T_pinv + Z z`` with ``Z`` a basis of the null space of the
structure matrix. In one dimension every objective is a function of a scalar ``t`` on an
interval; in two dimensions the feasible set is a polygon and the optimum lies at the free
minimum, on an edge line or at a vertex. Both are enumerated for all poses at once.
For the common 3 x 4 case (a point-mass robot with four cables) the null vector comes
from the generalised cross product, so no matrix factorisation is needed. The
null-space pieces shared with the capacity margin live in :mod:`tension_opt.problem.affine`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends import lowdim
from tension_opt.backends.base import Backend, RawResult, SequenceRun
from tension_opt.backends.lowdim import min_of_max_lines
from tension_opt.errors import BackendNotAvailableError
from tension_opt.kernels.launch import compiled_for
from tension_opt.problem.affine import RANK_TOL, pinv_and_null, solution_set
from tension_opt.problem.form import StandardForm
from tension_opt.status import STATUS_DTYPE, Status, status_array
from tension_opt.tolerances import FEASIBILITY_TOL, accuracy_target

#: Poses per block of the four-cable path (about 20 arrays of this length are live).
_BLOCK = 8192
#: Raw status of each code of the compiled kernel below its solver error (optimal,
#: infeasible, unbounded, inaccurate: optimal as the numpy path reports it); codes from
#: the solver error on go to the numpy path.
_RAW_STATUS = np.array([s.value for s in (Status.OPTIMAL, Status.INFEASIBLE,
                                          Status.UNBOUNDED, Status.OPTIMAL,
                                          Status.SOLVER_ERROR)], dtype=STATUS_DTYPE)
_SOLVER_ERROR = 4


class ClosedFormBackend(Backend):
    """Exact solutions where the null space has dimension 1 or 2.

    Parameters
    ----------
    compiled : bool
        Solve the poses with the compiled kernel
        (:func:`tension_opt.kernels.closed_form.solve_forms`, in parallel over large
        batches), the numpy path answering the poses it hands back (a singular or
        badly conditioned structure matrix, data near the float range), for batches of
        :data:`~tension_opt.kernels.launch.COMPILED_MIN` poses or more (smaller ones
        take the numpy path, which compiles nothing). False: the numpy path alone, the
        reference the kernel is tested against. The statuses,
        tensions (to rounding), uniqueness and infeasibility are those of the numpy
        path either way.
    """

    name = "closed_form"
    solver = "closed_form"
    exact = True

    def __init__(self, compiled: bool = True) -> None:
        self.compiled = bool(compiled)

    @property
    def version(self) -> str:
        if self.compiled:
            import numba

            return f"numba {numba.__version__}, numpy {np.__version__}"
        return f"numpy {np.__version__}"

    def unsupported(self, form: StandardForm) -> str | None:
        r = form.m - form.n
        if r not in (1, 2):
            return (f"closed_form needs a null space of dimension 1 or 2 (m - n = {r}); "
                    "use cvxpy, qpsolvers or scipy:highs")
        if form.G is not None:
            return "closed_form does not take extra inequality rows"
        if form.kind == "minmax_qp" or (form.kind == "minmax" and r == 2):
            return ("closed_form solves min-max only for null-space dimension 1 and without "
                    "smoothing; use cvxpy or qpsolvers")
        return None

    def solve(self, form: StandardForm, **options: Any) -> RawResult:
        """Exact solutions of ``form``; the solution judges them at the ``accuracy``
        option's target (exact to rounding, they meet any target the form's
        conditioning allows)."""
        target = accuracy_target(options.get("accuracy"))
        t0 = time.perf_counter()
        if self.compiled and form.N and compiled_for(form.N):
            T, status, unique, infeas = self._solve_compiled(form)
        else:
            T, status, unique, infeas = self._solve_numpy(form)
        elapsed = time.perf_counter() - t0
        return RawResult(T, status, np.zeros(form.N, dtype=int), 0.0, elapsed, unique, infeas,
                         accuracy_target=target)

    def runs_sequences(self, options: Mapping[str, Any], smoothed: StandardForm,
                       poses: int) -> bool:
        # The size rule counts the sequence's poses, not the one-pose form.
        return self.compiled and compiled_for(poses)

    def solve_sequence(self, base: StandardForm, smoothing: float, rate: NDArray,
                       last: NDArray, start: int, run: SequenceRun,
                       options: Mapping[str, Any]) -> int:
        """:meth:`Backend.solve_sequence` by the compiled kernel
        (:func:`~tension_opt.kernels.closed_form.solve_forms_sequence`); iterations
        stay 0, as :meth:`solve` reports them."""
        from tension_opt.kernels import closed_form

        T, status, unique, infeas = run.tensions, run.status, run.unique, run.infeasibility
        info, codes = np.empty((base.N, 2)), np.zeros(base.N, dtype=np.int64)
        A, b, lb, ub, q, c = (np.ascontiguousarray(x, dtype=float)
                              for x in (base.A, base.b, base.lb, base.ub, base.q, base.c))
        stop = closed_form.solve_forms_sequence(
            A, b, lb, ub, q, c, float(smoothing), np.ascontiguousarray(rate, dtype=float),
            FEASIBILITY_TOL, last, bool(np.isfinite(last).all()), T, info, codes, start)
        done = slice(start, stop)
        status[done] = _RAW_STATUS[codes[done]]
        unique[done], infeas[done] = info[done, 0] != 0.0, info[done, 1]
        return int(stop)

    def _solve_compiled(self, form: StandardForm) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """The compiled kernel over every pose; the poses it hands back by the numpy path.

        The kernel's status codes are the raw statuses of the numpy path, save its
        "inaccurate" (an optimum outside the feasibility check), which the numpy path
        reports as optimal, leaving the judgement to the solution.
        """
        from tension_opt.kernels import closed_form, launch
        from tension_opt.kernels.first_use import announce

        announce("closed form", closed_form.solve_forms_serial)

        N, m = form.N, form.m
        v = np.ones((1, m)) if form.minmax is None else np.asarray(
            form.minmax, dtype=float).reshape(-1, m)
        T, info, codes = np.empty((N, m)), np.empty((N, 2)), np.empty(N, dtype=np.int64)
        arrays = [np.ascontiguousarray(x, dtype=float)
                  for x in (form.A, form.b, form.lb, form.ub, form.q, form.c)]
        launch.run(closed_form.solve_forms, closed_form.solve_forms_serial, N, *arrays,
                   np.ascontiguousarray(v), form.minmax is not None, form.kind == "qp",
                   FEASIBILITY_TOL, T, info, codes)
        status = _RAW_STATUS[np.minimum(codes, len(_RAW_STATUS) - 1)]
        unique, infeas = info[:, 0] != 0.0, info[:, 1]
        redo = np.flatnonzero(codes >= _SOLVER_ERROR)
        if len(redo):
            T[redo], status[redo], unique[redo], infeas[redo] = self._solve_numpy(
                form.subset(redo))
        return T, status, unique, infeas

    def _solve_numpy(self, form: StandardForm) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """The numpy path (the reference) over every pose."""
        if (form.n, form.m) == (3, 4) and form.kind in ("lp", "qp"):
            # Blocks whose temporaries stay in cache: large batches are memory bound.
            parts = [self._solve_point4(form.subset(slice(i, i + _BLOCK)))
                     for i in range(0, form.N, _BLOCK)]
            T, status, unique, infeas = (np.concatenate(p) for p in zip(*parts, strict=True))
            return T, status, unique, infeas
        return self._solve_general(form)

    def _solve_general(self, form: StandardForm) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        # One SVD serves the rank check and, beyond 3 x 4, the particular solution and
        # the null space.
        svd = np.linalg.svd(form.A, full_matrices=True) if (form.n, form.m) != (3, 4) else None
        sv = svd[1] if svd is not None else np.linalg.svd(form.A, compute_uv=False)
        # Lost rank (smallest singular value below RANK_TOL of the largest).
        singular = sv[:, -1] <= RANK_TOL * sv[:, 0]
        if singular.any():
            return self._split_singular(form, singular)
        T0, Z = pinv_and_null(form.A, form.b, svd)
        scale = form.typical_tension()
        if Z.shape[2] == 1:
            return self._solve_1d(form, T0, Z[..., 0], scale)
        return self._solve_2d(form, T0, Z, scale)

    def _split_singular(self, form: StandardForm, singular: NDArray
                        ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Poses whose structure matrix has lost rank (e.g. every cable horizontal).

        No tensions hold a wrench outside the range of ``A``: such poses are infeasible
        at an infinite distance. If the wrench is in the range the null space is larger
        than the closed form handles, and the pose is reported as a solver error.
        """
        N, m = form.N, form.m
        T = np.full((N, m), np.nan)
        status = status_array(N)
        unique = np.ones(N, dtype=bool)
        infeas = np.full(N, np.nan)
        regular = np.flatnonzero(~singular)
        if regular.size:
            parts = self._solve_general(form.subset(regular))
            T[regular], status[regular], unique[regular], infeas[regular] = parts
        bad = np.flatnonzero(singular)
        in_range = solution_set(form.A[bad], form.b[bad]).consistent
        status[bad[in_range]] = Status.SOLVER_ERROR
        status[bad[~in_range]] = Status.INFEASIBLE
        infeas[bad] = np.where(in_range, np.nan, np.inf)
        return T, status, unique, infeas

    def _solve_point4(self, form: StandardForm) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Four cables, three equations: the 1-D formulas with poses along the last axis.

        Arrays are laid out (component, pose) so that every operation runs over long
        contiguous rows, and few operations are needed (small batches are dominated by
        their count). A particular solution comes from cables 1-3 (Cramer's rule through
        cross products), the null vector from the same cross products. Poses where cables
        1-3 are nearly coplanar, with no feasible tension, or with a cable that does not
        move along the null space, are handed to the general path.
        """
        N = form.N
        U = np.ascontiguousarray(form.A.transpose(2, 1, 0))  # (cable, xyz, pose)
        B = np.ascontiguousarray(form.b.T)  # (xyz, pose)
        # Rows: u2 x u3, u3 x u1, u1 x u2.
        C = np.cross(U[[1, 2, 0]], U[[2, 0, 1]], axis=1)
        det = np.einsum("ip,ip->p", U[0], C[0])
        Tp = np.zeros((4, N))
        with np.errstate(divide="ignore", invalid="ignore"):  # det = 0: general path
            Tp[:3] = np.einsum("ip,jip->jp", B, C) / det
        # Null vector: u1 (u4.c23) + u2 (u4.c31) + u3 (u4.c12) - u4 det(u1, u2, u3) = 0.
        n = np.empty((4, N))
        n[:3] = np.einsum("ip,jip->jp", U[3], C)
        n[3] = -det
        nn = np.einsum("kp,kp->p", n, n)
        n_abs = np.abs(n)
        moving = (n_abs > 1e-9 * n_abs.max(axis=0)).all(axis=0)
        up = n > 0
        lb, ub = form.lb.T, form.ub.T
        with np.errstate(divide="ignore", invalid="ignore"):
            r_lb = (lb - Tp) / n
            lo = np.where(up, r_lb, -np.inf).max(axis=0)
            hi = np.where(up, np.inf, r_lb).min(axis=0)
            if np.isfinite(ub).any():
                r_ub = (ub - Tp) / n
                lo = np.maximum(lo, np.where(up, -np.inf, r_ub).max(axis=0))
                hi = np.minimum(hi, np.where(up, r_ub, np.inf).min(axis=0))
            c, q = form.c.T, form.q.T
            if form.kind == "lp":
                slope = np.einsum("kp,kp->p", c, n)
                flat = np.abs(slope) <= lowdim.FLAT_TOL * np.sqrt(
                    np.einsum("kp,kp->p", c, c) * nn)
                # A tie: the minimum-norm point of the line, t = -Tp.n / n.n, clipped.
                t_norm = np.clip(-np.einsum("kp,kp->p", Tp, n) / nn, lo, hi)
                t = np.where(flat, t_norm, np.where(slope > 0, lo, hi))
                unique = ~flat | (lo == hi)
            else:
                t = -np.einsum("kp,kp->p", q * Tp + c, n) / np.einsum("kp,kp,kp->p", q, n, n)
                t = np.clip(t, lo, hi)
                unique = np.ones(N, dtype=bool)
            T = (Tp + t * n).T
        # Poses the shortcut cannot settle exactly go through the general path.
        redo = ~(np.abs(det) > 1e-9) | ~moving | ~(lo <= hi) | ~np.isfinite(t)
        status = status_array(N)
        infeas = np.full(N, np.nan)
        if redo.any():
            idx = np.flatnonzero(redo)
            T_r, st_r, un_r, inf_r = self._solve_general(form.subset(idx))
            T[idx], status[idx], unique[idx], infeas[idx] = T_r, st_r, un_r, inf_r
        return np.ascontiguousarray(T), status, unique, infeas

    def _solve_1d(self, form: StandardForm, T0: NDArray, n: NDArray, scale: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        lb, ub = form.lb, form.ub
        lo, hi = lowdim.interval(T0, n, lb, ub, scale)
        lo, hi = lowdim.widen(lo, hi, n, scale)
        feasible = lo <= hi
        unique = np.ones(form.N, dtype=bool)
        kind = form.kind
        if kind == "qp":
            curvature = np.einsum("nm,nm,nm->n", form.q, n, n)
            t = -np.einsum("nm,nm->n", form.q * T0 + form.c, n) / curvature
            t = np.clip(t, lo, hi)
        elif kind == "lp":
            slope = np.einsum("nm,nm->n", form.c, n)
            flat = np.abs(slope) <= lowdim.FLAT_TOL * np.linalg.norm(form.c, axis=1)
            t = np.where(slope > 0, lo, hi)
            # Tied optimum (zero slope): minimum 2-norm on the whole interval.
            t_norm = np.clip(-np.einsum("nm,nm->n", T0, n), lo, hi)
            t = np.where(flat, t_norm, t)
            unique = ~flat | (lo == hi)
        else:  # min-max: minimise max_i v_i (T0_i + t n_i)
            v = form.minmax
            t, fstar = min_of_max_lines(v * n, v * T0, lo, hi)
            # The optimal set {t : v_i T_i(t) <= f*} is an interval; take its min-norm point.
            tol = lowdim.FEAS_TOL * (np.abs(fstar) + scale)
            cap = (fstar + tol)[:, None] / v
            olo, ohi = lowdim.interval(T0, n, lb, np.minimum(ub, cap), scale)
            olo, ohi = np.maximum(olo, lo), np.minimum(ohi, hi)
            width_ok = ohi - olo > 10 * tol / np.abs(n).max(axis=1).clip(1e-300)
            t_norm = np.clip(-np.einsum("nm,nm->n", T0, n), olo, ohi)
            t = np.where(width_ok & np.isfinite(t_norm), t_norm, t)
            unique = ~width_ok
        unbounded = feasible & ~np.isfinite(t)
        T = T0 + t[:, None] * n
        status = status_array(form.N)
        status[~feasible] = Status.INFEASIBLE
        status[unbounded] = Status.UNBOUNDED
        T[~feasible | unbounded] = np.nan
        infeas = np.full(form.N, np.nan)
        if (~feasible).any():
            bad = ~feasible
            infeas[bad] = lowdim.infeasibility_1d(T0[bad], n[bad], lb[bad], ub[bad])
        return T, status, unique & feasible | ~feasible, infeas

    def _solve_2d(self, form: StandardForm, T0: NDArray, Z: NDArray, scale: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        if form.kind == "qp":
            z, feasible = lowdim.qp_2d(T0, Z, form.lb, form.ub, form.q, form.c, scale)
            unique = np.ones(form.N, dtype=bool)
        else:
            z, feasible, unique, _ = lowdim.lp_2d(T0, Z, form.lb, form.ub, form.c, scale)
            unique |= ~feasible
        T = T0 + np.einsum("nmi,ni->nm", Z, z)
        status = status_array(form.N)
        status[~feasible] = Status.INFEASIBLE
        T[~feasible] = np.nan
        return T, status, unique, np.full(form.N, np.nan)


def available() -> list[str]:
    """Registry names this family serves: the closed form needs nothing optional."""
    return ["closed_form"]


def make(solver: str | None) -> Backend:
    """The closed-form backend (it takes no solver suffix)."""
    if solver is not None:
        raise BackendNotAvailableError(
            f"the closed form takes no solver suffix, got 'closed_form:{solver}'")
    return ClosedFormBackend()
