"""The compiled one-pose coupled sag inverse kinematics (:class:`CoupledIK`) against the
numpy reference, ``catenary.inverse_kinematics(..., model="coupled")``.

The reference stops when the platform-end tensions change less than ``tol = 1e-10``
of the largest. Started cold (from the straight-line distribution, as the reference)
the kernel runs the same iterates, so it must agree within that tolerance and take
the same number of iterations; warm-started from another pose it reaches the same
fixed point, within ten times the tolerance.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary.coupled_ik import CERT_TOL, CoupledIK, force_slope_one
from catenary.geometry import cable_planes, force_slope, taut_catenaries
from tension_opt import presets
from tension_opt.status import Status

TOL = 1e-10  # the reference's default stopping tolerance
ALGAE = presets.algae_harvester()
COGIRO = presets.cogiro()
LOAD = ALGAE.mass * ALGAE.g  # the study robot's load without an external wrench (N)
SLOW = settings(max_examples=25, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])
# Poses under the study robot's towers (m).
ALGAE_POSES = st.tuples(st.floats(-46.5, 46.5), st.floats(-31.0, 31.0), st.floats(0.0, 7.5))


def assert_agree(got: catenary.InverseKinematicsResult,
                 ref: catenary.InverseKinematicsResult, rtol: float, load: float) -> None:
    """Same status; where converged, the same catenaries within ``rtol`` of the
    largest tension (forces) and of the longest cable (lengths), and end forces that
    balance the ``load`` (N) to the certificate."""
    assert got.status[0] == ref.status[0]
    if ref.status[0] != Status.CONVERGED:
        assert np.isnan(got.lengths).all() == np.isnan(ref.lengths).all()
        return
    scale = np.abs(ref.tensions_platform).max()
    for name in ("tensions_platform", "tensions", "horizontal_tensions", "platform_forces"):
        np.testing.assert_allclose(getattr(got, name), getattr(ref, name), rtol=0,
                                   atol=rtol * scale, err_msg=name)
    np.testing.assert_allclose(got.lengths, ref.lengths, rtol=0,
                               atol=rtol * ref.lengths.max())
    np.testing.assert_allclose(got.straight_lengths, ref.straight_lengths, rtol=1e-14)
    # The certificate of a converged answer: the end forces balance the load.
    assert got.equilibrium_residual[0] <= CERT_TOL * load


@SLOW
@given(pose=ALGAE_POSES)
@example(pose=(0.0, 0.0, 7.5))  # on both symmetry planes, at the towers' height
@example(pose=(2.0, 31.0, 7.5))  # no margin-search start: both from home
def test_cold_start_runs_the_reference_iterates(pose: tuple[float, float, float]) -> None:
    p = np.array(pose)
    ref = catenary.inverse_kinematics(ALGAE, p, model="coupled")
    got = CoupledIK(ALGAE, warm_start=False)(p)
    start = to.distribute(ALGAE, p, "min_sum")
    straight = start.status[0] == Status.OPTIMAL and bool(start.unique[0])
    # The same iteration: the same fixed point to the stopping tolerance (the last step
    # is below 1e-10 of the largest tension; where the reference's closed form and the
    # kernel differ in the last bits, the stopping test may pass one iteration apart).
    # Without a straight-line start the reference starts from its margin search, the
    # kernel from the home answer (both from the home answer where the margin search
    # settles nothing): the same fixed point, not the same iterates. A
    # straight-line optimum that is not unique (on the symmetry planes) is broken to the
    # minimum norm of its face, a step the two take in different order: again the same
    # fixed point (9 iterations against 4 at the centre of the towers' top).
    assert_agree(got, ref, 10 * TOL, LOAD)
    if ref.status[0] == Status.CONVERGED and straight:
        assert abs(int(got.iterations[0]) - int(ref.iterations[0])) <= 1


def test_a_pose_the_margin_search_does_not_settle_starts_from_home() -> None:
    """At (2, 31, 7.5) no straight-line tensions fit and the capacity-margin search
    finds no taut catenaries; the reference said "infeasible" without trying. From the
    home answer it converges: two cables 0.1 m below their anchors at 1.29 MN (t_max
    is infinite), the end forces balancing the load to the certificate's tolerance."""
    p = np.array([2.0, 31.0, 7.5])
    assert to.distribute(ALGAE, p, "min_sum").status[0] == Status.INFEASIBLE
    ref = catenary.inverse_kinematics(ALGAE, p, model="coupled")
    assert ref.status[0] == Status.CONVERGED
    assert ref.equilibrium_residual[0] <= CERT_TOL * LOAD
    assert (ref.tensions[0] >= ALGAE.t_min * (1 - 1e-12)).all()
    assert ref.tensions[0].max() > 1e6
    assert_agree(CoupledIK(ALGAE, warm_start=False)(p), ref, 10 * TOL, LOAD)


