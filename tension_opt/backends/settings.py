"""One table of solver settings: an accuracy target and a time limit, in each solver's words.

``accuracy`` names a target on the three measures of a solution's certificate, all
taken on the scaled problem (:mod:`tension_opt.certify.certificate`): primal residual (equilibrium
and bounds), dual residual (stationarity) and duality gap. ``"default"`` is 1e-7,
``"high"`` 1e-10, and a number between 1e-14 and 1e-2 is taken as the target itself.
:data:`SETTINGS` says, per solver, which of its options bound those measures and at
what fraction of the target to set them (solvers measure their own criteria a little
differently, so most are asked for a tenth of it), plus the options it needs to get
there (iteration caps, polishing). A solver whose :attr:`SolverSettings.floor` is above
the target is run at its floor and reports so (:func:`unreachable`); every answer is
judged by its certificate anyway, so a target a solver misses shows as ``inaccurate``.

A time limit (s) goes to the solvers that take one (OSQP, Clarabel, HiGHS, SCS), per
solver call (a pose, or a joint cvxpy solve of ``batch_size`` poses): the call's
``time_limit``, :data:`DEFAULT_TIME_LIMIT` (10 s) when it gives none, no limit only for
``time_limit=None`` given by name (:func:`time_limit_of`). A call stopped by it reads
``max_iter``, with a message in ``extras["errors"]``. The other solvers stop on their
own iteration caps (DAQP 10000 iterations, ProxQP 1000, PIQP, ECOS and quadprog their
defaults). Every backend translates through :func:`solver_options`, so a solver's
option names are written here once. The table is
keyed by the solver's lower-case name, whichever interface calls it (qpsolvers, cvxpy
or scipy); :data:`CVXPY_NAMES` renames the few options cvxpy spells differently and
:data:`CVXPY_DROPS` lists those its interface does not pass on.
"""

from __future__ import annotations

import math
import threading
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.tolerances import ACCURACY_TARGETS, DEFAULT_TARGET, accuracy_target

__all__ = ["ACCURACIES", "CVXPY_DROPS", "CVXPY_NAMES", "DEFAULT_TARGET", "DEFAULT_TIME_LIMIT",
           "OPTIONS", "SETTINGS", "WARNING_FILTER_LOCK", "SolverSettings", "accuracy_target",
           "check_accuracy", "check_options", "objective_scales", "quiet_solvers", "solver_options",
           "time_limit_message", "time_limit_of", "unreachable", "with_objective_scale"]

#: Accuracy names every backend accepts (a number between 1e-14 and 1e-2 is accepted too).
ACCURACIES: tuple[str, ...] = tuple(ACCURACY_TARGETS)
#: Keyword options every backend accepts (a backend ignores those it has no use for).
OPTIONS: tuple[str, ...] = ("accuracy", "time_limit", "solver_options", "warm_start",
                            "batch_size")
#: Seconds one solver call may run when the call gives no ``time_limit``.
DEFAULT_TIME_LIMIT = 10.0


@dataclass(frozen=True)
class SolverSettings:
    """How one solver is told an accuracy target and a time limit.

    Attributes
    ----------
    tolerances : dict
        The solver's tolerance options, each as a fraction of the target (the option
        is set to ``fraction * target``).
    fixed : dict
        Options passed with every target (e.g. polishing, an iteration budget large
        enough to reach it).
    always : dict
        Options of every per-pose call (a cap that keeps an infeasible pose from
        running for minutes); left out for larger problems (a whole path).
    floor : float
        Tightest target the solver reaches on these problems; below it the solver
        runs at its floor.
    time_limit : str, optional
        Name of the solver's time-limit option (s), if it has one.
    objective_scale : str, optional
        Name of the solver's option that scales the objective by a power of two
        (:func:`objective_scales`), if it needs one.
    nest : str, optional
        Name of a single option that holds the others as a dict (cvxpy's SCIPY).
    defaults : dict
        The solver's own defaults: an option asked at its default value is not passed
        (scipy's HiGHS wrapper checks each option it is given, at about 70 us apiece,
        longer than a small LP's solve).
    """

    tolerances: dict[str, float] = field(default_factory=dict)
    fixed: dict[str, Any] = field(default_factory=dict)
    always: dict[str, Any] = field(default_factory=dict)
    floor: float = 1e-14
    time_limit: str | None = None
    objective_scale: str | None = None
    nest: str | None = None
    defaults: dict[str, Any] = field(default_factory=dict)

    @property
    def high(self) -> dict[str, Any]:
        """The options of ``accuracy="high"`` (as earlier versions had them)."""
        return self.options(accuracy_target("high"))

    def options(self, target: float) -> dict[str, Any]:
        """The options that ask for ``target`` (at least the floor)."""
        goal = max(target, self.floor)
        options: dict[str, Any] = {name: fraction * goal
                                   for name, fraction in self.tolerances.items()}
        options.update(self.fixed)
        options = {name: value for name, value in options.items()
                   if name not in self.defaults or self.defaults[name] != value}
        return {self.nest: options} if self.nest and options else options


