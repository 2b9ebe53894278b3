"""The compiled distances between sagging cables (:mod:`catenary.interference_kernels`)
against their numpy reference (:func:`catenary.curve_distance` with ``compiled=False``):
random pairs of catenaries, the presets' cables, and pairs the kernel hands back."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary import CatenaryCurves, curve_distance, solve_forces
from catenary.interference_compiled import pack_curves, solve_pairs

#: Agreement of distances and lower bounds (m, relative to the cables' size): the same
#: steps, sums in another order.
ROUNDING = 1e-12


def random_curves(rng: np.random.Generator, S: int, EA: float) -> CatenaryCurves:
    """``S`` catenaries between random points a few metres apart, each with its own
    slack (solved for its end forces), anywhere in a 10 m box."""
    origin = rng.uniform(-5.0, 5.0, (S, 3))
    angle = rng.uniform(0.0, 2 * np.pi, S)
    e_h = np.stack([np.cos(angle), np.sin(angle), np.zeros(S)], axis=1)
    x = rng.uniform(0.5, 8.0, S)
    z = rng.uniform(-4.0, 4.0, S)
    L0 = np.hypot(x, z) * rng.uniform(1.0005, 1.2, S)
    w = 0.6
    sol = solve_forces(x, z, L0, w, EA=EA)
    return CatenaryCurves(origin, e_h, np.asarray(sol.H), np.asarray(sol.V_A), L0, w, EA,
                          np.zeros((S, 3)))


def assert_alike(got: catenary.CurveDistance, want: catenary.CurveDistance) -> None:
    np.testing.assert_allclose(got.distance, want.distance, rtol=0, atol=ROUNDING * 10)
    np.testing.assert_allclose(got.lower_bound, want.lower_bound, rtol=0,
                               atol=ROUNDING * 10)
    assert (got.lower_bound <= got.distance).all()
    # The closest points are actual points of the curves at the distance found.
    np.testing.assert_allclose(np.linalg.norm(got.point_a - got.point_b, axis=-1),
                               got.distance, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([np.inf, 2e5]), st.booleans())
def test_random_catenaries_give_the_numpy_distances(seed: int, EA: float,
                                                    trimmed: bool) -> None:
    rng = np.random.default_rng(seed)
    a, b = random_curves(rng, 20, EA), random_curves(rng, 20, EA)
    ra = rb = None
    if trimmed:  # compare only part of each cable, as for cables sharing an end
        ra = np.stack([0.1 * a.L0, 0.9 * a.L0], axis=-1)
        rb = np.stack([np.zeros(20), 0.7 * b.L0], axis=-1)
    want = curve_distance(a, b, ra, rb, compiled=False)
    got = curve_distance(a, b, ra, rb, compiled=True)
    assert_alike(got, want)


@pytest.mark.parametrize("model", ["thesis", "coupled"])
def test_the_presets_clearances_are_the_numpy_ones(model: str) -> None:
    robot = to.presets.cogiro()
    poses = np.array([[0.5, 0.3, 1.0, 0.05, 0.02, 0.1], [0.0, 0.0, 2.0, 0.0, 0.0, 0.0],
                      [-1.0, 0.5, 1.5, 0.0, 0.05, -0.1]])
    want = catenary.cable_clearance(robot, poses, model, compiled=False)
    got = catenary.cable_clearance(robot, poses, model, compiled=True)
    np.testing.assert_array_equal(got.pair, want.pair)
    np.testing.assert_allclose(got.distances, want.distances, rtol=0, atol=ROUNDING * 10)
    np.testing.assert_allclose(got.lower_bound, want.lower_bound, rtol=0,
                               atol=ROUNDING * 10)
    np.testing.assert_allclose(got.clearance, want.clearance, rtol=0, atol=ROUNDING * 10)


def test_a_vertical_cable_is_handed_to_the_numpy_path() -> None:
    """A cable hanging straight down (no horizontal tension), which the compiled spans
    leave, among 20 ordinary pairs: every pair gets the numpy answer."""
    rng = np.random.default_rng(3)
    a, b = random_curves(rng, 20, np.inf), random_curves(rng, 20, np.inf)
    H = np.array(a.H)
    H[4] = 0.0
    V_A = np.array(a.V_A)
    V_A[4] = -a.w * float(a.L0[4])  # hangs from its top, straight down
    a = CatenaryCurves(a.origin, a.e_h, H, V_A, a.L0, a.w, a.EA, a.closure)
    packed = np.concatenate([pack_curves(a), pack_curves(b)])
    pairs = np.stack([np.arange(20), 20 + np.arange(20)], axis=1)
    ranges = np.stack([np.zeros(20), a.L0, np.zeros(20), b.L0], axis=1)
    _, left = solve_pairs(packed, pairs, ranges, 33)
    assert left.tolist() == [k == 4 for k in range(20)]
    want = curve_distance(a, b, compiled=False)
    got = curve_distance(a, b, compiled=True)
    assert np.isfinite(want.distance[4])
    assert_alike(got, want)
