"""A fuzzed contract over the public entry points.

Every call either raises the package's own error (:class:`tension_opt.TensionOptError`
or :class:`catenary.CatenaryError`) whose message names the argument at fault, or
returns a result whose status is honest: where it says ``optimal`` the values are
finite and their certificate holds (equilibrium and bounds). No other exception type,
and no hang: every call runs under a watchdog besides hypothesis' per-example deadline.
The catenary solvers and the sag-aware kinematics have their own fuzzed contract in
``tests/catenary/test_contract.py``.

The examples are derandomised (the same on every run) and their number is bounded so
that the module runs in about two minutes on two cores. Random robots include
degenerate ones: coplanar or coincident attachments, anchors on a line, 1 to 12
cables, every kind.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from tension_opt.kinds import KINDS
from tension_opt.problem.objectives import OBJECTIVES
from tension_opt.status import Status
from tension_opt.tolerances import FEASIBILITY_TOL

# Kernels compile before the watchdog times any call (see tests/conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_kernels")

#: Longest a single call may take (s) before the watchdog calls it a hang.
CALL_LIMIT = 20.0
PACKAGE_ERRORS = (to.TensionOptError, catenary.CatenaryError)
BACKENDS = [*to.available_backends(), "auto"]


#: ``TENSION_OPT_FUZZ=10`` runs ten times the examples, freshly drawn, for a deeper hunt;
#: by default the examples are the same on every run.
DEPTH = float(os.environ.get("TENSION_OPT_FUZZ", "1"))


def contract_settings(examples: int) -> settings:
    """Deterministic settings (unless :data:`DEPTH` says otherwise) with a per-example
    deadline."""
    return settings(max_examples=int(examples * DEPTH), deadline=10_000,
                    derandomize=DEPTH == 1, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                           HealthCheck.data_too_large])


@contextmanager
def watchdog(seconds: float) -> Iterator[None]:
    """Raise TimeoutError in the main thread if the block runs longer than ``seconds``."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum: int, frame: Any) -> None:
        raise TimeoutError(f"no return after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def keeps_contract(call: Callable[[], Any], names: tuple[str, ...],
                   limit: float = CALL_LIMIT) -> Any:
    """``call()``, or None if it raised the package's error naming one of ``names``.

    Any other exception (a hang of more than ``limit`` s included) propagates and fails
    the example.
    """
    try:
        with watchdog(limit):
            return call()
    except PACKAGE_ERRORS as error:
        if isinstance(error, to.InvalidInputError | catenary.CatenaryError):
            text = str(error).lower()
            assert any(name.lower() in text for name in names), (
                f"{type(error).__name__} names none of {names}: {error}")
        return None


# --------------------------------------------------------------------- strategies
def _points(rng: np.random.Generator, layout: str, m: int, size: float) -> np.ndarray:
    angles = np.linspace(0.0, 2 * np.pi, m, endpoint=False) + rng.uniform(0, 0.3)
    ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(m)]) * size
    if layout == "ring_high":
        return ring + np.array([0.0, 0.0, size])
    if layout == "ring":
        return ring
    if layout == "coplanar":  # every point in one vertical plane
        return np.column_stack([rng.uniform(-size, size, m), np.zeros(m),
                                rng.uniform(0, size, m)])
    if layout == "line":
        return np.outer(rng.uniform(-1, 1, m), [1.0, 0.5, 0.2]) * size
    if layout == "coincident":
        return np.tile(rng.uniform(-size, size, 3), (m, 1))
    if layout == "zero":
        return np.zeros((m, 3))
    return rng.uniform(-size, size, (m, 3))  # "random"


