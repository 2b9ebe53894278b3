"""A large batch of independent poses on the compiled closed form, certified in one
compiled pass per chunk (:mod:`tension_opt.kernels.certified`).

:func:`tension_opt.distribute` cuts a large batch into chunks; on the compiled closed
form each chunk would go through the geometry, the standard form, the backend and
:meth:`~tension_opt.distribution.solution.TensionSolution.from_form` (the certificate on the scaled
batch) as arrays of the chunk, then be copied into the batch's arrays. Here one
compiled call per chunk does all of it pose by pose and writes the results into the
arrays of the whole batch. A pose it does not settle (see the kernel's module) is
solved by that path on its own, and its results written over the kernel's, so every
field is the path's to rounding.

:func:`certified_plan` says whether a call qualifies: a robot kind of the compiled
geometry, one of the package's five objectives without smoothing, rate limit or
per-pose rows, and the compiled closed form as the backend (named, an instance, or the
automatic choice).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.backends.registry import route
from tension_opt.certify.certificate import Multipliers
from tension_opt.distribution.packing import pack_certified
from tension_opt.distribution.solution import TensionSolution, reused_array
from tension_opt.errors import TensionOptError
from tension_opt.problem.form import TensionProblem
from tension_opt.robot import CableRobot
from tension_opt.status import STATUS_DTYPE, StatusCodes, status_codes
from tension_opt.tolerances import accuracy_target

__all__ = ["CertifiedBatch", "CertifiedPlan", "certified_plan", "plan_of"]


@dataclass(frozen=True)
class CertifiedPlan:
    """What the kernel needs of a call: its packed data
    (:func:`~tension_opt.distribution.packing.pack_certified`), the backend (for the
    labels), the accuracy target, and the shapes of the multipliers: ``n`` equations,
    ``g`` rows (the epigraph rows of a min-max term) and ``k`` scaled variables."""

    data: NDArray
    backend: ClosedFormBackend
    target: float
    n: int
    g: int
    k: int


def certified_plan(robot: CableRobot, problem: TensionProblem, backend: Any,
                   accuracy: object = None) -> CertifiedPlan | None:
    """The plan of a call of :func:`tension_opt.distribute` on a large batch of
    independent poses whose problem has no per-pose rows (bounds, reference), judged at
    the call's ``accuracy`` option, or None where the call does not qualify (see the
    module docstring). A problem or backend the path would reject is None too: the path
    raises its own error."""
    from tension_opt.kernels.geometry import compiled_kind

    if problem.is_sequential or compiled_kind(robot) < 0:
        return None
    n, m = robot.dof, robot.m
    try:  # the shapes and kind of the batch's forms, on a stand-in pose
        form = problem.standard_form_from(robot, np.zeros((1, n, m)), np.zeros((1, n)))
        chosen = route(backend, form).backend
    except TensionOptError:
        return None
    return plan_of(robot, problem, chosen, form, accuracy)


def plan_of(robot: CableRobot, problem: TensionProblem, chosen: Any, form: Any,
            accuracy: object = None) -> CertifiedPlan | None:
    """:func:`certified_plan` where the batch's ``form`` (or one of a stand-in pose) is
    at hand and routed to the backend ``chosen``."""
    from tension_opt.kernels.geometry import compiled_kind

    if problem.is_sequential or compiled_kind(robot) < 0 or not (
            isinstance(chosen, ClosedFormBackend) and chosen.compiled):
        return None
    n, m = robot.dof, robot.m
    # Exact to rounding, the closed form is judged at whatever target the call asks.
    target = accuracy_target(accuracy)
    data = pack_certified(robot, problem, target)
    if data is None:
        return None
    g = 0 if form.minmax is None else m
    return CertifiedPlan(data, chosen, target, n, g, m + (g > 0))


#: Per-pose fields of a :class:`TensionSolution` the kernel writes, in its order.
_MEASURES = ("objective", "residual", "bound_violation", "infeasibility",
             "primal_residual", "dual_residual", "duality_gap")


class CertifiedBatch:
    """The results of a batch, written chunk by chunk (:meth:`solve`, :meth:`put`) into
    arrays allocated once, then handed over as one :class:`TensionSolution`
    (:meth:`solution`). Chunks may be solved from several threads at once (the kernel
    releases the GIL; each chunk writes only its own rows).

    Parameters
    ----------
    plan : CertifiedPlan
    poses : ndarray, shape (N, n)
        Validated poses.
    wrench : ndarray, shape (n,) or (N, n), optional
        Finite external wrenches (N, N m).
    out : TensionSolution, optional
        A solution whose C-contiguous arrays take the results (checked by
        :func:`~tension_opt.distribution.solution.reusable`); others are allocated.
    """

    def __init__(self, plan: CertifiedPlan, poses: NDArray, wrench: NDArray | None,
                 out: TensionSolution | None = None) -> None:
        N, m = len(poses), int(plan.data[1])
        self.plan, self.N = plan, N
        self.poses = np.ascontiguousarray(poses, dtype=float)
        w = np.zeros((1, plan.n)) if wrench is None else np.asarray(wrench, dtype=float)
        self.wrench = np.ascontiguousarray(w.reshape(-1, plan.n))

        def array(name: str, shape: tuple[int, ...], dtype: Any = np.float64) -> NDArray:
            # The kernel's arrays are C-contiguous; distribute copies into any other.
            target = None if out is None else reused_array(out, name, shape, dtype)
            if target is None or not target.flags.c_contiguous:
                return np.empty(shape, dtype=dtype)
            return target

        self.tensions = array("tensions", (N, m))
        self.codes = np.empty(N, dtype=np.int8)
        # Fresh results keep the codes (1 byte a pose, decoded when read); out's status
        # array is written.
        self.status = None if out is None else array("status", (N,), STATUS_DTYPE)
        self.unique = array("unique", (N,), bool)
        self.measures = {name: array(name, (N,)) for name in _MEASURES}
        self.multipliers = Multipliers(*(array(f"multipliers.{name}", (N, cols)) for name, cols
                                         in (("y", plan.n), ("mu", plan.g), ("z", plan.k))))
        self.iterations: NDArray | None
        if out is None or out.iterations is None:
            self.iterations = np.zeros(N, dtype=int)  # the closed form's: none
        else:  # (written last: every array of out is checked first)
            self.iterations = reused_array(out, "iterations", (N,), None)
            self.iterations[...] = 0

    def solve(self, sl: slice) -> NDArray | slice | None:
        """Solve the poses ``sl`` by the kernel; returns the poses left to the caller
        (their indices in the batch; the whole slice if the kernel flags a pose's
        geometry, so that the caller's path raises its error as it would), or None."""
        from tension_opt.kernels.certified import (
            CODE_GEOMETRY,
            STATUS_VALUES,
            certified_poses,
        )
        from tension_opt.kernels.first_use import announce

        announce("certified pass", certified_poses)
        wrench = self.wrench if len(self.wrench) == 1 else self.wrench[sl]
        mult = self.multipliers
        objective, residual, violation, infeasibility, primal, dual, gap = (
            self.measures[name][sl] for name in _MEASURES)
        left = certified_poses(self.plan.data, self.poses[sl], wrench, self.tensions[sl],
                               self.codes[sl], self.unique[sl], objective, residual,
                               violation, infeasibility, primal, dual, gap,
                               mult.y[sl], mult.mu[sl], mult.z[sl])
        codes = self.codes[sl]
        if self.status is not None:
            np.take(STATUS_VALUES, codes, out=self.status[sl], mode="clip")
        if not left:
            return None
        if (codes == CODE_GEOMETRY).any():
            return sl
        return sl.start + np.flatnonzero(codes > len(STATUS_VALUES) - 1)

    def put(self, index: NDArray | slice, sol: TensionSolution) -> None:
        """Write the solution ``sol`` of the poses ``index``."""
        self.tensions[index], self.codes[index] = sol.tensions, status_codes(sol.status)
        if self.status is not None:
            self.status[index] = sol.status
        self.unique[index] = sol.unique
        for name, values in self.measures.items():
            values[index] = getattr(sol, name)
        iterations = self.iterations  # read once: another chunk's thread may drop it
        if sol.iterations is None:
            self.iterations = None
        elif iterations is not None:
            iterations[index] = sol.iterations
        assert sol.multipliers is not None  # from_form always certifies
        self.multipliers.put(index, sol.multipliers)

    def solution(self, problem: TensionProblem, extras: dict[str, Any],
                 setup_time: float, solve_time: float) -> TensionSolution:
        """The solution of the whole batch (no form, as any chunked batch)."""
        backend = self.plan.backend
        return TensionSolution(
            tensions=self.tensions, unique=self.unique,
            # the field's descriptor takes codes too (decoded when read)
            status=StatusCodes(self.codes) if self.status is None  # type: ignore[arg-type]
            else self.status,
            iterations=self.iterations, setup_time=setup_time, solve_time=solve_time,
            backend=backend.name, solver=backend.solver or backend.name.split(":")[-1],
            solver_version=backend.version,
            problem=problem, extras=extras, form=None, accuracy=self.plan.target,
            multipliers=self.multipliers, **self.measures)
