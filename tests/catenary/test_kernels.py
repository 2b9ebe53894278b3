"""The compiled catenary kernels against the numpy reference (catenary.elastic,
catenary.solve_length)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from benchmarks.cable_cases import random_cables
from catenary.elastic import axial_compliance, evaluate
from catenary.solve import compiled, kernels
from catenary.solve.kernels_spans import asinh_fast, spans_flex
from catenary.solve_compiled import solve_forces_compiled, solve_length_compiled

SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


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


def agree(got, ref, scale, tol, names):
    """Same statuses and NaN pattern; values within ``tol * scale``; the same iterations
    but for a few cables one apart (Newton stops once its step is below ``rtol``, and a
    last-bit difference between numpy's and the C library's functions may put that
    step on the other side of it: seen for 3 of 6144 cables)."""
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_array_equal(got.converged, ref.converged)
    steps = np.abs(got.iterations - ref.iterations)
    assert steps.max(initial=0) <= 1 and (steps > 0).sum() <= max(1, steps.size // 100)
    for name in names:
        a, b = getattr(got, name), getattr(ref, name)
        assert a.shape == b.shape
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        ok = np.isfinite(b)
        bound = tol * np.broadcast_to(scale, b.shape)
        close = (np.abs(a - b) <= bound) | (a == b)
        assert close[ok].all(), (name, np.max(np.abs(a - b)[ok]))


def kernel_codes(end, x, z, T, w, EA):
    """The kernel's codes for cables given as flat arrays of equal size."""
    out, ints = np.empty((4, x.size)), np.empty((2, x.size), dtype=np.int64)
    kernels.solve_length_cables(end == "B", x, z, T, w, EA, 1e-9, 30, out, ints)
    return ints[0]


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.sampled_from(["B", "A"]))
def test_compiled_solve_length_matches_numpy(seed, end):
    x, z, T, w, EA = random_cables(seed)
    ref = catenary.solve_length(x, z, T, w, EA, end=end, compiled=False)
    got = catenary.solve_length(x, z, T, w, EA, end=end)
    assert ref.converged.any() and (~ref.converged).any()
    # Most converged cables were answered by the kernel itself.
    codes = kernel_codes(end, x, z, T, w, EA)
    assert (codes == kernels.CONVERGED).sum() >= 0.8 * ref.converged.sum()
    # Same data in the same powers-of-two units, same steps: 1e-12 of the tension / L0.
    agree(got, ref, T, 1e-12, ("H", "V_A", "V_B"))
    agree(got, ref, np.abs(ref.L0), 1e-12, ("L0",))
    np.testing.assert_array_equal(solve_length_compiled(x, z, T, w, EA, end=end).L0, got.L0)


@pytest.mark.parametrize("end", ["B", "A"])
def test_interleaved_cables_match_each_cable_alone(end):
    """The batch kernel runs groups of cables side by side in the vector unit: each cable's
    outcome is bit for bit that of the cable solved alone (a batch of one), over a mix
    that ends in every code (converged, infeasible, fallback, invalid) and steps."""
    x, z, T, w, EA = random_cables(7, 600)
    x[10], T[11], EA[12] = -1.0, np.nan, 0.0  # invalid data
    n = x.size
    out, ints = np.full((4, n), -7.0), np.full((2, n), -7, dtype=np.int64)
    unsettled = kernels.solve_length_cables(end == "B", x, z, T, w, EA, 1e-9, 30, out, ints)
    alone_out, alone_ints = np.full((4, n), -7.0), np.full((2, n), -7, dtype=np.int64)
    for k in range(n):
        one = slice(k, k + 1)
        kernels.solve_length_cables(end == "B", x[one], z[one], T[one], w[one], EA[one],
                                    1e-9, 30, alone_out[:, one], alone_ints[:, one])
    np.testing.assert_array_equal(ints, alone_ints)
    np.testing.assert_array_equal(out, alone_out)  # NaN where not converged, both
    assert unsettled == (ints[0] != kernels.CONVERGED).sum()
    assert set(np.unique(ints[0])) == {kernels.CONVERGED, kernels.FALLBACK, kernels.INVALID,
                                       kernels.INFEASIBLE}
    assert len(np.unique(ints[1][ints[0] == kernels.CONVERGED])) >= 3
    parallel_out, parallel_ints = np.full((4, n), -7.0), np.full((2, n), -7, dtype=np.int64)
    kernels.solve_length_cables_parallel(end == "B", x, z, T, w, EA, 1e-9, 30,
                                         parallel_out, parallel_ints)
    np.testing.assert_array_equal(parallel_ints, ints)
    np.testing.assert_array_equal(parallel_out, out)


