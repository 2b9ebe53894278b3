"""Design optimisation: analytic gradients against finite differences, the criteria
against independent computations (the straight and the coupled workspaces, the coupled
inverse kinematics, per-pose LPs), the optimiser against a scan, and bad input."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import catenary
import tension_opt as to
from catenary import design as D
from catenary.design.cable_weight import HalfWeight
from catenary.design.tension_margin import tension_margins
from catenary.errors import InvalidDesignError
from tension_opt.workspace import wrench_feasible_workspace

PATH = np.array([[-3, -4, 1.0], [-3, -4, 2], [0.5, 0.6, 2], [3, 4, 2], [3, 4, 1],
                 [10, -5, 1.5]])


def study_grid(nx: int = 8, ny: int = 6, z: float = 1.0) -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(-38, 38, nx), np.linspace(-23, 23, ny))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])


def study_space() -> D.DesignSpace:
    robot = to.presets.algae_harvester(t_max=15000.0)
    return D.DesignSpace(robot, [
        D.anchor_coordinate("height", [0, 1, 2, 3], "z", 4, 20),
        D.anchor_coordinate("half length", [0, 1, 2, 3], "x", 35, 60, factors=[-1, -1, 1, 1]),
        D.anchor_coordinate("P2 y", [1], "y", 20, 40),
        D.cable_diameter(0.008, 0.03),
        D.winch_t_max("t_max", range(4), 8000, 30000)], material="steel")


def cogiro_space() -> D.DesignSpace:
    return D.DesignSpace(to.presets.cogiro(), [
        D.anchor_coordinate("height", range(8), "z", 4, 8),
        D.anchor_coordinate("A0 x", [0], "x", -10, 10),
        D.attachment_coordinate("a0 y", [0], "y", -1, 1),
        D.attachment_coordinate("a3 z", [3], "z", -1, 1),
        D.cable_diameter(0.002, 0.008),
        D.winch_t_max("t_max", range(8), 3000, 8000)])


def cogiro_poses() -> np.ndarray:
    rng = np.random.default_rng(1)
    return np.column_stack([rng.uniform(-2, 2, (6, 2)), rng.uniform(1.5, 2.5, 6),
                            rng.uniform(-0.1, 0.1, (6, 3))])


def central_difference(space: D.DesignSpace, criterion: D.Criterion, x: np.ndarray
                       ) -> np.ndarray:
    """Richardson-extrapolated central differences of the smooth value."""
    out = np.empty(space.k)
    for j in range(space.k):
        h = 1e-4 * (space.upper[j] - space.lower[j])
        e = np.zeros(space.k)
        e[j] = 1.0

        def diff(step: float, j: int = j, e: np.ndarray = e) -> float:
            plus = criterion.evaluate(space.robot_at(x + step * e)).value
            minus = criterion.evaluate(space.robot_at(x - step * e)).value
            return (plus - minus) / (2 * step)

        out[j] = (4 * diff(h / 2) - diff(h)) / 3
    return out


def one_sided_gap(space: D.DesignSpace, criterion: D.Criterion, x: np.ndarray
                  ) -> np.ndarray:
    """|forward - backward difference| per variable: large where a kink (an LP's active
    set changing) lies within the step, and the derivative does not exist."""
    at = criterion.evaluate(space.robot_at(x)).value
    out = np.empty(space.k)
    for j in range(space.k):
        h = 1e-4 * (space.upper[j] - space.lower[j])
        e = np.zeros(space.k)
        e[j] = h
        ahead = criterion.evaluate(space.robot_at(x + e)).value - at
        back = at - criterion.evaluate(space.robot_at(x - e)).value
        out[j] = abs(ahead - back) / h
    return out


def assert_gradient(space: D.DesignSpace, criterion: D.Criterion, x: np.ndarray,
                    rtol: float = 1e-6, smooth_only: bool = False) -> None:
    """The analytic gradient against differences; with ``smooth_only``, only for the
    variables along which the criterion has no kink within the step."""
    got = criterion.evaluate(space.robot_at(x))
    assert got.skipped == 0 and got.infeasible == 0
    analytic = space.chain(got.gradient)
    numeric = central_difference(space, criterion, x)
    scale = np.abs(numeric).max()
    assert scale > 0
    keep = np.ones(space.k, dtype=bool)
    if smooth_only:
        keep = one_sided_gap(space, criterion, x) <= 1e-4 * scale
        assert keep.sum() >= 2
    np.testing.assert_allclose(analytic[keep], numeric[keep], rtol=rtol, atol=rtol * scale)


STUDY_CRITERIA = {
    "peak": lambda: D.PeakTension(PATH),
    "peak ratio with weight": lambda: D.PeakTension(PATH, relative=True, cable_weight=True),
    "energy": lambda: D.TensionEnergy(PATH),
    "coverage with weight": lambda: D.WorkspaceCoverage(study_grid(), 1.0, 0.1),
    "coverage straight": lambda: D.WorkspaceCoverage(study_grid(), 1.0, 0.1,
                                                     cable_weight=False),
    "sag": lambda: D.SagCorrection(PATH),
    "mass": lambda: D.CableMass(PATH),
}


@pytest.mark.parametrize("name", sorted(STUDY_CRITERIA))
def test_study_gradients_match_differences(name: str) -> None:
    space = study_space()
    x = space.x0 + np.array([0.3, 0.2, 0.5, 0.001, 500.0])
    assert_gradient(space, STUDY_CRITERIA[name](), x)


def test_coupled_peak_tension_gradient() -> None:
    """The coupled catenary model's peak tension, by the tied heights, mirrored towers,
    one drawing point and the diameter (through w and EA)."""
    robot = to.presets.algae_harvester(t_max=15000.0)
    space = D.DesignSpace(robot, [
        D.anchor_coordinate("height", [0, 1, 2, 3], "z", 4, 20),
        D.anchor_coordinate("half length", [0, 1, 2, 3], "x", 35, 60, factors=[-1, -1, 1, 1]),
        D.anchor_coordinate("P2 y", [1], "y", 20, 40),
        D.cable_diameter(0.008, 0.03)], material="steel")
    x = space.x0 + np.array([0.3, 0.2, 0.5, 0.001])
    assert_gradient(space, D.PeakTension(PATH, model="coupled"), x, rtol=1e-6)


COGIRO_CRITERIA = {
    "peak": lambda P: D.PeakTension(P),
    "peak ratio with weight": lambda P: D.PeakTension(P, relative=True, cable_weight=True),
    "energy": lambda P: D.TensionEnergy(P),
    "coverage with weight": lambda P: D.WorkspaceCoverage(P, 1.0, 0.2),
    "sag": lambda P: D.SagCorrection(P),
    "mass": lambda P: D.CableMass(P),
}


@pytest.mark.parametrize("name", sorted(COGIRO_CRITERIA))
def test_six_dof_gradients_match_differences(name: str) -> None:
    """Attachment points, moments of the cables' weight and a turning platform."""
    space = cogiro_space()
    assert_gradient(space, COGIRO_CRITERIA[name](cogiro_poses()), space.x0)


