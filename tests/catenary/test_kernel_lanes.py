"""The length solve's cables side by side in the vector unit
(:mod:`catenary.solve.kernels_lanes`) against the same kernel one cable at a time
(``kernels.solve_length_cables_scalar``), bit for bit, and the two helpers written for
vector code (``log_fast``, ``power_of_two``) against libm."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import catenary
from benchmarks.cable_cases import random_cables
from catenary.solve import kernels, kernels_lanes
from catenary.solve.kernels_spans import log_fast, power_of_two

SPANS = st.sampled_from([0.0, 1e-9, 1e-3, 1.0, 30.0, 1e3, 1e6, 1e9])
HEIGHTS = st.sampled_from([-1e9, -10.0, -1.0, 0.0, 2.0, 1e3, 1e9])
WEIGHTS = st.sampled_from([0.0, 1e-300, 1e-9, 1e-3, 1.0, 24.0, 1e3, 1e6, 1e300])
STIFFNESSES = st.sampled_from([np.inf, 1e300, 1e9, 1e6, 1e3, 1.0, 1e-300])
TENSIONS = st.sampled_from([0.0, 1e-300, 1e-6, 1.0, 500.0, 1e6, 1e12, 1e100, 1e300])


def mixed_cables(seed: int, count: int) -> tuple[np.ndarray, ...]:
    """:func:`~benchmarks.cable_cases.random_cables` with four invalid cables."""
    x, z, T, w, EA = random_cables(seed, count)
    x[7], T[9], EA[11], z[13] = -1.0, np.nan, 0.0, np.inf
    return x, z, T, w, EA


def both(end: str, x: np.ndarray, z: np.ndarray, T: np.ndarray, w: np.ndarray,
         EA: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray, int], ...]:
    """``(out, ints, unsettled)`` of the lanes kernel and of the scalar one."""
    runs = []
    for solve in (kernels.solve_length_cables, kernels.solve_length_cables_scalar):
        out, ints = np.full((4, x.size), -7.0), np.full((2, x.size), -7, dtype=np.int64)
        unsettled = solve(end == "B", x, z, T, w, EA, 1e-9, 30, out, ints)
        runs.append((out, ints, unsettled))
    return tuple(runs)


def assert_same_bits(lanes: tuple, scalar: tuple) -> None:
    np.testing.assert_array_equal(lanes[1], scalar[1])
    np.testing.assert_array_equal(lanes[0].view(np.int64), scalar[0].view(np.int64))
    assert lanes[2] == scalar[2]


@pytest.mark.parametrize("end", ["B", "A"])
@pytest.mark.parametrize("count", [1, 7, 8, 9, 2001])
def test_lanes_give_the_scalar_kernels_bits(end: str, count: int) -> None:
    """Every code (converged, fallback, invalid, infeasible), iteration count and value
    of the lanes is the scalar kernel's, in full groups and a short last one."""
    x, z, T, w, EA = mixed_cables(3, max(count, 16))
    x, z, T, w, EA = x[-count:], z[-count:], T[-count:], w[-count:], EA[-count:]
    if count == 2001:
        x, z, T, w, EA = mixed_cables(3, count)
    lanes, scalar = both(end, x, z, T, w, EA)
    assert_same_bits(lanes, scalar)
    if count == 2001:
        codes = set(np.unique(lanes[1][0]).tolist())
        assert codes == {kernels.CONVERGED, kernels.FALLBACK, kernels.INVALID,
                         kernels.INFEASIBLE}


@settings(max_examples=60, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(SPANS, HEIGHTS, TENSIONS, WEIGHTS, STIFFNESSES), min_size=1,
                max_size=20), st.sampled_from(["B", "A"]))
def test_lanes_give_the_scalar_kernels_bits_at_extreme_magnitudes(cables: list,
                                                                  end: str) -> None:
    """Data at the edges of the float range, where lanes hand cables back to the
    scalar code (a libm ``hypot`` or ``asinh``, the family's screen, a finish)."""
    x, z, T, w, EA = (np.array(c, dtype=float) for c in zip(*cables, strict=True))
    lanes, scalar = both(end, x, z, T, w, EA)
    assert_same_bits(lanes, scalar)


