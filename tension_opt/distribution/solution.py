"""Result of a tension distribution: :class:`TensionSolution`, with its certificate.

Every solution carries, per pose, the three measures of its certificate on the scaled
problem (:mod:`tension_opt.certify.certificate`): primal residual, dual residual and duality
gap, and the accuracy target they are judged against. ``OPTIMAL`` means all three meet
the target (and the tensions are finite, in equilibrium and within their bounds in
newtons); a solver's "optimal" that misses it is ``INACCURATE``, its figures kept.

:class:`~tension_opt.status.Status` and :func:`~tension_opt.status.status_array` are
re-exported here.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from tension_opt.certify.certificate import (
    Certificate,
    Multipliers,
    certify_form,
    primal_residual_of,
)
from tension_opt.distribution.directional import DirectionalDerivative, directional_derivative
from tension_opt.distribution.sensitivity import Sensitivity, tension_jacobian
from tension_opt.errors import InvalidInputError
from tension_opt.status import STATUS_DTYPE, Status, StatusCodes
from tension_opt.tolerances import DEFAULT_TARGET, FEASIBILITY_TOL, accuracy_target

__all__ = ["PER_POSE", "TensionSolution", "per_pose_arrays", "reusable", "reused_array",
           "solution_of"]

if TYPE_CHECKING:
    from tension_opt.backends.base import Backend, RawResult
    from tension_opt.problem.form import StandardForm

#: The per-pose arrays of a solution besides its multipliers (first axis: the poses).
PER_POSE = ("tensions", "status", "unique", "objective", "residual", "bound_violation",
            "iterations", "infeasibility", "primal_residual", "dual_residual",
            "duality_gap")
_MULTIPLIER_PARTS = ("y", "mu", "z")
#: Held while a solution swaps its status codes for the decoded array.
_DECODING = threading.Lock()


class _StatusField:
    """The ``status`` field of a :class:`TensionSolution`: an array of :class:`Status`
    values, which may be given as :class:`~tension_opt.status.StatusCodes` and is then
    decoded when first read, once, whatever the threads reading it (the decoded array
    is kept and is the status from then on: writes into it hold). The value lives in
    the instance's ``_status`` attribute."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name, self.slot = name, f"_{name}"

    def __get__(self, obj: Any, owner: type | None = None) -> NDArray:
        if obj is None:  # no default for the dataclass field
            raise AttributeError(f"{self.name} has no default")
        held = obj.__dict__.get(self.slot)
        if held is None:
            raise AttributeError(self.name)
        if isinstance(held, StatusCodes):
            with _DECODING:  # one decoding, even for threads that read at once
                held = obj.__dict__[self.slot]
                if isinstance(held, StatusCodes):
                    held = obj.__dict__[self.slot] = held.decode()
        return held

    def __set__(self, obj: Any, value: NDArray | StatusCodes) -> None:
        obj.__dict__[self.slot] = value

    def equal_to(self, obj: Any, status: Status) -> NDArray:
        """Mask of the poses of ``obj`` whose status is ``status`` (not decoding codes)."""
        held = obj.__dict__.get(self.slot)
        if held is None:
            raise AttributeError(self.name)
        if isinstance(held, StatusCodes):
            return held.equal_to(status)
        return np.asarray(held == status, dtype=bool)


_STATUS = _StatusField()