@st.composite
def robot_fields(draw: st.DrawFn) -> dict[str, Any]:
    """Constructor arguments of a random robot: mostly sensible, sometimes degenerate."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(sorted(KINDS)))
    m = draw(st.integers(1, 12))
    size = draw(st.sampled_from([1.0, 10.0, 100.0]))
    anchors = _points(rng, draw(st.sampled_from(
        ["ring_high", "ring_high", "random", "coplanar", "line"])), m, size)
    attachments = _points(rng, draw(st.sampled_from(
        ["zero", "zero", "ring", "coplanar", "coincident", "random"])), m, size / 20)
    mass = draw(st.sampled_from([1.0, 10.0, 250.0]))
    weight = mass * 9.81
    return dict(anchors=anchors, attachments=attachments, mass=mass, kind=kind,
                t_min=draw(st.sampled_from([0.0, 0.0, 0.05 * weight])),
                t_max=draw(st.sampled_from([np.inf, np.inf, 20 * weight, 2 * weight])),
                name="fuzzed")


@st.composite
def robots(draw: st.DrawFn) -> to.CableRobot | None:
    """A random robot, or None where the constructor (rightly) refused its data."""
    fields = draw(robot_fields())
    return keeps_contract(lambda: to.CableRobot(**fields), ROBOT_NAMES)


ROBOT_NAMES = ("anchors", "attachments", "mass", "kind", "com", "g", "t_min", "t_max",
               "cable", "home", "diameter", "linear_mass", "EA", "weight")

#: Values numpy cannot make a float array of, or of a wrong shape or value.
GARBAGE = ["abc", [[1.0, 2.0], [3.0]], None, [[np.nan, 1.0, 2.0]], np.zeros((2, 2, 2)),
           [np.inf], -1.0, [], object()]


@st.composite
def poses_for(draw: st.DrawFn, robot: to.CableRobot) -> Any:
    """Poses near the robot's drawing points (N from 0 to 4), sometimes garbage."""
    if draw(st.integers(0, 19)) == 0:
        return draw(st.sampled_from(GARBAGE))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    N = draw(st.sampled_from([0, 1, 1, 2, 3, 4]))
    spread = float(np.ptp(robot.anchors, axis=0).max()) or 1.0
    centre = robot.anchors.mean(axis=0) - [0.0, 0.0, 0.3 * spread]
    home = robot.pattern.home(centre)
    step = np.full(robot.dof, 0.3)
    step[list(robot.pattern.positions)] = 0.3 * spread
    poses = home + rng.uniform(-1, 1, (N, robot.dof)) * step
    return poses[0] if N == 1 and draw(st.booleans()) else poses


#: Wrong values of each problem field, one of which spoils a few examples.
BAD_FIELDS: dict[str, list[Any]] = {
    "weights": ["abc", -1.0, [[1.0]], [np.nan]], "t_min": [-1e5, "x", [np.inf], np.ones((2, 2, 2))],
    "t_max": [-1.0, np.nan, [-np.inf]], "smoothing": [-1.0, np.nan, "1", True, 1e300],
    "rate_limit": [0.0, -1.0, np.ones((2, 2))], "reference": [[np.nan], -1.0, "r"],
    "tie_break": ["yes", None], "objective": ["min_summ", 3, None],
}


@st.composite
def problem_fields(draw: st.DrawFn, m: int) -> dict[str, Any]:
    """Fields of a TensionProblem: every objective, weights, bounds, smoothing, rate limits,
    references; one field is spoilt in about one example in eight."""
    objective = draw(st.sampled_from(sorted(OBJECTIVES)))
    fields: dict[str, Any] = {"objective": objective}
    scale = draw(st.sampled_from([1.0, 100.0, 1e4]))
    if draw(st.booleans()):
        fields["weights"] = draw(st.sampled_from([
            np.ones(m), np.linspace(0.5, 2.0, m), np.full(m, 1e-8), np.full(m, 1e8),
            np.ones(m + 1)]))
    if draw(st.integers(0, 3)) == 0:
        fields["t_min"] = draw(st.sampled_from([0.0, 0.1 * scale, np.full(m, scale),
                                                np.linspace(0, scale, m), np.zeros(m + 1)]))
    if draw(st.integers(0, 3)) == 0:
        fields["t_max"] = draw(st.sampled_from([np.inf, 10 * scale, np.full(m, 1e3 * scale),
                                                0.0]))
    if draw(st.integers(0, 2)) == 0:
        fields["smoothing"] = draw(st.sampled_from([1e-6, 1e-3, 1.0, 1e4, 1e10, 1e100]))
    if draw(st.integers(0, 3)) == 0:
        fields["rate_limit"] = draw(st.sampled_from([scale, 0.1 * scale, np.full(m, scale),
                                                     np.full(m + 2, 1.0)]))
    if objective == "min_norm" and draw(st.integers(0, 2)) == 0:
        fields["reference"] = draw(st.sampled_from([np.full(m, scale), np.zeros(m),
                                                    np.linspace(0, scale, m)]))
    if draw(st.integers(0, 4)) == 0:
        fields["tie_break"] = draw(st.booleans())
    if objective == "pinv":  # it takes no bounds
        for name in ("t_min", "t_max", "rate_limit"):
            fields.pop(name, None)
    if objective == "centered" and not np.all(np.isfinite(fields.get("t_max", np.inf))):
        fields["t_max"] = 1e3 * scale
    if draw(st.integers(0, 7)) == 0:
        name = draw(st.sampled_from(sorted(BAD_FIELDS)))
        fields[name] = draw(st.sampled_from(BAD_FIELDS[name]))
    return fields


