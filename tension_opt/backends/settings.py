"""One table of solver settings: an accuracy name and a time limit, in each solver's words.

``accuracy="default"`` leaves a solver at its own defaults; ``"high"`` asks for about
1e-10 on primal feasibility, dual feasibility and the duality gap of the scaled problem
(tensions in units of a typical tension per pose). A time limit (s) goes to the
solvers that take one. Every backend translates through :func:`solver_options`, so a
solver's option names are written here once.

The table is keyed by the solver's lower-case name, whichever interface calls it
(qpsolvers, cvxpy or scipy); :data:`CVXPY_NAMES` renames the few options cvxpy spells
differently.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tension_opt.errors import InvalidInputError

#: Accuracy names every backend accepts.
ACCURACIES: tuple[str, ...] = ("default", "high")
#: Keyword options every backend accepts (a backend ignores those it has no use for).
OPTIONS: tuple[str, ...] = ("accuracy", "time_limit", "solver_options", "warm_start",
                            "batch_size")


@dataclass(frozen=True)
class SolverSettings:
    """How one solver is told an accuracy and a time limit.

    Attributes
    ----------
    high : dict
        Options for ``accuracy="high"``, in the solver's own names.
    always : dict
        Options passed on every call (e.g. an iteration cap that keeps an infeasible
        pose from running for minutes).
    time_limit : str, optional
        Name of the solver's time-limit option (s), if it has one.
    """

    high: dict[str, Any] = field(default_factory=dict)
    always: dict[str, Any] = field(default_factory=dict)
    time_limit: str | None = None


#: Settings of every solver the backends know, by lower-case solver name.
SETTINGS: dict[str, SolverSettings] = {
    "daqp": SolverSettings(high={"primal_tol": 1e-10}),
    "osqp": SolverSettings(
        high={"eps_abs": 1e-10, "eps_rel": 1e-10, "polishing": True, "max_iter": 200000},
        time_limit="time_limit"),
    # ProxQP otherwise runs millions of iterations on an infeasible pose.
    "proxqp": SolverSettings(high={"eps_abs": 1e-10, "eps_rel": 0.0},
                             always={"max_iter": 200}),
    "piqp": SolverSettings(high={"eps_abs": 1e-10, "eps_rel": 1e-11,
                                 "eps_duality_gap_abs": 1e-10,
                                 "eps_duality_gap_rel": 1e-10}),
    "clarabel": SolverSettings(
        high={"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10},
        time_limit="time_limit"),
    "highs": SolverSettings(
        high={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
        time_limit="time_limit"),
    "scs": SolverSettings(high={"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 100000},
                          time_limit="time_limit_secs"),
    "quadprog": SolverSettings(),
    "ecos": SolverSettings(high={"abstol": 1e-10, "reltol": 1e-10, "feastol": 1e-10}),
    # cvxpy's SCIPY solver takes linprog's HiGHS options wrapped in one dictionary.
    "scipy": SolverSettings(high={"scipy_options": {"primal_feasibility_tolerance": 1e-10,
                                                    "dual_feasibility_tolerance": 1e-10}}),
}

#: Options that cvxpy names differently from the solver's own interface.
CVXPY_NAMES: dict[str, dict[str, str]] = {"osqp": {"polishing": "polish"}}


def check_accuracy(accuracy: object) -> str:
    """The accuracy name, checked.

    Raises
    ------
    InvalidInputError
        For a name outside :data:`ACCURACIES`.
    """
    if accuracy is None:
        return "default"
    if not isinstance(accuracy, str) or accuracy not in ACCURACIES:
        raise InvalidInputError(
            f"accuracy must be one of {list(ACCURACIES)}, got {accuracy!r}")
    return accuracy


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
    accuracy : {"default", "high"}
    time_limit : float, optional
        Seconds; passed where the solver has a time-limit option.
    user : mapping, optional
        The caller's ``solver_options``, in the solver's own names; they win.
    interface : {"qpsolvers", "cvxpy", "scipy"}
        Who passes the options (cvxpy renames a few).
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
    if check_accuracy(accuracy) == "high":
        options.update(entry.high)
    if time_limit is not None and entry.time_limit is not None:
        options[entry.time_limit] = float(time_limit)
    if interface == "cvxpy":
        renames = CVXPY_NAMES.get(name, {})
        options = {renames.get(k, k): v for k, v in options.items()}
    if user:
        if not isinstance(user, Mapping):
            raise InvalidInputError(
                f"solver_options must be a dict of the solver's own options, got {user!r}")
        options.update(user)
    return options