@pytest.mark.parametrize("pose", [[16.432, -27.23, 4.167], [-21.255, 23.538, 0.482],
                                  [36.777, 23.076, 0.139], [-42.502, 1.858, 3.579]])
def test_poses_without_a_straight_line_solution_start_from_home(pose: list[float]) -> None:
    """Sag makes these poses feasible although no straight-line tensions within the
    bounds hold the load."""
    p = np.array(pose)
    assert to.distribute(ALGAE, p, "min_sum").status[0] == Status.INFEASIBLE
    ref = catenary.inverse_kinematics(ALGAE, p, model="coupled")
    assert ref.status[0] == Status.CONVERGED
    assert_agree(CoupledIK(ALGAE, warm_start=False)(p), ref, 10 * TOL, LOAD)


@SLOW
@given(before=ALGAE_POSES, pose=ALGAE_POSES, objective=st.sampled_from(["min_sum", "min_norm"]))
def test_warm_start_reaches_the_reference_fixed_point(
        before: tuple[float, float, float], pose: tuple[float, float, float],
        objective: str) -> None:
    ik = CoupledIK(ALGAE, objective)
    ik(np.array(before))  # the stream's previous pose, far or near
    p = np.array(pose)
    ref = catenary.inverse_kinematics(ALGAE, p, "coupled", objective)
    assert_agree(ik(p), ref, 10 * TOL, LOAD)


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "centered", "pinv"])
def test_cogiro_random_poses_agree(objective: str) -> None:
    rng = np.random.default_rng(3)
    poses = COGIRO.default_home() + rng.uniform(-1, 1, (12, 6)) * [5, 3, 1.5, 0.2, 0.2, 0.3]
    cold, warm = CoupledIK(COGIRO, objective, warm_start=False), CoupledIK(COGIRO, objective)
    for p in poses:
        ref = catenary.inverse_kinematics(COGIRO, p, "coupled", objective)
        assert ref.status[0] == Status.CONVERGED  # the test is about agreement
        load = float(np.linalg.norm(COGIRO.required_wrench(p[None])))
        assert_agree(cold(p), ref, TOL, load)
        assert_agree(warm(p), ref, 10 * TOL, load)


def test_a_stream_of_nearby_poses_with_an_external_wrench() -> None:
    ik = CoupledIK(ALGAE)
    wrench = np.array([150.0, -80.0, 40.0])
    for s in np.linspace(0.0, 1.0, 15):
        p = np.array([-30.0, -20.0, 2.0]) + s * np.array([50.0, 35.0, 4.0])
        ref = catenary.inverse_kinematics(ALGAE, p, "coupled", wrench=wrench)
        assert ref.status[0] == Status.CONVERGED
        assert_agree(ik(p, wrench), ref, 10 * TOL, LOAD)


def test_infeasible_poses_are_not_converged() -> None:
    """Outside the workspace (above the anchors, beyond a tower) and high in the middle
    with a tension limit too low to lift the cables: the reference's status, no
    catenaries."""
    tight = presets.algae_harvester(t_max=15_000.0)
    cases = [(ALGAE, [0.0, 0.0, 20.0]), (ALGAE, [80.0, 0.0, 3.0]), (tight, [0.0, 0.0, 7.0])]
    for robot, pose in cases:
        ref = catenary.inverse_kinematics(robot, np.array(pose), model="coupled")
        got = CoupledIK(robot)(np.array(pose))
        assert ref.status[0] == Status.INFEASIBLE
        assert got.status[0] == Status.INFEASIBLE
        assert np.isnan(got.lengths).all() and np.isnan(got.equilibrium_residual).all()


