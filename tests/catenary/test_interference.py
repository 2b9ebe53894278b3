"""Interference of sagging cables: certified catenary distances against dense sampling
refined by a local solver, the weightless limit, a sag-touch case the chords miss, and
the presets' interference-free workspaces with sag."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

import catenary
import tension_opt as to
from catenary import CatenaryCurves, InvalidCableError, curve_distance, solve_forces
from tension_opt import workspace as ws
from tension_opt.errors import InvalidInputError


def dense(a: CatenaryCurves, b: CatenaryCurves, n: int = 1500) -> tuple[float, float]:
    """Smallest distance between ``n`` samples of two single curves (batch shape ()),
    and that minimum refined by a bounded local solver over the two arc parameters."""
    sa = np.linspace(0.0, float(a.L0), n)
    sb = np.linspace(0.0, float(b.L0), n)
    pa, pb = a.points(sa), b.points(sb)
    d = np.linalg.norm(pa[:, None] - pb[None], axis=-1)
    j, k = np.unravel_index(np.argmin(d), d.shape)

    def f(x):
        return float(np.linalg.norm(a.points(x[:1]) - b.points(x[1:])))

    res = minimize(f, [sa[j], sb[k]], bounds=[(0, float(a.L0)), (0, float(b.L0))],
                   method="L-BFGS-B", options={"ftol": 1e-15, "gtol": 1e-12})
    return float(d.min()), float(min(res.fun, d.min()))


def hanging(x0: np.ndarray, e_h: np.ndarray, span: float, L0: float, w: float) -> CatenaryCurves:
    """A level inextensible catenary of horizontal span ``span`` from ``x0`` along ``e_h``."""
    sol = solve_forces(span, 0.0, L0, w)
    return CatenaryCurves(np.asarray(x0, float), np.asarray(e_h, float), np.asarray(sol.H),
                          np.asarray(sol.V_A), np.asarray(float(L0)), w, np.inf, np.zeros(3))


def test_sag_touch_where_the_chords_clear():
    """Two level cables 10 m long in one vertical plane, 0.1 m apart: the upper one,
    0.3 % longer than its span, sags 0.33 m and passes through the lower one."""
    e_x = np.array([1.0, 0.0, 0.0])
    lower = hanging(np.zeros(3), e_x, 10.0, 10.0001, 5.0)
    upper = hanging(np.array([0.0, 0.0, 0.1]), e_x, 10.0, 10.03, 5.0)
    # The chords: 0.1 m apart, clear of a 20 mm cable.
    chords = ws.segment_distance(lower.points([0.0])[0], lower.points([lower.L0])[0],
                                 upper.points([0.0])[0], upper.points([upper.L0])[0])
    assert chords.distance == pytest.approx(0.1, abs=1e-9)
    res = curve_distance(lower, upper)
    assert float(res.distance) < 1e-9  # the cables touch (they cross in their plane)
    assert 0.0 <= float(res.lower_bound) <= float(res.distance)
    assert np.linalg.norm(res.point_a - res.point_b) == pytest.approx(float(res.distance))
    sag = 0.1 - upper.points([upper.L0 / 2])[0, 2]
    assert sag > 0.3
    # Moved 0.5 m sideways, out of the plane, they clear by that: the certified bound
    # brackets the dense-sampling minimum.
    side = hanging(np.array([0.0, 0.5, 0.1]), e_x, 10.0, 10.03, 5.0)
    res = curve_distance(lower, side)
    d_grid, d_ref = dense(lower, side)
    assert float(res.distance) == pytest.approx(0.5, abs=1e-9)
    assert float(res.lower_bound) <= float(res.distance) <= d_grid + 1e-12
    assert float(res.distance) == pytest.approx(d_ref, abs=1e-8)


def crossing_pairs():
    """Crossing catenaries in perpendicular planes, batch shape (4,)."""
    curves_a, curves_b = [], []
    for k, (za, zb) in enumerate([(0.0, 0.5), (0.0, 0.2), (0.3, 0.0), (1.0, -1.0)]):
        a = hanging(np.array([-5.0, 0.0, za]), np.array([1.0, 0.0, 0.0]), 10.0, 10.05 + k, 3.0)
        b = hanging(np.array([1.0, -4.0, zb]), np.array([0.0, 1.0, 0.0]), 8.0, 8.02, 8.0)
        curves_a.append(a)
        curves_b.append(b)

    def stack(cs):
        return CatenaryCurves(*(np.stack([getattr(c, f) for c in cs]) for f in
                                ("origin", "e_h", "H", "V_A", "L0")), cs[0].w, np.inf,
                              np.zeros((len(cs), 3)))

    return curves_a, curves_b, stack(curves_a), stack(curves_b)


def test_certified_bounds_bracket_dense_sampling_refined_by_a_local_solver():
    singles_a, singles_b, a, b = crossing_pairs()
    res = curve_distance(a, b)
    assert res.distance.shape == (4,)
    for k in range(4):
        d_grid, d_ref = dense(singles_a[k], singles_b[k])
        assert res.lower_bound[k] <= res.distance[k] <= d_grid + 1e-12
        assert res.distance[k] == pytest.approx(d_ref, abs=1e-8)
        assert res.gap[k] < 0.02
    # More samples tighten the certificate (as 1 / samples^2).
    fine = curve_distance(a, b, samples=129)
    assert (fine.gap <= res.gap + 1e-12).all()
    assert np.allclose(fine.distance, res.distance, atol=1e-9)


def test_weightless_cables_give_the_straight_distances():
    robot = to.presets.cogiro()
    light = robot.with_(cable=to.CableProperties(robot.cable.diameter, 1e-9, robot.cable.EA))
    poses = np.array([robot.home, [1.0, -1.0, 1.5, 0.1, 0.0, 0.2]])
    straight = ws.cable_clearance(light, poses)
    sag = catenary.cable_clearance(light, poses, "coupled")
    assert np.allclose(sag.distances, straight.distances, atol=1e-7)
    heavy = catenary.cable_clearance(robot, poses, "coupled")
    assert not np.allclose(heavy.distances, straight.distances, atol=1e-4)


@pytest.mark.parametrize("model", ["coupled", "thesis"])
def test_cogiro_home_with_sag_against_dense_sampling(model):
    robot = to.presets.cogiro()
    res = catenary.cable_clearance(robot, robot.home, model)
    assert res.model == model and res.extras["status"][0] == "converged"
    clearance, pair = res
    assert pair[0].tolist() == [6, 7]
    assert clearance[0] == pytest.approx(0.39789, abs=2e-5)
    assert (res.lower_bound <= res.distances).all()
    assert (res.extras["gap"] < 1e-3).all()
    ik = catenary.inverse_kinematics(robot, robot.home, model)
    curves = catenary.interference.robot_curves(
        robot, robot.as_poses(robot.home), ik.horizontal_tensions, ik.platform_forces[..., 2],
        ik.lengths)
    for p in (27, 7):  # the corner pair (6, 7) and the crossing pair (1, 2)
        i, j = res.pairs[p]
        d_grid, d_ref = dense(curves.take((0, i)), curves.take((0, j)))
        assert res.lower_bound[0, p] <= res.distances[0, p] <= d_grid + 1e-12
        assert res.distances[0, p] == pytest.approx(d_ref, abs=1e-8)
    # The curves end on the drawing points.
    ends = curves.points(ik.lengths[..., None])[..., 0, :]
    assert np.allclose(ends[0], robot.anchors, atol=1e-9)


def test_algae_harvester_home_is_clear_with_sag():
    robot = to.presets.algae_harvester()
    res = catenary.cable_clearance(robot, robot.home, "coupled")
    assert res.shared.all()
    assert res.clearance[0] > 3.0 > robot.cable.diameter
    assert res.pair[0].tolist() == [0, 1]
    assert (res.lower_bound <= res.distances).all()


def test_interference_free_workspace_with_sag():
    robot = to.presets.cogiro()
    grid = ws.workspace_grid([-3, -2, 1, 0, 0, 0], [3, 2, 3, 0, 0, 0], counts=[3, 3, 2, 1, 1, 1])
    res = catenary.interference_free_workspace(robot, grid, 0.38, model="coupled")
    straight = ws.interference_free_workspace(robot, grid, 0.38)
    assert res.N == 18 and np.isfinite(res.cable_clearance).all()
    assert np.abs(res.cable_clearance - straight.cable_clearance).max() < 0.05
    assert res.clearances is not None and res.clearances.model == "coupled"
    both = catenary.interference_free_workspace(robot, grid, 0.38, with_wrenches=True)
    assert np.array_equal(both.feasible, both.interference_free & both.wrench_feasible)
    home = catenary.interference_free_workspace(robot, robot.home, robot.cable.diameter)
    assert home.feasible.all()


@pytest.mark.parametrize(
    ("call", "error", "word"),
    [
        (lambda r: catenary.cable_clearance(r, r.home, "bogus"), InvalidInputError, "model"),
        (lambda r: catenary.cable_clearance(r, r.home, samples=0), InvalidInputError, "samples"),
        (lambda r: catenary.cable_clearance(r, r.home, shared_trim=-1), InvalidInputError,
         "shared_trim"),
        (lambda r: catenary.cable_clearance(r.with_(cable=None), r.home), InvalidCableError,
         "cable"),
        (lambda r: catenary.interference_free_workspace(r, r.home, -1.0), InvalidInputError,
         "clearance"),
    ],
)
def test_bad_input_names_the_argument(call, error, word):
    with pytest.raises(error, match=word):
        call(to.presets.cogiro())