PROBLEM_NAMES = ("objective", "weights", "reference", "t_min", "t_max", "smoothing",
                 "rate_limit", "tie_break")
DISTRIBUTE_NAMES = (*PROBLEM_NAMES, "pose", "wrench", "previous", "robot", "accuracy",
                    "option", "time_limit", "solver_options", "batch_size", "warm_start",
                    "backend", "drawing point", "overflow")


@st.composite
def options(draw: st.DrawFn) -> dict[str, Any]:
    """Backend options: mostly valid, sometimes a bad accuracy, name or solver option."""
    chosen: dict[str, Any] = {}
    if draw(st.booleans()):
        chosen["accuracy"] = draw(st.sampled_from(["default", "high"]))
    if draw(st.integers(0, 4)) == 0:
        chosen["time_limit"] = 10.0
    if draw(st.integers(0, 4)) == 0:
        chosen["warm_start"] = draw(st.booleans())
    if draw(st.integers(0, 11)) == 0:  # a bad one
        name, value = draw(st.sampled_from([
            ("accuracy", "ultra"), ("accuracy", 3), ("time_limit", 0.0), ("time_limit", "1"),
            ("solver_options", {"bogus_option": 1}), ("solver_options", [1, 2]),
            ("acuracy", "high"), ("warm_start", "x"), ("batch_size", 0)]))
        chosen[name] = value
    return chosen


def _vector(draw: st.DrawFn, size: int, scale: float) -> Any:
    if draw(st.integers(0, 9)) == 0:
        return draw(st.sampled_from(GARBAGE))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return rng.uniform(-scale, scale, size)


# ------------------------------------------------------------------- certificates
def certified(robot: to.CableRobot, poses: np.ndarray, wrench: Any,
              sol: to.TensionSolution, problem: to.TensionProblem) -> None:
    """Where a pose is optimal: finite tensions, equilibrium and bounds within tolerance,
    measured independently of the solution's own diagnostics."""
    p = robot.as_poses(poses)
    N = len(p)
    assert sol.tensions.shape == (N, robot.m) and sol.status.shape == (N,)
    assert set(map(str, sol.status)) <= {s.value for s in Status}
    ok = sol.status == Status.OPTIMAL
    if not ok.any():
        return
    T = sol.tensions[ok]
    assert np.isfinite(T).all(), "optimal with non-finite tensions"
    A = robot.structure_matrices(p)[ok]
    b = robot.required_wrench(p, wrench)[ok]
    lb, ub = problem.bounds(robot, N)
    lb, ub = lb[ok], ub[ok]
    scale = np.maximum(np.maximum(np.linalg.norm(b, axis=1),
                                  np.where(np.isfinite(lb), np.abs(lb), 0.0).max(axis=1)),
                       1e-12)
    tol = FEASIBILITY_TOL * scale * (1 + 1e-9)
    residual = np.linalg.norm(np.einsum("nij,nj->ni", A, T) - b, axis=1)
    assert (residual <= tol).all(), f"optimal out of equilibrium: {residual} > {tol}"
    assert (T >= lb - tol[:, None]).all(), f"optimal below t_min: {T} < {lb}"
    assert (T <= ub + tol[:, None]).all(), f"optimal above t_max: {T} > {ub}"
    if sol.form is not None:  # rate limits: the bounds of the form solved
        assert (T >= sol.form.lb[ok] - tol[:, None]).all()
        assert (T <= sol.form.ub[ok] + tol[:, None]).all()