@pytest.mark.parametrize("end", ["B", "A"])
def test_vectors_with_numbers_match_the_general_call(end):
    """Float64 vectors with ``w`` and ``EA`` numbers (a controller's call) go to the
    kernel as they are; the result is field for field that of the same data given as
    arrays (the general path), cables the kernel leaves included."""
    x, z, T, _, _ = random_cables(11, 300)
    seen: set[str] = set()
    few = compiled.FEW_CABLES
    for w, EA in ((1.0, np.inf), (20.0, 1e5), (np.float64(0.3), 1e8), (0.0, np.inf)):
        ref = catenary.solve_length(x, z, T, np.full(x.size, w), np.full(x.size, EA),
                                    end=end)
        for size in (1, 4, few, few + 1, x.size):  # the direct call up to FEW_CABLES
            got = catenary.solve_length(x[:size], z[:size], T[:size], w, EA, end=end)
            for name in ("H", "V_A", "V_B", "L0", "iterations", "converged", "status"):
                np.testing.assert_array_equal(getattr(got, name), getattr(ref, name)[:size])
            seen.update(got.status.tolist())
        strided = catenary.solve_length(x[::2], z[::2], T[::2], w, EA, end=end)
        np.testing.assert_array_equal(strided.L0, ref.L0[::2])
    assert {"converged", "infeasible"} <= seen
    # Every call's arrays are its own, the all-converged rows too.
    first = catenary.solve_length(x[:4], z[:4], 1e5 + T[:4], 1.0, np.inf, end=end)
    assert first.converged.all()
    first.status[:] = "changed"
    first.converged[:] = False
    second = catenary.solve_length(x[:4], z[:4], 1e5 + T[:4], 1.0, np.inf, end=end)
    assert second.converged.all() and (second.status == "converged").all()


