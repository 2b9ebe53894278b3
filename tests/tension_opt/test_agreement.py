"""Every backend against the exact closed form (or a high-accuracy reference): on the first
250 of 1000 random feasible poses in the default run, on all 1000 in the slow study
(``python -m pytest -m slow``).

Each backend is asked for the high target (1e-10 on the certificate's measures), or for
its floor where it cannot be asked for that (:mod:`tension_opt.backends.settings`);
what it labels optimal must agree with the reference, and what it does not carries the
label that says so.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import tension_opt as to
from tension_opt.backends.settings import SETTINGS
from tension_opt.tolerances import HIGH_TARGET
from tension_opt.workspace.sampling import random_feasible_poses

N_POSES = 1000
#: Poses of the default run: the first of the :data:`N_POSES`.
N_DEFAULT = 250
REL_TOL = 1e-6
#: Solvers that report failure (never a wrong answer) on a few poses of a problem class,
#: with the largest share of failed poses allowed (rounded up to whole poses). OSQP's
#: ADMM stalls short of 1e-8 on some CoGiRo LPs (4 and 5 poses in 1000); HiGHS's QP
#: solver stops with a primal infeasibility of 5e-5 on one CoGiRo pseudo-inverse.
KNOWN_FAILURES = {("OSQP", "lp"): 0.01, ("HIGHS", "qp"): 0.002}


# Boxes of the random poses (m, rad): the study's pond at heights 0..5 m, and CoGiRo
# near home (0, 0, 2 m) with rotations up to 0.1 rad.
POND = ([-40.45, -25.0, 0.0], [40.45, 25.0, 5.0])
NEAR_COGIRO_HOME = ([-3.0, -2.0, 0.8, -0.1, -0.1, -0.1], [3.0, 2.0, 3.0, 0.1, 0.1, 0.1])


def _feasible(robot: to.CableRobot, box: tuple[list[float], list[float]], seed: int,
              batch: int) -> np.ndarray:
    return random_feasible_poses(robot, N_POSES, seed=seed, low=box[0], high=box[1],
                                 batch=batch)


CASES = {
    "thesis": (to.presets.algae_harvester,
               lambda: _feasible(to.presets.algae_harvester(), POND, 11, 2 * N_POSES)),
    "cogiro": (to.presets.cogiro,
               lambda: _feasible(to.presets.cogiro(), NEAR_COGIRO_HOME, 5, 4 * N_POSES)),
}
_POSES: dict[str, np.ndarray] = {}
_REFERENCES: dict[tuple[str, str, int], to.TensionSolution] = {}


def _poses(case: str) -> np.ndarray:
    if case not in _POSES:
        _POSES[case] = CASES[case][1]()
        assert len(_POSES[case]) == N_POSES
    return _POSES[case]


def _reference(case: str, objective: str, count: int = N_DEFAULT) -> to.TensionSolution:
    key = (case, objective, count)
    if key not in _REFERENCES:
        robot = CASES[case][0]()
        poses = _poses(case)[:count]
        try:
            ref = to.distribute(robot, poses, objective, "closed_form")
        except to.UnsupportedProblemError:  # min-max with a 2-D null space
            ref = to.distribute(robot, poses, objective, "cvxpy:CLARABEL", accuracy="high")
        assert ref.success.all()
        _REFERENCES[key] = ref
    return _REFERENCES[key]


def _params():
    for count in (N_DEFAULT, N_POSES):
        for case in CASES:
            for objective in ("min_sum", "min_norm", "pinv", "min_max"):
                for backend in to.available_backends():
                    if backend == "closed_form":
                        continue
                    yield pytest.param(
                        case, objective, backend, count,
                        id=f"{case}-{objective}-{backend}-{count}",
                        marks=[pytest.mark.slow] if count == N_POSES else [])


@pytest.mark.parametrize(("case", "objective", "backend", "count"), list(_params()))
def test_backend_agrees_with_reference(case, objective, backend, count):
    robot = CASES[case][0]()
    poses = _poses(case)[:count]
    solver = backend.split(":")[-1].lower()
    floor = SETTINGS[solver].floor if solver in SETTINGS else 0.0
    try:
        sol = to.distribute(robot, poses, objective, backend,
                            accuracy=max(HIGH_TARGET, floor))
    except to.UnsupportedProblemError:
        pytest.skip(f"{backend} does not take {objective}")
    ref = _reference(case, objective, count)
    ok = sol.success
    kind = "qp" if objective in ("min_norm", "pinv") else "lp"
    allowed = KNOWN_FAILURES.get((backend.split(":")[-1].upper(), kind), 0.0)
    assert (~ok).sum() <= math.ceil(allowed * count), f"{(~ok).sum()} poses failed"
    # A failed pose says so and carries no tensions: no silent wrong answer.
    # An inaccurate pose keeps its tensions under that label (OSQP near its tolerance on
    # CoGiRo's min-max LP, now and then); every other failure carries none.
    failed = ~ok & (sol.status != to.Status.INACCURATE)
    assert np.isnan(sol.tensions[failed]).all()
    rel = np.abs(sol.tensions - ref.tensions)[ok].max(axis=1) / np.abs(ref.tensions)[ok].max(
        axis=1)
    assert rel.max() < REL_TOL, f"worst pose {rel.argmax()}: {rel.max():.2e}"
    assert (sol.residual[ok] / robot.weight).max() < 1e-8
    assert (sol.duality_gap[ok] <= sol.accuracy).all()
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