# -------------------------------------------------------------------------- tests
@contract_settings(2000)
@given(st.data())
def test_distribute_keeps_the_contract(data: st.DataObject) -> None:
    robot = data.draw(robots())
    if robot is None:
        return
    poses = data.draw(poses_for(robot))
    fields = data.draw(problem_fields(robot.m))
    backend = data.draw(st.sampled_from(BACKENDS))
    chosen = data.draw(options())
    wrench = None if data.draw(st.booleans()) else _vector(
        data.draw, robot.dof, data.draw(st.sampled_from([1.0, 1e3, 1e300])))
    previous = None if data.draw(st.booleans()) else _vector(data.draw, robot.m, 1e3)
    if isinstance(previous, np.ndarray) and data.draw(st.booleans()):
        previous = np.abs(previous)
    problem = keeps_contract(lambda: to.TensionProblem(**fields), PROBLEM_NAMES)
    if problem is None:
        return
    sol = keeps_contract(lambda: to.distribute(robot, poses, problem, backend, wrench=wrench,
                                               previous=previous, **chosen),
                         DISTRIBUTE_NAMES)
    if sol is not None:
        certified(robot, poses, wrench, sol, problem)


@contract_settings(1000)
@given(st.data())
def test_robot_constructor_keeps_the_contract(data: st.DataObject) -> None:
    fields = data.draw(robot_fields())
    spoil = data.draw(st.sampled_from([None, None, "anchors", "attachments", "mass", "kind",
                                       "t_min", "t_max", "com", "g", "home", "cable"]))
    if spoil is not None:
        fields[spoil] = data.draw(st.sampled_from(
            [*GARBAGE, 0.0, -5.0, np.inf, "10", "spatial7", np.ones((3, 3)), True, 1e308]))
    robot = keeps_contract(lambda: to.CableRobot(**fields), ROBOT_NAMES)
    if robot is None:
        return
    home = robot.default_home()
    geometry = keeps_contract(lambda: robot.cable_geometry(home), ("pose", "drawing point"))
    if geometry is not None:
        A = robot.structure_from(geometry)
        assert A.shape == (1, robot.dof, robot.m) and np.isfinite(A).all()


@contract_settings(300)
@given(st.data())
def test_smooth_jointly_keeps_the_contract(data: st.DataObject) -> None:
    from tension_opt.dynamics.trajectory import smooth_jointly

    robot = data.draw(robots())
    if robot is None:
        return
    poses = data.draw(poses_for(robot))
    objective = data.draw(st.sampled_from(sorted(OBJECTIVES)))
    weight = data.draw(st.sampled_from([0.0, 1e-3, 1.0, 1e10, -1.0, np.nan, "1"]))
    backend = data.draw(st.sampled_from(["qpsolvers:clarabel", "qpsolvers:piqp",
                                         "cvxpy:CLARABEL", "cvxpy", "closed_form", "nope"]))
    chosen = data.draw(options())
    problem = to.TensionProblem(objective)
    sol = keeps_contract(lambda: smooth_jointly(robot, poses, problem, weight, backend,
                                                **chosen),
                         (*DISTRIBUTE_NAMES, "weight", "smooth_jointly"))
    if sol is not None:
        certified(robot, poses, None, sol, problem)


@contract_settings(500)
@given(st.data())
def test_capacity_margin_keeps_the_contract(data: st.DataObject) -> None:
    robot = data.draw(robots())
    if robot is None:
        return
    poses = data.draw(poses_for(robot))
    wrench = None if data.draw(st.booleans()) else _vector(data.draw, robot.dof, 1e3)
    backend = data.draw(st.sampled_from(["auto", "closed_form", "qpsolvers:daqp",
                                         "scipy:highs", "cvxpy:CLARABEL"]))
    margin = keeps_contract(lambda: to.capacity_margin(robot, poses, wrench, backend),
                            (*DISTRIBUTE_NAMES, "margin"))
    if margin is None:
        return
    N = len(robot.as_poses(poses))
    assert margin.shape == (N,)
    # The margin's sign says whether the minimum-sum problem is feasible.
    sol = keeps_contract(lambda: to.distribute(robot, poses, "min_sum", "auto", wrench=wrench),
                         DISTRIBUTE_NAMES)
    if sol is None:
        return
    # At least the package's own tolerance floor (1e-12 N): with no load and no lower
    # bound, a margin of 1e-35 is zero, whatever its sign.
    scale = np.maximum(np.linalg.norm(robot.required_wrench(poses, wrench), axis=1),
                       max(robot.t_min.max(), 1e-12))
    clear = np.abs(margin) > 1e-4 * scale
    inside = clear & (margin > 0) & (sol.status != Status.SOLVER_ERROR)
    outside = clear & (margin < 0)
    assert (sol.status[inside] != Status.INFEASIBLE).all(), (margin, sol.status)
    assert (sol.status[outside] != Status.OPTIMAL).all(), (margin, sol.status)