@pytest.mark.parametrize("end", ["B", "A"])
def test_lanes_settle_most_cables_themselves(end: str) -> None:
    """Start, Newton and certificate run in the vector steps: on the benchmark's mix
    (spans 1-60 m, heights -5-10 m, tensions 0.5-5 kN, the study cable) at most 2 % of
    the lanes go back to the scalar code (a lane that always did would still give the
    same bits)."""
    rng = np.random.default_rng(0)
    W = np.zeros(kernels_lanes.FIELDS * kernels_lanes.LANES)
    codes = []
    for _ in range(200):
        for j in range(kernels_lanes.LANES):
            W[kernels_lanes.at(kernels_lanes.F_RX, j)] = rng.uniform(1.0, 60.0)
            W[kernels_lanes.at(kernels_lanes.F_RZ, j)] = rng.uniform(-5.0, 10.0)
            W[kernels_lanes.at(kernels_lanes.F_RT, j)] = rng.uniform(500.0, 5000.0)
            W[kernels_lanes.at(kernels_lanes.F_RW, j)] = 24.2
            W[kernels_lanes.at(kernels_lanes.F_REA, j)] = np.inf
        kernels_lanes.start_lanes(end == "B", W)
        start = W[kernels_lanes.F_CODE * kernels_lanes.LANES:][:kernels_lanes.LANES].copy()
        W[kernels_lanes.F_CODE * kernels_lanes.LANES:][:kernels_lanes.LANES][
            start == kernels_lanes.SCREEN] = kernels_lanes.INFEASIBLE  # decided apart
        kernels_lanes.newton_lanes(end == "B", W, 1e-9, 30)
        kernels_lanes.finish_lanes(end == "B", W)
        codes.extend(W[kernels_lanes.F_CODE * kernels_lanes.LANES:][:kernels_lanes.LANES])
    codes = np.array(codes)
    handed_back = np.isin(codes, [kernels_lanes.SCALAR, kernels_lanes.FINISH])
    assert handed_back.mean() <= 0.02
    assert (codes == kernels_lanes.CONVERGED).mean() >= 0.9


def test_log_fast_is_within_one_ulp() -> None:
    """``log_fast`` against an extended-precision log on ``[1, 2^512)``: within 0.9
    ulp (libm's 0.52), exact at 1 and on powers of two up to rounding of ``e ln 2``."""
    rng = np.random.default_rng(11)
    y = np.concatenate([1.0 + rng.random(100000), np.exp2(rng.uniform(0.0, 511.9, 100000)),
                        [1.0, np.nextafter(1.0, 2.0), math.sqrt(2.0), 2.0, 2.0**511]])
    got = np.array([log_fast(v) for v in y])
    want = np.log(y.astype(np.longdouble))
    ulps = np.abs(got - want) / np.spacing(np.abs(want.astype(float)))
    assert float(np.nanmax(ulps[1:])) <= 0.9
    assert log_fast(1.0) == 0.0
    assert abs(log_fast(2.0**300) - 300 * math.log(2.0)) <= np.spacing(300 * math.log(2.0))


def test_power_of_two_is_frexps() -> None:
    """``power_of_two`` (comparisons and exact scalings) is libm's ``ldexp(1, frexp(a)
    - 1)`` on every binade and at the clamps."""
    rng = np.random.default_rng(5)
    a = np.concatenate([np.exp2(rng.uniform(-1074.0, 1024.0, 20000)),
                        np.exp2(np.arange(-1074.0, 1024.0)),
                        np.nextafter(np.exp2(np.arange(-1021.0, 1024.0)), 0.0),
                        [0.0, -0.0, np.inf, -np.inf, np.nan, -3.0, np.finfo(float).max]])

    def reference(v: float) -> float:
        v = abs(v)
        if not v < np.inf:
            return 2.0**1023
        if not v >= 2.0**-1022:
            return 2.0**-1022
        return math.ldexp(1.0, math.frexp(v)[1] - 1)

    got = np.array([power_of_two(v) for v in a])
    np.testing.assert_array_equal(got, [reference(v) for v in a])


@pytest.mark.parametrize("count", [1, 4, 7, 8, 12, 15, 16])
@pytest.mark.parametrize("numbers", [True, False])
def test_few_cables_one_at_a_time_give_the_lanes_bits(count: int, numbers: bool,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Calls of fewer cables than two groups of lanes take the one-at-a-time kernel
    (catenary.solve.length.ONE_AT_A_TIME_BELOW): the same bits as the lanes."""
    from catenary.solve import length
    from catenary.solve.kernels_lanes import LANES

    assert length.ONE_AT_A_TIME_BELOW == 2 * LANES
    rng = np.random.default_rng(count)
    x, z = rng.uniform(0.5, 80.0, count), rng.uniform(-20.0, 20.0, count)
    T = rng.uniform(10.0, 1e4, count)
    w, EA = (1.5, 1e6) if numbers else (np.full(count, 1.5), np.full(count, 1e6))
    ours = catenary.solve_length(x, z, T, w, EA=EA)
    monkeypatch.setattr(length, "ONE_AT_A_TIME_BELOW", 0)  # every call through the lanes
    lanes = catenary.solve_length(x, z, T, w, EA=EA)
    for field in ("H", "V_A", "V_B", "L0", "iterations", "status"):
        assert np.array_equal(getattr(ours, field), getattr(lanes, field)), field