def forces_scale(ref, chord, L0):
    """Bound on the forces' disagreement (N): 1e-12 of the tension at B, more for cables
    nearly as long as their chord, whose forces are ill-conditioned: a relative change
    ``e`` of the data changes the tension by about ``e c / (2 |L0 - c|)`` relative, and
    a last-bit difference between numpy's and the C library's functions in the guess
    shows at 2e-12 of the tension for L0 = 1.0001 c (seen), at 2e-5 for L0 - c = 5e-15 c.
    Hence ``max(1e-12, 1e-14 c / |L0 - c|)`` of the tension (1e-10 at L0 = 1.0001 c)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        conditioning = 1e-14 * chord / np.abs(L0 - chord)
        return np.hypot(ref.H, ref.V_B) * np.maximum(1e-12, conditioning)


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_compiled_solve_forces_matches_numpy(seed):
    x, z, _, w, EA = random_cables(seed)
    rng = np.random.default_rng(seed)
    chord = np.hypot(x, z)
    # From stretched (shorter than the chord) to deeply sagging; some inextensible
    # cables too short to span their chord (infeasible).
    L0 = chord * rng.choice([0.9, 0.999, 1.0001, 1.05, 1.5, 3.0], x.size)
    ref = catenary.solve_forces(x, z, L0, w, EA, compiled=False)
    got = catenary.solve_forces(x, z, L0, w, EA)
    out, ints = np.empty((3, x.size)), np.empty((2, x.size), dtype=np.int64)
    kernels.solve_forces_cables(x, z, L0, w, EA, 1e-9, 30, out, ints)
    general = ref.converged & (w > 0) & (x > 1e-15 * chord)
    assert general.any() and (ints[0][general] == kernels.CONVERGED).mean() >= 0.8
    agree(got, ref, forces_scale(ref, chord, L0), 1.0, ("H", "V_A", "V_B"))
    np.testing.assert_array_equal(solve_forces_compiled(x, z, L0, w, EA).H, got.H)


def test_large_batches_run_in_parallel_and_agree():
    """Beyond PARALLEL_FROM cables the kernels run over threads: same answers."""
    x, z, T, w, EA = random_cables(7, 3 * kernels.PARALLEL_FROM)
    ref = catenary.solve_length(x, z, T, w, EA, compiled=False)
    agree(catenary.solve_length(x, z, T, w, EA), ref, T, 1e-12, ("H", "V_A", "V_B"))
    L0 = np.where(ref.converged, ref.L0, 2.0 * np.hypot(x, z))
    ref = catenary.solve_forces(x, z, L0, w, EA, compiled=False)
    agree(catenary.solve_forces(x, z, L0, w, EA), ref,
          forces_scale(ref, np.hypot(x, z), L0), 1.0, ("H", "V_A", "V_B"))


# The extreme magnitudes of the contract's fuzz tests (tests/catenary/test_contract.py).
SPANS = st.sampled_from([0.0, 1e-9, 1e-3, 1.0, 1e3, 1e6, 1e9])
HEIGHTS = st.sampled_from([-1e9, -10.0, -1.0, 0.0, 2.0, 1e3, 1e9])
WEIGHTS = st.sampled_from([0.0, 1e-300, 1e-9, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e300])
STIFFNESSES = st.sampled_from([np.inf, 1e300, 1e9, 1e6, 1e3, 1.0, 1e-300])
TENSIONS = st.sampled_from([0.0, 1e-300, 1e-6, 1.0, 1e6, 1e12, 1e100, 1e300])
RATIOS = st.sampled_from([1e-6, 0.5, 0.999, 1.0, 1.001, 1.2, 3.0, 1e3, 1e6])
EXTREME = settings(max_examples=60, deadline=None, database=None, derandomize=True,
                   suppress_health_check=[HealthCheck.too_slow])


def cable_batch(draw_from, size):
    return st.lists(st.tuples(*draw_from), min_size=size, max_size=size)


@EXTREME
@given(cable_batch((SPANS, HEIGHTS, TENSIONS, WEIGHTS, STIFFNESSES), 12),
       st.sampled_from(["B", "A"]))
def test_compiled_solve_length_agrees_at_extreme_magnitudes(cables, end):
    x, z, T, w, EA = (np.array(c) for c in zip(*cables, strict=True))
    with np.errstate(all="raise"):  # no floating-point warning from the plain call
        got = catenary.solve_length(x, z, T, w, EA, end=end)
    ref = catenary.solve_length(x, z, T, w, EA, end=end, compiled=False)
    agree(got, ref, T, 1e-12, ("H", "V_A", "V_B"))
    agree(got, ref, np.abs(ref.L0), 1e-12, ("L0",))


@EXTREME
@given(cable_batch((SPANS, HEIGHTS, RATIOS, WEIGHTS, STIFFNESSES), 12))
def test_compiled_solve_forces_agrees_at_extreme_magnitudes(cables):
    x, z, ratio, w, EA = (np.array(c) for c in zip(*cables, strict=True))
    chord = np.hypot(x, z)
    L0 = np.where(chord > 0, ratio * chord, ratio)
    got = catenary.solve_forces(x, z, L0, w, EA)
    ref = catenary.solve_forces(x, z, L0, w, EA, compiled=False)
    agree(got, ref, forces_scale(ref, np.where(chord > 0, chord, L0), L0), 1.0,
          ("H", "V_A", "V_B"))


def test_compiled_solve_forces_closed_forms_and_bad_input():
    """Weightless and vertical cables (numpy closed forms) through the plain call; a
    parabolic limit (light taut cable) against the kernel."""
    args = ([3.0, 0.0, 10.0], [4.0, 5.0, 0.0], [5.5, 6.0, 10.0], [0.0, 2.0, 1e-6], 1e6)
    got = catenary.solve_forces(*args)
    ref = catenary.solve_forces(*args, compiled=False)
    agree(got, ref, np.hypot(ref.H, ref.V_B), 1e-12, ("H", "V_A", "V_B"))
    assert got.status.tolist() == ["slack", "converged", "converged"]
    # Horizontal cable, length equal to the chord, EA = 1e6 N, w = 1e-6 N/m: the sag is
    # negligible and H balances the weight's parabola, H ~ (w^2 x^3 EA / 24 L0)^(1/3).
    assert abs(got.H[2] - (1e-12 * 1e3 * 1e6 / 24 / 10.0) ** (1 / 3)) <= 1e-3 * got.H[2]


def test_compiled_calls_keep_shapes_and_types():
    """Scalars give 0-d arrays, 2-D and broadcast arguments keep their shape, strided
    and read-only arrays are read correctly, empty batches stay empty; end "H" runs the
    numpy path."""
    x = np.array([[10.0, 20.0], [5.0, 0.0]])
    for args in ((x, 3.0, 500.0, 1.0, 1e7), (x, [3.0, -2.0], 500.0, 1.0, [[1e7], [1e6]]),
                 (x[:, ::-1], 3.0, np.full((1, 2), 500.0), 1.0, 1e7)):
        got, ref = catenary.solve_length(*args), catenary.solve_length(*args, compiled=False)
        assert got.L0.shape == (2, 2)
        agree(got, ref, np.abs(ref.L0), 1e-12, ("L0", "H", "V_A", "V_B"))
    one = catenary.solve_length(10.0, 3.0, 500.0, 1.0, 1e7)
    assert one.L0.shape == () and isinstance(one.L0, np.ndarray) and one.status == "converged"
    frozen = np.array([10.0, 20.0])
    frozen.setflags(write=False)
    np.testing.assert_array_equal(catenary.solve_forces(frozen, 1.0, 25.0, 1.0).H,
                                  catenary.solve_forces([10.0, 20.0], 1.0, 25.0, 1.0).H)
    assert catenary.solve_length(np.zeros(0), 1.0, 10.0, 1.0).L0.shape == (0,)
    h = catenary.solve_length(x, 3.0, 500.0, 1.0, 1e7, end="H")
    np.testing.assert_array_equal(
        h.L0, catenary.solve_length(x, 3.0, 500.0, 1.0, 1e7, end="H", compiled=False).L0)


BAD_LENGTH = [(-1.0, 0.0, 10.0, 1.0, 1e6), (1.0, np.inf, 10.0, 1.0, 1e6),
              ([1.0, np.nan], 0.0, 10.0, 1.0, 1e6), (1.0, 0.0, -10.0, 1.0, 1e6),
              (1.0, 0.0, [10.0, np.inf], 1.0, 1e6), (1.0, 0.0, 10.0, -1.0, 1e6),
              ([1.0, 2.0], 0.0, 10.0, [1.0, -2.0], 1e6), (1.0, 0.0, 10.0, 1.0, 0.0),
              (1.0, 0.0, 10.0, 1.0, -np.inf), (1.0, 0.0, 10.0, 1.0, np.nan),
              ([1.0, 2.0, 3.0], [0.0, 1.0], 10.0, 1.0, 1e6),
              (np.zeros(0), 0.0, 10.0, -1.0, 1e6)]


@pytest.mark.parametrize("args", BAD_LENGTH)
def test_bad_input_raises_the_numpy_paths_error(args):
    """The plain calls raise exactly the numpy path's error (type and message)."""
    for solve in (catenary.solve_length, catenary.solve_forces):
        with pytest.raises(catenary.CatenaryError) as ref:
            solve(*args, compiled=False)
        with pytest.raises(type(ref.value)) as got:
            solve(*args)
        assert str(got.value) == str(ref.value)
    with pytest.raises(catenary.CatenaryError, match="end"):
        catenary.solve_length(1.0, 0.0, 10.0, 1.0, end="C")


