"""Sensitivities of the thesis convention's sag-compensated lengths, against Richardson-
extrapolated central differences of the solver itself."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary.sensitivity import length_jacobian, length_partials


def lengths(robot: to.CableRobot, poses: np.ndarray, objective: str = "min_sum") -> np.ndarray:
    return catenary.inverse_kinematics(robot, poses, model="thesis", objective=objective,
                                       compiled=False).lengths


def richardson(f, h: float) -> np.ndarray:
    """d f / d s at 0, from central differences at h and h / 2 (error O(h^4))."""
    d1 = (f(h) - f(-h)) / (2 * h)
    d2 = (f(h / 2) - f(-h / 2)) / h
    return (4 * d2 - d1) / 3


def elastic_study() -> to.CableRobot:
    robot = to.presets.algae_harvester()
    c = robot.cable
    return robot.with_(cable=to.CableProperties(c.diameter, c.linear_mass, 5.0e6))


STUDY_POSES = np.array([[-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [10.0, -5.0, 2.0],
                        [-12.0, -18.0, 0.5]])


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max"])
def test_pose_jacobian_of_the_study_robot_matches_differences(objective):
    robot = elastic_study()
    J = length_jacobian(robot, STUDY_POSES, "pose", objective)
    assert (J.status == "ok").all()
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        fd = richardson(lambda s, e=e: lengths(robot, STUDY_POSES + s * e, objective), 1e-4)
        np.testing.assert_allclose(J.jacobian[:, :, k], fd, rtol=1e-6, atol=1e-8)


def test_pose_jacobian_of_a_spatial_robot_matches_differences():
    robot = to.presets.cogiro()
    rng = np.random.default_rng(3)
    poses = robot.home + rng.uniform(-1, 1, (4, 6)) * [0.8, 0.8, 0.4, 0.08, 0.08, 0.08]
    J = length_jacobian(robot, poses, "pose", "min_norm")
    ok = J.ok
    assert ok.sum() >= 3
    for k in range(6):
        e = np.zeros(6)
        e[k] = 1.0
        fd = richardson(lambda s, e=e: lengths(robot, poses + s * e, "min_norm"), 1e-4)
        np.testing.assert_allclose(J.jacobian[ok, :, k], fd[ok], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("wrt", ["weight_per_length", "EA", "tensions"])
def test_cable_parameter_derivatives_match_differences(wrt):
    robot = elastic_study()
    c = robot.cable
    J = length_jacobian(robot, STUDY_POSES, wrt)
    if wrt == "tensions":
        planes = catenary.geometry.cable_planes(robot, STUDY_POSES)
        T = to.distribute(robot, STUDY_POSES).tensions
        w = c.weight_per_length(robot.g)

        def f(s):
            return catenary.solve_length(planes.x, planes.z, T * (1 + s), w, c.EA, "B").L0
        fd = richardson(f, 1e-5) / T
    else:
        base = c.linear_mass if wrt == "weight_per_length" else c.EA

        def f(s):
            mass, EA = (base * (1 + s), c.EA) if wrt == "weight_per_length" else (
                c.linear_mass, base * (1 + s))
            return lengths(robot.with_(cable=to.CableProperties(c.diameter, mass, EA)),
                           STUDY_POSES)
        scale = base * (robot.g if wrt == "weight_per_length" else 1.0)
        fd = richardson(f, 1e-4) / scale
    np.testing.assert_allclose(J.jacobian, fd, rtol=1e-6)


def test_inextensible_cables_do_not_depend_on_EA_and_sag_less_when_pulled():
    robot = to.presets.algae_harvester()  # EA = inf
    J = length_jacobian(robot, STUDY_POSES, "EA")
    assert (J.jacobian == 0.0).all()
    # Pulling harder takes sag out: the length falls towards the chord.
    assert (length_jacobian(robot, STUDY_POSES, "tensions").jacobian < 0).all()
    # A heavier cable sags more.
    assert (length_jacobian(robot, STUDY_POSES, "weight_per_length").jacobian > 0).all()


def test_a_face_of_optima_has_no_derivative_and_says_so():
    robot = to.presets.algae_harvester()
    J = length_jacobian(robot, [[0.0, 0.0, 0.0], [-29.4, 10.2, 1.5]], "pose")
    assert J.status.tolist() == ["non_unique", "ok"]
    assert np.isnan(J.jacobian[0]).all() and np.isfinite(J.jacobian[1]).all()


def test_bad_arguments_are_refused():
    robot = to.presets.algae_harvester()
    with pytest.raises(catenary.InvalidCableError, match="wrt"):
        length_jacobian(robot, STUDY_POSES, "mass")
    with pytest.raises(catenary.InvalidCableError, match="pulleys"):
        length_jacobian(robot.with_(pulleys=[to.Pulley(0.3)] * 4), STUDY_POSES, "pose")


def test_partials_of_a_level_cable_against_the_parabola():
    """A shallow level cable: L0 ~ x + w^2 x^3 / (24 H^2) and H ~ T, so
    dL0/dT ~ -w^2 x^3 / (12 T^3) and dL0/dw ~ w x^3 / (12 T^2)."""
    x, T, w = 10.0, 1.0e4, 5.0
    part = length_partials(x, 0.0, T, w)
    assert float(part.d_T) == pytest.approx(-w**2 * x**3 / (12 * T**3), rel=1e-3)
    assert float(part.d_w) == pytest.approx(w * x**3 / (12 * T**2), rel=1e-3)
    assert float(part.d_x) == pytest.approx(1.0, abs=1e-5)


@settings(max_examples=20, deadline=None)
@given(x=st.floats(-38.0, 38.0), y=st.floats(-24.0, 24.0), z=st.floats(0.0, 5.0),
       objective=st.sampled_from(["min_sum", "min_norm"]))
def test_pose_jacobian_matches_differences_over_the_pond(x, y, z, objective):
    robot = elastic_study()
    pose = np.array([[x, y, z]])
    J = length_jacobian(robot, pose, "pose", objective)
    if not J.ok[0]:
        assert np.isnan(J.jacobian[0]).all()
        return
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        fd = richardson(lambda s, e=e: lengths(robot, pose + s * e, objective), 1e-4)
        if not np.isfinite(fd).all():
            continue  # a difference step left the workspace
        np.testing.assert_allclose(J.jacobian[0, :, k], fd[0], rtol=1e-5, atol=1e-7)
