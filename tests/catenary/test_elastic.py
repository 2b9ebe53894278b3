"""Span equations, Jacobian, stiffness and limits of the elastic catenary."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

import catenary as cat
from catenary import elastic

finite = {"allow_nan": False, "allow_infinity": False}


@st.composite
def cables(draw: st.DrawFn) -> tuple[float, float, float, float, float]:
    """Random end forces and cable data (H, V_B, L0, w, EA), all SI."""
    L0 = draw(st.floats(0.1, 1000.0, **finite))
    w = draw(st.floats(1e-3, 1e3, **finite))
    H = draw(st.floats(1e-2, 1e3, **finite)) * w * L0
    V_B = draw(st.floats(-1.0, 3.0, **finite)) * w * L0 + draw(st.floats(-1, 1, **finite)) * H
    EA = draw(st.sampled_from([1e3, 1e6, 1e9, np.inf])) * max(1.0, H / 1e3)
    return H, V_B, L0, w, EA


@settings(max_examples=200, deadline=None)
@given(cables())
def test_jacobian_matches_central_differences(c: tuple[float, ...]) -> None:
    H, V, L0, w, EA = c
    F = cat.flexibility(H, V, L0, w, EA)
    hH, hV = 1e-6 * H, 1e-6 * (abs(V) + H + w * L0)
    dH = (np.array(cat.spans(H + hH, V, L0, w, EA)) - cat.spans(H - hH, V, L0, w, EA)) / (2 * hH)
    dV = (np.array(cat.spans(H, V + hV, L0, w, EA)) - cat.spans(H, V - hV, L0, w, EA)) / (2 * hV)
    fd = np.column_stack([dH, dV])
    scale = np.abs(F).max()
    np.testing.assert_allclose(F, fd, rtol=0, atol=1e-6 * scale)


@settings(max_examples=200, deadline=None)
@given(cables())
def test_flexibility_symmetric_positive_and_stiffness_is_inverse(c: tuple[float, ...]) -> None:
    F = cat.flexibility(*c)
    K = cat.stiffness(*c)
    assert F[0, 1] == F[1, 0]
    assert F[0, 0] > 0 and F[1, 1] > 0
    assert np.linalg.det(F) > 0
    np.testing.assert_allclose(K @ F, np.eye(2), atol=1e-8)


@settings(max_examples=100, deadline=None)
@given(cables())
def test_length_derivative_matches_finite_difference(c: tuple[float, ...]) -> None:
    H, V, L0, w, EA = c
    h = 1e-6 * L0
    fd = (np.array(cat.spans(H, V, L0 + h, w, EA)) - cat.spans(H, V, L0 - h, w, EA)) / (2 * h)
    np.testing.assert_allclose(cat.length_derivative(H, V, L0, w, EA), fd, atol=1e-6)


@settings(max_examples=50, deadline=None)
@given(cables())
def test_stretched_length_matches_quadrature(c: tuple[float, ...]) -> None:
    H, V, L0, w, EA = c
    if np.isinf(EA):
        assert cat.stretched_length(H, V, L0, w, EA) == L0
        return
    integral = quad(lambda s: float(cat.tension(H, V, L0, w, s)), 0.0, L0, epsrel=1e-12)[0]
    assert cat.stretched_length(H, V, L0, w, EA) == pytest.approx(L0 + integral / EA, rel=1e-11)


def test_weightless_limit_is_straight_elastic_bar() -> None:
    # Tension 500 N along a chord (3, 4) of a bar with L0 = 5 m, EA = 1e5 N.
    T, L0, EA = 500.0, 5.0, 1e5
    H, V = T * 3 / 5, T * 4 / 5
    chord = L0 * (1 + T / EA)
    x0, z0 = cat.spans(H, V, L0, 0.0, EA)
    np.testing.assert_allclose([x0, z0], [0.6 * chord, 0.8 * chord], rtol=1e-15)
    # w -> 0 is continuous (no cancellation blow-up) down to 1e-300.
    for w in (1e-3, 1e-8, 1e-12, 1e-300):
        x, z = cat.spans(H, V + 0.5 * w * L0, L0, w, EA)
        np.testing.assert_allclose([x, z], [x0, z0], rtol=max(w, 1e-15) * 10)
    # And the forward solver recovers T = EA (chord - L0) / L0 along the chord.
    r = cat.solve_forces(0.6 * chord, 0.8 * chord, L0, 0.0, EA)
    np.testing.assert_allclose([r.H, r.V_B, r.V_A], [H, V, V], rtol=1e-12)


def test_inextensible_limit() -> None:
    H, V, L0, w = 40.0, 30.0, 10.0, 0.5
    xi, zi = cat.spans(H, V, L0, w)
    for EA in (1e12, 1e15):
        x, z = cat.spans(H, V, L0, w, EA)
        # The elastic correction is O(T L0 / EA).
        assert abs(x - xi) == pytest.approx(H * L0 / EA, rel=1e-3)
        assert abs(z - zi) < 100 * L0 / EA * 50
    assert cat.stretched_length(H, V, L0, w) == L0


def test_vertical_cable_h_zero() -> None:
    # Hanging vertically with both ends pulling up: taut straight cable.
    x, z = cat.spans(0.0, 30.0, 10.0, 1.0, 1e4)
    assert x == 0.0
    # z = L0 + L0 * mean(V) / EA with mean V = 25 N.
    assert z == pytest.approx(10.0 + 10.0 * 25.0 / 1e4, rel=1e-15)
    # Folded cable (V_A < 0): z = (T_B - T_A) / w + stretch.
    x, z = cat.spans(0.0, 6.0, 10.0, 1.0)
    assert (x, z) == (0.0, pytest.approx((6.0 - 4.0) / 1.0, rel=1e-15))
    F = cat.flexibility(0.0, 30.0, 10.0, 1.0, 1e4)
    assert F[0, 1] == 0.0
    # dx/dH of a vertical cable = integral ds / T = ln(V_B / V_A) / w.
    assert F[0, 0] == pytest.approx(10.0 / 1e4 + np.log(30.0 / 20.0), rel=1e-14)


def test_light_taut_cable_keeps_full_precision() -> None:
    # w L0 / T = 1e-11: the naive asinh/sqrt differences cancel to ~5 digits,
    # while the true spans differ from the weightless bar by only ~1e-11.
    H, V, L0, EA = 16016.0, 12012.0, 9.99, 2e7
    w = 1e-8
    x0, z0 = cat.spans(H, V, L0, 0.0, EA)
    x, z = cat.spans(H, V + 0.5 * w * L0, L0, w, EA)
    np.testing.assert_allclose([x, z], [x0, z0], rtol=1e-10)
    Vb = V + 0.5 * w * L0
    a, b = Vb / H, (Vb - w * L0) / H
    x_naive = H * L0 / EA + H / w * (np.arcsinh(a) - np.arcsinh(b))
    z_naive = (Vb * L0 - w * L0**2 / 2) / EA + H / w * (np.sqrt(1 + a * a) - np.sqrt(1 + b * b))
    assert max(abs(x_naive / x0 - 1), abs(z_naive / z0 - 1)) > 1e-7


def test_profile_ends_and_tension() -> None:
    H, V, L0, w, EA = 30.0, 20.0, 8.0, 3.0, 500.0
    s, x, z = cat.profile([H, H], V, L0, w, EA, n=11)
    assert s.shape == x.shape == z.shape == (2, 11)
    assert x[0, 0] == 0.0 and z[0, 0] == 0.0
    np.testing.assert_allclose([x[0, -1], z[0, -1]], cat.spans(H, V, L0, w, EA), rtol=1e-14)
    assert np.all(np.diff(x[0]) > 0)
    assert cat.tension(H, V, L0, w, 0.0) == pytest.approx(np.hypot(H, V - w * L0))
    assert cat.tension(H, V, L0, w, L0) == pytest.approx(np.hypot(H, V))


def test_broadcasting_shapes() -> None:
    H = np.linspace(10, 20, 3)[:, None]
    L0 = np.array([5.0, 6.0])
    x, z = cat.spans(H, 5.0, L0, 1.0, 1e4)
    assert x.shape == z.shape == (3, 2)
    assert cat.flexibility(H, 5.0, L0, 1.0).shape == (3, 2, 2, 2)
    assert cat.stiffness(H, 5.0, L0, 1.0).shape == (3, 2, 2, 2)


def test_series_helpers_match_direct_forms_away_from_zero() -> None:
    u = np.array([0.0999999, 0.1000001, -0.0999999])
    np.testing.assert_allclose(elastic._asinhc_m1(u), np.arcsinh(u) / u - 1, rtol=1e-9)
    np.testing.assert_allclose(elastic._g(u), np.arcsinh(u) - u / np.sqrt(1 + u * u), rtol=1e-8)