IK_FIELDS = ("lengths", "straight_lengths", "tensions", "tensions_platform",
             "horizontal_tensions", "platform_forces", "equilibrium_residual")


def ik_agree(got, ref):
    """Same statuses and iterations; values within 1e-12 of the largest of their kind."""
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_array_equal(got.catenary_iterations, ref.catenary_iterations)
    np.testing.assert_array_equal(got.iterations, ref.iterations)
    for field in IK_FIELDS:
        a, b = getattr(got, field), getattr(ref, field)
        assert a.shape == b.shape, field
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        ok = np.isfinite(b)
        assert (np.abs(a - b)[ok] <= 1e-12 * np.abs(b[ok]).max(initial=1e-300)).all(), field


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["algae", "cogiro"]),
       st.sampled_from(["min_sum", "min_norm"]))
def test_compiled_thesis_ik_matches_inverse_kinematics(seed, name, objective):
    """One pose through the plain call (its cached compiled solver) and through
    ThesisIK, against the numpy reference: home, poses outside the workspace, a pose
    far above the drawing points (no tensions hold it), with and without a wrench."""
    from catenary.thesis_ik import ThesisIK
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
        ref = catenary.inverse_kinematics(robot, pose, "thesis", objective, wrench=w,
                                          compiled=False)
        ik_agree(catenary.inverse_kinematics(robot, pose, "thesis", objective, wrench=w), ref)
        ik_agree(ik(pose, w), ref)
        solved += bool(ref.status[0] == "converged")
    assert ref.status[0] != "converged"  # the pose far above the robot
    assert solved >= 1


