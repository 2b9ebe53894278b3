"""The backend interface: :class:`Backend` and the :class:`RawResult` it returns.

A backend solves batches of :class:`~tension_opt.problem.form.StandardForm`. Generic
solvers implement one stage (:meth:`Backend.solve_stage`); :meth:`Backend.solve` adds
the two-stage tie-break of non-unique LP optima (:mod:`tension_opt.backends.tiebreak`).

Contract of every backend (the rest of the package relies on it):

- **Threads.** One instance serves every thread: a backend keeps no state of a call
  in progress on itself (each backend's docstring says how: per-call solver objects,
  per-thread caches or a lock).
- **Honest statuses.** :meth:`Backend.solve` labels a pose ``OPTIMAL`` only with
  finite tensions whose certificate (:mod:`tension_opt.certify.certificate`: primal residual,
  dual residual and duality gap of the scaled problem, from the solver's multipliers
  where it gives them) meets the accuracy target of the call; a solver's "optimal"
  that misses it is ``INACCURATE``. The certificate, its multipliers and the target
  are the typed fields :attr:`RawResult.certificate`, :attr:`RawResult.multipliers`
  and :attr:`RawResult.accuracy_target` (a solver asked for more than it can reach
  says so in ``extras["accuracy"]``). A solver's exception on one
  pose becomes that pose's ``SOLVER_ERROR``, its message kept in ``extras["errors"]``.
- **Options.** ``solver_options`` a solver rejects (an unknown name, a value out of
  range) raise :class:`~tension_opt.errors.SolverError` carrying the solver's message
  before any pose is solved (:meth:`Backend.check_solver_options`).
"""

from __future__ import annotations

import re
import threading
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.feasibility import settle_failures
from tension_opt.backends.settings import (
    WARNING_FILTER_LOCK,
    objective_scales,
    time_limit_message,
    unreachable,
)
from tension_opt.backends.tiebreak import face_min_norm, lp_optimum_is_unique, optimal_face
from tension_opt.certify.certificate import Certificate, Multipliers, certify
from tension_opt.certify.scaling import ScaledBatch, narrowed, scaled_batch
from tension_opt.errors import SolverError
from tension_opt.problem.form import StandardForm
from tension_opt.status import STATUS_DTYPE, Status, status_array
from tension_opt.tolerances import accuracy_target

#: Per-pose solver messages kept in ``extras["errors"]`` (the first ones of a batch).
MAX_ERRORS = 10
#: A solution of a problem whose far bounds were lowered
#: (:func:`tension_opt.certify.scaling.narrowed`) is solved again with the bounds as
#: given where a lowered bound's tension reaches this share of it.
NEAR_CAP = 0.5


@dataclass
class RawResult:
    """What a backend returns for a batch: tensions (N, m) and per-pose diagnostics.

    ``multipliers`` are the solver's, of the scaled problem
    (:func:`tension_opt.certify.scaling.scaled_batch`), NaN rows where it gave none.
    ``accuracy_target`` is the target the call was judged at, and ``certificate`` the
    measures of ``tensions`` as they stand (set by :meth:`Backend.solve`, kept up to
    date by whatever changes the tensions afterwards, else None):
    :meth:`~tension_opt.distribution.solution.TensionSolution.from_form` takes them
    instead of measuring again.
    """

    tensions: NDArray
    status: NDArray
    iterations: NDArray | None
    setup_time: float = 0.0
    solve_time: float = 0.0
    unique: NDArray | None = None
    infeasibility: NDArray | None = None
    extras: dict[str, Any] = field(default_factory=dict)
    multipliers: Multipliers | None = None
    accuracy_target: float | None = None
    certificate: Certificate | None = None

    def put(self, poses: NDArray, other: RawResult) -> None:
        """Write ``other``'s answers (of the poses ``poses``, indices) into these: the
        tensions, statuses and diagnostics, the certificate's rows (else None, to be
        measured afresh) and the times added."""
        self.tensions[poses], self.status[poses] = other.tensions, other.status
        if self.unique is not None:
            self.unique[poses] = True if other.unique is None else other.unique
        if self.iterations is not None:
            self.iterations[poses] = 0 if other.iterations is None else other.iterations
        if self.infeasibility is not None:
            self.infeasibility[poses] = (np.nan if other.infeasibility is None
                                         else other.infeasibility)
        if self.certificate is not None and other.certificate is not None:
            self.certificate.put(poses, other.certificate)
        else:  # measured afresh by the solution
            self.certificate = None
            if self.multipliers is not None and other.multipliers is not None:
                self.multipliers.put(poses, other.multipliers)
        errors = other.extras.get("errors", {})
        if errors:
            mine = self.extras.setdefault("errors", {})
            for pose, message in errors.items():
                mine.setdefault(int(poses[int(pose)]), message)
        self.setup_time += other.setup_time
        self.solve_time += other.solve_time


