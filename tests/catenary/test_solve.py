"""Forward and inverse catenary solvers: reference vectors, sweeps, statuses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary as cat

DATA = Path(__file__).resolve().parents[1] / "data"

VECTORS = json.loads((DATA / "catenary_vectors.json").read_text())["cases"]


def _case_args(c: dict) -> tuple[float, float, float, float, float]:
    EA = np.inf if c["EA"] is None else c["EA"]
    return c["x"], c["z"], c["L0"], c["w"], EA


@pytest.mark.parametrize("case", VECTORS, ids=[c["name"] for c in VECTORS])
def test_forward_matches_reference_vectors(case: dict) -> None:
    r = cat.solve_forces(*_case_args(case))
    assert r.status == "converged"
    assert r.converged
    for key in ("H", "V_A", "V_B"):
        assert getattr(r, key) == pytest.approx(case[key], rel=1e-6), key


def test_forward_vectorised_over_reference_vectors() -> None:
    args = np.array([_case_args(c) for c in VECTORS]).T
    r = cat.solve_forces(*args)
    ref = np.array([[c["H"], c["V_A"], c["V_B"]] for c in VECTORS]).T
    np.testing.assert_allclose([r.H, r.V_A, r.V_B], ref, rtol=1e-6)
    # MoorPy's own expected value for this case (56804.6) is 2.7 % off.
    i = [c["name"] for c in VECTORS].index("near_taut_exact")
    assert abs(r.H[i] / 56804.6 - 1) > 0.02


@pytest.mark.parametrize("end", ["B", "A", "H"])
def test_inverse_recovers_reference_lengths(end: str) -> None:
    args = np.array([_case_args(c) for c in VECTORS]).T
    x, z, L0, w, EA = args
    H = np.array([c["H"] for c in VECTORS])
    VB = np.array([c["V_B"] for c in VECTORS])
    VA = np.array([c["V_A"] for c in VECTORS])
    T = {"B": np.hypot(H, VB), "A": np.hypot(H, VA), "H": H}[end]
    r = cat.solve_length(x, z, T, w, EA, end=end)
    assert np.all(r.converged)
    # The reference forces carry ~10 digits; L0 follows within 1e-6.
    np.testing.assert_allclose(r.L0, L0, rtol=1e-6)


# ----------------------------------------------------------------------------
# the sweep


def test_sweep_covers_requested_ranges(swept) -> None:
    s, r = swept
    ratio = s["L0"] / np.hypot(s["x"], s["z"])
    assert ratio.min() == pytest.approx(1 - 1e-3) and ratio.max() == pytest.approx(3)
    assert np.any(np.abs(ratio - (1 + 1e-9)) < 1e-12)
    Hw = (r.H / s["w"])[s["x"] > 0]
    assert Hw.min() < 1e-2 and Hw.max() > 1e9
    assert np.any(s["x"] == 0) and np.any(s["z"] == 0)
    assert np.any(s["z"] > 0) and np.any(s["z"] < 0)
    assert s["w"].min() == 1e-6 and s["w"].max() == 1e3
    assert s["EA"].min() == 1e3 and np.any(np.isinf(s["EA"]))


def test_forward_converges_on_whole_sweep_with_tiny_residual(swept) -> None:
    s, r = swept
    assert np.all(r.converged), np.unique(r.status, return_counts=True)
    assert np.all(r.status == "converged")
    x, z = cat.spans(r.H, r.V_B, s["L0"], s["w"], s["EA"])
    scale = s["L0"] + np.hypot(s["x"], s["z"])
    assert np.max(np.abs(x - s["x"]) / scale) < 1e-12
    assert np.max(np.abs(z - s["z"]) / scale) < 1e-12
    assert np.all(r.H >= 0)
    np.testing.assert_array_equal(r.V_A, r.V_B - s["w"] * s["L0"])


def _taut_branch(s: dict, r: cat.ForcesResult, end: str) -> np.ndarray:
    """True where dT_end/dL0 < 0 at fixed geometry (the taut branch)."""
    return _dT_dL0(s, r, end) < 0


def _dT_dL0(s: dict, r: cat.ForcesResult, end: str) -> np.ndarray:
    """Derivative of the end tension with respect to L0 at fixed geometry."""
    with np.errstate(all="ignore"):
        F = cat.flexibility(r.H, r.V_B, s["L0"], s["w"], s["EA"])
        xl, zl = cat.length_derivative(r.H, r.V_B, s["L0"], s["w"], s["EA"])
        q = np.linalg.solve(F, np.stack([xl, zl], -1)[..., None])[..., 0]
        if end == "B":
            c = (r.H / r.T_B, r.V_B / r.T_B, 0.0)
        elif end == "A":
            c = (r.H / r.T_A, r.V_A / r.T_A, -s["w"] * r.V_A / r.T_A)
        else:
            c = (1.0, 0.0, 0.0)
        return c[2] - c[0] * q[:, 0] - c[1] * q[:, 1]


@pytest.mark.parametrize("end", ["B", "A", "H"])
def test_round_trip_over_sweep(swept, end: str) -> None:
    s, r = swept
    T = {"B": r.T_B, "A": r.T_A, "H": r.H}[end]
    inv = cat.solve_length(s["x"], s["z"], T, s["w"], s["EA"], end=end)
    vertical = s["x"] == 0
    if end == "H":
        # H = 0 does not determine the length of a vertical cable.
        assert np.all(inv.status[vertical] == "indeterminate")
        assert np.all(inv.converged[~vertical])
    else:
        assert np.all(inv.converged), np.unique(inv.status, return_counts=True)
    taut = _taut_branch(s, r, end) & ~vertical
    assert taut.sum() > 1000
    # Taut-branch cables: the inverse returns the same cable (1e-10 on L0).
    err = np.abs(inv.L0 / s["L0"] - 1)
    assert np.max(err[taut]) < 1e-10
    # Others (deep sag or folded vertical): the taut root is the shorter one,
    # and it carries the prescribed tension.
    other = inv.converged & ~taut
    assert np.all(inv.L0[other] <= s["L0"][other] * (1 + 1e-10))
    T_back = {"B": inv.T_B, "A": inv.T_A, "H": inv.H}[end]
    ok = inv.converged
    # Where the tension hardly depends on the length (near-vertical cables
    # given H), T is only as accurate as L0 allows: kappa = |dlnT/dlnL0|.
    with np.errstate(invalid="ignore"):  # H = 0 on vertical cables: 0/0, no bound needed
        kappa = np.abs(_dT_dL0(s, r, end) * s["L0"] / T)
    tol = 1e-9 + 1e-14 * np.nan_to_num(kappa, nan=0.0)
    assert np.all(np.abs(T_back[ok] - T[ok]) <= tol[ok] * T[ok])
    # ... and back: forward from the returned length gives the same forces.
    fine = ok & ~vertical
    fwd = cat.solve_forces(s["x"][fine], s["z"][fine], inv.L0[fine], s["w"][fine], s["EA"][fine])
    assert np.all(fwd.converged)
    # (kappa of T_B can exceed that of the prescribed tension: 10x margin)
    assert np.all(np.abs(fwd.T_B - inv.T_B[fine]) <= 10 * tol[fine] * inv.T_B[fine])


@pytest.mark.parametrize("end", ["B", "A", "H"])
def test_inverse_round_trip_well_conditioned_cables_1e10(end: str) -> None:
    # Elastic, moderately taut cables: tension -> length -> tension within 1e-10.
    rng = np.random.default_rng(1)
    n = 2000
    x = rng.uniform(0, 80, n)
    z = rng.uniform(-10, 10, n)
    w = rng.uniform(1, 50, n)
    EA = rng.uniform(1e6, 1e8, n)
    # Tension well above the minimum that can hold the cable up.
    T = rng.uniform(2e3, 2e4, n) + w * (np.abs(z) + 2 * np.hypot(x, z))
    inv = cat.solve_length(x, z, T, w, EA, end=end)
    assert np.all(inv.converged)
    fwd = cat.solve_forces(x, z, inv.L0, w, EA)
    T_back = {"B": fwd.T_B, "A": fwd.T_A, "H": fwd.H}[end]
    np.testing.assert_allclose(T_back, T, rtol=1e-10)


def test_inverse_iterations_on_thesis_workspace() -> None:
    rng = np.random.default_rng(2)
    n = 20000
    pose = np.column_stack(
        [rng.uniform(-40.45, 40.45, n), rng.uniform(-25, 25, n), rng.uniform(0, 5, n)]
    )
    tower = np.array([46.55, 31.1])
    x = np.hypot(tower[0] - np.abs(pose[:, 0]), tower[1] - np.abs(pose[:, 1]))
    z = 7.6 - pose[:, 2]
    w = 7860 * np.pi / 4 * 0.02**2 * 9.81
    T = rng.uniform(2537, 15000, n)
    r = cat.solve_length(x, z, T, w, end="B")
    assert np.all(r.converged)
    assert np.percentile(r.iterations, 99) <= 6
    # Thesis snapshot 1 (pose at the centre, T = 4714.6 N): sag adds 207.4 mm.
    c = np.hypot(46.55, 31.1)
    one = cat.solve_length(c, 7.6, 4714.6, w, end="B")
    assert (one.L0 - np.hypot(c, 7.6)) * 1e3 == pytest.approx(207.4, abs=0.2)


# ----------------------------------------------------------------------------
# statuses and argument errors


def test_infeasible_and_degenerate_cases_reported_per_cable() -> None:
    r = cat.solve_forces([10.0, 10.0, 10.0, 10.0], 0.0, [9.0, 12.0, 9.0, 12.0], [1.0, 1, 0, 0])
    assert r.status.tolist() == ["infeasible", "converged", "infeasible", "slack"]
    assert r.converged.tolist() == [False, True, False, True]
    assert np.isnan(r.H[0]) and r.H[3] == 0.0
    # Elastic cables may be shorter than the chord (stretched).
    e = cat.solve_forces(10.0, 0.0, 9.0, 1.0, 1e4)
    assert e.converged and e.H == pytest.approx(1e4 * (10 / 9 - 1), rel=1e-3)
    # Tension too small to hold the cable up: infeasible, not an exception.
    q = cat.solve_length([50.0, 50.0], [5.0, 5.0], [1.0, 5000.0], 24.2)
    assert q.status.tolist() == ["infeasible", "converged"]
    assert np.isnan(q.L0[0]) and q.L0[1] > 50.0


def test_infeasible_threshold_matches_minimum_tension() -> None:
    # Inextensible: the end-B tension over L0 has a minimum T*; just above it
    # the inverse converges, just below it is infeasible.
    x, z, w = 30.0, 10.0, 2.0
    L = np.linspace(np.hypot(x, z) * 1.001, 3 * np.hypot(x, z), 20001)
    Tb = cat.solve_forces(x, z, L, w).T_B
    t_star = Tb.min()
    r = cat.solve_length(x, z, [t_star * 1.001, t_star * 0.999], w)
    assert r.status.tolist() == ["converged", "infeasible"]
    assert r.L0[0] < L[np.argmin(Tb)]


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("EA", [np.inf, 1e4])
@pytest.mark.parametrize("end", ["B", "A"])
def test_nearly_level_cables_are_decided_as_level_ones(end: str, EA: float,
                                                       compiled: bool) -> None:
    """A chord a hair off level (|z| from 1e-14 to 1e-5 of x) gets the level cable's
    answer: infeasible below the least tension that holds it (where the search once
    lost the mean end angle among subnormal numbers and said "not_converged"), and
    above it a length continuous in z."""
    z = np.array([0.0, 1e-14, 1e-12, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5]) * 10.0
    low = cat.solve_length(10.0, z, 5.0, 1.0, EA, end=end, compiled=compiled)
    assert (low.status == "infeasible").all(), low.status
    held = cat.solve_length(10.0, z, 8.0, 1.0, EA, end=end, compiled=compiled)
    assert (held.status == "converged").all(), held.status
    np.testing.assert_allclose(held.L0, held.L0[0], rtol=1e-5)


def test_vertical_cables() -> None:
    # Hanging straight: V_B = w L0 + V_A; folded: V_A < 0.
    r = cat.solve_forces(0.0, [5.0, 5.0], [5.0 - 1e-3, 8.0], 2.0, [1e6, np.inf])
    assert r.H.tolist() == [0.0, 0.0]
    assert r.V_A[1] == pytest.approx(2.0 * (5 - 8) / 2) and r.V_B[1] == pytest.approx(13.0)
    assert r.V_A[0] > 0
    q = cat.solve_length(0.0, 5.0, 100.0, 2.0, end="B")
    assert q.L0 == 5.0 and q.V_B == 100.0 and q.V_A == pytest.approx(90.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"x": -1.0}, "x"),
        ({"x": np.nan}, "x"),
        ({"w": -0.1}, "w"),
        ({"L0": 0.0}, "L0"),
        ({"EA": 0.0}, "EA"),
        ({"z": np.inf}, "z"),
    ],
)
def test_bad_arguments_raise_named_errors(kwargs: dict, match: str) -> None:
    args = {"x": 3.0, "z": 4.0, "L0": 6.0, "w": 1.0, "EA": 1e5} | kwargs
    with pytest.raises(cat.InvalidCableError, match=match):
        cat.solve_forces(**args)
    with pytest.raises(ValueError):
        cat.solve_forces(**args)


def test_bad_end_and_tension_raise() -> None:
    with pytest.raises(cat.CatenaryError, match="end"):
        cat.solve_length(3.0, 4.0, 10.0, 1.0, end="C")  # type: ignore[arg-type]
    with pytest.raises(cat.InvalidCableError, match="tension"):
        cat.solve_length(3.0, 4.0, -10.0, 1.0)


finite = {"allow_nan": False, "allow_infinity": False}


@settings(max_examples=150, deadline=None)
@given(
    x=st.floats(0.0, 500.0, **finite),
    z=st.floats(-500.0, 500.0, **finite),
    slack=st.floats(1e-6, 2.0, **finite),
    w=st.floats(1e-4, 1e3, **finite),
    EA=st.sampled_from([1e4, 1e7, 1e10, np.inf]),
)
def test_random_forward_problems_solve_to_tiny_residual(x, z, slack, w, EA) -> None:
    c = np.hypot(x, z)
    if c < 1e-3:
        return
    L0 = c * (1 + slack)
    r = cat.solve_forces(x, z, L0, w, EA)
    assert r.converged
    xs, zs = cat.spans(r.H, r.V_B, L0, w, EA)
    assert abs(xs - x) <= 1e-11 * (L0 + c)
    assert abs(zs - z) <= 1e-11 * (L0 + c)


# ----------------------------------------------------------------------------
# very light cables and the "converged means solved" contract

LIGHT_W = (0.0, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)


def _end_tension(r: cat.LengthResult, end: str) -> np.ndarray:
    return {"B": r.T_B, "A": r.T_A, "H": r.H}[end]


@pytest.mark.parametrize("end", ["B", "A", "H"])
@pytest.mark.parametrize("w", LIGHT_W)
def test_light_cable_keeps_tension_and_tends_to_straight_bar(end: str, w: float) -> None:
    # Cables whose sag is far below the rounding of their length: L0 carries
    # no information on the tension, which must still be met exactly.
    g = np.array(
        np.meshgrid(
            [50.0, 0.3, 1000.0],
            [5.0, -30.0, 0.0, 400.0],
            [5000.0, 1e5],
            [np.inf, 1e6, 1e9],
            indexing="ij",
        )
    ).reshape(4, -1)
    x, z, T, EA = g
    r = cat.solve_length(x, z, T, w, EA, end=end)
    assert np.all(r.converged), np.unique(r.status, return_counts=True)
    np.testing.assert_allclose(_end_tension(r, end), T, rtol=1e-9, atol=0)
    np.testing.assert_array_equal(r.V_A, r.V_B - w * r.L0)
    # Straight elastic bar: the tension at mid-length differs from the end
    # tension by half the weight component along the bar, w (L0/2) sin(theta).
    c = np.hypot(x, z)
    L_bar = c
    for _ in range(3):
        half = 0.5 * w * z * L_bar / c
        mid = {"B": T - half, "A": T + half, "H": T * c / x}[end]
        L_bar = c / (1.0 + mid / EA)
    np.testing.assert_allclose(r.L0, L_bar, rtol=1e-12, atol=0)
    # The cable leaves the chord by half its transverse weight over T:
    # w L0 cos(theta) / (2 T) (parabola).
    if end != "H":
        phi = np.arctan2(r.V_B if end == "B" else r.V_A, r.H)
        dev = (phi - np.arctan2(z, x)) * (1 if end == "B" else -1)
        np.testing.assert_allclose(dev, w * r.L0 * x / (2 * T * c), rtol=1e-3, atol=1e-13)


def test_light_cable_reported_case() -> None:
    # x = 50, z = 5, T = 5000, w = 1e-8 returned H = 7.6 as "converged".
    for end in ("A", "B"):
        r = cat.solve_length(50.0, 5.0, 5000.0, 1e-8, end=end)
        assert r.converged
        assert r.H == pytest.approx(5000 * 50 / np.hypot(50, 5), rel=1e-9)
        assert _end_tension(r, end) == pytest.approx(5000.0, rel=1e-12)
        assert r.L0 == pytest.approx(np.hypot(50, 5), rel=1e-15)


def test_weightless_inextensible_cable_is_the_chord() -> None:
    # w = 0, EA = inf: L0 is the chord and the tension acts along it.
    for end in ("B", "A", "H"):
        r = cat.solve_length(3.0, 4.0, 100.0, 0.0, end=end)
        assert r.converged and r.L0 == pytest.approx(5.0, rel=1e-15)
        T = 100.0 if end != "H" else 100.0 * 5 / 3
        assert r.H == pytest.approx(T * 0.6, rel=1e-14)
        assert r.V_B == pytest.approx(T * 0.8, rel=1e-14) and r.V_A == r.V_B


def test_steep_cables_given_horizontal_tension_converge_quickly() -> None:
    # Nearly vertical (89.9 deg) cables with prescribed H: Newton from the
    # catenary in end angles, no bracketing fallback.
    ang = np.radians(89.9)
    c = np.array([0.1, 10.0, 1000.0])[:, None, None]
    w = np.array([1e-6, 1e-3, 1.0, 1e3])[None, :, None]
    EA = np.array([1e3, 1e6, np.inf])[None, None, :]
    x, z = c * np.cos(ang), c * np.sin(ang)
    f = cat.solve_forces(x, z, 1.01 * c, w, EA)
    assert np.all(f.converged)
    r = cat.solve_length(x, z, f.H, w, EA, end="H")
    assert np.all(r.converged)
    assert r.iterations.max() <= 8
    np.testing.assert_allclose(r.L0, np.broadcast_to(1.01 * c, r.L0.shape), rtol=1e-10)


@settings(max_examples=300, deadline=None)
@given(
    x=st.floats(1e-3, 1000.0, **finite),
    z=st.floats(-1000.0, 1000.0, **finite),
    T=st.floats(-3.0, 7.0, **finite).map(lambda e: 10.0**e),
    w=st.one_of(st.just(0.0), st.floats(-14.0, 3.0, **finite).map(lambda e: 10.0**e)),
    EA=st.sampled_from([1e3, 1e6, 1e10, 1e20, np.inf]),
    end=st.sampled_from(["B", "A", "H"]),
)
def test_converged_inverse_solves_span_and_tension_equations(x, z, T, w, EA, end) -> None:
    # The contract: a converged flag implies the span equations AND the
    # tension condition hold; anything else is reported with NaN values.
    r = cat.solve_length(x, z, T, w, EA, end=end)
    if not r.converged:
        assert r.status in ("infeasible", "indeterminate", "not_converged")
        assert np.isnan(r.L0)
        return
    assert r.status == "converged" and r.L0 > 0 and r.H >= 0
    assert abs(_end_tension(r, end) - T) <= 1e-9 * T
    xs, zs = cat.spans(r.H, r.V_B, r.L0, w, EA)
    assert abs(xs - x) <= 1e-9 * (x + r.L0)
    assert abs(zs - z) <= 1e-9 * (abs(z) + r.L0)


# ----------------------------------------------------------------------------
# extreme but legal magnitudes: every answer certified, or honestly not one


@pytest.mark.parametrize("end", ["B", "A", "H"])
@pytest.mark.parametrize("T", [1e100, 1e200, 1e300])
def test_huge_tension_stretches_an_elastic_cable_into_a_straight_bar(end: str, T: float) -> None:
    # Once did not return (1e200) or took 1.3 s and 5383 iterations (1e100): the
    # weight (w c / T < 1e-98) is far below rounding, so this is the straight elastic
    # bar, L0 = c / (1 + T_bar / EA), with the tension along the chord.
    x, z, w, EA = 10.0, 2.0, 20.0, 1e6
    c = np.hypot(x, z)
    r = cat.solve_length(x, z, T, w, EA, end=end)
    assert r.status == "converged"
    T_bar = T * c / x if end == "H" else T
    assert r.L0 == pytest.approx(c / (1.0 + T_bar / EA), rel=1e-14)
    assert r.H == pytest.approx(T_bar * x / c, rel=1e-14)
    assert r.V_B == pytest.approx(T_bar * z / c, rel=1e-14)
    assert r.iterations <= 3


def test_a_cable_far_longer_than_its_chord() -> None:
    # L0 = 1e300 m on a 10 m chord reported converged with V = -inf. No double
    # answer exists: the spans' rounding, eps * L0, is 1e283 chords.
    x, z, w = 10.0, 2.0, 20.0
    r = cat.solve_forces(x, z, 1e300, w)
    assert r.status == "not_converged" and np.isnan(r.H) and np.isnan(r.V_A)
    # A million chords long is still within reach: the inextensible catenary of
    # sinh(lam)/lam = sqrt(L0^2 - z^2)/x, with H = w x / (2 lam).
    c = np.hypot(x, z)
    L0 = 1e6 * c
    r = cat.solve_forces(x, z, L0, w)
    assert r.status == "converged"
    lam = np.log(2.0 * np.sqrt(L0**2 - z**2) / x)
    for _ in range(50):
        lam = np.log(2.0 * lam * np.sqrt(L0**2 - z**2) / x)
    assert r.H == pytest.approx(w * x / (2.0 * lam), rel=1e-9)
    xs, zs = cat.spans(r.H, r.V_B, L0, w)
    assert abs(xs - x) <= 1e-9 * c and abs(zs - z) <= 1e-9 * c


def test_stretch_beyond_rounding_is_not_converged() -> None:
    # Once "converged" after 1181 iterations, 1.9e-5 m off a 10 m chord. A cable
    # whose own weight (3e10 N) stretches it 1e10-fold has the height z = -10 m as a
    # difference of terms of 1e11 m: no double V_B reproduces it to 1e-8 of the
    # chord. Shown on the vertical cable, in closed form
    # (V_B = z / (L0/EA + 2/w) + w L0 / 2), over a range of 200 doubles around it.
    z, L0, w, EA = -10.0, 30.0, 1e9, 1.0
    V = z / (L0 / EA + 2.0 / w) + 0.5 * w * L0
    candidates = V + np.arange(-100, 101) * np.spacing(V)
    _, zs = cat.spans(0.0, candidates, L0, w, EA)
    assert np.min(np.abs(zs - z)) > 1e-8 * abs(z)
    for x in (0.0, 1e-9):
        r = cat.solve_forces(x, z, L0, w, EA)
        assert r.status == "not_converged" and np.isnan(r.H)
    # Heavily stretched but within rounding: converged (once refused).
    r = cat.solve_forces(1e9, 2.0, 683404.4285009323, 1e9, 1e6)
    assert r.status == "converged"
    xs, zs = cat.spans(r.H, r.V_B, 683404.4285009323, 1e9, 1e6)
    assert abs(xs - 1e9) <= 1e-8 * 1e9 and abs(zs - 2.0) <= 1e-8 * 1e9


def test_small_end_a_tension_under_a_heavy_cable_is_met_exactly() -> None:
    # V_A was V_B - w L0 with V_B = 1e6 N: the end-A tension of 1e-6 N came out 3.6e-5
    # off. V_A is now kept as the solver found it, T sin(phi).
    r = cat.solve_length(1e-9, 1000.0, 1e-6, 1000.0, end="A")
    assert r.status == "converged"
    assert r.T_A == pytest.approx(1e-6, rel=1e-12)
    assert r.L0 == pytest.approx(1000.0, rel=1e-12)
    assert r.V_B == pytest.approx(1000.0 * r.L0 + r.V_A, rel=1e-15)


@pytest.mark.parametrize(
    ("x", "z", "T", "w", "EA"),
    [(1000.0, -10.0, 1e-6, 1e9, 1000.0), (1.0, 1000.0, 1.0, 1e9, 1000.0)],
)
def test_infeasible_tension_reported_without_a_long_search(x, z, T, w, EA) -> None:
    # These took 24 s, or did not return within 2 s. The end-A tension of every
    # catenary through the two points (forward solves over 1e-6 to 1e6 chords of
    # length) exceeds the prescribed one more than ten-thousandfold.
    r = cat.solve_length(x, z, T, w, EA, end="A")
    assert r.status == "infeasible" and np.isnan(r.L0)
    assert r.iterations == 0  # decided without a search to count (Newton steps only)
    L = np.geomspace(1e-6, 1e6, 2001) * np.hypot(x, z)
    f = cat.solve_forces(x, z, L, w, EA)
    assert f.converged.sum() > 100
    assert np.min(f.T_A[f.converged]) > 1e4 * T


def test_fallback_root_of_a_long_cable_given_h_round_trips() -> None:
    # A cable 1000 chords long, its span mostly stretch (H L0 / EA = 0.999 x): Newton
    # leaves it to the bracketing search over the family of catenaries, whose root
    # the forward solver reproduces (once reported infeasible).
    x, z, H, w, EA = 332877886.8169483, -10.0, 1.0, 1e-3, 1000.0
    r = cat.solve_length(x, z, H, w, EA, end="H")
    assert r.status == "converged" and r.H == pytest.approx(H, rel=1e-12)
    assert r.L0 / np.hypot(x, z) == pytest.approx(999.88, rel=1e-4)
    f = cat.solve_forces(x, z, r.L0, w, EA)
    assert f.status == "converged" and f.H == pytest.approx(H, rel=1e-8)


def test_extreme_cables_in_one_batch_solve_as_one_by_one() -> None:
    # Scaling is per cable: a batch mixing ordinary and extreme cables gives each the
    # answer it gets alone.
    x = np.array([10.0, 10.0, 1e-9, 50.0, 1000.0, 1e9])
    z = np.array([2.0, 2.0, 1000.0, 5.0, -10.0, 2.0])
    T = np.array([1e200, 5000.0, 1e-6, 1.0, 1e-6, 1e12])
    w = np.array([20.0, 24.2, 1000.0, 24.2, 1e9, 1e-9])
    EA = np.array([1e6, np.inf, np.inf, np.inf, 1000.0, 1e9])
    end = "A"
    batch = cat.solve_length(x, z, T, w, EA, end=end)
    assert batch.status.tolist() == ["converged", "converged", "converged", "infeasible",
                                     "infeasible", "converged"]
    for i in range(x.size):
        one = cat.solve_length(x[i], z[i], T[i], w[i], EA[i], end=end)
        assert one.status == batch.status[i]
        np.testing.assert_allclose([one.L0, one.H, one.V_A], [batch.L0[i], batch.H[i],
                                                               batch.V_A[i]], rtol=1e-14)
    # Forward round trip (not for cable 2: the forward solver's V_A = V_B - w L0 keeps
    # only 1e-10 N of the 1e-6 N under 1e6 N of weight).
    ok = batch.converged & (np.arange(x.size) != 2)
    f = cat.solve_forces(x[ok], z[ok], batch.L0[ok], w[ok], EA[ok])
    np.testing.assert_allclose(f.T_A, T[ok], rtol=1e-8)


@settings(max_examples=200, deadline=None)
@given(
    H=st.floats(1e-3, 1e3),
    V_B=st.floats(-1e3, 1e3),
    L0=st.floats(1e-2, 1e2),
    w=st.floats(0.0, 10.0),
    EA=st.sampled_from([1e2, 1e5, np.inf]),
    k=st.integers(-1000, 1000),
)
def test_spans_are_exact_under_power_of_two_force_scaling(H, V_B, L0, w, EA, k) -> None:
    # Forces times 2**k (with w and EA) leave the spans unchanged and divide the
    # flexibility by 2**k, to rounding: the evaluation works in units of the force
    # scale (a power of two), so the
    # squares and fourth powers of forces near 1e300 or 1e-300 neither overflow nor
    # underflow (they did above about 1e77 N).
    s = 2.0**k
    scaled = (H * s, V_B * s, L0, w * s, EA * s)
    with np.errstate(over="ignore", under="ignore"):
        # Only exact scalings of normal numbers: no overflow, nothing near the subnormals.
        pairs = zip((H, V_B, L0, w, EA), scaled, strict=True)
        if not np.isfinite(scaled).all() or any(
                v != 0.0 and min(abs(v), abs(v2)) < 1e-290 for v, v2 in pairs):
            return
    # To a few roundings of the cable's size (a product may land among the subnormals).
    x0, z0 = cat.spans(H, V_B, L0, w, EA)
    x1, z1 = cat.spans(*scaled)
    size = L0 + abs(x0) + abs(z0)
    assert abs(x1 - x0) <= 4e-15 * size and abs(z1 - z0) <= 4e-15 * size
    F0 = cat.flexibility(H, V_B, L0, w, EA)
    F1 = cat.flexibility(*scaled)
    np.testing.assert_allclose(F1 * s, F0, rtol=4e-15, atol=4e-15 * np.abs(F0).max())


def test_folded_cable_with_a_subnormal_weight_keeps_its_span() -> None:
    # V_A < 0 < V_B with w = 1.1e-308 N/m: H/w overflowed and the span lost its
    # catenary part (x = 0.04 m, the stretch alone). The cable is a straight bar to
    # rounding: x = L0 (1 + H/EA), z = 0.
    H, V_B, L0, w, EA = 2.0, 1.1125369292536007e-308, 2.0, 1.1125369292536007e-308, 100.0
    x, z = cat.spans(H, V_B, L0, w, EA)
    assert x == pytest.approx(L0 * (1.0 + H / EA), rel=1e-15) and z == 0.0
    F = cat.flexibility(H, V_B, L0, w, EA)
    np.testing.assert_allclose(F, [[L0 / EA, 0.0], [0.0, L0 / EA + L0 / H]], rtol=1e-15)


UNREADABLE = [[[1.0, 2.0], [3.0]], "abc", [1.0, "x", 2.0], "10", ["10", "3"]]


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("value", UNREADABLE,
                         ids=["ragged", "string", "mixed", "number_text", "number_texts"])
@pytest.mark.parametrize("name", ["x", "z", "w", "EA"])
def test_unreadable_arguments_raise_the_package_error_naming_them(name: str, value: object,
                                                                   compiled: bool) -> None:
    """Strings and ragged lists meet InvalidCableError naming the argument, on the
    compiled path and on numpy's (both once let numpy's ValueError through)."""
    good = {"x": 10.0, "z": -2.0, "w": 2.0, "EA": 1e6}
    bad = {**good, name: value}
    with pytest.raises(cat.InvalidCableError, match=rf"\b{name}\b"):
        cat.solve_length(bad["x"], bad["z"], 500.0, bad["w"], bad["EA"], compiled=compiled)
    with pytest.raises(cat.InvalidCableError, match=rf"\b{name}\b"):
        cat.solve_forces(bad["x"], bad["z"], 10.5, bad["w"], bad["EA"], compiled=compiled)