@contract_settings(300)
@given(st.data())
def test_workspace_keeps_the_contract(data: st.DataObject) -> None:
    robot = data.draw(robots())
    if robot is None:
        return
    poses = data.draw(poses_for(robot))
    wrenches = None if data.draw(st.booleans()) else np.vstack(
        [np.zeros(robot.dof), np.random.default_rng(0).uniform(-1e3, 1e3, (2, robot.dof))])
    backend = data.draw(st.sampled_from(["auto", "closed_form", "qpsolvers:daqp"]))
    result = keeps_contract(
        lambda: to.wrench_feasible_workspace(robot, poses, wrenches, backend=backend),
        (*DISTRIBUTE_NAMES, "wrenches", "bounds"))
    if result is None:
        return
    ok = result.feasible
    assert np.isfinite(result.tensions[ok]).all()
    assert (result.status[ok] == Status.OPTIMAL).all()
    assert (result.margin[ok] >= -1e-6 * robot.weight).all()


EXACT = [b for b in ("auto", "qpsolvers:daqp", "scipy:highs", "cvxpy:CLARABEL",
                     "qpsolvers:quadprog") if b == "auto" or b in to.available_backends()]


@contract_settings(300)
@given(st.data())
def test_backends_agree_where_they_say_optimal(data: st.DataObject) -> None:
    """An optimum is an optimum: backends that say optimal agree on the objective, on
    the tensions where the objective is strictly convex (or a tie is broken), and none
    calls infeasible a pose that another has certified feasible with room to spare."""
    robot = data.draw(robots())
    if robot is None:
        return
    poses = data.draw(poses_for(robot))
    if not isinstance(poses, np.ndarray) or poses.dtype != float:
        return
    poses = np.atleast_2d(poses)
    fields = data.draw(problem_fields(robot.m))
    fields.pop("rate_limit", None)
    fields.pop("smoothing", None)
    problem = keeps_contract(lambda: to.TensionProblem(**fields), PROBLEM_NAMES)
    if problem is None:
        return
    solutions = {}
    for backend in EXACT:
        high = {} if backend in ("auto", "qpsolvers:daqp", "qpsolvers:quadprog") else {
            "accuracy": "high"}
        sol = keeps_contract(lambda b=backend, o=high: to.distribute(robot, poses, problem, b,
                                                                      **o), DISTRIBUTE_NAMES)
        if sol is not None:
            certified(robot, poses, None, sol, problem)
            solutions[backend] = sol
    if len(solutions) < 2:
        return
    names = list(solutions)
    scale = solutions[names[0]].form.load_scale()
    weights = problem.cable_weights(robot.m)
    for i, first in enumerate(names):
        for second in names[i + 1:]:
            one, two = solutions[first], solutions[second]
            both = (one.status == Status.OPTIMAL) & (two.status == Status.OPTIMAL)
            # What a tension error of 1e-6 of the typical tension can do to the objective.
            size = np.nanmax(np.abs(one.tensions), axis=1, initial=0.0) + scale
            slack = 1e-5 * (np.abs(one.objective) + weights.sum() * size * (
                1.0 if problem.is_linear else 2.0 * size))
            assert (np.abs(one.objective - two.objective)[both] <= slack[both]).all(), (
                first, second, one.objective, two.objective)
            if problem.tie_break or not problem.is_linear:
                gap = np.abs(one.tensions - two.tensions).max(axis=1, initial=0.0)
                assert (gap[both] <= 1e-4 * scale[both]).all(), (
                    first, second, one.tensions, two.tensions)
            for a, c in ((one, two), (two, one)):
                room = np.minimum(a.tensions - a.form.lb, a.form.ub - a.tensions)
                roomy = (a.status == Status.OPTIMAL) & (a.residual <= 1e-9 * scale) & (
                    np.nan_to_num(room, nan=0.0).min(axis=1, initial=1.0) > 1e-3 * scale)
                assert not (roomy & (c.status == Status.INFEASIBLE)).any(), (
                    first, second, one.status, two.status)


def test_the_watchdog_stops_a_call() -> None:
    import time

    with pytest.raises(TimeoutError), watchdog(0.2):
        time.sleep(1.0)
