"""The compiled decision of the cables Newton does not settle
(catenary.solve.kernels_bracket): infeasible tensions and taut roots, against the numpy
path's bracketing search (catenary.solve_length(..., compiled=False)), closed forms and
brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

import catenary
from catenary.elastic import evaluate
from catenary.solve import kernels
from catenary.solve import kernels_bracket as kb
from tension_opt import presets

SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def compliance(EA: float) -> float:
    return 0.0 if EA == np.inf else 1.0 / EA


def feasible(end: str, x: float, z: float, T: float, w: float, EA: float) -> bool:
    """Whether a cable through both ends carries ``T`` (the module's criterion, exact
    but for the last digits): a positive far tension and ``w x`` within the widest
    span."""
    inv_EA = compliance(EA)
    Tf = kb.far_tension(T, w * (-z if end == "B" else z), inv_EA)
    if not Tf > 0.0:
        return False
    lower, upper, _, _ = kb.widest_span(min(T, Tf), max(T, Tf), inv_EA)
    return w * x <= 0.5 * (lower + upper)


def edge_tension(end: str, x: float, z: float, w: float, EA: float) -> float:
    """The least tension (N) at ``end`` of any cable through both ends: bisection in
    ``log T`` on :func:`feasible` (feasibility grows with the tension)."""
    c = math.hypot(x, z)
    lo, hi = math.log(1e-14 * w * c), math.log(1e3 * w * c)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if feasible(end, x, z, math.exp(mid), w, EA):
            hi = mid
        else:
            lo = mid
    return math.exp(hi)


def kernel(end: str, x, z, T, w, EA) -> tuple[np.ndarray, np.ndarray]:
    """``(out (4, n), ints (2, n))`` of the batch kernel in the calling thread."""
    x, z, T, w, EA = (np.ascontiguousarray(a).ravel() for a in np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, z, T, w, EA))))
    out, ints = np.empty((4, x.size)), np.empty((2, x.size), dtype=np.int64)
    kernels.solve_length_cables(end == "B", x, z, T, w, EA, 1e-9, 30, out, ints)
    return out, ints


def newton_codes(end: str, x, z, T, w, EA) -> np.ndarray:
    """The codes of the kernel's Newton alone (:func:`kernels.solve_length_one`)."""
    args = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (x, z, T, w, EA)))
    sol = np.empty(5)
    return np.array([kernels.solve_length_one(end == "B", xk, zk, Tk, wk, compliance(Ek),
                                              1e-9, 30, sol)
                     for xk, zk, Tk, wk, Ek in zip(*(a.ravel() for a in args), strict=True)])