@dataclass(eq=False)
class TensionSolution:
    """Tensions of a batch of poses and how they were found.

    Attributes
    ----------
    tensions : ndarray, shape (N, m)
        Cable tensions (N); NaN where the pose has no solution.
    status : ndarray of Status, shape (N,)
        Of :data:`~tension_opt.status.STATUS_DTYPE`. A large batch on the compiled
        closed form holds it as one-byte codes, decoded when first read (a
        :class:`~tension_opt.status.StatusCodes` may be given for it); :attr:`success`
        reads the codes without decoding them. It is kept as ``_status`` in the
        instance's ``__dict__``; a shallow copy of a result not yet read decodes its own
        array.
    unique : ndarray of bool, shape (N,)
        False where the optimum is not unique (the tie was broken to the minimum
        2-norm among the optima).
    objective : ndarray, shape (N,)
        Objective value as the problem defines it (NaN where not solved).
    residual : ndarray, shape (N,)
        Equilibrium residual ``||A T - b||_2`` (N, N m).
    bound_violation : ndarray, shape (N,)
        Largest violation of ``t_min <= T <= t_max`` (N); 0 when the bounds hold.
    iterations : ndarray of int, shape (N,), or None
        Solver iterations per pose (both stages of a tie-break added); None when the
        solver does not report them; 0 for closed forms.
    infeasibility : ndarray, shape (N,)
        For infeasible poses, where cheap to know: the smallest largest bound
        violation (N) of any tension set in equilibrium; NaN where unknown.
    setup_time : float
        Time to build the problem for the batch (s).
    solve_time : float
        Time in the solver for the whole batch (s).
    backend, solver, solver_version : str
    problem : object
        The :class:`~tension_opt.problem.form.TensionProblem` solved.
    extras : dict
        Backend-specific information.
    form : StandardForm, optional
        The problems solved, against which the diagnostics were measured.
    primal_residual, dual_residual, duality_gap : ndarray, shape (N,)
        The certificate's measures on the scaled problem (dimensionless; see
        :mod:`tension_opt.certify.certificate`); NaN where the pose has no solution (and the
        last two for a solution not judged on optimality, such as a jointly smoothed
        path).
    accuracy : float
        The target the measures are judged against.
    multipliers : Multipliers, optional
        The multipliers of the certificate (scaled units), the solver's where it gave
        them.

    A solution is built by :meth:`from_form`, which measures the tensions against their
    own problem form: a solver's "optimal" whose certificate misses the target, or whose
    equilibrium or bounds miss :data:`FEASIBILITY_TOL` of the typical tension in
    newtons, becomes ``INACCURATE``.
    """

    tensions: NDArray
    if TYPE_CHECKING:  # a field without a default, as the descriptor makes it at run time
        status: NDArray
    else:
        status: NDArray = _STATUS
    unique: NDArray
    objective: NDArray
    residual: NDArray
    bound_violation: NDArray
    iterations: NDArray | None
    infeasibility: NDArray
    setup_time: float
    solve_time: float
    backend: str
    solver: str
    solver_version: str
    problem: Any = None
    extras: dict[str, Any] = field(default_factory=dict)
    form: StandardForm | None = field(default=None, repr=False)
    primal_residual: NDArray | None = None
    dual_residual: NDArray | None = None
    duality_gap: NDArray | None = None
    accuracy: float = DEFAULT_TARGET
    multipliers: Multipliers | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        # A solution put together without a certificate (e.g. from chunks) says so.
        for name in ("primal_residual", "dual_residual", "duality_gap"):
            if getattr(self, name) is None:
                setattr(self, name, np.full(self.N, np.nan))

    @classmethod
    def from_form(
        cls,
        form: StandardForm,
        tensions: NDArray,
        status: NDArray,
        *,
        backend: str,
        solver: str,
        solver_version: str = "",
        unique: NDArray | None = None,
        iterations: NDArray | None = None,
        infeasibility: NDArray | None = None,
        setup_time: float = 0.0,
        solve_time: float = 0.0,
        extras: dict[str, Any] | None = None,
        multipliers: Multipliers | None = None,
        accuracy: object = None,
        optimality: bool = True,
        certificate: Certificate | None = None,
    ) -> TensionSolution:
        """A solution of ``form`` with its diagnostics and certificate measured against it.

        Parameters
        ----------
        form : StandardForm
            The problems solved (N poses).
        tensions : ndarray, shape (N, m)
            Tensions (N) as returned; set to NaN where the status is not a solution.
        status : array_like, shape (N,)
            :class:`Status` values; ``OPTIMAL`` is downgraded to ``INACCURATE`` where the
            certificate misses the accuracy target or the equilibrium or bounds miss
            :data:`FEASIBILITY_TOL` of the typical tension, and ``OPTIMAL`` or
            ``INACCURATE`` to ``SOLVER_ERROR`` where a tension is not finite:
            ``OPTIMAL`` always means finite tensions within the certificate.
        backend, solver, solver_version : str
            Labels of what solved it.
        unique, iterations, infeasibility : ndarray, shape (N,), optional
        setup_time, solve_time : float
            Seconds.
        extras : dict, optional
            Backend information.
        multipliers : Multipliers, optional
            The solver's multipliers of the scaled problem; estimated where missing.
        accuracy : {"default", "high"} or float, optional
            Target of the certificate (default 1e-7).
        optimality : bool
            False for tensions that are not meant to be optimal pose by pose (a path
            smoothed as a whole): only the primal residual is certified.
        certificate : Certificate, optional
            The backend's certificate of exactly these ``tensions`` on ``form`` at this
            target (:attr:`tension_opt.backends.base.RawResult.certificate`), taken
            instead of measured again; NaN where the status is not a solution.
        """
        extras = dict(extras or {})
        target = accuracy_target(accuracy)
        T, status, solved = _solutions(tensions, status)
        with np.errstate(over="ignore", invalid="ignore"):
            residual = form.equilibrium_residual(T)
            violation = form.bound_violation(T)
            tol = max(FEASIBILITY_TOL, 10.0 * target) * form.load_scale()
            objective = form.objective_value(T)
        violation[~solved] = np.nan
        # Written so that a NaN measure (an overflow) fails the certificate.
        feasible = (residual <= tol) & (violation <= tol)
        certificate, certified = _certificate(form, T, multipliers, target, optimality,
                                              certificate, solved)
        status[solved & ~(feasible & certified)] = Status.INACCURATE
        N = len(T)
        return cls(
            tensions=T, status=status,
            unique=np.ones(N, dtype=bool) if unique is None else np.asarray(unique, dtype=bool),
            objective=objective, residual=residual, bound_violation=violation,
            iterations=iterations,
            infeasibility=np.full(N, np.nan) if infeasibility is None else infeasibility,
            setup_time=setup_time, solve_time=solve_time, backend=backend, solver=solver,
            solver_version=solver_version, problem=form.problem, extras=extras,
            form=form, primal_residual=certificate.primal_residual,
            dual_residual=certificate.dual_residual, duality_gap=certificate.duality_gap,
            accuracy=target, multipliers=certificate.multipliers,
        )

    @property
    def certified(self) -> NDArray:
        """Poses whose certificate meets :attr:`accuracy`, shape (N,) (whatever the status
        says; ``OPTIMAL`` implies it)."""
        # filled in by __post_init__
        assert (self.primal_residual is not None and self.dual_residual is not None
                and self.duality_gap is not None)
        t = self.accuracy
        return np.asarray((self.primal_residual <= t) & (self.dual_residual <= t)
                          & (self.duality_gap <= t), dtype=bool)

    @property
    def N(self) -> int:
        """Number of poses."""
        return int(self.tensions.shape[0])

    @property
    def success(self) -> NDArray:
        """Boolean mask of poses solved to optimality, shape (N,)."""
        return _STATUS.equal_to(self, Status.OPTIMAL)

    @property
    def time_per_pose(self) -> float:
        """``(setup_time + solve_time) / N`` (s)."""
        return (self.setup_time + self.solve_time) / max(self.N, 1)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: status, tensions ``T1..Tm``, diagnostics in newtons
        and the certificate (``primal_residual``, ``dual_residual``, ``duality_gap``
        on the scaled problem, and the ``accuracy`` target they are judged against)."""
        frame = pd.DataFrame(
            self.tensions, columns=[f"T{i + 1}" for i in range(self.tensions.shape[1])]
        )
        frame.insert(0, "pose", np.arange(self.N))
        frame.insert(1, "status", [str(s) for s in self.status])
        frame["unique"] = self.unique
        frame["objective"] = self.objective
        frame["residual"] = self.residual
        frame["bound_violation"] = self.bound_violation
        frame["iterations"] = (
            pd.array(self.iterations, dtype="Int64") if self.iterations is not None
            else pd.array([None] * self.N, dtype="Int64")
        )
        frame["infeasibility"] = self.infeasibility
        frame["primal_residual"] = self.primal_residual
        frame["dual_residual"] = self.dual_residual
        frame["duality_gap"] = self.duality_gap
        frame["accuracy"] = self.accuracy
        frame["backend"] = self.backend
        return frame

    def written_into(self, out: TensionSolution) -> TensionSolution:
        """This solution with its per-pose arrays copied into those of ``out``
        (:func:`tension_opt.distribute`'s ``out=``), which it then holds; a field
        ``out`` lacks (None) stays this solution's own array.

        Raises
        ------
        InvalidInputError
            If an array of ``out`` has another shape than this solution's (``out`` is
            then left as it was).
        """
        theirs, ours = per_pose_arrays(out), per_pose_arrays(self)
        shared = [(name, mine) for name, mine in ours.items()
                  if mine is not None and theirs.get(name) is not None]
        for name, array in shared:  # every array checked before any is written
            reused_array(out, name, array.shape, None)
        held: dict[str, Any] = {}  # the fields' values by name (arrays, or None)
        for name, mine in ours.items():
            target = theirs.get(name)
            if mine is not None and target is not None:  # one of the shared arrays
                if target is not mine:
                    target[...] = mine
                mine = target
            held[name] = mine
        multipliers = None if self.multipliers is None else Multipliers(
            *(held[f"multipliers.{k}"] for k in _MULTIPLIER_PARTS))
        return replace(self, multipliers=multipliers, **{k: held[k] for k in PER_POSE})

    def jacobian(self, wrt: str, *, robot: Any = None, poses: Any = None, wrench: Any = None,
                 previous: Any = None) -> Sensitivity:
        """Derivatives of the optimal tensions by ``wrt``, by implicit differentiation of
        the KKT conditions at the certified active set
        (:func:`tension_opt.distribution.sensitivity.tension_jacobian`, which documents
        the arguments, shapes and per-pose statuses).

        ``wrt`` is ``"wrench"``, ``"pose"``, ``"t_min"``, ``"t_max"``,
        ``"drawing_points"``, ``"attachment_points"`` or ``"previous"`` (the tensions a
        smoothed or rate-limited pose was solved against); the pose and the points need
        ``robot=`` and ``poses=``, as does a solution solved in chunks (no form kept).
        """
        return tension_jacobian(self, wrt, robot=robot, poses=poses, wrench=wrench,
                                previous=previous)

    def directional_derivative(self, wrt: str, direction: Any, *, robot: Any = None,
                               poses: Any = None, wrench: Any = None,
                               previous: Any = None) -> DirectionalDerivative:
        """One-sided derivatives of the optimal tensions along ``direction`` of ``wrt``,
        also where the Jacobian does not exist because a bound is just touched
        (:func:`tension_opt.distribution.directional.directional_derivative`, which
        documents the arguments and statuses)."""
        return directional_derivative(self, wrt, direction, robot=robot, poses=poses,
                                      wrench=wrench, previous=previous)

    def __repr__(self) -> str:
        counts = pd.Series([str(s) for s in self.status]).value_counts().to_dict()
        return (
            f"TensionSolution(N={self.N}, m={self.tensions.shape[1]}, backend={self.backend!r}, "
            f"status={counts}, non_unique={int((~self.unique).sum())}, "
            f"max_residual={np.nanmax(self.residual, initial=0.0):.3g})"
        )


def reusable(out: object, N: int, m: int, inputs: Sequence[object]) -> TensionSolution:
    """``out`` (:func:`tension_opt.distribute`'s ``out=``) checked to take the results
    of ``N`` poses of ``m`` cables: a :class:`TensionSolution` whose arrays are
    writeable, of ``N`` rows and share no memory with ``inputs``.

    Raises
    ------
    InvalidInputError
        Naming ``out`` (or its field) and what to pass instead.
    """
    if not isinstance(out, TensionSolution):
        raise InvalidInputError(f"out must be a TensionSolution (a result of distribute) or "
                                f"None, got {type(out).__name__}")
    reused_array(out, "tensions", (N, m), np.float64)
    for name, array in per_pose_arrays(out).items():
        if array is None:
            continue
        if not (isinstance(array, np.ndarray) and array.flags.writeable
                and len(array) == N):
            raise InvalidInputError(
                f"out.{name} must be a writeable array of {N} rows: pass a solution "
                "distribute returned for as many poses, or out=None")
        for given in inputs:
            if isinstance(given, np.ndarray) and np.may_share_memory(array, given):
                raise InvalidInputError(
                    f"out.{name} shares memory with an input of the call: pass inputs that "
                    "are not out's arrays (a copy), or out=None")
    return out


def per_pose_arrays(sol: TensionSolution) -> dict[str, NDArray | None]:
    """The per-pose arrays of ``sol`` by name (:data:`PER_POSE`, then the members of its
    multipliers as ``"multipliers.y"`` ..., where it has them)."""
    arrays = {name: getattr(sol, name) for name in PER_POSE}
    if sol.multipliers is not None:
        arrays.update({f"multipliers.{k}": getattr(sol.multipliers, k)
                       for k in _MULTIPLIER_PARTS})
    return arrays


def reused_array(out: TensionSolution, name: str, shape: tuple[int, ...],
                 dtype: type | np.dtype | None) -> NDArray:
    """The array ``name`` of ``out`` (``"multipliers.mu"`` for a member of its
    multipliers), checked to have ``shape`` and ``dtype`` (None: any).

    Raises
    ------
    InvalidInputError
        If it has another shape or dtype, or is missing.
    """
    array: Any = out
    for part in name.split("."):
        array = getattr(array, part, None)
    if (not isinstance(array, np.ndarray) or array.shape != tuple(shape)
            or (dtype is not None and array.dtype != np.dtype(dtype))):
        found = (f"shape {array.shape}, dtype {array.dtype}" if isinstance(array, np.ndarray)
                 else "None")
        wanted = f"shape {tuple(shape)}" + ("" if dtype is None else f", dtype {np.dtype(dtype)}")
        raise InvalidInputError(
            f"out.{name} has {found}, this call's results have {wanted}: pass the result of "
            "a call on as many poses of the same robot and problem, or out=None")
    return array


def _solutions(tensions: NDArray, status: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Tensions (NaN where not a solution), statuses and the mask of solutions: a
    "solution" with a non-finite tension is no solution, whatever the solver said."""
    T = np.array(tensions, dtype=float)
    status = np.array(status, dtype=STATUS_DTYPE)
    solved = (status == Status.OPTIMAL) | (status == Status.INACCURATE)
    broken = solved & ~np.isfinite(T).all(axis=1)
    status[broken] = Status.SOLVER_ERROR
    solved &= ~broken
    T[~solved] = np.nan
    return T, status, solved


def _certificate(form: StandardForm, tensions: NDArray, multipliers: Multipliers | None,
                 target: float, optimality: bool, given: Certificate | None = None,
                 solved: NDArray | None = None) -> tuple[Certificate, NDArray]:
    """The certificate of ``tensions`` on ``form`` and the poses it certifies; with
    ``optimality`` False only the primal residual is measured and judged (the dual
    residual and gap are NaN). A certificate ``given`` by the backend, of these tensions
    at this target, is taken instead, its measures NaN where a pose is not ``solved``."""
    if given is not None and optimality and given.target == target and solved is not None:
        if not solved.all():
            given.forget(~solved)
        return given, given.certified
    if form.N == 0:
        empty = np.zeros(0)
        return Certificate(empty, empty, empty, target, Multipliers(
            np.zeros((0, form.n)), np.zeros((0, 0)), np.zeros((0, form.m)))), empty > 0
    if optimality:
        certificate = certify_form(form, tensions, multipliers, target)
        return certificate, certificate.certified
    primal = primal_residual_of(form, tensions)
    nan = np.full(form.N, np.nan)
    none = Multipliers(np.full((form.N, form.n), np.nan), np.zeros((form.N, 0)),
                       np.full((form.N, form.m), np.nan))
    return Certificate(primal, nan, nan.copy(), target, none), primal <= target


def solution_of(form: StandardForm, raw: RawResult, backend: Backend,
                setup_time: float = 0.0) -> TensionSolution:
    """The :class:`TensionSolution` of a backend's raw result on ``form``.

    ``setup_time`` (s) is added to the backend's own (e.g. the geometry's).
    """
    return TensionSolution.from_form(
        form, raw.tensions, raw.status, backend=backend.name,
        solver=backend.solver or backend.name.split(":")[-1],
        solver_version=backend.version, unique=raw.unique, iterations=raw.iterations,
        infeasibility=raw.infeasibility, setup_time=raw.setup_time + setup_time,
        solve_time=raw.solve_time, extras=raw.extras, multipliers=raw.multipliers,
        accuracy=raw.accuracy_target, certificate=raw.certificate)
