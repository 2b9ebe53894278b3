"""The backend interface: :class:`Backend` and the :class:`RawResult` it returns.

A backend solves batches of :class:`~tension_opt.problems.StandardForm`. Generic
solvers implement one stage (:meth:`Backend.solve_stage`); :meth:`Backend.solve` adds
the two-stage tie-break of non-unique LP optima (:mod:`tension_opt.backends.tiebreak`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.tiebreak import low_dim_face_solve, lp_optimum_is_unique, optimal_face
from tension_opt.problems import StandardForm
from tension_opt.solution import Status, status_array


@dataclass
class RawResult:
    """What a backend returns for a batch: tensions (N, m) and per-pose diagnostics."""

    tensions: NDArray
    status: NDArray
    iterations: NDArray | None
    setup_time: float = 0.0
    solve_time: float = 0.0
    unique: NDArray | None = None
    infeasibility: NDArray | None = None
    extras: dict[str, Any] = field(default_factory=dict)


class Backend:
    """A way of solving :class:`~tension_opt.problems.StandardForm` batches.

    Subclasses implement :meth:`unsupported` and :meth:`solve`; generic solvers
    implement :meth:`solve_stage` and inherit :meth:`solve`, which adds the
    two-stage tie-break of LP optima.
    """

    #: Registry name, e.g. ``"qpsolvers:daqp"``.
    name: str = ""
    #: Whether the backend solves to machine precision (no iterative tolerance).
    exact: bool = False
    #: Whether the backend can warm start from the previous pose.
    warm_start: bool = False

    @property
    def solver(self) -> str:
        """Name of the underlying solver."""
        return self.name.split(":")[-1]

    @property
    def version(self) -> str:
        """Version of the underlying library."""
        return ""

    def unsupported(self, form: StandardForm) -> str | None:
        """Why this backend cannot solve ``form`` (None if it can)."""
        return None

    def solve(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve a batch; LP optima are tested for uniqueness and ties broken."""
        first = self.solve_stage(form, **options)
        problem = form.problem
        if not form.is_linear or (problem is not None and not problem.tie_break):
            first.unique = np.ones(form.N, dtype=bool)
            return first
        ok = first.status == Status.OPTIMAL
        unique = np.ones(form.N, dtype=bool)
        idx = np.flatnonzero(ok)
        if len(idx):
            unique[idx] = lp_optimum_is_unique(form.subset(idx), first.tensions[idx])
        tied = np.flatnonzero(~unique)
        if len(tied):
            t0 = time.perf_counter()
            face = optimal_face(form.subset(tied), first.tensions[tied])
            if self.unsupported(face) is not None:
                # An LP-only solver: break the tie exactly on the (small) optimal face.
                broken = low_dim_face_solve(form.subset(tied), first.tensions[tied])
                if broken is None:
                    first.extras["tie_break"] = "optimal face above 2-D: vertex kept"
                else:
                    first.tensions[tied] = broken
                first.solve_time += time.perf_counter() - t0
                first.unique = unique
                return first
            second = self.solve_stage(face, **options)
            first.solve_time += time.perf_counter() - t0 - second.setup_time
            first.setup_time += second.setup_time
            good = second.status == Status.OPTIMAL
            first.tensions[tied[good]] = second.tensions[good]
            first.status[tied[~good]] = Status.INACCURATE
            if first.iterations is not None and second.iterations is not None:
                first.iterations[tied] += second.iterations
        first.unique = unique
        return first

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve one stage (no tie-break). Generic backends override this."""
        raise NotImplementedError


def pose_loop_result(N: int, m: int) -> tuple[NDArray, NDArray, NDArray]:
    """Empty tensions (NaN), statuses (NOT_RUN) and iterations (0) for a pose loop."""
    return np.full((N, m), np.nan), status_array(N, Status.NOT_RUN), np.zeros(
        N, dtype=int)
