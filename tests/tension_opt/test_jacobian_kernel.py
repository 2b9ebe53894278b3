"""The compiled Jacobians of a batch solved in chunks (:mod:`tension_opt.kernels.sensitivity`)
against the numpy path's (:class:`tension_opt.distribution.sensitivity.KktSystem`) on the
same poses, every robot kind, and against finite differences of the solver."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from tension_opt.distribution.compiled_sensitivity import compiled_jacobian
from tension_opt.workspace.sampling import random_feasible_poses

ROBOTS = {
    "study": lambda: to.presets.algae_harvester(t_max=15000.0),
    "cogiro": to.presets.cogiro,
    "ipanema3": to.presets.ipanema3,
    "kntu_planar": to.presets.kntu_planar,
    "point_xz_4cable": to.presets.point_xz_4cable,
}
OBJECTIVES = ("min_sum", "min_norm", "centered", "pinv")


def _both(robot, poses, problem, wrt, wrench=None):
    """The numpy path's Jacobian (a whole batch keeps its form) and the compiled one (the
    same poses solved in chunks keep none)."""
    whole = to.distribute(robot, poses, problem, "closed_form", wrench=wrench)
    chunked = to.distribute(robot, poses, problem, "closed_form", wrench=wrench,
                            chunk_size=16)
    assert whole.form is not None and chunked.form is None
    assert compiled_jacobian(chunked, wrt, robot, poses, wrench) is not None
    numpy_path = whole.jacobian(wrt, robot=robot, poses=poses, wrench=wrench)
    compiled = chunked.jacobian(wrt, robot=robot, poses=poses, wrench=wrench)
    return numpy_path, compiled


def _agree(a, b):
    np.testing.assert_array_equal(a.status, b.status)
    ok = a.ok
    assert np.isnan(b.jacobian[~ok]).all()
    scale = max(np.abs(a.jacobian[ok]).max(initial=0.0), 1e-12)
    np.testing.assert_allclose(b.jacobian[ok], a.jacobian[ok], rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("name", list(ROBOTS))
@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("wrt", ["wrench", "pose", "t_min", "t_max", "drawing_points",
                                 "attachment_points"])
def test_compiled_jacobian_is_the_numpy_one(name, objective, wrt):
    robot = ROBOTS[name]()
    poses = random_feasible_poses(robot, 48, seed=3)
    a, b = _both(robot, poses, objective, wrt)
    assert a.ok.sum() >= 24
    _agree(a, b)


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "centered"])
@pytest.mark.parametrize("name", ["study", "cogiro"])
def test_active_bounds_and_their_statuses_agree(name, objective):
    """Bounds tight enough that many poses have active bounds, infeasible poses among
    them; a wrench per pose."""
    robot = ROBOTS[name]()
    poses = random_feasible_poses(robot, 64, seed=5)
    free = to.distribute(robot, poses, "min_norm", "closed_form").tensions
    t_max = float(np.quantile(free.max(axis=1), 0.6))
    t_min = float(np.quantile(free.min(axis=1), 0.3))
    problem = to.TensionProblem(objective, t_min=t_min, t_max=t_max)
    rng = np.random.default_rng(0)
    wrench = rng.normal(0.0, 0.01 * robot.weight, (len(poses), robot.dof))
    moved = 0
    for wrt in ("wrench", "pose", "t_min", "t_max", "drawing_points", "attachment_points"):
        a, b = _both(robot, poses, problem, wrt, wrench)
        _agree(a, b)
        if wrt.startswith("t_"):
            moved += int((np.abs(b.jacobian[b.ok]) > 0.5).sum())
    assert moved  # some active bound moves its cable by one
    assert len(set(a.status)) >= 2  # more than one status among these poses


def test_compiled_jacobian_against_finite_differences():
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 20, seed=9)
    sol = to.distribute(robot, poses, "min_norm", "closed_form", chunk_size=8)
    sens = sol.jacobian("pose", robot=robot, poses=poses)
    assert sens.ok.all()
    h = 1e-6
    for j in range(robot.dof):
        step = np.zeros(robot.dof)
        step[j] = h
        plus = to.distribute(robot, poses + step, "min_norm", "closed_form").tensions
        minus = to.distribute(robot, poses - step, "min_norm", "closed_form").tensions
        fd = (plus - minus) / (2 * h)
        np.testing.assert_allclose(sens.jacobian[:, :, j], fd, rtol=0,
                                   atol=2e-5 * np.abs(fd).max())


def test_routes_the_compiled_path_only_where_it_applies():
    robot = ROBOTS["study"]()
    poses = random_feasible_poses(robot, 40, seed=2)
    chunked = to.distribute(robot, poses, "min_max", "closed_form", chunk_size=16)
    assert compiled_jacobian(chunked, "wrench", robot, poses, None) is None  # min-max
    chunked = to.distribute(robot, poses, "min_sum", "closed_form", chunk_size=16)
    assert compiled_jacobian(chunked, "previous", robot, poses, None) is None  # another wrt
    assert compiled_jacobian(chunked, "wrench", robot, poses[:3], None) is None  # poses
    whole = to.distribute(robot, poses, "min_sum", "closed_form")
    assert compiled_jacobian(whole, "wrench", robot, poses, None) is None  # a form kept
    # Bounds per pose: the numpy path, the same answers as the whole batch's.
    rows = to.TensionProblem("min_norm", t_max=np.linspace(8000.0, 15000.0, len(poses))[:, None]
                             * np.ones(robot.m))
    chunked = to.distribute(robot, poses, rows, "closed_form", chunk_size=16)
    assert compiled_jacobian(chunked, "pose", robot, poses, None) is None
    a = to.distribute(robot, poses, rows, "closed_form").jacobian("pose", robot=robot,
                                                                   poses=poses)
    b = chunked.jacobian("pose", robot=robot, poses=poses)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_allclose(b.jacobian[a.ok], a.jacobian[a.ok], rtol=1e-9, atol=1e-9)
    # Poses other than those solved: the KKT point is not the solution (or its
    # multipliers change sign), never a finite number.
    moved = chunked.jacobian("wrench", robot=robot, poses=poses + 0.5)
    assert not moved.ok.any() and np.isnan(moved.jacobian).all()
    assert (moved.status == "not_optimal").sum() >= 30


# ------------------------------------------------------------ the real-time path
@pytest.mark.parametrize("name", ["study", "cogiro", "kntu_planar", "point_xz_4cable"])
@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "centered"])
def test_distributor_jacobian_is_the_solution_jacobian(name, objective):
    robot = ROBOTS[name]()
    poses = random_feasible_poses(robot, 12, seed=11)
    dist = to.Distributor(robot, objective)
    sol = to.distribute(robot, poses, objective, "closed_form")
    for wrt in ("wrench", "pose", "t_min", "t_max", "drawing_points", "attachment_points"):
        ref = sol.jacobian(wrt, robot=robot, poses=poses)
        got = [dist.with_jacobian(np.ascontiguousarray(p), wrt) for p in poses]
        assert all(g.compiled for g in got)
        status = np.array([g.jacobian_status for g in got])
        J = np.array([g.jacobian for g in got])
        np.testing.assert_array_equal(status, ref.status)
        ok = ref.ok
        assert ok.sum() >= 6 and np.isnan(J[~ok]).all()
        np.testing.assert_allclose(J[ok], ref.jacobian[ok], rtol=0,
                                   atol=1e-9 * np.abs(ref.jacobian[ok]).max())
        np.testing.assert_array_equal(np.array([g.tensions for g in got]), dist(poses).tensions)


def test_distributor_jacobian_with_active_bounds_a_wrench_and_from_threads():
    robot = ROBOTS["cogiro"]()
    poses = random_feasible_poses(robot, 16, seed=5)
    free = to.distribute(robot, poses, "min_norm", "closed_form").tensions
    problem = to.TensionProblem("min_norm", t_min=float(np.quantile(free.min(axis=1), 0.4)),
                                t_max=float(np.quantile(free.max(axis=1), 0.6)))
    wrench = np.array([5.0, -3.0, 2.0, 0.1, 0.2, -0.1])
    dist = to.Distributor(robot, problem)
    sol = to.distribute(robot, poses, problem, "closed_form", wrench=wrench)
    ref = sol.jacobian("pose", robot=robot, poses=poses, wrench=wrench)
    assert len(set(ref.status)) >= 2

    def run(_):
        return [dist.with_jacobian(p, "pose", wrench=wrench) for p in poses]

    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(run, range(4)))
    for got in runs:
        np.testing.assert_array_equal([g.jacobian_status for g in got], ref.status)
        J = np.array([g.jacobian for g in got])
        np.testing.assert_allclose(J[ref.ok], ref.jacobian[ref.ok], rtol=0,
                                   atol=1e-9 * np.abs(ref.jacobian[ref.ok]).max())


def test_distributor_jacobian_off_the_compiled_route():
    robot = ROBOTS["study"]()
    poses = random_feasible_poses(robot, 4, seed=6)
    # min-max: the numpy path's Jacobian of the same pose
    dist = to.Distributor(robot, "min_max")
    ref = to.distribute(robot, poses, "min_max", "closed_form").jacobian("wrench")
    for k, p in enumerate(poses):
        got = dist.with_jacobian(p, "wrench")
        assert got.jacobian_status == ref.status[k]
        np.testing.assert_allclose(got.jacobian, ref.jacobian[k], rtol=1e-9, atol=1e-12)
    # a smoothed stream: against the previous tensions it was smoothed against
    smoothed = to.TensionProblem("min_norm", smoothing=0.5)
    dist = to.Distributor(robot, smoothed)
    first = dist.with_jacobian(poses[0], "pose")
    second = dist.with_jacobian(poses[1], "pose")
    sol = to.distribute(robot, poses[1:2], smoothed, "closed_form", previous=first.tensions)
    ref = sol.jacobian("pose", robot=robot, poses=poses[1:2], previous=first.tensions)
    assert second.jacobian_status == ref.status[0] == "ok"
    np.testing.assert_allclose(second.jacobian, ref.jacobian[0], rtol=1e-9, atol=1e-12)
    # an unsolved pose: no Jacobian
    out = to.Distributor(robot, "min_norm").with_jacobian(np.array([0.0, 0.0, -50.0]))
    assert out.jacobian_status == "not_optimal" and np.isnan(out.jacobian).all()


def test_distributor_jacobian_bad_input_is_named():
    dist = to.Distributor(ROBOTS["study"]())
    with pytest.raises(to.InvalidInputError, match="wrt must be"):
        dist.with_jacobian(np.zeros(3), "previous")
    with pytest.raises(to.InvalidInputError, match="one pose"):
        dist.with_jacobian(np.zeros((2, 3)))
    assert dist(np.array([0.0, 0.0, 1.0])).jacobian is None  # a plain call has none


def test_the_real_time_kernel_leaves_the_certificates_multipliers_where_read():
    from tension_opt.kernels.distributor import multipliers_offset

    robot = ROBOTS["study"]()
    poses = random_feasible_poses(robot, 6, seed=1)
    dist = to.Distributor(robot, "min_sum")
    sol = to.distribute(robot, poses, "min_sum", "closed_form")
    offset = multipliers_offset(robot.m, robot.dof)
    for k, p in enumerate(poses):
        dist(p)
        z = dist._local.work[offset:offset + robot.m]
        np.testing.assert_allclose(z, sol.multipliers.z[k], rtol=1e-9, atol=1e-12)
        assert (np.abs(z) > 1e-5).any()  # a bound active: the read is not vacuous


@pytest.mark.parametrize(("t_max", "problem"), [
    (np.inf, "min_sum"), (np.inf, "min_norm"), (6000.0, "min_sum"), (6000.0, "centered"),
    (15000.0, to.TensionProblem("min_norm", t_min=2000.0)),
    (15000.0, to.TensionProblem("min_sum", weights=[1.0, 2.0, 0.5, 1.5])),
])
@pytest.mark.parametrize("wrt", ["wrench", "pose", "t_min", "t_max"])
def test_four_cable_lanes_are_the_pose_by_pose_loop(t_max, problem, wrt):
    """The point robot on four cables runs its common poses side by side; the others go
    pose by pose. Both give the same statuses and Jacobians to rounding, here with
    vertices, interior optima, poses on both bounds and unsolved poses."""
    from tension_opt.distribution.compiled_sensitivity import _CODES, _arrays
    from tension_opt.distribution.packing import pack_certified
    from tension_opt.kernels.arrays import frozen
    from tension_opt.kernels.sensitivity import MOVES_TARGET, jacobian_poses

    robot = to.presets.algae_harvester(t_max=t_max)
    rng = np.random.default_rng(4)
    poses = np.column_stack([rng.uniform(-45, 45, 3000), rng.uniform(-28, 28, 3000),
                             rng.uniform(-1.0, 4.0, 3000)])
    sol = to.distribute(robot, poses, problem, "closed_form")
    arrays = _arrays(sol, robot, poses, None, 4, 3, len(poses))
    data = frozen(pack_certified(robot, sol.problem, 0.0))  # the route's types: one signature
    code = _CODES[wrt] + (MOVES_TARGET if wrt.startswith("t_") and sol.problem.objective
                          == "centered" else 0)
    D = 3 if wrt in ("wrench", "pose") else 4
    out = [(np.empty((len(poses), 4, D)), np.empty(len(poses), np.int8)) for _ in range(2)]
    for (J, codes), side in zip(out, (True, False), strict=True):
        jacobian_poses(data, *arrays, code, J, codes, side)
    (Ja, ca), (Jb, cb) = out
    np.testing.assert_array_equal(ca, cb)
    ok = cb == 0
    assert ok.sum() >= 300 and (~ok).any()
    np.testing.assert_allclose(Ja[ok], Jb[ok], rtol=0,
                               atol=1e-12 * max(np.abs(Jb[ok]).max(), 1.0))
    assert np.isnan(Ja[~ok]).all()
    if wrt.startswith("t_") and robot.t_max[0] < np.inf and problem != "min_norm":
        assert (np.abs(Jb[ok]) > 0.5).any()  # some bound moves its cable


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "centered"])
@pytest.mark.parametrize("wrt", ["t_min", "t_max"])
def test_bound_jacobian_against_finite_differences(objective, wrt):
    """dT / d t_min and d t_max of the compiled path against central differences of the
    solver, bound by bound, on study poses with active bounds."""
    robot = ROBOTS["study"]()
    poses = random_feasible_poses(robot, 24, seed=21)
    lo, hi = 2000.0, 9000.0
    problem = to.TensionProblem(objective, t_min=lo, t_max=hi)
    sol = to.distribute(robot, poses, problem, "closed_form", chunk_size=8)
    sens = sol.jacobian(wrt, robot=robot, poses=poses)
    assert sens.ok.sum() >= 12
    h = 1e-3
    for j in range(robot.m):
        bounds = {"t_min": np.full(robot.m, lo), "t_max": np.full(robot.m, hi)}

        def solve(delta, bounds=bounds, j=j):
            moved = {k: v.copy() for k, v in bounds.items()}
            moved[wrt][j] += delta
            return to.distribute(robot, poses, to.TensionProblem(objective, **moved),
                                 "closed_form").tensions

        fd = (solve(h) - solve(-h)) / (2 * h)
        ok = sens.ok
        np.testing.assert_allclose(sens.jacobian[ok, :, j], fd[ok], rtol=0, atol=1e-6)