@settings(max_examples=8, deadline=None)
@given(st.floats(5.0, 15.0), st.floats(-3.0, 3.0).filter(lambda v: abs(v) > 0.05),
       st.floats(0.01, 0.025), st.floats(9000.0, 25000.0))
def test_random_designs_gradients(height: float, shift: float, d: float, t_max: float
                                  ) -> None:
    """Random designs off the symmetric one (where the margin LPs of symmetric grid
    points have several optimal tensions: the documented subgradient case)."""
    space = study_space()
    x = np.array([height, 46.55 + shift, 31.1 - shift, d, t_max])
    for criterion in (D.PeakTension(PATH, cable_weight=True),
                      D.WorkspaceCoverage(study_grid(7, 5), 1.0, 0.1)):
        got = criterion.evaluate(space.robot_at(x))
        if got.infeasible:
            continue
        # A random design may put a grid point's margin LP at a change of active set:
        # there the margin has a kink, and only the smooth directions are compared.
        assert_gradient(space, criterion, x, rtol=1e-5, smooth_only=True)


def test_cable_strength_against_the_catalogue() -> None:
    space = study_space()
    x = space.x0 + np.array([0.0, 0.0, 0.0, -0.006, 3000.0])
    criterion = D.CableStrength(3.0).with_material("steel")
    got = criterion.evaluate(space.robot_at(x))
    assert got.value == pytest.approx(3 * 18000.0 / float(catenary.breaking_load("steel", 0.014)),
                                      rel=1e-12)
    assert_gradient(space, criterion, x)
    with pytest.raises(InvalidDesignError, match="catalogue material"):
        D.CableStrength().evaluate(space.robot_at(x))
    with pytest.raises(InvalidDesignError, match="no rope strength"):
        D.CableStrength(material="aramid").evaluate(space.robot_at(x))


