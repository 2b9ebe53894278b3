"""The certificate of the real-time path against the numpy reference.

:class:`tension_opt.Distributor` certifies each compiled answer as
:func:`tension_opt.distribute` does (primal residual, dual residual and duality gap of
the pose's scaled problem at the call's accuracy target): the fields equal the plain
call's to rounding, ``optimal`` implies certified, and an answer whose certificate
misses is not labelled optimal. A huge min-norm ``reference`` does not make DAQP call
a feasible pose infeasible.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt import presets
from tension_opt.backends.qpsolvers_backend import objective_factors
from tension_opt.certify.certificate import refit_poses
from tension_opt.distribution.packing import pack_realtime
from tension_opt.kernels.closed_form import CODE_FALLBACK
from tension_opt.kernels.dense_qp import (
    LINEAR_CAP,
    objective_factor,
    qp_judge,
    qp_problem,
    qp_size,
    qp_views,
)
from tension_opt.tolerances import accuracy_target

_spec = importlib.util.spec_from_file_location(
    "realtime_helpers", Path(__file__).with_name("test_realtime.py")
)
assert _spec is not None and _spec.loader is not None
_helpers = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_helpers)
any_robot, poses_of, KINDS = _helpers.any_robot, _helpers.poses_of, _helpers.KINDS

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
#: The measures of one answer by the kernel and by numpy differ by rounding only.
ATOL = 1e-11
MEASURES = ("primal_residual", "dual_residual", "duality_gap")


#: Rounding of a measure of the scaled problem (of order one): two answers that agree
#: to the last bits may still differ by this much in a dual residual.
ROUNDING = 1e-13


def _near_target(sol: to.TensionSolution, target: float) -> np.ndarray:
    """Poses with a measure within a factor 2 of the target, or within the measures'
    rounding of it (an accuracy of 1e-14 is at that level), where rounding may tip the
    verdict either way."""
    near = np.zeros(sol.N, dtype=bool)
    for name in MEASURES:
        value = getattr(sol, name)
        with np.errstate(invalid="ignore"):
            near |= (value > 0.5 * target - ROUNDING) & (value < 2.0 * target + ROUNDING)
    return near


def assert_same_certificate(
    result: to.RealtimeResult, sol: to.TensionSolution, accuracy: object = None
) -> None:
    """Statuses equal (save where a measure is within a factor 2 of the target), the
    three measures equal to rounding, and every optimal answer certified."""
    target = accuracy_target(accuracy)
    status = np.asarray(result.status, dtype=str).reshape(-1)
    clear = ~_near_target(sol, target)
    np.testing.assert_array_equal(status[clear], sol.status.astype(str)[clear])
    # A refit's multipliers are a bounded least-squares fit solved by scipy on one path
    # and by the compiled refit on the other, to the fit's conditioning: its measures are
    # each within the target where optimal (asserted below), not equal to rounding.
    solved = np.isfinite(sol.tensions).all(axis=1)
    refit = np.zeros(sol.N, dtype=bool)
    if sol.form is not None and solved.any():
        refit[solved] = refit_poses(sol.form.subset(np.flatnonzero(solved)),
                                    sol.tensions[solved], target)
    for name in MEASURES:
        got, want = np.atleast_1d(getattr(result, name)), getattr(sol, name)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=name)
        ok = np.isfinite(want) & ~(refit & (name != "primal_residual"))
        assert (np.abs(got - want)[ok] <= ATOL).all(), (name, got, want)
    optimal = status == to.Status.OPTIMAL.value
    assert np.atleast_1d(result.certified(accuracy))[optimal].all()
    residual, expected = np.atleast_1d(result.residual), sol.residual
    ok = np.isfinite(expected)
    scale = np.linalg.norm(np.nan_to_num(sol.tensions), axis=1).max(initial=1.0)
    assert (np.abs(residual - expected)[ok] <= 1e-12 * scale).all()


OBJECTIVES = ["min_sum", "min_norm", "pinv", "centered", "min_max"]
ACCURACIES = [None, "high", 1e-13, 1e-14]


@SETTINGS
@given(
    st.sampled_from(KINDS),
    st.integers(0, 10_000),
    st.sampled_from(OBJECTIVES),
    st.sampled_from(ACCURACIES),
)
def test_the_distributors_certificate_is_distributes(shape, seed, objective, accuracy):
    kind, m = shape
    robot = any_robot(kind, seed, m)
    if objective == "centered" and not np.isfinite(robot.t_max).all():
        robot = robot.with_(t_max=50 * robot.t_min + 100.0)
    p = poses_of(robot, seed)
    options = {} if accuracy is None else {"accuracy": accuracy}
    solver = to.Distributor(robot, objective, **options)
    sol = to.distribute(robot, p, objective, "auto", **options)
    assert_same_certificate(solver(p), sol, accuracy)  # a batch: the certified pass
    for k in range(3):  # one pose at a time: the certified real-time kernel
        one = solver(p[k])
        assert isinstance(one.primal_residual, float)
        assert_same_certificate(
            one, to.distribute(robot, p[k], objective, "auto", **options), accuracy
        )


@SETTINGS
@given(st.integers(0, 10_000), st.sampled_from([None, 1e-14]), st.booleans())
def test_streams_and_independent_previous_tensions_are_certified_as_distribute(
    seed, accuracy, rate
):
    robot = any_robot("point3", seed, 4) if seed % 2 else any_robot("spatial6", seed, 8)
    problem = to.TensionProblem(
        "min_norm", smoothing=0.3, rate_limit=robot.mass * 9.81 if rate else None
    )
    options = {} if accuracy is None else {"accuracy": accuracy}
    p = poses_of(robot, seed)
    stream = to.Distributor(robot, problem, **options)
    assert_same_certificate(stream(p), to.distribute(robot, p, problem, **options), accuracy)
    rng = np.random.default_rng(seed)
    previous = rng.uniform(1.0, 3.0, (len(p), robot.m)) * robot.mass * 9.81 / robot.m
    independent = to.Distributor(robot, problem, **options)(p, previous=previous)
    assert_same_certificate(
        independent, to.distribute(robot, p, problem, previous=previous, **options), accuracy
    )


def test_an_uncertified_answer_is_inaccurate_not_optimal():
    """A min-norm reference far above the load (1e12 N) gives multipliers of its order,
    whose rounding alone misses the target: the exact closed form's answers are
    inaccurate (the compiled call hands such a pose, whose dual measures miss, to the
    numpy path's sign-constrained refit, which misses too), with the figures that
    missed; none is labelled optimal."""
    robot = presets.cogiro()
    problem = to.TensionProblem("min_norm", reference=1e12)
    p = poses_of(robot, 5, 30)
    solver = to.Distributor(robot, problem, "closed_form")
    sol = to.distribute(robot, p, problem, "closed_form")
    got = [solver(pose) for pose in p]
    missed = [k for k, one in enumerate(got) if np.isfinite(one.tensions).all()]
    assert len(missed) >= 3
    for k in missed:
        assert got[k].status == to.Status.INACCURATE and not got[k].certified()
        assert max(got[k].dual_residual, got[k].duality_gap) > 1e-7
    assert not any(one.status == to.Status.OPTIMAL for one in got)
    # The same statuses in a batch and by the plain call (the measures themselves are
    # the rounding of multipliers of 1e12: equal in kind, not to the digit).
    batch = solver(p)
    np.testing.assert_array_equal(batch.status, sol.status)
    np.testing.assert_array_equal([one.status.value for one in got], sol.status.astype(str))
    assert not batch.certified()[np.isfinite(batch.tensions).all(axis=1)].any()


def test_a_perturbed_daqp_answer_is_not_certified():
    """The compiled verdict of DAQP's answer (the Distributor's DAQP path) certifies
    the exact answer and turns down one moved along the null space of the equations:
    still in equilibrium and within its bounds, no longer optimal."""
    import daqp

    robot = presets.cogiro()
    m, n = robot.m, robot.dof
    problem = to.TensionProblem("min_norm")
    target = accuracy_target(None)
    data = pack_realtime(robot, problem, target)
    pose = robot.default_home()
    qp, work = np.zeros(qp_size(m, n)), np.zeros(n * m + 2 * n + 4 * m)
    code, s = qp_problem(data, pose, np.zeros(n), np.zeros(m), False, work, qp)
    assert code == 0
    H, f, Ad, upper, lower = qp_views(qp, m, n)
    sense = np.zeros(m + n, dtype=np.intc)
    sense[m:] = 5
    x, _, flag, info = daqp.solve(
        H.copy(), f.copy(), Ad.copy(), upper.copy(), lower.copy(), sense.copy()
    )
    assert flag > 0
    T = np.empty(m)
    verdict = qp_judge(data, work, qp, x, info["lam"], s, target, T, sense.copy(), False)
    assert verdict[0] == 0 and max(verdict[2:]) <= target
    null = np.linalg.svd(Ad)[2][-1]
    moved = x + 1e-3 * null / np.abs(null).max() * np.abs(x).min()
    verdict = qp_judge(data, work, qp, moved, info["lam"], s, target, T, sense.copy(), False)
    assert verdict[0] == CODE_FALLBACK and max(verdict[3:]) > target


@pytest.mark.parametrize(
    "robot",
    [presets.cogiro(), presets.algae_harvester(), presets.cogiro().with_(t_max=np.inf)],
    ids=["cogiro", "study", "cogiro-unbounded"],
)
def test_a_huge_reference_does_not_make_daqp_call_a_feasible_pose_infeasible(robot):
    poses = poses_of(robot, 2, 20)
    feasible = to.distribute(robot, poses, "min_norm", "closed_form").success
    assert feasible.sum() >= 3
    p = poses[feasible]
    for reference in (1e15, 1e18):
        problem = to.TensionProblem("min_norm", reference=reference)
        sol = to.distribute(robot, p, problem, "qpsolvers:daqp")
        assert not (sol.status == to.Status.INFEASIBLE).any(), sol.status
        assert ((sol.status == to.Status.OPTIMAL) | (sol.status == to.Status.INACCURATE)).all()
        solver = to.Distributor(robot, problem, "qpsolvers:daqp")
        for pose in p[:4]:
            assert solver(pose).status != to.Status.INFEASIBLE
        assert not (solver(p).status == to.Status.INFEASIBLE).any()


@given(st.lists(st.floats(-1e300, 1e300), min_size=1, max_size=9))
@settings(max_examples=200, deadline=None)
def test_daqps_objective_factor_is_its_numpy_reference(c):
    f = np.array(c)
    factor = objective_factor(f)
    assert factor == objective_factors(f[None, :])[0]
    largest = np.abs(f).max()
    if largest <= LINEAR_CAP:
        assert factor == 1.0
    else:
        assert LINEAR_CAP / 2 < largest * factor <= LINEAR_CAP
        assert np.log2(factor) == np.round(np.log2(factor))  # a power of two: exact
