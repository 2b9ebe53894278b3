"""The compiled catenary kernels against the numpy reference (catenary.elastic,
catenary.solve_length)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import catenary
from catenary import kernels
from catenary.elastic import axial_compliance, evaluate
from catenary.realtime import solve_forces_compiled, solve_length_compiled

SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def random_cables(seed: int, count: int = 200) -> tuple[np.ndarray, ...]:
    """Spans, tensions, weights and stiffnesses from taut to heavily sagging, steep,
    downhill, weightless, inextensible; some tensions too small to hold the cable."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.1, 80.0, count)
    z = rng.uniform(-40.0, 40.0, count)
    w = rng.choice([0.0, 0.05, 1.0, 20.0], count) * rng.uniform(0.5, 2.0, count)
    T = 10.0 ** rng.uniform(0.0, 5.0, count)
    EA = rng.choice([np.inf, 1e5, 1e8], count)
    x[:5] = 0.0  # vertical cables: the numpy path
    return x, z, T, w, EA


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_span_kernel_matches_evaluate(seed):
    rng = np.random.default_rng(seed)
    H = 10.0 ** rng.uniform(-1, 5, 50)
    V_B = rng.uniform(-2, 2, 50) * H * rng.uniform(0.1, 10, 50)
    L0 = rng.uniform(0.1, 100, 50)
    w = rng.choice([0.0, 0.1, 10.0], 50)
    inv_EA = axial_compliance(rng.choice([np.inf, 1e6], 50))
    ref = evaluate(H, V_B, L0, w, inv_EA)
    span = np.abs(ref[0]) + np.abs(ref[1])
    flex = np.abs(ref[2]) + np.abs(ref[3]) + np.abs(ref[4])
    for k in range(50):
        x, z, fxx, fxz, fzz, t_a, t_b, regular = kernels.spans_one(
            H[k], V_B[k], L0[k], w[k], inv_EA[k])
        assert regular
        assert abs(x - ref[0][k]) <= 1e-12 * span[k] and abs(z - ref[1][k]) <= 1e-12 * span[k]
        for got, want in ((fxx, ref[2][k]), (fxz, ref[3][k]), (fzz, ref[4][k])):
            assert abs(got - want) <= 1e-12 * flex[k]
        assert abs(t_a - ref[6][k]) <= 1e-14 * ref[6][k]
        assert abs(t_b - ref[7][k]) <= 1e-14 * ref[7][k]


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.sampled_from(["B", "A"]))
def test_compiled_solve_length_matches_numpy(seed, end):
    x, z, T, w, EA = random_cables(seed)
    ref = catenary.solve_length(x, z, T, w, EA, end=end)
    got = solve_length_compiled(x, z, T, w, EA, end=end)
    np.testing.assert_array_equal(got.status, ref.status)
    assert ref.converged.any() and (~ref.converged).any()
    # Most converged cables were answered by the kernel itself.
    codes = np.empty(x.size, dtype=np.int64)
    kernels.solve_length_serial(end == "B", x, z, T, w, axial_compliance(EA), 1e-9, 30,
                                np.zeros((x.size, 5)), codes)
    assert (codes == kernels.CONVERGED).sum() >= 0.8 * ref.converged.sum()
    for name in ("L0", "H", "V_A", "V_B"):
        a, b = getattr(got, name), getattr(ref, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        ok = np.isfinite(b)
        scale = np.maximum(np.abs(ref.L0) if name == "L0" else T, 1e-300)
        assert (np.abs(a - b)[ok] <= 1e-12 * scale[ok]).all(), name


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_compiled_solve_forces_matches_numpy(seed):
    x, z, _, w, EA = random_cables(seed)
    rng = np.random.default_rng(seed)
    chord = np.hypot(x, z)
    # From stretched (shorter than the chord) to deeply sagging; some inextensible
    # cables too short to span their chord (infeasible).
    L0 = chord * rng.choice([0.9, 0.999, 1.0001, 1.05, 1.5, 3.0], x.size)
    ref = catenary.solve_forces(x, z, L0, w, EA)
    got = solve_forces_compiled(x, z, L0, w, EA)
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_array_equal(got.converged, ref.converged)
    np.testing.assert_array_equal(got.iterations, ref.iterations)
    codes = np.empty(x.size, dtype=np.int64)
    kernels.solve_forces_batch(x, z, L0, w, axial_compliance(EA), 1e-9, 30,
                               np.zeros((x.size, 4)), codes, False)
    general = ref.converged & (w > 0) & (x > 1e-15 * chord)
    assert general.any() and (codes[general] == kernels.CONVERGED).mean() >= 0.8
    # Same iterations from the same guess; Newton stops at a step of rtol = 1e-9, and a
    # nearly taut cable amplifies the last rounding of its guess in H (seen: 1.0e-12 of
    # the tension at L0 = 1.0001 chord), hence 1e-10 of the tension, not 1e-12.
    scale = np.hypot(ref.H, ref.V_B)  # the tension at B (N)
    for name in ("H", "V_A", "V_B"):
        a, b = getattr(got, name), getattr(ref, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        ok = np.isfinite(b)
        assert (np.abs(a - b)[ok] <= 1e-10 * np.maximum(scale[ok], 1e-300)).all(), name


def test_compiled_solve_forces_closed_forms_and_bad_input():
    """Weightless and vertical cables (numpy closed forms) through the wrapper; a
    parabolic limit (light taut cable) against the kernel."""
    got = solve_forces_compiled([3.0, 0.0, 10.0], [4.0, 5.0, 0.0], [5.5, 6.0, 10.0],
                                [0.0, 2.0, 1e-6], 1e6)
    ref = catenary.solve_forces([3.0, 0.0, 10.0], [4.0, 5.0, 0.0], [5.5, 6.0, 10.0],
                                [0.0, 2.0, 1e-6], 1e6)
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_allclose(got.H, ref.H, rtol=1e-12)
    # Horizontal cable, length equal to the chord, EA = 1e6 N, w = 1e-6 N/m: the sag is
    # negligible and H balances the weight's parabola, H ~ (w^2 x^3 EA / 24 L0)^(1/3).
    assert abs(got.H[2] - (1e-12 * 1e3 * 1e6 / 24 / 10.0) ** (1 / 3)) <= 1e-3 * got.H[2]
    import pytest

    with pytest.raises(catenary.CatenaryError, match="L0"):
        solve_forces_compiled(1.0, 0.0, -1.0, 1.0)


def test_compiled_solve_length_keeps_shapes_and_end_h():
    x = np.array([[10.0, 20.0], [5.0, 0.0]])
    got = solve_length_compiled(x, 3.0, 500.0, 1.0, 1e7)
    ref = catenary.solve_length(x, 3.0, 500.0, 1.0, 1e7)
    assert got.L0.shape == (2, 2)
    np.testing.assert_allclose(got.L0, ref.L0, rtol=1e-12)
    h = solve_length_compiled(x, 3.0, 500.0, 1.0, 1e7, end="H")
    np.testing.assert_array_equal(h.L0, catenary.solve_length(x, 3.0, 500.0, 1.0, 1e7,
                                                              end="H").L0)


def test_bad_input_raises_the_package_error():
    import pytest

    with pytest.raises(catenary.CatenaryError, match="x"):
        solve_length_compiled(-1.0, 0.0, 10.0, 1.0)
    with pytest.raises(catenary.CatenaryError, match="end"):
        solve_length_compiled(1.0, 0.0, 10.0, 1.0, end="C")


IK_FIELDS = ("lengths", "straight_lengths", "tensions", "tensions_platform",
             "horizontal_tensions", "platform_forces", "equilibrium_residual")


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["algae", "cogiro"]),
       st.sampled_from(["min_sum", "min_norm"]))