def test_straight_coverage_is_the_wrench_feasible_workspace() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    grid = study_grid(33, 21)
    margins, _ = D.WorkspaceCoverage(grid, 1.0, cable_weight=False).margins(robot)
    feasible = wrench_feasible_workspace(robot, grid).feasible
    np.testing.assert_array_equal(margins.margin >= -1e-9, feasible)
    assert 50 < feasible.sum() < len(grid)


def test_margins_match_one_lp_per_pose() -> None:
    robot = to.presets.cogiro()
    P = cogiro_poses()
    A, b = robot.structure_matrices(P), robot.required_wrench(P)
    lo = np.full((len(P), 8), 100.0)
    up = np.full((len(P), 8), 5000.0)
    got = tension_margins(A, b, lo, up)
    half = 0.5 * (up[0] - lo[0])
    for k in range(len(P)):
        c = np.zeros(9)
        c[-1] = -1.0
        A_ub = np.block([[-np.eye(8), half[:, None]], [np.eye(8), half[:, None]]])
        res = linprog(c, A_ub=A_ub, b_ub=np.concatenate([-lo[k], up[k]]),
                      A_eq=np.hstack([A[k], np.zeros((6, 1))]), b_eq=b[k],
                      bounds=(None, None), method="highs")
        assert res.status == 0
        assert got.margin[k] == pytest.approx(-res.fun, abs=1e-9)


@pytest.mark.parametrize(("diameter", "tol"), [(0.02, 0.01), (0.01, 0.002)])
def test_half_weight_tensions_match_the_coupled_model(diameter: float, tol: float) -> None:
    """The drawing-point tensions of the half-weight model against the coupled catenary
    inverse kinematics, min-norm, on the study robot."""
    robot = to.presets.algae_harvester(cable_diameter=diameter)
    P = np.array([[-3, -4, 1.0], [-3, -4, 2], [0.5, 0.6, 2], [10, -5, 1.5], [-30, 15, 2]])
    coupled = catenary.inverse_kinematics(robot, P, model="coupled", objective="min_norm")
    assert (coupled.status == "converged").all()
    half = HalfWeight(robot, P)
    straight = to.distribute(robot.with_(t_min=0.0), P, "min_norm", wrench=half.wrench)
    top = straight.tensions + half.half_height
    assert np.abs(top - coupled.tensions).max() / coupled.tensions.max() < tol


def test_half_weight_coverage_against_the_sag_workspace() -> None:
    """Where the half-weight margin and the coupled workspace disagree, the margin is
    within 1 % of a half-range of zero (20 mm steel, t_max 15 kN)."""
    robot = to.presets.algae_harvester(t_max=15000.0)
    grid = study_grid(33, 21)
    margins, _ = D.WorkspaceCoverage(grid, 1.0).margins(robot)
    coupled = catenary.sag_workspace(robot, grid).feasible
    ours = margins.margin >= -1e-9
    assert ours.sum() > 300
    assert np.abs(margins.margin[ours != coupled]).max(initial=0.0) < 0.01


