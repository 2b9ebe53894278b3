"""Sag-aware (coupled catenary) workspace: light-cable limit, equilibrium, optimality of
the coupled margin, the poses only sag makes feasible, executors and plots."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest
from scipy.optimize import minimize

import catenary
import tension_opt as to
from catenary import workspace as cws
from catenary.geometry import cable_planes, extreme_tensions, platform_forces, taut_catenaries
from tension_opt import workspace as ws

matplotlib.use("Agg")



def test_light_cables_give_the_straight_workspace(poses):
    # Cable density 1e-3 kg/m^3: w = 3e-9 N/m, the catenaries are straight lines.
    robot = to.presets.algae_harvester(cable_density=1e-3, t_max=15_000.0)
    sag = cws.sag_workspace(robot, poses)
    straight = ws.wrench_feasible_workspace(robot, poses)
    np.testing.assert_array_equal(sag.feasible, straight.feasible)
    both = np.isfinite(sag.margin)
    assert both.sum() >= 0.9 * len(poses)
    np.testing.assert_allclose(sag.margin[both], straight.margin[both], rtol=1e-6,
                               atol=1e-6 * robot.weight)
    np.testing.assert_allclose(sag.straight_margin, straight.margin, rtol=1e-12)
    ok = sag.feasible
    assert np.nanmax(sag.sag_correction[ok]) < 1e-6  # metres
    # (The coupled inverse kinematics of near-weightless cables matches the straight
    # min-sum tensions to about 2e-6 where a t_max is active.)
    np.testing.assert_allclose(sag.tensions[ok], straight.tensions[ok], rtol=1e-5)
    # Polyethylene (1150 kg/m^3) sags, less than steel (7860 kg/m^3).
    poly = to.presets.algae_harvester(cable_density=1150.0)
    light = cws.sag_workspace(poly, poses[:100])
    heavy = cws.sag_workspace(to.presets.algae_harvester(), poses[:100])
    common = light.feasible & heavy.feasible
    assert common.sum() > 40
    # (Not pose by pose: the tension distributions differ too.)
    ratio = light.sag_correction[common] / heavy.sag_correction[common]
    assert np.median(ratio) < 0.2 and np.mean(ratio < 1) > 0.9


def test_coupled_equilibrium_and_bounds_hold_where_feasible(steel):
    robot = steel.robot
    ok = steel.feasible
    assert 0.15 < ok.mean() < 0.5  # t_max = 15 kN on the highest tension
    assert np.all(steel.equilibrium_residual[ok] < 1e-6 * robot.weight)
    assert np.all(steel.margin[ok] >= -1e-6 * robot.weight)
    assert np.all(steel.margin[~ok & np.isfinite(steel.margin)] < 0)
    assert np.all((steel.margin_status == "converged") | ~ok)
    assert np.all(steel.margin_residual[steel.margin_status == "converged"]
                  < 1e-6 * robot.weight)
    # The reported tensions (drawing-point ends) rebuild catenaries in equilibrium with
    # every cable's lowest and highest tension within the bounds.
    geo = cable_planes(robot, steel.poses[ok])
    w = robot.cable.weight_per_length(robot.g)
    H, V_A, V_B, L0, _, conv = taut_catenaries(geo.x, geo.z, steel.tensions[ok], w, np.inf, "B")
    assert conv.all()
    np.testing.assert_allclose(L0, steel.lengths[ok], rtol=1e-9)
    low, high = extreme_tensions(H, V_A, V_B)
    assert np.all(low >= robot.t_min - 1e-6 * robot.weight)
    assert np.all(high <= robot.t_max + 1e-6 * robot.weight)
    forces = platform_forces(geo, H, V_A).sum(axis=1)
    np.testing.assert_allclose(forces, np.tile([0, 0, robot.weight], (ok.sum(), 1)),
                               atol=1e-6 * robot.weight)
    # The length corrections are the study's order of magnitude (0.2 m at the centre).
    assert 0.0 < np.nanmin(steel.sag_correction) and np.nanmax(steel.sag_correction) < 5.0


def test_sag_widens_the_study_workspace_beyond_the_straight_one(steel):
    # Poses where no straight-line tensions are within bounds, but catenaries are: long
    # cables that dip below the platform pull it down, so the others may pull harder.
    only_sag = steel.feasible & (steel.straight_margin < 0)
    assert only_sag.sum() >= 5
    assert np.all(steel.margin[only_sag] > 0)
    # catenary.inverse_kinematics starts such poses from the margin search by itself,
    # and from the margin's tensions given explicitly it finds the same solution.
    robot = steel.robot
    p = steel.poses[only_sag]
    assert not to.distribute(robot, p, "min_sum").success.any()
    plain = catenary.inverse_kinematics(robot, p, model="coupled")
    assert plain.success.all()
    _, T_m, st, _, _ = cws.coupled_margin(robot, p)
    assert (st == "converged").all()
    started = catenary.inverse_kinematics(robot, p, model="coupled", initial_tensions=T_m)
    assert started.success.all()
    np.testing.assert_allclose(started.tensions, steel.tensions[only_sag], rtol=1e-8)
    np.testing.assert_allclose(plain.tensions, steel.tensions[only_sag], rtol=1e-8)


def test_coupled_margin_is_the_optimum_of_the_nonlinear_problem(steel):
    """Independent check: SLSQP on the max-min over the platform-end tensions, with the
    catenary equilibrium as equality constraints, from another start."""
    robot = steel.robot
    w = robot.cable.weight_per_length(robot.g)
    W = robot.weight
    picks = [int(i) for i in np.flatnonzero(steel.margin_status == "converged")[:4]]
    assert len(picks) == 4
    margins, T, _, _, _ = cws.coupled_margin(robot, steel.poses[picks])
    for k, i in enumerate(picks):
        geo = cable_planes(robot, steel.poses[i:i + 1])

        def cables(v, geo=geo):
            t = v[:4] * W
            if (t <= 0).any():
                return None
            h, va, vb, _, _, conv = taut_catenaries(geo.x, geo.z, t[None], w, np.inf, "A")
            return (h, va, vb) if conv.all() else None

        def balance(v, geo=geo, cables=cables):
            c = cables(v)
            if c is None:
                return np.full(3, 1e3)
            return platform_forces(geo, c[0], c[1]).sum(axis=1)[0] / W - [0, 0, 1]

        def bounds(v, cables=cables):
            c = cables(v)
            if c is None:
                return np.full(8, -1e3)
            low, high = (e[0] / W for e in extreme_tensions(*c))
            s = v[4]
            return np.concatenate([low - robot.t_min / W - s, robot.t_max / W - high - s])

        x0 = np.r_[T[k] / W * 1.1, (margins[k] - 0.1 * abs(margins[k])) / W]
        out = minimize(lambda v: -v[4], x0, method="SLSQP", options={"ftol": 1e-13,
                                                                      "maxiter": 300},
                       constraints=[{"type": "eq", "fun": balance},
                                    {"type": "ineq", "fun": bounds}])
        assert out.success
        assert out.x[4] * W == pytest.approx(margins[k], rel=1e-6, abs=1e-6 * W)
        assert margins[k] == pytest.approx(steel.margin[i], rel=1e-9)


def test_same_result_in_process_and_with_processes(poses):
    robot = to.presets.algae_harvester(t_max=15_000.0)
    here = cws.sag_workspace(robot, poses[:90], chunk_size=30)
    pool = cws.sag_workspace(robot, poses[:90], chunk_size=30, executor="processes:2")
    for name in ("feasible", "margin", "tensions", "lengths", "sag_correction",
                 "straight_margin", "equilibrium_residual"):
        np.testing.assert_array_equal(getattr(here, name), getattr(pool, name), err_msg=name)
    assert [str(s) for s in here.status] == [str(s) for s in pool.status]


def test_grid_plot_and_table_of_the_sag_correction():
    import matplotlib.pyplot as plt

    robot = to.presets.algae_harvester()
    grid = ws.workspace_grid([-46.55, -31.1, 1.5], [46.55, 31.1, 2.5], spacing=[9.0, 9.0, 1.0])
    res = cws.sag_workspace(robot, grid)
    assert res.grid_shape == (11, 7, 1)
    ax = ws.plot_slice(res, z=2.0, quantity="sag_correction")
    assert ax.figure.axes[-1].get_ylabel() == "largest sag length correction (m)"
    assert ax.get_xlabel() == "x (m)"
    plt.close("all")
    frame = res.to_frame()
    for column in ("sag_correction", "straight_margin", "margin_status", "L1", "L4"):
        assert column in frame.columns
    centre = ws.wrench_feasible_workspace(robot, grid)
    assert res.fraction() >= centre.fraction()


def test_no_poses_a_pose_on_a_drawing_point_and_the_repr():
    robot = to.presets.algae_harvester()
    empty = cws.sag_workspace(robot, np.zeros((0, 3)))
    assert empty.N == 0 and empty.lengths.shape == (0, 4) and empty.to_frame().shape[0] == 0
    P = np.array([[0.0, 0.0, 2.0], robot.anchors[0], [10.0, 5.0, 1.0]])
    res = cws.sag_workspace(robot, P, chunk_size=2)
    alone = cws.sag_workspace(robot, P[[0, 2]])
    assert not res.feasible[1] and res.margin[1] == -np.inf
    assert res.status[1] == to.Status.INFEASIBLE and res.margin_status[1] == "singular"
    for name in ("tensions", "lengths", "straight_lengths"):
        assert np.isnan(getattr(res, name)[1]).all(), name
        np.testing.assert_allclose(getattr(res, name)[[0, 2]], getattr(alone, name),
                                   rtol=1e-9, err_msg=name)
    assert np.isnan(res.sag_correction[1])
    np.testing.assert_array_equal(res.feasible[[0, 2]], alone.feasible)
    # The one-line repr of the parent, not every array.
    text = repr(res)
    assert text.startswith("SagWorkspaceResult('algae harvester', N=3") and "\n" not in text
    assert "array" not in text