def test_compiled_thesis_ik_cache_and_the_cases_it_leaves():
    """The plain call reuses one compiled solver per robot and problem; smoothed
    objectives, other backends, batches and bad poses take the numpy path (same
    answers, same errors)."""
    from catenary import thesis_ik_kernels
    from tension_opt import presets

    robot = presets.algae_harvester()
    pose = robot.default_home()
    first = thesis_ik_kernels.thesis_solver(robot, "min_sum", "auto", {})
    assert first is not None and thesis_ik_kernels.thesis_solver(robot, "min_sum", "auto",
                                                               {}) is first
    # The closed form and the catenaries answer in one compiled call.
    assert first._fused is not None and first.solve(pose, None) is not None
    assert thesis_ik_kernels.thesis_solver(robot, "min_norm", "auto", {}) is not first
    assert thesis_ik_kernels.thesis_solver(robot, "min_sum", "scipy:highs", {}) is None
    smooth = to.TensionProblem("min_norm", smoothing=1.0)
    assert thesis_ik_kernels.thesis_solver(robot, smooth, "auto", {}) is None
    for args in ((pose, "thesis", smooth), (np.stack([pose, pose + 0.5]), "thesis"),
                 (pose, "thesis", "min_sum", "scipy:highs")):
        ik_agree(catenary.inverse_kinematics(robot, *args),
                 catenary.inverse_kinematics(robot, *args, compiled=False))
    for bad in (np.full(3, np.nan), np.zeros(2)):
        with pytest.raises(to.TensionOptError) as ref:
            catenary.inverse_kinematics(robot, bad, compiled=False)
        with pytest.raises(type(ref.value), match=str(ref.value)[:20]):
            catenary.inverse_kinematics(robot, bad)
    for _ in range(thesis_ik_kernels.CACHE_SIZE + 2):  # the cache stays bounded
        thesis_ik_kernels.thesis_solver(presets.algae_harvester(), "min_sum", "auto", {})
    assert len(thesis_ik_kernels._CACHE) <= thesis_ik_kernels.CACHE_SIZE


