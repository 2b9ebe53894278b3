"""Sensitivities of the coupled sag model: tensions and lengths of catenaries whose end
forces balance the load (:func:`catenary.inverse_kinematics`, ``model="coupled"``).

At a solution of the coupled model with the minimum-sum objective, each cable ``i``
hangs as an elastic catenary with end forces ``(H_i, V_Bi)`` and unstretched length
``L0_i``. The solution is a vertex of the model's (curved) feasible set: as many
bounds active as the robot has redundant cables (``r = m - n``). Then the ``3 m``
unknowns ``u = (H, V_B, L0)`` solve ``3 m`` equations ``G(u, q) = 0``:

- the two spans of every catenary equal its chord's (``2 m``);
- the cables' end forces on the platform, ``H_i e_h,i + (V_Bi - w L0_i) e_z`` with
  their moments, balance the load ``b`` (``n``);
- each active bound holds: the cable's lowest tension is ``t_min`` or its highest
  ``t_max`` (``r``; :func:`catenary.geometry.extreme_tensions`).

By the implicit function theorem ``du/dq = -G_u^-1 G_q``, for ``q`` the pose, the
external wrench, the weight per length or ``EA``. ``G_u`` uses the catenary's analytic
flexibility and length derivative. ``G_q`` uses the chord's analytic derivatives by
the pose (:func:`tension_opt.robot.derivatives.vector_derivatives`), the load's
(:func:`~tension_opt.robot.derivatives.pose_derivatives`) and the spans' partials
by the cable (:func:`catenary.sensitivity.span_partials`). The tensions at the platform
(``T_A``) and at the drawing point (``T_B``) follow.

The vertex is checked by its multipliers. They solve ``G_u' lambda = -grad f`` for the
objective ``f = sum_i T_A,i``, and each active bound's multiplier must have the sign
of a binding bound (strict complementarity). A pose with fewer or more active bounds,
or with a bound's multiplier near zero, has no derivative this way. It gets
``"not_vertex"`` or ``"degenerate"`` and NaN.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.robot.derivatives import pose_derivatives, vector_derivatives

from .elastic import axial_compliance, evaluate, length_derivative
from .errors import InvalidCableError
from .geometry import cable_data, cable_planes, check_robot
from .inverse import InverseKinematicsResult, inverse_kinematics
from .sensitivity import span_partials

__all__ = ["COUPLED_WRT", "CoupledSensitivity", "coupled_jacobian"]

FloatArray = NDArray[np.float64]

#: What :func:`coupled_jacobian` differentiates by.
COUPLED_WRT = ("pose", "wrench", "weight_per_length", "EA")
#: Relative distance within which a cable's extreme tension is on its bound.
BOUND_TOL = 1e-7
#: Smallest size of an active bound's multiplier (per unit of the objective).
MULTIPLIER_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class CoupledSensitivity:
    """Jacobians of the coupled model's solution by ``wrt``, with a status per pose.

    Attributes
    ----------
    tensions : ndarray, shape (N, m, D)
        Of the tensions at the drawing points (N per unit of ``wrt``).
    tensions_platform : ndarray, shape (N, m, D)
        Of the tensions at the platform.
    lengths : ndarray, shape (N, m, D)
        Of the unstretched lengths (m per unit of ``wrt``).
    status : ndarray of str, shape (N,)
        ``"ok"``; ``"not_converged"`` (the coupled model found no solution);
        ``"not_vertex"`` (not as many active bounds as redundant cables);
        ``"degenerate"`` (an active bound's multiplier near zero, or a singular system).
    wrt : str
        ``D`` is ``n`` for ``"pose"`` and ``"wrench"``, 1 for ``"weight_per_length"``
        and ``"EA"``.
    """

    tensions: FloatArray
    tensions_platform: FloatArray
    lengths: FloatArray
    status: NDArray[np.str_]
    wrt: str

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Poses whose Jacobian exists, shape (N,)."""
        return np.asarray(self.status == "ok", dtype=bool)


def coupled_jacobian(robot: CableRobot, poses: ArrayLike, wrt: str,
                     wrench: ArrayLike | None = None, *,
                     result: InverseKinematicsResult | None = None,
                     **options: Any) -> CoupledSensitivity:
    """Jacobians of the coupled model's minimum-sum solution (module notes).

    Parameters
    ----------
    robot : CableRobot
        With cable properties (weight per length > 0), without guide pulleys.
    poses : array_like, shape (N, n) or (n,)
    wrt : {"pose", "wrench", "weight_per_length", "EA"}
    wrench : array_like, optional
        The external wrench (N, N m), as in :func:`catenary.inverse_kinematics`.
    result : InverseKinematicsResult, optional
        The coupled solution of these poses with ``objective="min_sum"``, if at hand;
        else it is solved here (``**options`` go to :func:`catenary.inverse_kinematics`).

    Returns
    -------
    CoupledSensitivity

    Raises
    ------
    InvalidCableError
        For an unknown ``wrt``, weightless cables, a robot with pulleys, or a result of
        another model.
    """
    if wrt not in COUPLED_WRT:
        raise InvalidCableError(f"wrt must be one of {COUPLED_WRT}, got {wrt!r}")
    check_robot(robot)
    w, EA = cable_data(robot)
    if not w > 0:
        raise InvalidCableError("weightless cables do not sag: differentiate the straight "
                                "distribution (TensionSolution.jacobian)")
    p = robot.as_poses(poses)
    if result is None:
        result = inverse_kinematics(robot, p, "coupled", "min_sum", wrench=wrench, **options)
    if result.model != "coupled" or result.lengths.shape[0] != len(p):
        raise InvalidCableError("result must be the coupled model's solution of these poses")
    N, m = result.lengths.shape
    n = robot.dof
    D = n if wrt in ("pose", "wrench") else 1
    system = _System(robot, p, result, w, EA)
    status = np.where(result.status == "converged", "ok", "not_converged").astype(object)
    status[(status == "ok") & ~system.vertex] = "not_vertex"
    status[(status == "ok") & ~system.strict] = "degenerate"
    out = [np.full((N, m, D), np.nan) for _ in range(3)]
    rows = np.flatnonzero(status == "ok")
    if len(rows):
        du = -np.linalg.solve(system.G_u[rows], system.G_q(wrt, rows))   # (k, 3m, D)
        dH, dV_B, dL0 = du[:, :m], du[:, m:2 * m], du[:, 2 * m:]
        H, V_B, L0 = (a[rows][..., None] for a in (system.H, system.V_B, system.L0))
        V_A = V_B - w * L0
        dV_A = dV_B - w * dL0 - (L0 if wrt == "weight_per_length" else 0.0)
        out[0][rows] = (H * dH + V_B * dV_B) / np.hypot(H, V_B)
        out[1][rows] = (H * dH + V_A * dV_A) / np.hypot(H, V_A)
        out[2][rows] = dL0
    return CoupledSensitivity(out[0], out[1], out[2], status.astype(str), wrt)


class _System:
    """The equations ``G(u, q) = 0`` of a batch of coupled solutions and their
    derivatives by the unknowns (``G_u``, (N, 3m, 3m)) and by a parameter."""

    def __init__(self, robot: CableRobot, poses: FloatArray, result: InverseKinematicsResult,
                 w: float, EA: float) -> None:
        self.robot, self.poses, self.w, self.EA = robot, poses, w, EA
        N, m = result.lengths.shape
        self.rows_w = list(robot.wrench_rows)
        n = len(self.rows_w)
        self.planes = cable_planes(robot, poses)
        self.H = np.nan_to_num(result.horizontal_tensions, nan=1.0)
        self.L0 = np.nan_to_num(result.lengths, nan=1.0)
        V_A = np.nan_to_num(result.platform_forces[..., 2], nan=0.0)
        self.V_B = V_A + w * self.L0
        c = float(axial_compliance(np.asarray(EA, dtype=float)))
        with np.errstate(all="ignore"):
            F_xx, F_xz, F_zz = evaluate(self.H, self.V_B, self.L0, w, c)[2:5]
            x_L, z_L = length_derivative(self.H, self.V_B, self.L0, w, EA)
        H, V_B = self.H, self.V_B
        T_A, T_B = np.hypot(H, V_A), np.hypot(H, V_B)
        dip = (V_A < 0) & (V_B > 0)
        low = np.where(dip, H, np.minimum(T_A, T_B))
        high = np.maximum(T_A, T_B)
        t_min = np.broadcast_to(np.asarray(robot.t_min, dtype=float), (m,))
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (m,))
        on_min = np.abs(low - t_min) <= BOUND_TOL * np.maximum(t_min, 1.0)
        on_max = np.isfinite(t_max) & (np.abs(high - t_max) <= BOUND_TOL * t_max)
        self.vertex = (on_min | on_max).sum(axis=1) == m - n
        G = np.zeros((N, 3 * m, 3 * m))
        i = np.arange(m)
        G[:, i, i], G[:, i, m + i], G[:, i, 2 * m + i] = F_xx, F_xz, x_L
        G[:, m + i, i], G[:, m + i, m + i], G[:, m + i, 2 * m + i] = F_xz, F_zz, z_L
        # Equilibrium: dF_i = e_h dH + e_z dV_B - w e_z dL0, with its moment.
        e_z = np.broadcast_to(np.array([0.0, 0.0, 1.0]), self.planes.e_h.shape)
        for block, force in ((0, self.planes.e_h), (1, e_z), (2, -w * e_z)):
            G[:, 2 * m:2 * m + n, block * m:(block + 1) * m] = self._wrench(force)
        # Active bounds: d(extreme tension) by (H, V_B, L0), V_A = V_B - w L0.
        k = np.zeros(N, dtype=int)
        grad_f = np.zeros((N, 3 * m))
        grad_f[:, :m], grad_f[:, m:2 * m], grad_f[:, 2 * m:] = H / T_A, V_A / T_A, -w * V_A / T_A
        sides = np.zeros((N, m))
        for cable in range(m):
            for active, which, sign in ((on_min[:, cable], low, -1.0),
                                        (on_max[:, cable], high, 1.0)):
                use = active & self.vertex & (k < m - n)
                if not use.any():
                    continue
                row = 2 * m + n + k[use]
                a = np.flatnonzero(use)
                at_A = np.isclose(which[use, cable], T_A[use, cable], rtol=0, atol=0)
                only_H = dip[use, cable] & (which is low)
                T_end = np.where(at_A, T_A[use, cable], T_B[use, cable])
                V_end = np.where(at_A, V_A[use, cable], V_B[use, cable])
                G[a, row, cable] = np.where(only_H, 1.0, H[use, cable] / T_end)
                G[a, row, m + cable] = np.where(only_H, 0.0, V_end / T_end)
                G[a, row, 2 * m + cable] = np.where(only_H | ~at_A, 0.0, -w * V_end / T_end)
                sides[a, cable] = sign
                k[use] += 1
        self.G_u = G
        self.active = sides
        ok = self.vertex & np.isfinite(G).all(axis=(1, 2))
        self.strict = ok.copy()
        if ok.any():
            cond = np.linalg.cond(G[ok])
            lam = np.full((N, 3 * m), np.nan)
            good = np.flatnonzero(ok)[cond < 1e12]
            G_t = np.swapaxes(G[good], 1, 2)
            lam[good] = -np.linalg.solve(G_t, grad_f[good][..., None])[..., 0]
            bound = lam[:, 2 * m + n:]
            # The active bounds in the order of their rows: a lower bound binds with
            # a negative multiplier, an upper one with a positive.
            order = np.where(sides != 0, sides, np.nan)
            signs = np.array([row[~np.isnan(row)] for row in order[good]]).reshape(
                len(good), -1)
            self.strict[:] = False
            self.strict[good] = (signs * bound[good] > MULTIPLIER_TOL).all(axis=1)

    def _wrench(self, force: FloatArray) -> FloatArray:
        """The wrench rows (N, n, m) of per-cable forces (N, m, 3) at the attachments."""
        full = np.concatenate([force, np.cross(self.planes.arms, force)], axis=-1)
        return np.swapaxes(full[..., self.rows_w], 1, 2)

    def G_q(self, wrt: str, rows: NDArray[np.intp]) -> FloatArray:
        """``dG / dq`` (k, 3m, D) of the poses ``rows``."""
        w = self.w
        m, n = self.H.shape[1], len(self.rows_w)
        k = len(rows)
        H, V_B, L0 = self.H[rows], self.V_B[rows], self.L0[rows]
        if wrt == "wrench":  # G holds W - b with b = -(w_g + wrench)
            out = np.zeros((k, 3 * m, n))
            out[:, 2 * m:2 * m + n] = np.eye(n)
            return out
        if wrt in ("weight_per_length", "EA"):
            part = span_partials(H, V_B, L0, w, self.EA)
            out = np.zeros((k, 3 * m, 1))
            if wrt == "weight_per_length":
                out[:, :m, 0], out[:, m:2 * m, 0] = part.x_w, part.z_w
                e_z = np.zeros((k, m, 3))
                e_z[..., 2] = -L0
                out[:, 2 * m:2 * m + n, 0] = self._wrench_of(e_z, rows).sum(axis=2)
                # An active bound at end A moves with V_A = V_B - w L0.
                out[:, 2 * m + n:, 0] = self._bound_by_w(rows)
                return out
            c = float(axial_compliance(np.asarray(self.EA, dtype=float)))
            out[:, :m, 0], out[:, m:2 * m, 0] = -c * c * part.x_c, -c * c * part.z_c
            return out
        return self._by_pose(rows)

    def _wrench_of(self, force: FloatArray, rows: NDArray[np.intp]) -> FloatArray:
        arms = self.planes.arms[rows]
        full = np.concatenate([force, np.cross(arms, force)], axis=-1)
        return np.swapaxes(full[..., self.rows_w], 1, 2)

    def _bound_by_w(self, rows: NDArray[np.intp]) -> FloatArray:
        """``d(extreme tension) / dw`` (k, m - n) of the active bounds' rows: an end-A
        tension moves with ``V_A = V_B - w L0``, whose ``L0`` column is ``-w V_A / T_A``,
        so its ``w`` derivative is that entry times ``L0 / w``."""
        m, n = self.H.shape[1], len(self.rows_w)
        by_length = self.G_u[rows, 2 * m + n:, 2 * m:]                     # (k, r, m)
        return np.einsum("krc,kc->kr", by_length, self.L0[rows]) / self.w

    def _by_pose(self, rows: NDArray[np.intp]) -> FloatArray:
        robot, p = self.robot, self.poses[rows]
        m, n = self.H.shape[1], len(self.rows_w)
        k = len(rows)
        pl = self.planes
        e_h, x, arms = pl.e_h[rows], pl.x[rows], pl.arms[rows]
        dv = vector_derivatives(robot, p)                                 # (k, m, 3, n)
        # The reference point's motion: the vector of an attachment at the origin.
        origin = robot.with_(attachments=np.zeros_like(robot.attachments))
        dpos = -vector_derivatives(origin, p)[:, 0]                       # (k, 3, n)
        darm = -dv - dpos[:, None]                                        # d(R a_i)
        out = np.zeros((k, 3 * m, n))
        out[:, :m] = -np.einsum("kmi,kmij->kmj", e_h, dv)                 # -dx_i
        out[:, m:2 * m] = -dv[:, :, 2, :]                                 # -dz_i
        # dF_i = H de_h, de_h = (I - e_h e_h') dv_h / x (horizontal).
        proj = np.eye(3)[None, None] - e_h[..., :, None] * e_h[..., None, :]
        proj[..., 2, :] = 0.0
        proj[..., :, 2] = 0.0
        with np.errstate(all="ignore"):
            de_h = np.einsum("kmab,kmbj->kmaj", proj, dv) / x[..., None, None]
        de_h = np.nan_to_num(de_h)
        H, V_A = self.H[rows], self.V_B[rows] - self.w * self.L0[rows]
        force = H[..., None] * e_h
        force[..., 2] += V_A
        dforce = H[..., None, None] * de_h                                # (k, m, 3, n)
        dmoment = (np.cross(darm, force[..., :, None], axisa=2, axisb=2, axisc=2)
                   + np.cross(arms[..., :, None], dforce, axisa=2, axisb=2, axisc=2))
        full = np.concatenate([dforce, dmoment], axis=2)[:, :, self.rows_w]   # (k, m, n, n)
        _, db = pose_derivatives(robot, p)
        out[:, 2 * m:2 * m + n] = full.sum(axis=1) - db
        return out
