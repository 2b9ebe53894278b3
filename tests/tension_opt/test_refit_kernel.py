"""The compiled sign-constrained refit (:mod:`tension_opt.kernels.refit`) against its
numpy reference (scipy's bounded least squares in ``certify``), and the compiled
two-dimensional QP, which skips the crossings that cannot win, against the
enumeration of every candidate."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

import tension_opt as to
from benchmarks.peers_toolkit import select_poses
from tension_opt import presets
from tension_opt.certify import certificate as cert
from tension_opt.certify.scaling import scaled_batch
from tension_opt.distribution.certified import CertifiedBatch, certified_plan
from tension_opt.kernels import lowdim
from tension_opt.kernels.refit import bounded_lstsq, pose_refit, refit_work_size
from tension_opt.problem.form import TensionProblem

#: Agreement of the two fits (relative to a pose's largest multiplier, at least 1).
FIT_REL = 1e-10


def _stuck(robot: to.CableRobot, poses: np.ndarray, objective: str) -> tuple:
    """The scaled batch, scaled tensions, cheap-dual multipliers, their measures and the
    poses the refit takes."""
    A, b = robot.equilibrium(poses, None)
    form = TensionProblem(objective=objective).standard_form_from(robot, A, b, None)
    tensions = to.distribute(robot, poses, objective, "closed_form").tensions
    batch = scaled_batch(form)
    x = batch.lift(tensions)
    mult = cert.estimate_multipliers(batch, x)
    measured = cert.measures(batch, x, mult)
    stuck = np.flatnonzero(cert.refit_poses(form, tensions))
    return batch, x, mult, measured, stuck


@pytest.mark.parametrize(("robot", "objective", "seed"), [
    (presets.cogiro(), "centered", 1), (presets.cogiro(), "min_norm", 3),
    (presets.cogiro(), "min_sum", 4), (presets.ipanema3(), "centered", 2),
], ids=["cogiro-centered", "cogiro-min-norm", "cogiro-min-sum", "ipanema-centered"])
def test_the_compiled_refit_is_scipys(robot: to.CableRobot, objective: str,
                                      seed: int) -> None:
    poses = select_poses(robot, 1500, False, seed)
    batch, x, mult, measured, stuck = _stuck(robot, poses, objective)
    assert len(stuck) > 0  # poses with active bounds where the cheap fit misses a cone
    reference = cert.Multipliers(mult.y.copy(), mult.mu.copy(), mult.z.copy())
    cert._refit(batch, x, stuck, reference)
    after = cert.measures(batch, x, reference)
    n, k, g = batch.Aeq.shape[1], batch.k, batch.G.shape[1]
    work, station = np.empty(refit_work_size(n, g, k)), np.empty(k)
    for i in stuck:
        y, mu, z = mult.y[i].copy(), mult.mu[i].copy(), mult.z[i].copy()
        *got, kept = pose_refit(batch.P[i], batch.c[i], batch.Aeq[i], batch.beq[i],
                                batch.G[i], batch.h[i], batch.lb[i], batch.ub[i], x[i], y,
                                mu, z, tuple(m[i] for m in measured), station, work)
        assert kept == 1
        top = max(1.0, np.abs(reference.y[i]).max(), np.abs(reference.z[i]).max())
        assert np.abs(y - reference.y[i]).max() <= FIT_REL * top
        assert np.abs(z - reference.z[i]).max() <= FIT_REL * top
        assert max(got[1:]) <= 1e-7 and max(after[1][i], after[2][i]) <= 1e-7


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 6), st.integers(1, 5))
def test_bounded_least_squares_is_scipys(seed: int, rows_extra: int, cols: int) -> None:
    """Random full-rank problems, each variable free, nonnegative or nonpositive."""
    rng = np.random.default_rng(seed)
    C = cols + 2
    R = C + rows_extra
    M = rng.standard_normal((R, C))
    rhs = rng.standard_normal(R) * 3.0
    kind = rng.integers(0, 3, C)
    lo = np.where(kind == 1, 0.0, -np.inf)
    hi = np.where(kind == 2, 0.0, np.inf)
    u = np.empty(C)
    assert bounded_lstsq(M, rhs, lo, hi, u, np.empty(2 * R * C + 4 * R + 9 * C), 50 * C)
    want = lsq_linear(M, rhs, bounds=(lo, hi), method="bvls", tol=1e-15).x
    assert np.abs(u - want).max() <= 1e-9 * max(1.0, np.abs(want).max())
    assert (u >= lo).all() and (u <= hi).all()


def test_the_certified_pass_leaves_no_pose_with_active_bounds_to_numpy() -> None:
    """CoGiRo poses whose closed form leaves the bounds: the refit is in the kernel."""
    robot = presets.cogiro()
    problem = TensionProblem(objective="centered")
    poses = select_poses(robot, 1500, False, 1)
    plan = certified_plan(robot, problem, "closed_form", None)
    assert plan is not None
    batch = CertifiedBatch(plan, poses, None)
    assert batch.solve(slice(0, len(poses))) is None
    assert (batch.codes == 0).all()


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 100_000), st.integers(3, 9))
def test_the_2d_qp_skips_only_crossings_that_cannot_win(seed: int, m: int) -> None:
    """The same point, bit for bit, as every candidate in the reference's order."""
    rng = np.random.default_rng(seed)
    Z = np.ascontiguousarray(np.linalg.qr(rng.standard_normal((m, 2)))[0])
    lb = rng.uniform(-5.0, 1.0, m)
    ub = np.where(rng.random(m) < 0.2, np.inf, lb + rng.uniform(0.01, 8.0, m))
    T0 = np.clip(lb + (ub - lb) * rng.random(m), -1e3, 1e3) + rng.normal(0.0, 0.3, m)
    q = rng.uniform(0.5, 2.0, m)
    c = rng.normal(0.0, 30.0, m)
    work = np.empty(lowdim.lowdim_work(m))
    got = lowdim.qp_2d(T0, Z, lb, ub, q, c, 10.0, work)
    # The reference's enumeration: every candidate of the numpy backend's order.
    H = Z.T @ (q[:, None] * Z)
    g = Z.T @ (q * T0 + c)
    normals, beta, present = lowdim._lines(T0, Z, lb, ub, np.empty(8 * m))
    L = 2 * m
    limits = lowdim._slacks(normals, beta, present, 10.0, np.empty(L))
    free = -np.linalg.solve(H, g)
    if lowdim._feasible(free[0], free[1], normals, limits):
        return
    det = H[0, 0] * H[1, 1] - H[0, 1] ** 2
    Hi = np.array([[H[1, 1], -H[0, 1]], [-H[0, 1], H[0, 0]]]) / det
    f = -(Hi @ g)
    on_lines = np.full((L, 2), np.nan)
    for j in range(L):
        if present[j]:
            a = normals[j]
            ha = Hi @ a
            on_lines[j] = f + ha * (beta[j] - a @ f) / (a @ ha)
    crossings = lowdim._vertices(normals, beta, present, np.empty(L * L))
    best, want = np.inf, (np.nan, np.nan)
    for x, y in np.concatenate([on_lines, crossings]):  # the reference's order
        if lowdim._feasible(x, y, normals, limits):
            value = 0.5 * (H[0, 0] * x * x + 2.0 * H[0, 1] * x * y + H[1, 1] * y * y) \
                + g[0] * x + g[1] * y
            if value < best or np.isnan(want[0]):
                best, want = value, (x, y)
    assert got[2] == (not np.isnan(want[0]))
    if got[2]:
        np.testing.assert_allclose(got[:2], want, rtol=1e-12, atol=1e-12)