def test_optimum_beats_a_scan_of_the_height() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    space = D.DesignSpace(robot, [D.anchor_coordinate("height", [0, 1, 2, 3], "z", 4, 20)])
    criterion = D.WorkspaceCoverage(study_grid(17, 11), 21.6)
    result = D.optimize_design(space, criterion, maximize=True, starts=3)
    assert result.status == "converged"
    scan = [criterion.evaluate(space.robot_at([h])).value for h in np.linspace(4, 20, 81)]
    assert result.smooth >= max(scan) - 1e-6 * abs(max(scan))
    assert result.objective == criterion.evaluate(result.robot).plain
    assert len(result.starts) == 3 and result.robot.anchors[0, 2] == result.x[0]


def test_constraint_is_met_and_materials_are_compared() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    space = D.DesignSpace(robot, [D.anchor_coordinate("height", [0, 1, 2, 3], "z", 5, 12),
                                  D.cable_diameter(0.008, 0.03)])
    mass = D.CableMass(PATH)
    result = D.optimize_design(space, D.PeakTension(PATH, cable_weight=True), starts=2,
                               constraints=[D.DesignConstraint(mass, upper=200.0),
                                            D.DesignConstraint(D.CableStrength(), upper=1.0)],
                               materials=["steel", "dyneema"])
    assert result.status == "converged"
    assert result.material in ("steel", "dyneema")
    assert mass.evaluate(result.robot).value <= 200.0 * (1 + 1e-6)
    assert set(result.starts["material"]) == {"steel", "dyneema"}


def test_a_design_that_cannot_hold_its_path_is_reported() -> None:
    """With t_min = m g, four steep cables pull more than the load: no tensions."""
    robot = to.presets.algae_harvester()
    space = D.DesignSpace(robot, [D.anchor_coordinate("height", [0, 1, 2, 3], "z", 60, 80)])
    got = D.TensionEnergy(PATH).evaluate(space.robot_at([70.0]))
    assert np.isnan(got.value) and got.infeasible == len(PATH)
    result = D.optimize_design(space, D.TensionEnergy(PATH), starts=2)
    assert result.status == "infeasible" and np.isnan(result.objective)


def test_robot_at_sets_tied_entries() -> None:
    space = study_space()
    robot = space.robot_at([9.0, 50.0, 33.0, 0.012, 12000.0])
    np.testing.assert_array_equal(robot.anchors[:, 2], 9.0)
    np.testing.assert_array_equal(robot.anchors[:, 0], [-50, -50, 50, 50])
    assert robot.anchors[1, 1] == 33.0 and robot.anchors[2, 1] == 31.1
    w, EA = catenary.cable_properties("steel", 0.012)
    assert robot.cable.linear_mass * robot.g == pytest.approx(float(w), rel=1e-12)
    assert robot.cable.EA == pytest.approx(float(EA), rel=1e-12)
    np.testing.assert_array_equal(robot.t_max, 12000.0)
    np.testing.assert_allclose(space.x0, [7.6, 46.55, 31.1, 0.02, 15000.0])


def test_criteria_are_safe_from_threads() -> None:
    space = study_space()
    criterion = D.WorkspaceCoverage(study_grid(), 1.0)
    xs = [space.x0 + np.array([0.1 * i, 0, 0, 0, 0]) for i in range(6)]
    alone = [criterion.evaluate(space.robot_at(x)).value for x in xs]
    with ThreadPoolExecutor(3) as pool:
        together = list(pool.map(lambda x: criterion.evaluate(space.robot_at(x)).value, xs))
    assert together == alone


def test_crossed_bounds_keep_a_defined_margin() -> None:
    """Where the hanging weights close a winch's range (t_max - h < t_min + h), every
    point is infeasible but its margin stays defined and differentiable."""
    robot = to.presets.algae_harvester(t_max=2536.866 + 300.0, cable_diameter=0.03)
    space = D.DesignSpace(robot, [D.anchor_coordinate("height", [0, 1, 2, 3], "z", 4, 30)])
    criterion = D.WorkspaceCoverage(study_grid(), 1.0, 0.5)
    got = criterion.evaluate(space.robot_at([20.0]))
    assert got.infeasible == 0 and got.plain == 0.0 and got.value > 0.0
    margins, _ = criterion.margins(space.robot_at([20.0]))
    assert (margins.margin < 0).all()
    assert_gradient(space, criterion, np.array([20.0]))


