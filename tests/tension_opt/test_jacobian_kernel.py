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
@pytest.mark.parametrize("wrt", ["wrench", "pose"])
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
    for wrt in ("wrench", "pose"):
        a, b = _both(robot, poses, problem, wrt, wrench)
        _agree(a, b)
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
    assert compiled_jacobian(chunked, "t_min", robot, poses, None) is None  # another wrt
    assert compiled_jacobian(chunked, "wrench", robot, poses[:3], None) is None  # poses
    whole = to.distribute(robot, poses, "min_sum", "closed_form")
    assert compiled_jacobian(whole, "wrench", robot, poses, None) is None  # a form kept
    # Poses other than those solved: the KKT point is not the solution (or its
    # multipliers change sign), never a finite number.
    moved = chunked.jacobian("wrench", robot=robot, poses=poses + 0.5)
    assert not moved.ok.any() and np.isnan(moved.jacobian).all()
    assert (moved.status == "not_optimal").sum() >= 30