@dataclass
class SequenceRun:
    """The raw results of a smoothed or rate-limited sequence of N poses, which a
    backend's compiled run (:meth:`Backend.solve_sequence`) writes pose by pose."""

    tensions: NDArray
    status: NDArray
    unique: NDArray
    infeasibility: NDArray
    iterations: NDArray | None
    extras: dict[str, Any]


class Backend:
    """A way of solving :class:`~tension_opt.problem.form.StandardForm` batches.

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

    #: Name of the underlying solver (an attribute, set by each backend: the flow reads
    #: it without a call).
    solver: str = ""

    @property
    def version(self) -> str:
        """Version of the underlying library."""
        return ""

    def unsupported(self, form: StandardForm) -> str | None:
        """Why this backend cannot solve ``form`` (None if it can)."""
        return None

    def solve(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve a batch, certify it, test LP optima for uniqueness and break ties.

        Raises
        ------
        SolverError
            If the solver rejects ``options["solver_options"]``.
        """
        self.check_solver_options(options)
        narrow, lowered = narrowed(form)  # far bounds would loosen the certificate
        raw = honest(self._solve_and_break_ties(narrow, options))
        if lowered is not None:
            # Poses whose lowered bound nears activity, or that the narrowed problem
            # does not solve, are solved again with the bounds as given.
            cap = narrow.ub
            with np.errstate(invalid="ignore"):
                near = (lowered & ~(raw.tensions < NEAR_CAP * cap)).any(axis=1)
            again = np.flatnonzero(lowered.any(axis=1)
                                   & (near | (raw.status != Status.OPTIMAL)))
            if len(again):
                raw.put(again, honest(self._solve_and_break_ties(form.subset(again),
                                                                 options)))
        settle_failures(form, raw, MAX_ERRORS)  # a silent failure or impossible verdict
        return raw

    def _certified(self, form: StandardForm, raw: RawResult, target: float) -> RawResult:
        """``raw`` with its certificate: ``OPTIMAL`` poses that miss ``target`` become
        ``INACCURATE``; the certificate, its multipliers (completed where the solver
        gave none) and the target go to their fields."""
        batch = scaled_batch(form)
        certificate = certify(batch, batch.lift(raw.tensions), raw.multipliers, target)
        raw.status = np.asarray(raw.status, dtype=STATUS_DTYPE)
        raw.status[(raw.status == Status.OPTIMAL) & ~certificate.certified] = Status.INACCURATE
        raw.multipliers = certificate.multipliers
        raw.certificate = certificate
        raw.accuracy_target = target
        note = None if self.exact else unreachable(self.solver, target)
        if note is not None:
            raw.extras["accuracy"] = note
        return raw

    def _solve_and_break_ties(self, form: StandardForm, options: dict[str, Any]) -> RawResult:
        target = accuracy_target(options.get("accuracy"))
        first = self._certified(form, self.solve_stage(form, **options), target)
        problem = form.problem
        if not form.is_linear or (problem is not None and not problem.tie_break):
            first.unique = np.ones(form.N, dtype=bool)
            return first
        assert first.multipliers is not None  # set by _certified
        z = first.multipliers.z[:, :form.m]  # of the tension bounds, scaled problem
        unique = np.ones(form.N, dtype=bool)
        idx = np.flatnonzero(first.status == Status.OPTIMAL)
        if len(idx):
            unique[idx] = lp_optimum_is_unique(form.subset(idx), first.tensions[idx], z[idx])
        tied = np.flatnonzero(~unique)
        first.unique = unique
        if len(tied):
            self._break_ties(form, first, tied, z[tied], options, target)
        return first

    def _break_ties(self, form: StandardForm, first: RawResult, tied: NDArray, z: NDArray,
                    options: dict[str, Any], target: float) -> None:
        """Move the tied poses of ``first`` to the minimum-norm point of their optimal
        face (a second stage of this solver, certified on the face, else exactly), then
        certify them again with the LP's multipliers (an LP's multipliers hold on its
        whole optimal face)."""
        t0 = time.perf_counter()
        sub = form.subset(tied)
        face = optimal_face(sub, first.tensions[tied], z)
        setup = 0.0
        if self.unsupported(face) is not None:
            # An LP-only solver: break the tie exactly on the optimal face.
            broken, found = face_min_norm(sub, first.tensions[tied], z)
            first.tensions[tied] = broken
            if not found.all():
                first.extras["tie_break"] = (
                    f"{int((~found).sum())} optimal face(s) empty after rounding: vertex kept")
        else:
            second = self.solve_stage(face, **options)
            # The face's own certificate: a solver that stops short of the minimum norm
            # (or keeps the vertex) hands the tie to the exact method.
            face_batch = scaled_batch(face)
            good = (second.status == Status.OPTIMAL) & certify(
                face_batch, face_batch.lift(second.tensions), second.multipliers,
                target).certified
            first.tensions[tied[good]] = second.tensions[good]
            if not good.all():  # the solver failed on the face: break the tie exactly
                bad = tied[~good]
                broken, found = face_min_norm(form.subset(bad), first.tensions[bad], z[~good])
                first.tensions[bad] = broken
                first.status[bad[~found]] = Status.INACCURATE
            setup = second.setup_time
            if first.iterations is not None and second.iterations is not None:
                first.iterations[tied] += second.iterations
        batch = scaled_batch(sub)
        assert first.multipliers is not None and first.certificate is not None
        again = certify(batch, batch.lift(first.tensions[tied]),
                        first.multipliers.subset(tied), target)
        first.certificate.put(tied, again)  # its multipliers are first.multipliers
        missed = tied[(first.status[tied] == Status.OPTIMAL) & ~again.certified]
        first.status[missed] = Status.INACCURATE
        first.solve_time += time.perf_counter() - t0 - setup
        first.setup_time += setup

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve one stage (no tie-break). Generic backends override this."""
        raise NotImplementedError

    def runs_sequences(self, options: Mapping[str, Any], smoothed: StandardForm,
                       poses: int) -> bool:
        """Whether :meth:`solve_sequence` runs the poses of a smoothed or rate-limited
        sequence in one compiled loop with these options (else each pose is solved on
        its own form by :meth:`solve`); ``smoothed`` is the form of one pose smoothed
        against some tensions, ``poses`` the length of the sequence."""
        return False

    def solve_sequence(self, base: StandardForm, smoothing: float, rate: NDArray,
                       last: NDArray, start: int, run: SequenceRun,
                       options: Mapping[str, Any]) -> int:
        """Poses ``start, start + 1, ...`` of a smoothed or rate-limited sequence in one
        compiled loop, each as :meth:`solve` would solve its one-pose form.

        Parameters
        ----------
        base : StandardForm
            The unsmoothed forms of all N poses (no min-max term, no extra rows).
        smoothing : float
            The problem's smoothing weight.
        rate : ndarray, shape (m,)
            Rate limit per cable (N), ``inf`` where none.
        last : ndarray, shape (m,)
            Tensions (N) the first pose is smoothed against (NaN: none); takes those of
            each pose reported optimal, in place.
        start : int
        run : SequenceRun
            Raw results, written for the poses solved.
        options : mapping
            The call's backend options.

        Returns
        -------
        int
            The first pose left to :meth:`solve` on its own form (one the loop does not
            settle), or N.
        """
        raise NotImplementedError

    # ------------------------------------------------------------ solver options
    def rejected_options(self, user: Mapping[str, Any]) -> str | None:
        """Why the solver would refuse ``user`` options it would otherwise ignore
        silently (an unknown name), or None. Backends whose solver ignores unknown
        names override this; the others are caught by :meth:`check_solver_options`."""
        return None

    def check_solver_options(self, options: Mapping[str, Any]) -> None:
        """Raise :class:`SolverError` if the solver rejects the call's ``solver_options``.

        The options are tried once (per backend, accuracy and options) on a two-cable
        problem with a known answer: an exception, a warning of the solver or a
        ``SOLVER_ERROR`` where the solver's defaults succeed is reported with the
        solver's own message, instead of a silent ``solver_error`` on every pose.
        """
        user = options.get("solver_options")
        if not user:
            return
        key = (self.name, repr(options.get("accuracy")), repr(options.get("time_limit")),
               repr(sorted(user.items(), key=lambda item: str(item[0]))))
        with _CHECKED_LOCK:
            known = _CHECKED.get(key, _UNSEEN)
        if known is _UNSEEN:
            known = self.rejected_options(user) or self._probe_options(options)
            with _CHECKED_LOCK:
                _CHECKED[key] = known
        if known is not None:
            raise SolverError(f"{self.name} rejects solver_options={dict(user)!r}: {known}")

    def _probe_options(self, options: Mapping[str, Any]) -> str | None:
        forms = [probe_form(q) for q in (0.0, 2.0)]
        form = next((f for f in forms if self.unsupported(f) is None), None)
        if form is None:
            return None
        # Some solvers only warn about their options (scipy's linprog). Recording
        # warnings swaps the process's filters, so no other solve may start or end
        # meanwhile: the probe holds the lock of the solvers' filter.
        with WARNING_FILTER_LOCK, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            raw = self.solve_stage(form, **options)
        errors = raw.extras.get("errors")
        if errors:
            return str(next(iter(errors.values())))
        complaints = [str(w.message) for w in caught if _OPTION_WORDS.search(str(w.message))]
        if complaints:
            return "; ".join(complaints)
        if raw.status[0] == Status.SOLVER_ERROR:
            plain = {k: v for k, v in options.items() if k != "solver_options"}
            if self.solve_stage(form, **plain).status[0] != Status.SOLVER_ERROR:
                return "the solver fails with these options on a problem it solves without them"
        return None


#: Warnings of solvers about their options.
_OPTION_WORDS = re.compile(r"unrecogni[sz]ed option|invalid option|unknown option|"
                           r"undefined solver setting", re.IGNORECASE)
_UNSEEN = object()
_CHECKED: dict[tuple[str, ...], Any] = {}
_CHECKED_LOCK = threading.Lock()


def probe_form(q: float) -> StandardForm:
    """A two-cable problem every solver settles at once: ``T1 + T2 = 1``, ``T >= 0``,
    minimising ``T1 + 2 T2`` (``q = 0``, optimum (1, 0)) or ``q/2 |T|^2`` (optimum
    (0.5, 0.5))."""
    c = np.array([[1.0, 2.0]]) if q == 0 else np.zeros((1, 2))
    return StandardForm(np.ones((1, 1, 2)), np.ones((1, 1)), np.zeros((1, 2)),
                        np.full((1, 2), np.inf), np.full((1, 2), q), c)


def honest(result: RawResult) -> RawResult:
    """``result`` with ``OPTIMAL`` or ``INACCURATE`` poses whose tensions are not all
    finite relabelled ``SOLVER_ERROR`` (and their tensions NaN)."""
    result.status = np.asarray(result.status, dtype=STATUS_DTYPE)  # room for every value
    solved = (result.status == Status.OPTIMAL) | (result.status == Status.INACCURATE)
    bad = solved & ~np.isfinite(result.tensions).all(axis=1)
    if bad.any():
        result.status[bad] = Status.SOLVER_ERROR
        result.tensions[bad] = np.nan
        errors = result.extras.setdefault("errors", {})
        for i in np.flatnonzero(bad)[:MAX_ERRORS]:
            errors.setdefault(int(i), "non-finite tensions returned as a solution")
    return result


def describe(error: BaseException) -> str:
    """A solver's exception as text: its type and message (OSQP's bare error codes
    get their names; OSQP prints the details itself)."""
    chain = [error]
    while len(chain) < 5 and (chain[-1].__cause__ or chain[-1].__context__) is not None:
        chain.append(chain[-1].__cause__ or chain[-1].__context__)  # type: ignore[arg-type]
    # OSQP's own exception, wherever a wrapper (cvxpy) or its helpers put it.
    error = next((e for e in chain if type(e).__name__ == "OSQPException"), error)
    text = str(error)
    if type(error).__name__ == "OSQPException" and text.strip().isdigit():
        try:
            from osqp.ext_builtin import osqp_error_type

            text = f"{osqp_error_type(int(text)).name} (OSQP printed the details)"
        except (ImportError, ValueError):
            text = f"OSQP error {text}"
    return f"{type(error).__name__}: {text}"


def note_error(extras: dict[str, Any], pose: int, error: BaseException) -> None:
    """Keep the message of a solver's exception on ``pose`` in ``extras["errors"]``."""
    errors = extras.setdefault("errors", {})
    if len(errors) < MAX_ERRORS:
        errors[pose] = describe(error)