class _SlowBowl(D.Criterion):
    """A numerically differentiated bowl over the drawing points that takes 2 ms."""

    name = "slow bowl"
    numeric = True

    def evaluate(self, robot: to.CableRobot) -> D.CriterionValue:
        import time

        time.sleep(0.002)
        value = float(((robot.anchors - 1.0) ** 2).sum())
        return D.CriterionValue(value, value, None)


def test_time_limit_returns_the_best_point_met(monkeypatch: pytest.MonkeyPatch) -> None:
    """The best point survives the cache (here one evaluation long) and the deadline."""
    monkeypatch.setattr("catenary.design.optimize.CACHE_SIZE", 1)
    robot = to.presets.algae_harvester()
    space = D.DesignSpace(robot, [D.anchor_coordinate(f"A{i}{a}", [i], a, -60, 60)
                                  for i in range(4) for a in "xy"])
    result = D.optimize_design(space, _SlowBowl(), starts=2, time_limit=0.3)
    assert result.status in ("time_limit", "max_iter", "failed", "converged")
    assert (result.starts["status"] == "time_limit").any()
    assert np.isfinite(result.objective)


def test_constraints_of_the_same_name_are_told_apart() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    space = D.DesignSpace(robot, [D.cable_diameter(0.008, 0.03)], material="steel")
    result = D.optimize_design(space, D.CableMass(PATH), starts=1, constraints=[
        D.DesignConstraint(D.CableStrength(3.0), upper=1.0),
        D.DesignConstraint(D.CableStrength(6.0), upper=1.0)])
    one, two = result.constraints["cable strength use (1)"], result.constraints[
        "cable strength use (2)"]
    assert two == pytest.approx(2 * one, rel=1e-12) and two <= 1.0 + 1e-6


def test_cable_strength_keeps_its_own_material() -> None:
    given = D.CableStrength(material="dyneema")
    assert given.with_material("steel").material == "dyneema"
    assert D.CableStrength().with_material("steel").material == "steel"
    with pytest.raises(InvalidDesignError, match="finite t_max"):
        D.CableStrength(material="steel").evaluate(to.presets.algae_harvester())