def test_argument_types_reach_the_kernels_as_contiguous_float64():
    """The serial kernels are called without numba's type checks: strided, read-only,
    integer, list and scalar arguments must answer as contiguous float64 ones."""
    x = np.array([40.0, 35.0, 30.0, 45.0, 12.0])
    z = np.array([7.0, -7.5, 6.0, 8.0, 0.0])
    T = np.array([3000.0, 2500.0, 4000.0, 3500.0, 800.0])
    w, EA = 24.0, 2.0e6
    ref = catenary.solve_length(x, z, T, w, EA)
    assert ref.converged.all()
    # Strided columns whose neighbours are valid data too: read as contiguous, they
    # would be other cables, not rejected ones.
    wide = np.column_stack([x, x + 1.0, z, z + 1.0, T, T + 100.0])
    frozen = T.copy()
    frozen.flags.writeable = False
    for args in ((wide[:, 0], wide[:, 2], wide[:, 4], w, EA),  # strided columns
                 (x, z, frozen, np.array(w), np.array([EA])),
                 (list(x), z.tolist(), T, int(w), EA),
                 (x[::-1][::-1], z, T, np.float64(w), EA)):
        got = catenary.solve_length(*args)
        for name in ("L0", "H", "V_A", "V_B", "iterations"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name))
        back = catenary.solve_forces(args[0], args[1], got.L0, args[3], args[4])
        np.testing.assert_allclose(back.H, ref.H, rtol=1e-9)


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_length_solve_spans_match_evaluate(seed):
    """The spans of the length solve (one asinh for a low point between the ends, the
    fast asinh) agree with the numpy reference as closely as the plain ones; the
    flexibility too but where it is a small difference of large terms (a long cable
    without a low point: ``qm1 + ...`` near 0), which amplifies the last bit by which
    the two asinh may differ (up to 4.5e-11 seen over 150,000 cables; only Newton's
    convergence rate depends on it)."""
    rng = np.random.default_rng(seed)
    H = 10.0 ** rng.uniform(-3, 5, 50)
    V_B = rng.uniform(-2, 2, 50) * H * 10.0 ** rng.uniform(-4, 1, 50)
    L0 = rng.uniform(0.1, 100, 50)
    w = rng.choice([0.1, 10.0], 50)
    inv_EA = axial_compliance(rng.choice([np.inf, 1e6], 50))
    ref = evaluate(H, V_B, L0, w, inv_EA)
    span = np.abs(ref[0]) + np.abs(ref[1])
    flex = np.abs(ref[2]) + np.abs(ref[3]) + np.abs(ref[4])
    for k in range(50):
        x, z, fxx, fxz, fzz, _, _, regular = spans_flex(H[k], V_B[k], L0[k], w[k],
                                                         inv_EA[k], True)
        assert regular
        assert abs(x - ref[0][k]) <= 1e-13 * span[k] and abs(z - ref[1][k]) <= 1e-13 * span[k]
        for got, want in ((fxx, ref[2][k]), (fxz, ref[3][k]), (fzz, ref[4][k])):
            assert abs(got - want) <= 1e-9 * flex[k]


def test_fast_asinh_is_within_two_ulps_of_libm():
    rng = np.random.default_rng(7)
    a = np.concatenate([rng.uniform(0.0, 1.0, 20000), 10.0 ** rng.uniform(-300, 300, 20000),
                        [0.0, 0.1, np.nextafter(0.1, 0), 1e100, np.nextafter(1e100, 0),
                         1e300, 5e-324]])
    a = np.concatenate([a, -a])
    got = np.array([asinh_fast(v) for v in a])
    want = np.arcsinh(a)
    assert (np.abs(got - want) <= 2.0 * np.spacing(np.abs(want))).all()
    assert np.copysign(1.0, asinh_fast(-0.0)) == -1.0
    assert asinh_fast(np.inf) == np.inf and asinh_fast(-np.inf) == -np.inf
    assert np.isnan(asinh_fast(np.nan))