def test_compiled_thesis_ik_matches_inverse_kinematics(seed, name, objective):
    from catenary.realtime_ik import ThesisIK
    from tension_opt import presets

    robot = presets.algae_harvester() if name == "algae" else presets.cogiro()
    rng = np.random.default_rng(seed)
    ik = ThesisIK(robot, objective)
    poses = robot.default_home() + np.zeros((6, robot.dof))
    poses[1:, :2] += rng.uniform(-8.0, 8.0, (5, 2))  # home, then some outside the workspace
    poses[-1, 2] += 1e3  # far above the drawing points: no tensions hold it
    wrench = rng.normal(size=robot.dof) * 50.0
    solved = 0
    for k, pose in enumerate(poses):
        w = wrench if k % 2 else None
        ref = catenary.inverse_kinematics(robot, pose, "thesis", objective, wrench=w)
        got = ik(pose, w)
        np.testing.assert_array_equal(got.status, ref.status)
        np.testing.assert_array_equal(got.catenary_iterations, ref.catenary_iterations)
        for field in IK_FIELDS:
            a, b = getattr(got, field), getattr(ref, field)
            np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
            ok = np.isfinite(b)
            assert (np.abs(a - b)[ok] <= 1e-12 * np.abs(b[ok]).max(initial=1e-300)).all(), field
        solved += bool(ref.status[0] == "converged")
    assert ref.status[0] != "converged"  # the pose far above the robot
    assert solved >= 1