@pytest.mark.parametrize(("make", "match"), [
    (lambda: D.optimize_design(study_space(), D.TensionEnergy(PATH), materials=[]),
     "materials"),
    (lambda: D.optimize_design(study_space(), D.TensionEnergy(PATH), materials="steel"),
     "materials"),
    (lambda: D.optimize_design(study_space(), D.TensionEnergy(PATH),
                               constraints=[D.TensionEnergy(PATH)]), "DesignConstraint"),
    (lambda: D.optimize_design(study_space(), D.TensionEnergy(PATH), max_iter=0),
     "max_iter"),
    (lambda: D.DesignConstraint(D.TensionEnergy(PATH), lower=5.0, upper=1.0), "above"),
    (lambda: D.DesignVariable("d", "diameter", ((0, 0, 1.0),), 0.01, 0.03), "no entries"),
    (lambda: D.DesignVariable("t", "t_max", ((0, 1, 1.0),), 1.0, 3.0), "t_max entry"),
    (lambda: D.anchor_coordinate("h", [0.5], "z", 4, 5), "integer"),
    (lambda: D.LowestFrequency(PATH, model="bogus"), "model"),
    (lambda: D.anchor_coordinate("h", [0], "z", 5, 4), "lower < upper"),
    (lambda: D.anchor_coordinate("h", [0], "w", 4, 5), "axis"),
    (lambda: D.cable_diameter(0.0, 0.01), "diameter"),
    (lambda: D.winch_t_max("t", [0, 1], -1, 5), "t_max"),
    (lambda: D.anchor_coordinate("h", [0, 1], "z", 4, 5, factors=[1]), "factors"),
    (lambda: D.DesignSpace(to.presets.algae_harvester(), []), "non-empty"),
    (lambda: D.DesignSpace(to.presets.algae_harvester(),
                           [D.anchor_coordinate("a", [0], "z", 1, 2),
                            D.anchor_coordinate("b", [0], "z", 1, 2)]), "both set"),
    (lambda: D.DesignSpace(to.presets.algae_harvester(),
                           [D.anchor_coordinate("a", [7], "z", 1, 2)]), "cable 7"),
    (lambda: D.DesignSpace(to.presets.algae_harvester(),
                           [D.cable_diameter(0.01, 0.02)], material="unobtainium"),
     "unknown cable material"),
    (lambda: study_space().robot_at([1.0, 2.0]), "5 finite numbers"),
    (lambda: D.DesignSpace(to.presets.algae_harvester(),
                           [D.pulley_radius("r", [0], 0.1, 0.5)]), "without a guide pulley"),
    (lambda: D.pulley_radius("r", [0], 0.0, 0.5), "pulley_radius's lower bound"),
    (lambda: D.DesignSpace(to.presets.algae_harvester().with_(pulleys=[to.Pulley(0.3)] * 4),
                           [D.pulley_radius("r", [0], 0.1, 0.5)]).chain(
                               D.RobotGradient.zeros(4)), "no analytic gradient"),
    (lambda: D.DesignConstraint(D.TensionEnergy(PATH)), "no bound"),
    (lambda: D.WorkspaceCoverage(study_grid(), -1.0), "cell_volume"),
    (lambda: D.PeakTension(np.full((2, 3), np.nan)), "path"),
    (lambda: D.PeakTension(PATH, objective="min_norm", model="coupled"), "minimum-sum"),
    (lambda: D.PeakTension(PATH, model="catenary"), "model"),
    (lambda: D.optimize_design(study_space(), "peak"), "Criterion"),
    (lambda: D.optimize_design(study_space(), D.TensionEnergy(PATH), starts=0), "starts"),
    (lambda: D.WorkspaceCoverage(study_grid(), 1.0).evaluate(
        to.presets.algae_harvester()), "finite t_max"),
])
def test_bad_input_names_the_argument(make, match: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises((InvalidDesignError, catenary.InvalidCableError), match=match):
        make()


# ------------------------------------------------------------------ guide pulleys
def pulley_space():
    robot = to.presets.algae_harvester(t_max=15000.0).with_(
        pulleys=[to.Pulley(0.3, [0, 0, -1])] * 4)
    return D.DesignSpace(robot, [D.pulley_radius("wheel radius", [0, 1, 2, 3], 0.05, 1.5),
                                 D.anchor_coordinate("tower height", [0, 1, 2, 3], "z",
                                                     4.0, 12.0)])


def test_a_pulley_radius_sets_the_wheels_and_is_optimised_numerically():
    space = pulley_space()
    assert space.numeric
    np.testing.assert_allclose(space.x0, [0.3, space.robot.anchors[0, 2]])
    robot = space.robot_at([0.8, 7.0])
    assert all(p.radius == 0.8 for p in robot.pulleys)
    assert (robot.anchors[:, 2] == 7.0).all()
    # The radius moves the exit points, so the straight cables' peak tension.
    peak = D.PeakTension(PATH)
    values = [peak.evaluate(space.robot_at([r, 7.0])).plain for r in (0.05, 0.8, 1.5)]
    assert values[0] > values[1] > values[2]
    result = D.optimize_design(space, peak, starts=2, max_iter=30, progress=False)
    assert result.status == "converged"
    start = peak.evaluate(space.robot_at(space.x0)).plain
    assert result.objective < 0.9 * start
    assert (result.x >= space.lower).all() and (result.x <= space.upper).all()


def test_a_sag_criterion_on_a_pulley_space_names_what_is_missing():
    from catenary.errors import InvalidCableError

    with pytest.raises(InvalidCableError, match="guide pulleys"):
        D.optimize_design(pulley_space(), D.SagCorrection(PATH), starts=1, progress=False)
