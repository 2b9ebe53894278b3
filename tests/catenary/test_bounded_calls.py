"""Every catenary call ends in bounded time and memory, and refuses what would not.

Solver settings that could let Newton run to any limit (a tolerance of zero, negative
or NaN; an iteration limit beyond :data:`~catenary.solve.common.MAX_ITER_CAP`) meet the
package's error naming them, on both paths; the numpy path solves a large batch in
pieces (:func:`~catenary.solve.common.in_pieces`) with the answers of one piece, and a
peak memory of the results plus one piece's work.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import catenary as cat
import tension_opt as to
from catenary.solve import common

BAD_TOLERANCES = [-1.0, 0.0, np.nan, np.inf, 1.0, "1e-9", None, True]
BAD_LIMITS = [0, -1, 2.5, 10**30, common.MAX_ITER_CAP + 1, "30", None, True]
CABLES = (np.array([10.0, 5.0]), np.array([2.0, -1.0]))


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("solver", ["solve_length", "solve_forces"])
def test_settings_that_could_run_unbounded_are_refused(solver: str, compiled: bool) -> None:
    x, z = CABLES
    third = np.array([1e3, 2e3]) if solver == "solve_length" else 1.05 * np.hypot(x, z)
    call = getattr(cat, solver)
    for rtol in BAD_TOLERANCES:
        with pytest.raises(cat.InvalidCableError, match=r"\brtol\b"):
            call(x, z, third, 2.0, 1e6, rtol=rtol, compiled=compiled)
    for max_iter in BAD_LIMITS:
        with pytest.raises(cat.InvalidCableError, match=r"\bmax_iter\b"):
            call(x, z, third, 2.0, 1e6, max_iter=max_iter, compiled=compiled)
    # numpy's numbers are numbers: the same answer as Python's
    plain = call(x, z, third, 2.0, 1e6, rtol=1e-10, max_iter=40, compiled=compiled)
    numpy = call(x, z, third, 2.0, 1e6, rtol=np.float32(1e-10), max_iter=np.int64(40),
                 compiled=compiled)
    assert (plain.status == "converged").all()
    np.testing.assert_allclose(numpy.H, plain.H, rtol=1e-12)


def test_kinematics_check_their_settings_robot_and_start() -> None:
    robot = to.presets.algae_harvester()
    home = robot.default_home()
    lengths = cat.inverse_kinematics(robot, home).lengths
    with pytest.raises(cat.InvalidCableError, match=r"\btol\b"):
        cat.inverse_kinematics(robot, home, model="coupled", tol=np.nan)
    with pytest.raises(cat.InvalidCableError, match=r"\bmax_iter\b"):
        cat.forward_kinematics(robot, lengths, max_iter=-1)
    for call in (lambda: cat.inverse_kinematics(None, home),  # type: ignore[arg-type]
                 lambda: cat.forward_kinematics("robot", lengths)):  # type: ignore[arg-type]
        with pytest.raises(cat.InvalidCableError, match="CableRobot"):
            call()
    for start, match in (([1.0, 2.0], "shape"), ([-1.0, 2, 3, 4], ">= 0"),
                         ([np.inf, 2, 3, 4], "finite"), ("abc", "numbers")):
        with pytest.raises(cat.InvalidCableError, match=rf"initial_tensions.*{match}"):
            cat.inverse_kinematics(robot, home, model="coupled", initial_tensions=start)
    # NaN marks a pose without a start: the default start, the same answer
    free = cat.inverse_kinematics(robot, home, model="coupled")
    marked = cat.inverse_kinematics(robot, home, model="coupled",
                                    initial_tensions=[np.nan] * robot.m)
    assert (marked.status == "converged").all()
    np.testing.assert_allclose(marked.lengths, free.lengths, rtol=1e-12)


def test_cable_properties_check_gravity_and_diameter() -> None:
    for g in (-9.81, np.nan, np.inf, "9.81"):
        with pytest.raises(cat.InvalidCableError, match=r"\bg\b"):
            cat.cable_properties("steel", 0.01, g=g)  # type: ignore[arg-type]
    with pytest.raises(cat.InvalidCableError, match="diameter"):
        cat.cable_properties("steel", "0.01")  # type: ignore[arg-type]
    w, _ = cat.cable_properties("steel", 0.02, g=0)
    assert w == 0.0


def random_cables(n: int, seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 50.0, n)
    x[::17] = 0.0  # vertical cables take their own branch
    return (x, rng.uniform(-20.0, 20.0, n), rng.uniform(0.0, 5000.0, n),
            rng.uniform(0.5, 30.0, n), rng.choice([1e5, 1e7, np.inf], n))


@pytest.mark.parametrize("end", ["B", "A", "H"])
def test_a_batch_in_pieces_gives_the_whole_batch(end: str,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """The numpy path's pieces give the answers of one piece, to the bit (the tension
    is a length for solve_forces)."""
    x, z, T, w, EA = random_cables(500, 3)
    whole = cat.solve_length(x, z, T, w, EA, end=end, compiled=False)
    L0 = np.where(np.isfinite(whole.L0), whole.L0 * 1.01, 1.05 * np.hypot(x, z) + 0.1)
    forces = cat.solve_forces(x, z, L0, w, EA, compiled=False)
    monkeypatch.setattr(common, "PIECE", 37)
    pieces = cat.solve_length(x, z, T, w, EA, end=end, compiled=False)
    forces_pieces = cat.solve_forces(x, z, L0, w, EA, compiled=False)
    assert {"converged", "infeasible"} <= set(whole.status)
    for a, b in ((whole, pieces), (forces, forces_pieces)):
        for name in ("H", "V_A", "V_B", "iterations", "status", "converged"):
            np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
    np.testing.assert_array_equal(pieces.L0, whole.L0)


def test_a_large_batch_takes_the_memory_of_its_results_and_one_piece() -> None:
    """400k cables with the tension given as H (always the numpy path): the peak is the
    inputs, results and one piece's work (one piece at once took 270 MB)."""
    n = 400_000
    x, z, T, w, _ = random_cables(n, 5)
    cat.solve_length(x[:8], z[:8], T[:8], w[:8], 1e7, end="H")
    tracemalloc.start()
    try:
        result = cat.solve_length(x, z, T, w, 1e7, end="H")
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert (result.status == "converged").mean() > 0.5
    assert kept > 30e6  # the results are counted
    assert peak < kept + 80e6, (kept, peak)
