"""Every backend against the exact closed form (or a high-accuracy reference), on 1000 poses."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_cogiro_poses, random_thesis_poses

import tension_opt as to

N_POSES = 1000
REL_TOL = 1e-6
#: Solvers that report failure (never a wrong answer) on a few poses of a problem class,
#: with the largest share of failed poses allowed. OSQP's ADMM stalls short of 1e-8 on
#: some CoGiRo LPs (4 and 5 poses in 1000); HiGHS's QP solver stops with a primal
#: infeasibility of 5e-5 on one CoGiRo pseudo-inverse.
KNOWN_FAILURES = {("OSQP", "lp"): 0.01, ("HIGHS", "qp"): 0.002}


def _feasible_thesis_poses(N: int) -> np.ndarray:
    robot = to.presets.algae_harvester()
    poses = random_thesis_poses(2 * N, seed=11)
    ok = to.distribute(robot, poses, "min_sum", "closed_form").success
    return poses[ok][:N]


CASES = {
    "thesis": (to.presets.algae_harvester, lambda: _feasible_thesis_poses(N_POSES)),
    "cogiro": (to.presets.cogiro, lambda: random_cogiro_poses(N_POSES, seed=5)),
}
_POSES: dict[str, np.ndarray] = {}
_REFERENCES: dict[tuple[str, str], to.TensionSolution] = {}


def _poses(case: str) -> np.ndarray:
    if case not in _POSES:
        _POSES[case] = CASES[case][1]()
        assert len(_POSES[case]) == N_POSES
    return _POSES[case]


def _reference(case: str, objective: str) -> to.TensionSolution:
    key = (case, objective)
    if key not in _REFERENCES:
        robot = CASES[case][0]()
        try:
            ref = to.distribute(robot, _poses(case), objective, "closed_form")
        except to.UnsupportedProblemError:  # min-max with a 2-D null space
            ref = to.distribute(robot, _poses(case), objective, "cvxpy:CLARABEL",
                                accuracy="high")
        assert ref.success.all()
        _REFERENCES[key] = ref
    return _REFERENCES[key]


def _params():
    for case in CASES:
        for objective in ("min_sum", "min_norm", "pinv", "min_max"):
            for backend in to.available_backends():
                if backend == "closed_form":
                    continue
                yield pytest.param(case, objective, backend, id=f"{case}-{objective}-{backend}")


@pytest.mark.parametrize(("case", "objective", "backend"), list(_params()))
def test_backend_agrees_with_reference(case, objective, backend):
    robot = CASES[case][0]()
    poses = _poses(case)
    try:
        sol = to.distribute(robot, poses, objective, backend, accuracy="high")
    except to.UnsupportedProblemError:
        pytest.skip(f"{backend} does not take {objective}")
    ref = _reference(case, objective)
    ok = sol.success
    kind = "qp" if objective in ("min_norm", "pinv") else "lp"
    allowed = KNOWN_FAILURES.get((backend.split(":")[-1].upper(), kind), 0.0)
    assert (~ok).mean() <= allowed, f"{(~ok).sum()} poses failed"
    # A failed pose says so and carries no tensions: no silent wrong answer.
    assert np.isnan(sol.tensions[~ok]).all()
    rel = np.abs(sol.tensions - ref.tensions)[ok].max(axis=1) / np.abs(ref.tensions)[ok].max(
        axis=1)
    assert rel.max() < REL_TOL, f"worst pose {rel.argmax()}: {rel.max():.2e}"
    assert (sol.residual[ok] / robot.weight).max() < 1e-8
    if objective != "pinv":
        scale = np.abs(ref.tensions[ok]).max(axis=1)
        assert (sol.bound_violation[ok] / scale).max() < 1e-6
    np.testing.assert_array_equal(sol.unique[ok], ref.unique[ok])


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "pinv", "min_max"])
def test_reference_is_in_equilibrium_within_bounds(case, objective):
    robot = CASES[case][0]()
    ref = _reference(case, objective)
    assert (ref.residual / robot.weight).max() < 1e-10
    if objective != "pinv":
        assert (ref.tensions >= robot.t_min - 1e-9 * robot.weight).all()
        assert (ref.tensions <= robot.t_max + 1e-9 * robot.weight).all()