def test_certify_refits_a_compiled_size_batch_as_scipy_does(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The batch's refit by the kernel, and by scipy where the batch is too small for
    the kernels: the same multipliers and verdicts."""
    from tension_opt.kernels import launch

    robot = presets.cogiro()
    poses = select_poses(robot, 600, False, 1)
    batch, x, _mult, _measured, stuck = _stuck(robot, poses, "centered")
    assert len(stuck) > 0
    compiled = cert.certify(batch, x)
    monkeypatch.setattr(launch, "COMPILED_MIN", 10**9)
    reference = cert.certify(batch, x)
    np.testing.assert_array_equal(compiled.certified, reference.certified)
    for name in ("y", "z"):
        a = getattr(compiled.multipliers, name)[stuck]
        b = getattr(reference.multipliers, name)[stuck]
        top = np.maximum(1.0, np.abs(b).max(axis=1, keepdims=True))
        assert (np.abs(a - b) <= FIT_REL * top).all(), name


def test_the_distributor_refits_in_its_compiled_call() -> None:
    """CoGiRo poses with active bounds whose cheap fit misses a cone: one pose per call,
    each answered by the compiled kernel, optimal and certified, with distribute's
    status."""
    robot = presets.cogiro()
    poses = select_poses(robot, 600, False, 1)
    _batch, _x, _mult, _measured, stuck = _stuck(robot, poses, "centered")
    solver = to.Distributor(robot, "centered", "closed_form")
    for i in stuck:
        got = solver(np.ascontiguousarray(poses[i]))
        assert got.compiled and got.status == to.Status.OPTIMAL
        assert max(got.primal_residual, got.dual_residual, got.duality_gap) <= 1e-7
        plain = to.distribute(robot, poses[i], "centered", "closed_form")
        assert plain.status[0] == to.Status.OPTIMAL.value
        np.testing.assert_allclose(got.tensions, plain.tensions[0], rtol=1e-12, atol=1e-9)