def note_time_limit(extras: dict[str, Any], pose: int, limit: float | None,
                    status: str) -> Status:
    """The status of a pose whose solver call ran out of its time ``limit`` without an
    answer, ``MAX_ITER`` (an inaccurate answer or a verdict keeps its own), its message
    put in ``extras["errors"]``."""
    errors = extras.setdefault("errors", {})
    if len(errors) < MAX_ERRORS:
        errors[pose] = time_limit_message(limit)
    if status in (Status.SOLVER_ERROR, Status.NOT_RUN):
        return Status.MAX_ITER
    return Status(status)


def objective_powers(solver: str, form: StandardForm, batch: ScaledBatch) -> NDArray | None:
    """Per pose, the power of two by which ``solver`` is asked to scale the objective of
    the scaled ``batch`` of ``form`` (:func:`~tension_opt.backends.settings.objective_scales`:
    the reference tension over the typical tension), or None."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = batch.scale / form.typical_tension()
    quadratic = batch.P.max(axis=1, initial=0.0) > 0
    return objective_scales(solver, ratio, quadratic)


def pose_loop_result(N: int, m: int) -> tuple[NDArray, NDArray, NDArray]:
    """Empty tensions (NaN), statuses (NOT_RUN) and iterations (0) for a pose loop."""
    return np.full((N, m), np.nan), status_array(N, Status.NOT_RUN), np.zeros(
        N, dtype=int)