#: Largest power of two an objective is scaled by (a reference 1e6 times the typical
#: tension). HiGHS's QP solver fails on the study robot from t_max = 1e11 N whatever the
#: power; from 2^50 it turned the inaccurate answers it gave at 1e15 N into errors.
_MAX_OBJECTIVE_POWER = 40

#: HiGHS's own feasibility tolerances (its documentation's defaults).
_HIGHS_DEFAULTS = {"primal_feasibility_tolerance": 1e-7, "dual_feasibility_tolerance": 1e-7}

#: Settings of every solver the backends know, by lower-case solver name.
SETTINGS: dict[str, SolverSettings] = {
    # Active-set solvers land on vertices: their tolerance is one of feasibility. DAQP's
    # equations hold to a few 1e-10 of the scaled problem (CoGiRo's LPs: up to 2e-9),
    # whatever it is asked: its floor.
    "daqp": SolverSettings({"primal_tol": 0.1}, floor=1e-8),
    "quadprog": SolverSettings(),
    "osqp": SolverSettings(
        {"eps_abs": 0.1, "eps_rel": 0.1},
        {"polishing": True, "polish_refine_iter": 10, "max_iter": 50000},
        floor=1e-12, time_limit="time_limit"),
    # ProxQP otherwise runs millions of iterations on an infeasible pose.
    "proxqp": SolverSettings(
        {"eps_abs": 0.1, "eps_duality_gap_abs": 0.1},
        {"eps_rel": 0.0, "check_duality_gap": True}, always={"max_iter": 1000},
        floor=1e-12),
    "piqp": SolverSettings({"eps_abs": 0.1, "eps_rel": 0.01, "eps_duality_gap_abs": 0.1,
                            "eps_duality_gap_rel": 0.1}, floor=1e-12),
    "clarabel": SolverSettings({"tol_gap_abs": 0.1, "tol_gap_rel": 0.1, "tol_feas": 0.1,
                                "tol_ktratio": 0.1}, floor=1e-12, time_limit="time_limit"),
    # HiGHS refuses feasibility tolerances below 1e-10; its simplex lands on vertices.
    # Its QP solver stalls on objectives far below one (:func:`objective_scales`).
    "highs": SolverSettings({"primal_feasibility_tolerance": 1.0,
                             "dual_feasibility_tolerance": 1.0}, floor=1e-10,
                            time_limit="time_limit", objective_scale="user_objective_scale",
                            defaults=_HIGHS_DEFAULTS),
    "scs": SolverSettings({"eps_abs": 0.1, "eps_rel": 0.1}, {"max_iters": 100000},
                          floor=1e-10, time_limit="time_limit_secs"),
    "ecos": SolverSettings({"abstol": 0.1, "reltol": 0.1, "feastol": 0.1}, floor=1e-12),
    # cvxpy's SCIPY solver takes linprog's HiGHS options wrapped in one dictionary.
    "scipy": SolverSettings({"primal_feasibility_tolerance": 1.0,
                             "dual_feasibility_tolerance": 1.0}, floor=1e-10,
                            nest="scipy_options", defaults=_HIGHS_DEFAULTS),
}

#: Options that cvxpy names differently from the solver's own interface.
CVXPY_NAMES: dict[str, dict[str, str]] = {"osqp": {"polishing": "polish"}}
#: Options that cvxpy's interface of a solver does not pass on (it would drop them).
CVXPY_DROPS: dict[str, frozenset[str]] = {
    "proxqp": frozenset({"check_duality_gap", "eps_duality_gap_abs"}),
    "osqp": frozenset({"polish_refine_iter"}),
}


def time_limit_of(options: Mapping[str, Any]) -> float | None:
    """The time limit (s) of each solver call of a call with these backend options: its
    ``time_limit``, :data:`DEFAULT_TIME_LIMIT` if it has none, None (no limit) only
    where it says ``time_limit=None``."""
    return options["time_limit"] if "time_limit" in options else DEFAULT_TIME_LIMIT