def assert_decisions_match(end, x, z, T, w, EA, offset=1.0) -> tuple[np.ndarray, object]:
    """Every cable the family decides (the kernel's Newton alone does not settle it) has
    the numpy path's status; its roots agree with the numpy path's, with the same
    iterations; infeasible ones report NaN and 0 iterations; the plain call (kernel,
    then numpy for the rest) agrees with the numpy path on them and on the rest it
    leaves. Returns the kernel's codes and the numpy result.

    The roots agree to 1e-12 (``L0`` relative, forces of the cable's largest tension),
    but near the edge: a tension ``1 + offset`` times the least one puts the root a
    distance ``~sqrt(offset)`` from the fold of the family, where last-bit differences
    between numpy's and the C library's functions move it by ``~1e-16 /
    sqrt(offset)``: there ``1e-14 / sqrt(offset)``. (The cables Newton settles are
    tests/catenary/test_kernels.py's.)"""
    out, ints = kernel(end, x, z, T, w, EA)
    ref = catenary.solve_length(x, z, T, w, EA, end=end, compiled=False)
    code = ints[0]
    family = newton_codes(end, x, z, T, w, EA) != kernels.CONVERGED
    no = code == kernels.INFEASIBLE
    assert (ref.status[no] == "infeasible").all()
    assert np.isnan(out[:, no]).all() and (ints[1][no] == 0).all()
    yes = family & (code == kernels.CONVERGED)
    assert (ref.status[yes] == "converged").all()
    tol = np.broadcast_to(np.maximum(1e-12, 1e-14 / np.sqrt(np.abs(offset))),
                          ref.L0.shape)[yes]
    assert np.all(np.abs(out[3][yes] - ref.L0[yes]) <= tol * ref.L0[yes])
    force = np.maximum(ref.T_A, ref.T_B)[yes]
    for row, name in ((0, "H"), (1, "V_B"), (2, "V_A")):
        got, want = out[row][yes], getattr(ref, name)[yes]
        assert np.all(np.abs(got - want) <= tol * force), name
    steps = np.abs(ints[1][yes] - ref.iterations[yes])  # as tests/catenary/test_kernels
    assert steps.max(initial=0) <= 1 and (steps > 0).sum() <= max(1, steps.size // 100)
    plain = catenary.solve_length(x, z, T, w, EA, end=end)
    np.testing.assert_array_equal(plain.status[family], ref.status[family])
    left = family & (code == kernels.FALLBACK)
    np.testing.assert_array_equal(plain.iterations[left], ref.iterations[left])
    np.testing.assert_array_equal(plain.L0[left], ref.L0[left])
    return code, ref


# ----------------------------------------------------------------------------
# the maths: far tension, widest span, its bounds, the edge


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_far_tension_is_the_other_end_tension_of_every_cable(seed):
    """``T_far`` is fixed by the tension and the height alone: the end tensions of any
    elastic catenary (numpy's spans) map onto each other."""
    rng = np.random.default_rng(seed)
    H = 10.0 ** rng.uniform(-1, 4, 50)
    V_B = rng.uniform(-3, 3, 50) * H
    L0 = rng.uniform(0.1, 100, 50)
    w = 10.0 ** rng.uniform(-2, 2, 50)
    inv_EA = rng.choice([0.0, 1e-9, 1e-6, 1e-3], 50)
    _, z, *_, T_A, T_B = evaluate(H, V_B, L0, w, inv_EA, jacobian=False)
    for k in range(50):
        assert kb.far_tension(T_B[k], -w[k] * z[k], inv_EA[k]) == pytest.approx(
            T_A[k], rel=1e-11, abs=1e-12 * T_B[k])
        assert kb.far_tension(T_A[k], w[k] * z[k], inv_EA[k]) == pytest.approx(
            T_B[k], rel=1e-11, abs=1e-12 * T_A[k])


def phi(H, T_lo, T_hi, inv_EA):
    """The span ``w x`` (N) of the member with a low point between the ends."""
    return (H * (np.arccosh(T_lo / H) + np.arccosh(T_hi / H))
            + inv_EA * H * (np.sqrt(T_lo**2 - H**2) + np.sqrt(T_hi**2 - H**2)))


@SETTINGS
@given(st.floats(0.0, 12.0), st.sampled_from([0.0, 1e-6, 1e-3, 0.1, 1.0, 30.0]))
def test_widest_span_bounds_the_brute_force_maximum(log_rho, stretch):
    """The bounds of max phi hold and are 1e-10 apart; the cheap bound lies above max phi
    but within ``1 / BAND`` of it."""
    T_lo, T_hi = 1.0, 10.0**log_rho
    inv_EA = stretch / T_hi
    lower, upper, t_star, found = kb.widest_span(T_lo, T_hi, inv_EA)
    assert found and lower <= upper <= lower * (1.0 + 1e-10)
    best = minimize_scalar(lambda H: -phi(H, T_lo, T_hi, inv_EA), bounds=(1e-12, 1.0),
                           method="bounded", options={"xatol": 1e-13})
    assert -best.fun <= upper and -best.fun >= lower * (1.0 - 1e-9)
    assert best.x == pytest.approx(T_lo / math.cosh(t_star), rel=1e-5)
    cheap = kb.span_bound(T_lo, T_hi, inv_EA)
    assert -best.fun <= cheap <= upper / kb.BAND


def test_least_tension_of_a_level_and_of_a_vertical_cable():
    """Closed forms: a level inextensible catenary needs ``w x cosh(t) / (2 t)``, ``t
    tanh t = 1`` (0.7544 w x); a cable hanging from B over a short span needs about its
    weight, ``w z``, inextensible, and ``EA (sqrt(1 + 2 w z / EA) - 1)`` elastic."""
    t = 1.1996786402577338
    assert edge_tension("B", 40.0, 0.0, 2.0, np.inf) == pytest.approx(
        2.0 * 40.0 * math.cosh(t) / (2 * t), rel=1e-12)
    assert edge_tension("A", 40.0, 0.0, 2.0, np.inf) == pytest.approx(0.7544398 * 80.0, rel=1e-7)
    assert edge_tension("B", 1e-7, 30.0, 2.0, np.inf) == pytest.approx(60.0, rel=1e-7)
    EA = 500.0
    assert edge_tension("B", 1e-7, 30.0, 2.0, EA) == pytest.approx(
        EA * (math.sqrt(1.0 + 2.0 * 2.0 * 30.0 / EA) - 1.0), rel=1e-7)


EDGE_CASES = [("B", 40.0, 0.0, 2.0, np.inf), ("A", 40.0, 0.0, 2.0, 1e4),
              ("B", 30.0, 12.0, 24.2, np.inf), ("B", 30.0, -12.0, 24.2, 1e6),
              ("A", 30.0, 12.0, 24.2, 1e9), ("A", 30.0, -12.0, 24.2, np.inf),
              ("B", 1e-3, 50.0, 1.0, np.inf), ("B", 10.0, -20.0, 1.0, 1e5),
              ("B", 2.0, -50.0, 1.0, 1e5),
              ("A", 5.0, 1e3, 0.1, 1e6), ("B", 100.0, 0.3, 10.0, 200.0)]


@pytest.mark.parametrize(("end", "x", "z", "w", "EA"), EDGE_CASES)
def test_edge_is_where_the_numpy_search_turns_infeasible(end, x, z, w, EA):
    """1e-6 below the edge the numpy path finds no cable, 1e-6 above it the taut one
    (and so does the kernel); 1e-10 around it (within the certificate's tolerance) the
    family decides nothing (Newton alone may settle the cable, as the numpy path's)."""
    T = edge_tension(end, x, z, w, EA)
    offset = np.array([-1e-6, 1e-6])
    code, ref = assert_decisions_match(end, np.full(2, x), z, T * (1 + offset), w, EA,
                                       offset)
    assert ref.status.tolist() == ["infeasible", "converged"]
    if w * math.hypot(x, z) > kb.HEAVY * T:  # the numpy path's to decide
        assert code[0] == kernels.FALLBACK
    else:  # (level cables may reach V_A = -V_B, a limit the kernel leaves to numpy)
        assert code[0] == kernels.INFEASIBLE and (code[1] == kernels.CONVERGED or z == 0.0)
    offset = np.array([-1e-10, 1e-10])
    c, F = math.hypot(x, z), T
    for Tk in T * (1 + offset):
        for full in (False, True):
            assert kb.family_decision(end == "B", x / c, z / c, Tk / F, w * c / F,
                                      compliance(EA) * F, full)[0] == kb.UNDECIDED
    assert_decisions_match(end, np.full(2, x), z, T * (1 + offset), w, EA, offset)


# ----------------------------------------------------------------------------
# the kernel against the numpy path

ANGLES = st.one_of(st.floats(-1.5, 1.5), st.sampled_from(
    [0.0, math.pi / 2 - 1e-6, -(math.pi / 2 - 1e-6), math.pi / 2 - 1e-3, -1.2]))
OFFSETS = st.one_of(st.sampled_from([-0.5, -1e-2, -1e-5, 1e-5, 1e-2, 0.5, 3.0]),
                    st.floats(-0.9, 3.0).filter(lambda d: abs(d) > 1e-6))
CABLES = st.tuples(st.floats(0.1, 500.0), ANGLES, st.floats(0.01, 100.0),
                   st.sampled_from([np.inf, 1e9, 1e6, 1e4]), OFFSETS)


@SETTINGS
@given(st.lists(CABLES, min_size=6, max_size=6), st.sampled_from(["B", "A"]))
def test_kernel_decides_as_the_numpy_search_around_the_edge(cables, end):
    """Spans of every slope (level, steep up and down), light to heavy, stiff and
    elastic, tensions from a tenth to four times the least one: the kernel's statuses,
    roots and iterations are the numpy path's; it calls no feasible cable infeasible
    and shows every infeasible one so that is clearly off the edge (but the data it
    leaves to the numpy path)."""
    chord, angle, w, EA, offset = (np.array(c) for c in zip(*cables, strict=True))
    x, z = chord * np.cos(angle), chord * np.sin(angle)
    edge = np.array([edge_tension(end, *c) for c in zip(x, z, w, EA, strict=True)])
    T = edge * (1.0 + offset)
    code, ref = assert_decisions_match(end, x, z, T, w, EA, offset)
    # Off the edge by more than the certificate's 1e-8 c of span (and 100 MARGIN).
    clear = np.abs(offset) * x > 1e-5 * chord
    assert np.all(ref.status[clear & (offset < 0)] != "converged")
    assert np.all(ref.status[clear & (offset > 0)] != "infeasible")
    assert (code[clear & (offset < 0)] != kernels.CONVERGED).all()
    usual = ((w * chord <= kb.HEAVY * T) & (T * np.where(EA < np.inf, 1 / EA, 0) <= 1.0)
             & ((z == 0) | (np.abs(z) >= kb.NEARLY_LEVEL * chord)))
    assert (code[usual & clear & (offset < 0)] == kernels.INFEASIBLE).all()


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["B", "A"]))
def test_taut_roots_newton_leaves_match_the_numpy_polish(seed, end):
    """Strongly stretched, heavy cables (``T / EA`` 1 to 60) where the kernel's Newton
    often stops off the root: the taut member of the family, polished by the same
    Newton, is the numpy path's bracketed and polished root."""
    rng = np.random.default_rng(seed)
    n = 400
    angle = rng.uniform(-1.4, 1.4, n)
    chord = 10.0 ** rng.uniform(-1, 2, n)
    x, z = chord * np.cos(angle), chord * np.sin(angle)
    T = 10.0 ** rng.uniform(0, 4, n)
    w = rng.uniform(2.0, 20.0, n) * T / chord
    EA = T / rng.uniform(1.0, 60.0, n)
    code, ref = assert_decisions_match(end, x, z, T, w, EA)
    rooted = (code == kernels.CONVERGED) & (newton_codes(end, x, z, T, w, EA)
                                            != kernels.CONVERGED)
    assert rooted.sum() >= 0.1 * n  # about a quarter of these cables
    assert (ref.status[rooted] == "converged").all()


