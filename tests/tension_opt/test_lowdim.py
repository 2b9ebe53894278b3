"""The low-dimensional solvers of the closed form, against hand-solved and HiGHS answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog, minimize

from tension_opt.backends.lowdim import infeasibility_1d, interval, lp_2d, min_of_max_lines, qp_2d


def test_interval_of_a_line_within_bounds() -> None:
    # T = (1, 2) + t (1, -1) within [0, 3]^2: t in [-1, 2].
    lo, hi = interval(np.array([[1.0, 2.0]]), np.array([[1.0, -1.0]]), np.zeros((1, 2)),
                      np.full((1, 2), 3.0), np.ones(1))
    assert (lo[0], hi[0]) == (-1.0, 2.0)


def test_infeasibility_is_the_smallest_largest_violation() -> None:
    # T = (t, -t - 2) with T >= 0: the best t = -1 violates both bounds by 1.
    value = infeasibility_1d(np.array([[0.0, -2.0]]), np.array([[1.0, -1.0]]),
                             np.zeros((1, 2)), np.full((1, 2), np.inf))
    assert value[0] == pytest.approx(1.0, abs=1e-12)


def test_min_of_max_lines_finds_the_lowest_point_of_the_upper_envelope() -> None:
    # max(t, 2 - t, 0.5) on [-10, 10] is lowest at t = 1 with value 1.
    t, value = min_of_max_lines(np.array([[1.0, -1.0, 0.0]]), np.array([[0.0, 2.0, 0.5]]),
                                np.array([-10.0]), np.array([10.0]))
    assert t[0] == pytest.approx(1.0) and value[0] == pytest.approx(1.0)


def _random_2d(seed: int, N: int = 200) -> tuple[np.ndarray, ...]:
    """Points T0 + Z z with five cables and a 2-D null space around a feasible T0."""
    rng = np.random.default_rng(seed)
    T0 = rng.uniform(5.0, 10.0, (N, 5))
    Z = rng.standard_normal((N, 5, 2))
    lb = np.full((N, 5), 1.0)
    ub = np.where(rng.random((N, 5)) < 0.5, 20.0, np.inf)
    return T0, Z, lb, ub


def test_lp_2d_matches_highs() -> None:
    T0, Z, lb, ub = _random_2d(4)
    c = np.random.default_rng(5).uniform(0.5, 2.0, T0.shape)
    z, feasible, _unique, bounded = lp_2d(T0, Z, lb, ub, c, np.full(len(T0), 10.0))
    for k in range(len(T0)):
        cost = Z[k].T @ c[k]
        finite = np.isfinite(ub[k])
        res = linprog(cost, A_ub=np.vstack([-Z[k], Z[k][finite]]),
                      b_ub=np.concatenate([T0[k] - lb[k], (ub[k] - T0[k])[finite]]),
                      bounds=[(None, None)] * 2, method="highs")
        if res.status == 3:
            assert not bounded[k]
            continue
        assert feasible[k] and bounded[k]
        assert cost @ z[k] == pytest.approx(res.fun, rel=1e-9, abs=1e-9)


def test_qp_2d_matches_a_general_minimiser() -> None:
    T0, Z, lb, ub = _random_2d(6, N=40)
    q = np.full(T0.shape, 2.0)
    c = np.zeros_like(T0)
    z, feasible = qp_2d(T0, Z, lb, ub, q, c, np.full(len(T0), 10.0))
    assert feasible.all()
    for k in range(len(T0)):
        def f(v: np.ndarray, k: int = k) -> float:
            T = T0[k] + Z[k] @ v
            return float(0.5 * q[k] @ T**2 + c[k] @ T)
        finite = np.isfinite(ub[k])
        cons = [{"type": "ineq", "fun": lambda v, k=k: T0[k] + Z[k] @ v - lb[k]},
                {"type": "ineq", "fun": lambda v, k=k, f=finite: (ub[k] - T0[k] - Z[k] @ v)[f]}]
        ref = minimize(f, np.zeros(2), constraints=cons, method="SLSQP",
                       options={"ftol": 1e-14, "maxiter": 500})
        assert f(z[k]) <= ref.fun * (1 + 1e-7) + 1e-9
