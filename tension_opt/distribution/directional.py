"""One-sided directional derivatives of optimal tensions where the Jacobian does not exist.

At a *degenerate* pose (:mod:`tension_opt.distribution.sensitivity`) a bound is just
touched: the point is on it and its multiplier is zero. The tensions then move
differently depending on the direction the parameters move in. On one side the bound
stays active, and on the other the tension leaves it. For a strictly convex objective
(a positive curvature on every tension: ``min_norm``, ``centered``, ``pinv``, and their
smoothed forms) with independent constraints, the one-sided derivative along a direction
``d`` of the parameters exists and is unique. It solves the KKT conditions linearised
on the critical cone:

- the bounds with a nonzero multiplier stay active (``dx_i = d bound_i``);
- each weakly active bound either stays active, with a multiplier change of its
  multiplier's sign (``dz_i <= 0`` lower, ``>= 0`` upper), or is left, with
  ``dx_i >= d lb_i`` (lower) or ``dx_i <= d ub_i`` (upper);
- everything else as in the two-sided derivative.

The weakly active bounds of a pose are few (one or two on a robot's typical
trajectory), so the pose's subsets of them are tried in turn (smallest first) until one
satisfies its signs: a small linear solve each. This loop runs over the degenerate
poses only. A pose with a Jacobian gets ``J d``; a face of optima, a linear objective
at a degenerate vertex, dependent constraints or more than :data:`MAX_WEAK` weak bounds
get NaN and their status.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.certify.scaling import scaled_batch
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.robot.derivatives import column_derivatives, pose_derivatives

from .sensitivity import (
    CHUNK,
    COND_MAX,
    MULTIPLIER_TOL,
    NEEDS_ROBOT,
    KktSystem,
    checked_form,
    jacobian_shape,
    tension_jacobian,
)

__all__ = ["DIRECTIONAL_STATUSES", "MAX_WEAK", "DirectionalDerivative",
           "directional_derivative"]

#: Statuses of a :class:`DirectionalDerivative`.
DIRECTIONAL_STATUSES = ("ok", "one_sided", "non_unique", "unavailable", "not_optimal")
#: Most weakly active bounds of a pose whose subsets are tried.
MAX_WEAK = 6
#: Slack (relative to the direction's size) within which a sign condition holds.
SIGN_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class DirectionalDerivative:
    """One-sided derivatives ``lim_{t -> 0+} (T(theta + t d) - T(theta)) / t`` of a batch.

    Attributes
    ----------
    derivative : ndarray, shape (N, m)
        In newtons per unit of the direction. NaN where the status is neither
        ``"ok"`` nor ``"one_sided"``.
    status : ndarray of str, shape (N,)
        ``"ok"``: the Jacobian exists, and ``derivative`` is ``J d``. ``"one_sided"``:
        a degenerate pose, from the critical cone (module notes). ``"non_unique"``: a
        face of optima. ``"unavailable"``: a degenerate pose of a linear objective, with
        dependent constraints, or with more than :data:`MAX_WEAK` weak bounds.
        ``"not_optimal"``: no certified optimum.
    wrt : str
    """

    derivative: NDArray
    status: NDArray
    wrt: str


def _directions(direction: ArrayLike, shape: tuple[int, ...]) -> NDArray:
    """``direction`` as (N, D): one direction for every pose or one per pose."""
    N, D = shape[0], int(np.prod(shape[2:]))
    d = np.asarray(direction, dtype=float)
    per_pose = d.shape[:1] == (N,) and d[0].size == D and d.size == N * D
    if d.size == D and not (per_pose and N > 1):
        d = np.broadcast_to(d.reshape(1, D), (N, D))
    elif per_pose:
        d = d.reshape(N, D)
    else:
        raise InvalidInputError(
            f"direction must have {shape[2:]} entries (one direction for every pose) or "
            f"({N}, ...) of them, got shape {np.shape(direction)}")
    if not np.isfinite(d).all():
        raise InvalidInputError("direction must be finite")
    return d


def directional_derivative(
    solution: Any,
    wrt: str,
    direction: ArrayLike,
    *,
    robot: CableRobot | None = None,
    poses: ArrayLike | None = None,
    wrench: ArrayLike | None = None,
    previous: ArrayLike | None = None,
) -> DirectionalDerivative:
    """One-sided derivatives of the optimal tensions of ``solution`` along ``direction``
    of the parameters ``wrt`` (module notes).

    Parameters
    ----------
    solution : TensionSolution
    wrt : str
        As :meth:`~tension_opt.TensionSolution.jacobian`.
    direction : array_like
        The parameters' direction: the shape of one pose's Jacobian columns, ``(n,)``
        for ``"wrench"`` and ``"pose"``, ``(m,)`` for the bounds and ``"previous"``,
        ``(m, 3)`` for the points; or one per pose, with a leading ``N``.
    robot, poses, wrench, previous
        As :meth:`~tension_opt.TensionSolution.jacobian`.

    Returns
    -------
    DirectionalDerivative
    """
    jac = tension_jacobian(solution, wrt, robot=robot, poses=poses, wrench=wrench,
                           previous=previous)
    N, m = solution.tensions.shape
    form, p = checked_form(solution, wrt, robot, poses, wrench, previous)
    d = _directions(direction, jacobian_shape(wrt, N, m, form.n))
    out = np.full((N, m), np.nan)
    ok = jac.ok
    out[ok] = np.einsum("kad,kd->ka", jac.jacobian[ok].reshape(-1, m, d.shape[1]), d[ok])
    status = np.where(ok, "ok", jac.status).astype(object)
    status[status == "degenerate"] = "unavailable"
    degenerate = np.flatnonzero(jac.status == "degenerate")
    if len(degenerate):
        batch = scaled_batch(form)
        # Only a strictly convex objective has the one-sided derivative computed here.
        convex = batch.epigraph is None and (batch.P[degenerate] > 0).all(axis=1)
        todo = degenerate[convex]
        # In chunks: a pose's KKT matrix, its inverse and right-hand sides.
        for idx in np.array_split(todo, -(-len(todo) // CHUNK)) if len(todo) else []:
            kkt = KktSystem(form, batch, solution, idx, near=True)
            extra: Any = None
            if wrt in NEEDS_ROBOT:
                assert robot is not None and p is not None
                extra = (pose_derivatives(robot, p[idx]) if wrt == "pose"
                         else column_derivatives(robot, p[idx], wrt))
            rhs = np.einsum("ksd,kd->ks", kkt.rhs(wrt, extra), d[idx])
            z = solution.multipliers.z[idx]
            for j in range(len(idx)):
                got = _one_sided(kkt, j, rhs[j], z[j])
                if got is not None:
                    out[idx[j]] = got * kkt.s[j]
                    status[idx[j]] = "one_sided"
    return DirectionalDerivative(out, status.astype(str), wrt)


def _one_sided(kkt: KktSystem, j: int, rhs: NDArray, z: NDArray) -> NDArray | None:
    """The one-sided derivative (scaled) of degenerate pose ``j`` of ``kkt`` (built with
    every touched bound active), or None where no subset of its weak bounds passes."""
    k, n, g = kkt.k, kkt.n, kkt.g
    o_z = k + n + g
    lo, hi = kkt.lo[j], kkt.hi[j]
    weak = np.flatnonzero((lo | hi) & ~(np.abs(z) > MULTIPLIER_TOL))
    if len(weak) > MAX_WEAK or not np.linalg.cond(kkt.K[j]) <= COND_MAX:
        return None  # too many subsets, or dependent constraints: multipliers not unique
    scale = max(float(np.abs(rhs).max()), 1e-300)
    moves = rhs[o_z:].copy()  # d bound_i of every touched bound
    for size in range(len(weak) + 1):
        for kept in combinations(weak, size):
            left = [i for i in weak if i not in kept]
            K = kkt.K[j].copy()
            r = rhs.copy()
            for i in left:  # the bound is left: its multiplier stays zero
                K[o_z + i, i] = 0.0
                K[o_z + i, o_z + i] = 1.0
                r[o_z + i] = 0.0
            if not np.linalg.cond(K) <= COND_MAX:
                continue
            sol = np.linalg.solve(K, r)
            dx, dz = sol[:k], sol[o_z:]
            tol = SIGN_TOL * scale
            leaves = all((dx[i] - moves[i] >= -tol) if lo[i] else (dx[i] - moves[i] <= tol)
                         for i in left)
            stays = all((dz[i] <= tol) if lo[i] else (dz[i] >= -tol) for i in kept)
            if leaves and stays:
                return np.asarray(dx[: kkt.m])
    return None
