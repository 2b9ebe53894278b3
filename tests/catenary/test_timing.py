"""Sag-aware time-optimal timing: the coupled sag model around the straight timing."""

from __future__ import annotations

import numpy as np
import pytest

import catenary as cat
import tension_opt as to
from benchmarks.scenarios import pick_and_place
from catenary.timing import time_optimal_sag
from tension_opt import dynamics as dyn

#: The study robot with a finite upper bound (t_max = inf leaves a lift unlimited).
ROBOT = to.presets.algae_harvester(t_max=15_000.0)


@pytest.fixture(scope="module")
def sag() -> cat.SagTimingResult:
    return time_optimal_sag(ROBOT, pick_and_place())


def _dynamic_wrench(timing: dyn.TimingResult, scale: float = 1.0) -> np.ndarray:
    """The external-wrench argument that makes a static solve hold the timing's motion,
    with the motion slowed in time so that its inertial wrench is ``scale`` times."""
    W = dyn.required_wrench(ROBOT, timing.poses, timing.velocities, timing.accelerations)
    static = ROBOT.required_wrench(timing.poses)
    return -scale * (W - static)


def test_the_fixed_point_is_reached_and_consistent(sag) -> None:
    assert sag.success and sag.status == to.Status.CONVERGED
    assert 2 <= sag.iterations <= 10
    assert abs(sag.durations[-1] - sag.durations[-2]) <= 1e-5 * sag.duration
    # The catenaries carrying the timing's platform-end tensions supply the wrench ...
    assert sag.equilibrium_residual.max() < 1e-6 * ROBOT.t_max[0]
    # ... within the bounds on the lowest and highest tension along every cable.
    assert (sag.lowest >= ROBOT.t_min - 1e-6).all()
    assert (sag.highest <= ROBOT.t_max * (1 + 1e-9)).all()
    assert np.isfinite(sag.lengths).all() and (sag.lengths > 0).all()


def test_sag_makes_the_study_path_slower(sag) -> None:
    # Heavy steel cables (2.47 kg/m, 50-90 m): the towers carry the cables' weight too.
    assert sag.slowdown > 0.1
    assert sag.straight.duration == pytest.approx(
        dyn.time_optimal(ROBOT, pick_and_place()).duration, rel=1e-9)


def _coupled_between(timing: dyn.TimingResult, per: int = 16) -> np.ndarray:
    """Coupled margin (N) of the timing's motion at ``per + 1`` evenly spaced points of
    every interval, both ends included (``s''`` kept from a grid point to the next),
    shape (K - 1, per + 1)."""
    spline, s = timing.extras["path"], timing.s
    t = np.arange(per + 1) / per
    own = np.repeat(np.arange(len(s) - 1), per + 1)
    at = (s[:-1, None] + np.diff(s)[:, None] * t).ravel()
    x = np.maximum(timing.sd[own] ** 2 + 2 * (at - s[own]) * timing.sdd[own], 0.0)
    q, dq, ddq = spline(at), spline(at, 1), spline(at, 2)
    W = dyn.required_wrench(ROBOT, q, dq * np.sqrt(x)[:, None],
                            dq * timing.sdd[own][:, None] + ddq * x[:, None], rates="pose")
    margin = cat.coupled_margin(ROBOT, q, ROBOT.required_wrench(q) - W)[0]
    return margin.reshape(len(s) - 1, per + 1)


def test_the_sag_timing_holds_between_grid_points(sag) -> None:
    """Checked at its grid points only, the sag-aware timing of the study path needed
    -12.8 kN of coupled margin between them (s = 0.31 m); now within 15 N (1e-3 of
    t_max): the sag model is linearised at the grid points and interpolated between
    them, and the timing checks that."""
    between = _coupled_between(sag.timing)
    assert between.min() >= -1e-3 * ROBOT.t_max[0]
    assert sag.timing.min_margin_between >= -1e-6 * ROBOT.t_max[0]


def test_coupled_model_holds_the_sag_timing_but_not_the_straight_one(sag) -> None:
    """Independent check by the coupled inverse kinematics and margin of catenary."""
    poses = sag.timing.poses
    on_limit = cat.coupled_margin(ROBOT, poses, _dynamic_wrench(sag.timing))[0]
    assert on_limit.min() >= -1e-6 * ROBOT.t_max[0]  # the sag timing is feasible ...
    # ... and on the boundary somewhere in most intervals: time-optimal.
    assert np.median(np.abs(_coupled_between(sag.timing).min(axis=1))) < 1.0
    slower = _dynamic_wrench(sag.timing, 0.99**2)
    ik = cat.inverse_kinematics(ROBOT, poses, "coupled", wrench=slower)
    assert ik.success.all()
    straight = cat.coupled_margin(ROBOT, poses, _dynamic_wrench(sag.straight))[0]
    assert straight.min() < -100.0  # newtons: the straight timing is too fast with sag


def test_light_cables_barely_change_the_timing() -> None:
    light = to.presets.algae_harvester(t_max=15_000.0, cable_density=50.0)
    res = time_optimal_sag(light, pick_and_place())
    assert res.success
    # (Slightly faster, even: a light sagging cable leaves the platform a little steeper.)
    assert abs(res.slowdown) < 0.02


def test_a_path_the_sagging_cables_cannot_hold_is_reported_not_raised() -> None:
    # With t_max = 10 kN the steel cables' weight leaves no static tensions on this path.
    robot = to.presets.algae_harvester(t_max=10_000.0)
    assert cat.coupled_margin(robot, pick_and_place())[0].max() < 0
    res = time_optimal_sag(robot, pick_and_place())
    assert not res.success and res.status == to.Status.INFEASIBLE
    assert res.duration == np.inf and res.straight.success


def test_sag_timing_needs_cable_properties() -> None:
    robot = to.presets.algae_harvester().with_(cable=None)
    with pytest.raises(cat.CatenaryError, match="cable"):
        time_optimal_sag(robot, pick_and_place())