@pytest.mark.parametrize("EA", [np.inf, 1e6, 1e9])
@pytest.mark.parametrize("end", ["B", "A"])
def test_random_cables_of_the_study_robot(EA, end):
    """10^4 cables of the study robot's steel cable (4 % of them infeasible): the same
    statuses as the numpy path, every infeasible one decided in the kernel (none left
    to the numpy search), before Newton, and every other one converged in it."""
    robot = presets.algae_harvester()
    rng = np.random.default_rng(0)
    n = 10**4
    x, z = rng.uniform(1.0, 60.0, n), rng.uniform(-5.0, 10.0, n)
    T = rng.uniform(500.0, 5000.0, n)
    w = robot.cable.weight_per_length(robot.g)
    code, ref = assert_decisions_match(end, x, z, T, w, EA)
    infeasible = ref.status == "infeasible"
    assert 0.02 * n <= infeasible.sum() <= 0.08 * n
    np.testing.assert_array_equal(code == kernels.INFEASIBLE, infeasible)
    assert (code[~infeasible] == kernels.CONVERGED).all()
    # Before Newton: the screen alone shows each of them infeasible.
    h = -z if end == "B" else z
    for k in np.flatnonzero(infeasible)[:200]:
        c, F = math.hypot(x[k], z[k]), T[k]
        outcome = kb.family_decision(end == "B", x[k] / c, z[k] / c, 1.0, w * c / F,
                                     compliance(EA) * F, False)[0]
        assert outcome == kb.INFEASIBLE, (x[k], h[k], T[k])


def test_infeasible_cables_through_the_plain_call():
    """Status "infeasible", not converged, NaN values and 0 iterations, in the input's
    shape, as the numpy path; very heavy cables (beyond ``HEAVY``) are the numpy
    path's to decide."""
    T = np.array([[10.0, 1e3], [50.0, 2.0]])  # the least tension is 58.4 N
    got = catenary.solve_length(40.0, 2.0, T, 2.0, 1e6, end="A")
    ref = catenary.solve_length(40.0, 2.0, T, 2.0, 1e6, end="A", compiled=False)
    assert got.status.tolist() == [["infeasible", "converged"], ["infeasible", "infeasible"]]
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_array_equal(got.iterations, ref.iterations)
    assert (got.iterations[got.status == "infeasible"] == 0).all()
    assert np.isnan(got.L0[~got.converged]).all() and np.isnan(got.H[~got.converged]).all()
    # w c / T = 80 / 2 = 40 > HEAVY: the kernel leaves that one to the numpy path.
    codes = kernel("A", 40.0, 2.0, T.ravel(), 2.0, 1e6)[1][0]
    assert codes.tolist() == [kernels.INFEASIBLE, kernels.CONVERGED, kernels.INFEASIBLE,
                              kernels.FALLBACK]
