"""The tie-break of non-unique LP optima on hand-made problems with known answers."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.backends.tiebreak import (
    _cone_has_ray,
    _cone_has_ray_lp,
    held_bounds,
    low_dim_face_solve,
    lp_optimum_is_unique,
    optimal_face,
)
from tension_opt.certify.certificate import certify_form
from tension_opt.problem.form import StandardForm


def _form(c: list[float], minmax: bool = False) -> StandardForm:
    """Three cables, one equation ``T1 + T2 + T3 = 6`` with ``T >= 0``: a 2-D null space."""
    A = np.ones((1, 1, 3))
    b = np.array([[6.0]])
    lb, ub = np.zeros((1, 3)), np.full((1, 3), np.inf)
    if minmax:
        return StandardForm(A, b, lb, ub, np.zeros((1, 3)), np.zeros((1, 3)),
                            minmax=np.ones(3))
    return StandardForm(A, b, lb, ub, np.zeros((1, 3)), np.array([c]))


def test_a_vertex_of_a_strict_cost_is_unique() -> None:
    # min T1 + 2 T2 + 3 T3: the only optimum is (6, 0, 0).
    form = _form([1.0, 2.0, 3.0])
    assert lp_optimum_is_unique(form, np.array([[6.0, 0.0, 0.0]])).tolist() == [True]


def test_a_flat_cost_has_a_whole_face_of_optima_broken_to_its_minimum_norm() -> None:
    # min T1 + T2 + T3 on the simplex: every point is optimal; min norm is (2, 2, 2).
    form = _form([1.0, 1.0, 1.0])
    vertex = np.array([[6.0, 0.0, 0.0]])
    assert lp_optimum_is_unique(form, vertex).tolist() == [False]
    np.testing.assert_allclose(low_dim_face_solve(form, vertex), [[2.0, 2.0, 2.0]],
                               atol=1e-9)
    face = optimal_face(form, vertex)
    assert face.G is not None and face.G.shape == (1, 1, 3)  # c.T <= c.T* (+ slack)
    assert (face.q == 1.0).all() and (face.c == 0.0).all()


def test_an_edge_of_optima_is_broken_on_that_edge() -> None:
    # min T1 + T2 + 2 T3: optima are the edge T1 + T2 = 6, T3 = 0; min norm (3, 3, 0).
    form = _form([1.0, 1.0, 2.0])
    vertex = np.array([[0.0, 6.0, 0.0]])
    assert lp_optimum_is_unique(form, vertex).tolist() == [False]
    np.testing.assert_allclose(low_dim_face_solve(form, vertex), [[3.0, 3.0, 0.0]],
                               atol=1e-9)


def test_min_max_ties_are_detected() -> None:
    # min max T_i on the simplex: the unique optimum is the centre (2, 2, 2).
    form = _form([0.0, 0.0, 0.0], minmax=True)
    assert lp_optimum_is_unique(form, np.array([[2.0, 2.0, 2.0]])).tolist() == [True]


def test_every_backend_breaks_the_study_robots_tie_the_same_way() -> None:
    # At the pond centre the min-sum LP has a segment of optima; the published
    # tensions (4714.6 N each) are its minimum-norm point.
    robot = to.presets.algae_harvester()
    for backend in ("closed_form", "scipy:highs", "qpsolvers:daqp", "cvxpy:CLARABEL"):
        sol = to.distribute(robot, [[0.0, 0.0, 0.0]], "min_sum", backend=backend)
        assert sol.unique.tolist() == [False], backend
        np.testing.assert_allclose(sol.tensions[0], 4714.6, atol=0.15)


def test_the_certificates_multipliers_hold_bounds_on_the_face() -> None:
    # min T1 + T2 + 2 T3: T3's bound multiplier is -1/2 (scaled), T1's and T2's zero, so
    # T3 stays at 0 on the whole optimal face; the face and the test see the same thing.
    form = _form([1.0, 1.0, 2.0])
    vertex = np.array([[0.0, 6.0, 0.0]])
    z = certify_form(form, vertex).multipliers.bound_multipliers(3)
    np.testing.assert_allclose(z, [[0.0, 0.0, -0.5]], atol=1e-12)
    lower, upper = held_bounds(form, vertex, z)
    assert lower.tolist() == [[False, False, True]] and not upper.any()
    face = optimal_face(form, vertex, z)
    assert face.ub[0, 2] <= 1e-9  # T3 kept at its bound (within the face's slack)
    assert lp_optimum_is_unique(form, vertex, z).tolist() == [False]
    np.testing.assert_allclose(low_dim_face_solve(form, vertex, z), [[3.0, 3.0, 0.0]],
                               atol=1e-9)
    # A strict cost: the vertex's multipliers hold both other bounds, a single optimum.
    strict = _form([1.0, 2.0, 3.0])
    point = np.array([[6.0, 0.0, 0.0]])
    z = certify_form(strict, point).multipliers.bound_multipliers(3)
    assert held_bounds(strict, point, z)[0].tolist() == [[False, True, True]]
    assert lp_optimum_is_unique(strict, point, z).tolist() == [True]


@st.composite
def _cones(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal basis (m, dim) of a random subspace and random active bounds; some
    bases repeat a column's direction in rows so that the cone is degenerate."""
    m = draw(st.integers(3, 9))
    dim = draw(st.integers(2, min(5, m - 1)))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    raw = rng.standard_normal((m, dim))
    if draw(st.booleans()):  # rows along few directions: rank-deficient row sets
        raw[: m // 2] = raw[0] * rng.standard_normal((m // 2, 1))
    basis = np.linalg.qr(raw)[0]
    lower = rng.random(m) < draw(st.floats(0.2, 0.9))
    upper = ~lower & (rng.random(m) < 0.5)
    return basis, lower, upper


@settings(deadline=None)
@given(_cones())
def test_the_positive_span_test_agrees_with_the_linear_programs(
        cone: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    basis, lower, upper = cone
    assert _cone_has_ray(basis, lower, upper) == _cone_has_ray_lp(basis, lower, upper)


def test_the_cone_test_on_cones_with_known_answers() -> None:
    # Rows +-e1, +-e2 span the plane positively: only z = 0.
    basis = np.eye(2)
    both = np.array([True, True])
    assert not _cone_has_ray(np.vstack([basis, basis]), np.r_[both, both * False],
                             np.r_[both * False, both])
    # A thin cone |z1| <= 1e-6 z2 still holds the ray z = (0, 1).
    thin = np.array([[1.0, -1e-6], [-1.0, -1e-6]])
    assert _cone_has_ray(thin, np.zeros(2, bool), np.ones(2, bool))
    # Three rows at 120 degrees span the plane positively, a fourth does not change that.
    angles = np.deg2rad([90.0, 210.0, 330.0, 10.0])
    rows = np.c_[np.cos(angles), np.sin(angles)]
    assert not _cone_has_ray(rows, np.zeros(4, bool), np.ones(4, bool))
    assert _cone_has_ray(rows[[0, 1]], np.zeros(2, bool), np.ones(2, bool))