def time_limit_message(limit: float | None) -> str:
    """The message of a pose whose solver call was stopped by the time limit."""
    return (f"the solver was stopped at the time limit of {limit:g} s per call "
            "(time_limit=...; None for no limit)")


def objective_scales(solver: str, ratio: NDArray, quadratic: NDArray) -> NDArray | None:
    """Per pose, the power of two by which ``solver`` scales the objective, or None.

    The scaled problem's tensions are over a reference floored at ``UB_SHARE`` of the
    largest finite upper bound (:mod:`tension_opt.certify.scaling`): with a bound far
    above the load its tensions are ``1 / ratio`` (``ratio`` = reference over typical
    tension) and its objective about ``ratio^-2`` (QP). The study robot at
    ``t_max = 1e10`` N has a reference of 1e7 N, tensions of 5e-4 and a min-norm
    objective of 1e-7, on which HiGHS's QP solver, whose thresholds on a step's
    improvement are absolute, stalled for over 400 s (3 of 40 pond poses); asked to
    scale the objective by ``2^22`` (its ``user_objective_scale``, undone on the
    answer and its multipliers) it solves them in milliseconds. The exponent is
    ``round(log2(ratio^2))`` for a QP, 0 for an LP (HiGHS's simplex does not stall on
    them) and wherever the reference is the typical tension itself: there nothing is
    passed and every answer is as before.

    Parameters
    ----------
    solver : str
        Solver name, any case.
    ratio : ndarray, shape (N,)
        Reference tension over typical tension per pose (>= 1; NaN or inf counts as 1).
    quadratic : ndarray of bool, shape (N,)
        Whether the pose's objective has a quadratic term.

    Returns
    -------
    ndarray of int, shape (N,), or None
        None where the solver has no such option or no pose needs it.
    """
    if SETTINGS.get(solver.lower(), SolverSettings()).objective_scale is None:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        power = np.where(np.isfinite(ratio) & (ratio > 1.0) & quadratic,
                         np.rint(2.0 * np.log2(np.where(ratio > 1.0, ratio, 1.0))), 0.0)
    exponents = np.clip(power, 0, _MAX_OBJECTIVE_POWER).astype(np.int64)
    return exponents if exponents.any() else None


def with_objective_scale(solver: str, settings: dict[str, Any], exponent: int,
                         user: Mapping[str, Any] | None) -> dict[str, Any]:
    """``settings`` of one call with the objective scaled by ``2^exponent``
    (:func:`objective_scales`); the user's own value of that option wins."""
    name = SETTINGS.get(solver.lower(), SolverSettings()).objective_scale
    if name is None or exponent == 0 or (user is not None and name in user):
        return settings
    return {**settings, name: int(exponent)}


def unreachable(solver: str, accuracy: object) -> str | None:
    """Why ``solver`` cannot be asked for the target of ``accuracy`` (None if it can)."""
    target = accuracy_target(accuracy)
    entry = SETTINGS.get(solver.lower(), SolverSettings())
    if target < entry.floor:
        return (f"{solver} cannot be asked for an accuracy of {target:g} (its floor is "
                f"{entry.floor:g}); it ran at {entry.floor:g} and its answers are certified "
                f"against {target:g}")
    return None


def check_accuracy(accuracy: object) -> str | float:
    """The accuracy, checked: a name of :data:`ACCURACIES` (None is ``"default"``) or a
    target between 1e-14 and 1e-2.

    Raises
    ------
    InvalidInputError
        For another name or a number out of range.
    """
    accuracy_target(accuracy)
    return "default" if accuracy is None else accuracy  # type: ignore[return-value]


def check_options(options: Mapping[str, Any]) -> None:
    """Check backend options by name and value.

    Raises
    ------
    InvalidInputError
        For an unknown option (listing the known ones), an unknown accuracy, a time
        limit that is not a positive number of seconds, a ``batch_size`` that is not a
        positive whole number, a ``warm_start`` that is not a bool, or
        ``solver_options`` that is not a dict with names as keys.
    """
    unknown = sorted(map(str, set(options) - set(OPTIONS)))
    if unknown:
        raise InvalidInputError(
            f"unknown option(s) {unknown}; backends take {list(OPTIONS)} (a solver's own "
            "settings go in solver_options={...})")
    check_accuracy(options.get("accuracy"))
    limit = options.get("time_limit")
    if limit is not None and not (_is_real(limit) and limit > 0 and not math.isnan(limit)):
        raise InvalidInputError(f"time_limit must be a positive number of seconds, got {limit!r}")
    size = options.get("batch_size")
    if size is not None and not (isinstance(size, int | np.integer)
                                 and not isinstance(size, bool) and size >= 1):
        raise InvalidInputError(f"batch_size must be a whole number >= 1, got {size!r}")
    warm = options.get("warm_start")
    if warm is not None and not isinstance(warm, bool | np.bool_):
        raise InvalidInputError(f"warm_start must be True or False, got {warm!r}")
    user = options.get("solver_options")
    if user is not None and not isinstance(user, Mapping):
        raise InvalidInputError(
            f"solver_options must be a dict of the solver's own options, got {user!r}")
    if user is not None and not all(isinstance(key, str) for key in user):
        raise InvalidInputError(
            f"solver_options must be keyed by the solver's option names, got {list(user)!r}")