def test_a_loose_tolerance_settles_but_is_not_called_converged() -> None:
    """With ``tol=0.5`` the iteration stops after two steps with forces that do not
    balance the load: the step criterion is met, the certificate is not, and both the
    kernel and the numpy function say so (the numpy function once said converged)."""
    p = np.array([10.0, 5.0, 3.0])
    ref = catenary.inverse_kinematics(ALGAE, p, model="coupled", tol=0.5)
    got = CoupledIK(ALGAE, tol=0.5, warm_start=False)(p)
    assert ref.status[0] == got.status[0] == Status.INACCURATE
    assert got.equilibrium_residual[0] > 1e3 * CERT_TOL * LOAD
    np.testing.assert_allclose(got.equilibrium_residual, ref.equilibrium_residual, rtol=1e-6)


def test_the_iteration_cap_holds() -> None:
    p = np.array([10.0, 5.0, 3.0])
    ref = catenary.inverse_kinematics(ALGAE, p, model="coupled", max_iter=1)
    got = CoupledIK(ALGAE, max_iter=1, warm_start=False)(p)
    assert ref.status[0] == got.status[0] == Status.MAX_ITER
    assert got.iterations[0] == 1
    np.testing.assert_allclose(got.lengths, ref.lengths, rtol=1e-9)


def test_problems_the_kernel_does_not_cover_give_the_reference_answer() -> None:
    """Min-max (an epigraph LP) runs the numpy function itself."""
    p = np.array([5.0, -3.0, 2.0])
    ref = catenary.inverse_kinematics(ALGAE, p, "coupled", "min_max")
    got = CoupledIK(ALGAE, "min_max")(p)
    assert got.status[0] == ref.status[0] == Status.CONVERGED
    np.testing.assert_array_equal(got.lengths, ref.lengths)


@settings(max_examples=60, deadline=None)
@given(pose=ALGAE_POSES, tension=st.floats(3e3, 3e5))
def test_force_slope_of_one_cable_matches_numpy(pose: tuple[float, float, float],
                                                tension: float) -> None:
    planes = cable_planes(ALGAE, np.array([pose]))
    w, EA = ALGAE.cable.weight_per_length(ALGAE.g), ALGAE.cable.EA
    c = taut_catenaries(planes.x, planes.z, np.full((1, 4), tension), w, EA, "A")
    ref = force_slope(planes, c.H, c.V_A, c.V_B, c.L0, w, EA)[0]
    for i in range(4):
        dH, dV, regular = force_slope_one(planes.x[0, i], planes.chord[0, i], c.H[0, i],
                                          c.V_A[0, i], c.V_B[0, i], c.L0[0, i], w, 0.0)
        assert regular
        np.testing.assert_allclose([dH * planes.e_h[0, i, 0], dH * planes.e_h[0, i, 1], dV],
                                   ref[i], rtol=1e-11, atol=1e-13)


def test_bad_input_names_the_argument() -> None:
    ik = CoupledIK(ALGAE)
    with pytest.raises(catenary.InvalidCableError, match="pose must have shape"):
        ik(np.zeros((2, 3)))
    with pytest.raises(catenary.InvalidCableError, match="pose must be numbers"):
        ik(["a", "b", "c"])
    with pytest.raises(to.TensionOptError, match="non-finite"):
        ik(np.array([np.nan, 0.0, 1.0]))
    with pytest.raises(catenary.InvalidCableError, match="wrench must"):
        ik(np.zeros(3), wrench=[np.inf, 0.0, 0.0])
    with pytest.raises(catenary.InvalidCableError, match="wrench must have shape"):
        ik(np.zeros(3), wrench=np.zeros(6))
    with pytest.raises(catenary.InvalidCableError, match="tol"):
        CoupledIK(ALGAE, tol=0.0)
    with pytest.raises(catenary.InvalidCableError, match="max_iter"):
        CoupledIK(ALGAE, max_iter=0)
    with pytest.raises(catenary.InvalidCableError, match="smoothing"):
        CoupledIK(ALGAE, to.TensionProblem("min_sum", smoothing=1.0))
    with pytest.raises(catenary.InvalidCableError, match="no cable properties"):
        CoupledIK(dataclasses.replace(ALGAE, cable=None))