def _is_real(value: object) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool)


def solver_options(solver: str, accuracy: object = "default",
                   time_limit: float | None = None,
                   user: Mapping[str, Any] | None = None, *,
                   interface: str = "qpsolvers", per_pose: bool = True) -> dict[str, Any]:
    """Options for one solver call: the table's, then the user's own.

    Parameters
    ----------
    solver : str
        Solver name, any case (``"osqp"``, ``"CLARABEL"``).
    accuracy : {"default", "high"} or float
        The target on the certificate's measures (see the module docstring).
    time_limit : float, optional
        Seconds; passed where the solver has a time-limit option.
    user : mapping, optional
        The caller's ``solver_options``, in the solver's own names; they win.
    interface : {"qpsolvers", "cvxpy", "scipy"}
        Who passes the options (cvxpy renames a few and drops others).
    per_pose : bool
        Whether the call solves one pose's small problem; the ``always`` caps are sized
        for those and left out for larger problems (a whole path).

    Returns
    -------
    dict
    """
    name = solver.lower()
    entry = SETTINGS.get(name, SolverSettings())
    options: dict[str, Any] = dict(entry.always) if per_pose else {}
    options.update(entry.options(accuracy_target(accuracy)))
    if time_limit is not None and entry.time_limit is not None:
        options[entry.time_limit] = float(time_limit)
    if interface == "cvxpy":
        renames, drops = CVXPY_NAMES.get(name, {}), CVXPY_DROPS.get(name, frozenset())
        options = {renames.get(k, k): v for k, v in options.items() if k not in drops}
    if user:
        if not isinstance(user, Mapping):
            raise InvalidInputError(
                f"solver_options must be a dict of the solver's own options, got {user!r}")
        options.update(user)
    return options


class _Quiet:
    """Process-wide silencing of the solver libraries' own warnings, counted by user.

    Their warnings (a matrix converted to CSC, "OSQP exited with status ...") repeat
    what the statuses say. :func:`warnings.catch_warnings` per call is not safe across
    threads (overlapping calls restore each other's filters and can leave warnings off
    for good), so one filter is added when the first solve starts and removed when the
    last one ends.
    """

    #: Modules whose warnings are silenced, and messages (cvxpy attributes its
    #: "Solution may be inaccurate" to the caller).
    MODULES = r"(qpsolvers|osqp|cvxpy|scs|clarabel|piqp|proxsuite|daqp|highspy)(\.|$)"
    MESSAGES = r"Solution may be inaccurate"

    def __init__(self) -> None:
        # Re-entrant: an option probe holds it around solves that enter it again.
        self.lock = threading.RLock()
        self.users = 0
        self.entries: list[Any] = []

    def enter(self) -> None:
        with self.lock:
            if self.users == 0:
                warnings.filterwarnings("ignore", module=self.MODULES)
                warnings.filterwarnings("ignore", message=self.MESSAGES)
                self.entries = list(warnings.filters[:2])
            self.users += 1

    def leave(self) -> None:
        with self.lock:
            self.users -= 1
            if self.users == 0:
                for entry in self.entries:
                    if entry in warnings.filters:
                        # The module's list (its stubs type it as a read-only sequence).
                        cast("list[Any]", warnings.filters).remove(entry)


_QUIET = _Quiet()
#: Held while a solve swaps the process's warning filters (an option probe), so that no
#: other solve starts or ends meanwhile.
WARNING_FILTER_LOCK = _QUIET.lock


@contextmanager
def quiet_solvers() -> Iterator[None]:
    """Silence the solver libraries' warnings while the block runs (thread-safe)."""
    _QUIET.enter()
    try:
        yield
    finally:
        _QUIET.leave()
