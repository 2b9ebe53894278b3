"""Sensitivities of the coupled sag model: tensions and lengths of catenaries whose end
forces balance the load (:func:`catenary.inverse_kinematics`, ``model="coupled"``).

A solution of the coupled model with the minimum-sum objective is a point
``u = (H, V_B, L0)`` (each cable's end forces and unstretched length, ``3 m``
unknowns) that minimises ``f(u) = sum_i T_A,i`` (the tensions at the platform)
subject to

- the two spans of every catenary equal its chord's (``2 m`` equations);
- the cables' end forces on the platform, ``H_i e_h,i + (V_Bi - w L0_i) e_z`` with
  their moments, balance the load ``b`` (``n``);
- each cable's lowest tension is at least ``t_min`` and its highest at most ``t_max``
  (:func:`catenary.geometry.extreme_tensions`); the bounds the solution is on are
  equations.

Unlike the straight model, its optimum is often inside the bounds: the equilibrium
manifold is curved, so the minimum sum can lie between vertices (the study robot's
poses mostly do). Its derivatives by a parameter ``q`` (the pose, the external
wrench, the weight per length, ``EA``) come from the KKT conditions
``grad f + G_u' lambda = 0``, ``G = 0`` differentiated at the solution's active set:

    [ H_L   G_u' ] [ du      ]     [ d(grad_u L)/dq ]
    [ G_u   0    ] [ dlambda ] = - [ dG/dq          ]

with ``H_L`` the Hessian of the Lagrangian ``L = f + lambda' G``. The first
derivatives are analytic: the catenary's flexibility and length derivative, the chord's
derivatives by the pose (:func:`tension_opt.robot.derivatives.vector_derivatives`) and
the load's (:func:`~tension_opt.robot.derivatives.pose_derivatives`), and the spans'
partials by the cable (:func:`catenary.sensitivity.span_partials`). The second
derivatives of the spans, of the tensions and by the cable's parameters are central
differences of those analytic first derivatives (a relative step of
:data:`SECOND_STEP`; about 1e-10 relative), and the equilibrium's cross terms by the
pose are analytic. ``lambda`` solves the stationarity at the solution in least squares.
A residual above :data:`STATIONARITY_TOL` marks the pose ``"not_optimal"``. An active
bound whose multiplier is near zero, or a singular system, marks it ``"degenerate"``:
there the derivative is one-sided or not unique. The tensions at the platform
(``T_A``) and at the drawing point (``T_B``) follow from ``du``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot, TensionProblem
from tension_opt.robot.derivatives import pose_derivatives, vector_derivatives

from .elastic import axial_compliance, evaluate, length_derivative
from .errors import InvalidCableError
from .geometry import cable_planes, check_robot, sagging_cable_data
from .inverse import InverseKinematicsResult, inverse_kinematics
from .sensitivity import span_partials

__all__ = ["COUPLED_WRT", "CoupledSensitivity", "coupled_jacobian", "coupled_jacobians"]

FloatArray = NDArray[np.float64]

#: What :func:`coupled_jacobian` differentiates by.
COUPLED_WRT = ("pose", "wrench", "weight_per_length", "EA", "drawing_points",
               "attachment_points")
#: Relative distance within which a cable's extreme tension is on its bound.
BOUND_TOL = 1e-7
#: Smallest size of an active bound's multiplier (per unit of the objective).
MULTIPLIER_TOL = 1e-6
#: Largest stationarity residual of the multipliers, relative to the objective's gradient.
STATIONARITY_TOL = 1e-6
#: Relative step of the central differences of the first derivatives.
SECOND_STEP = 1e-6
#: Poses per chunk of KKT systems (bounds the memory of large batches).
CHUNK = 512


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
        ``"not_optimal"`` (no multipliers make the solution stationary);
        ``"degenerate"`` (an active bound's multiplier near zero, or a singular system).
    wrt : str
        ``D`` is ``n`` for ``"pose"`` and ``"wrench"``, 1 for ``"weight_per_length"``
        and ``"EA"``; for ``"drawing_points"`` (base frame) and ``"attachment_points"``
        (platform frame) the arrays are (N, m, m, 3), ``[k, a, i, c]`` the derivative
        of cable ``a``'s value by coordinate ``c`` of cable ``i``'s point (per m).
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
    wrt : {"pose", "wrench", "weight_per_length", "EA", "drawing_points", "attachment_points"}
    wrench : array_like, optional
        The external wrench (N, N m), as in :func:`catenary.inverse_kinematics`.
    result : InverseKinematicsResult, optional
        The coupled solution of these poses with the minimum-sum objective (equal
        weights; the bounds are its problem's), if at hand; else it is solved here
        (``**options`` go to :func:`catenary.inverse_kinematics`).

    Returns
    -------
    CoupledSensitivity

    Raises
    ------
    InvalidCableError
        For an unknown ``wrt``, weightless cables, a robot with pulleys, or a result of
        another model, of another objective (or unequal weights), or of an unknown
        problem.
    """
    return coupled_jacobians(robot, poses, (wrt,), wrench, result=result, **options)[wrt]


def coupled_jacobians(robot: CableRobot, poses: ArrayLike, wrts: Sequence[str],
                      wrench: ArrayLike | None = None, *,
                      result: InverseKinematicsResult | None = None,
                      **options: Any) -> dict[str, CoupledSensitivity]:
    """:func:`coupled_jacobian` by several parameters ``wrts`` at once, each pose's KKT
    system built and factored once; a dict by ``wrt``."""
    for wrt in wrts:
        if wrt not in COUPLED_WRT:
            raise InvalidCableError(f"wrt must be one of {COUPLED_WRT}, got {wrt!r}")
    check_robot(robot)
    w, EA = sagging_cable_data(robot, "differentiate the straight distribution "
                                      "(TensionSolution.jacobian)")
    p = robot.as_poses(poses)
    if result is None:
        result = inverse_kinematics(robot, p, "coupled", "min_sum", wrench=wrench, **options)
    if result.model != "coupled" or result.lengths.shape[0] != len(p):
        raise InvalidCableError("result must be the coupled model's solution of these poses")
    lb, ub = _min_sum_bounds(robot, result.problem, len(p))
    N, m = result.lengths.shape
    n = robot.dof
    sizes = {wrt: {"pose": n, "wrench": n, "drawing_points": 3 * m,
                   "attachment_points": 3 * m}.get(wrt, 1) for wrt in wrts}
    status = np.where(result.status == "converged", "ok", "not_converged").astype(object)
    out = {wrt: [np.full((N, m, D), np.nan) for _ in range(3)] for wrt, D in sizes.items()}
    ok_rows = np.flatnonzero(status == "ok")
    # In chunks: a pose's KKT matrix is (6m + n)^2 numbers (23 kB for 8 cables).
    for rows in np.array_split(ok_rows, -(-len(ok_rows) // CHUNK)) if len(ok_rows) else []:
        kkt = _Kkt(robot, p[rows], result, rows, w, EA, (lb[rows], ub[rows]))
        status[rows[kkt.code == 1]] = "not_optimal"
        status[rows[kkt.code == 2]] = "degenerate"
        good = kkt.code == 0
        if not good.any():
            continue
        rhs = np.concatenate([kkt.rhs(wrt)[good] for wrt in wrts], axis=2)
        du_all = -np.linalg.solve(kkt.K[good], rhs)[:, :3 * m]          # (k, 3m, sum D)
        H, V_B, L0 = (a[good][..., None] for a in (kkt.H, kkt.V_B, kkt.L0))
        V_A = V_B - w * L0
        at = rows[good]
        start = 0
        for wrt in wrts:
            du = du_all[..., start:start + sizes[wrt]]
            start += sizes[wrt]
            dH, dV_B, dL0 = du[:, :m], du[:, m:2 * m], du[:, 2 * m:]
            dV_A = dV_B - w * dL0 - (L0 if wrt == "weight_per_length" else 0.0)
            out[wrt][0][at] = (H * dH + V_B * dV_B) / np.hypot(H, V_B)
            out[wrt][1][at] = (H * dH + V_A * dV_A) / np.hypot(H, V_A)
            out[wrt][2][at] = dL0
    done = {}
    for wrt, arrays in out.items():
        if wrt.endswith("points"):
            arrays = [a.reshape(N, m, m, 3) for a in arrays]
        done[wrt] = CoupledSensitivity(arrays[0], arrays[1], arrays[2],
                                       status.astype(str), wrt)
    return done


def _min_sum_bounds(robot: CableRobot, problem: TensionProblem | None, N: int
                    ) -> tuple[FloatArray, FloatArray]:
    """The tension bounds (N, m) of a minimum-sum ``problem`` with equal weights: the
    only one whose KKT system :class:`_Kkt` writes; else the package's error."""
    if problem is None:
        raise InvalidCableError(
            "result's tension problem is unknown: pass a result of "
            "catenary.inverse_kinematics(..., model='coupled', objective='min_sum') or of "
            "CoupledIK, or leave result out")
    objective = problem.objective
    name = objective if isinstance(objective, str) else objective.name
    if name != "min_sum":
        raise InvalidCableError(
            f"result answers the {name!r} objective; the coupled Jacobians differentiate the "
            "minimum-sum solution: solve with objective='min_sum', or leave result out")
    weights = problem.cable_weights(robot.m)
    if not np.allclose(weights, weights[0], rtol=1e-14, atol=0.0):
        raise InvalidCableError(
            "result answers a weighted minimum sum; the coupled Jacobians differentiate the "
            "unweighted one: solve without weights, or leave result out")
    return problem.bounds(robot, N)


def _first(H: FloatArray, V_B: FloatArray, L0: FloatArray, w: float, c: float
           ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Gradients by ``(H, V_B, L0)`` (..., 3) of each cable's spans ``x``, ``z`` and its
    tensions ``T_A``, ``T_B``: the pieces whose differences give the second derivatives."""
    EA = np.inf if c == 0.0 else 1.0 / c
    with np.errstate(all="ignore"):
        F_xx, F_xz, F_zz = evaluate(H, V_B, L0, w, c)[2:5]
        x_L, z_L = length_derivative(H, V_B, L0, w, EA)
        V_A = V_B - w * L0
        T_A, T_B = np.hypot(H, V_A), np.hypot(H, V_B)
        g_A = np.stack([H / T_A, V_A / T_A, -w * V_A / T_A], -1)
        g_B = np.stack([H / T_B, V_B / T_B, np.zeros_like(H)], -1)
    return (np.stack([F_xx, F_xz, x_L], -1), np.stack([F_xz, F_zz, z_L], -1), g_A, g_B)


class _Kkt:
    """The KKT system of a batch of coupled solutions at their active sets (module
    notes): ``K`` (k, S, S) over ``[du (3m), lambda_span (2m), y (n), lambda_bound (m)]``,
    an inactive bound's row holding its multiplier at zero; ``code`` (k,) 0 ok,
    1 not stationary, 2 degenerate."""

    def __init__(self, robot: CableRobot, poses: FloatArray, result: InverseKinematicsResult,
                 rows: NDArray[np.intp], w: float, EA: float,
                 bounds: tuple[FloatArray, FloatArray]) -> None:
        self.robot, self.poses, self.w, self.EA = robot, poses, w, EA
        self.lb, self.ub = bounds
        self.c = float(axial_compliance(np.asarray(EA, dtype=float)))
        k, m = len(rows), robot.m
        self.rows_w = list(robot.wrench_rows)
        n = len(self.rows_w)
        self.m, self.n = m, n
        planes = cable_planes(robot, poses)
        self.e_h, self.x, self.arms = planes.e_h, planes.x, planes.arms
        self.rotation = np.asarray(planes.rotation)
        self.H = result.horizontal_tensions[rows]
        self.L0 = result.lengths[rows]
        V_A = result.platform_forces[rows, :, 2]
        self.V_B = V_A + w * self.L0
        g_x, g_z, g_A, g_B = _first(self.H, self.V_B, self.L0, w, self.c)
        # Which bound each cable is on (0 none), and the gradient of that extreme tension.
        self.kind, g_bound = self._bounds(V_A, g_A, g_B)
        active = self.kind != 0
        S = 6 * m + n
        self.S = S
        K = np.zeros((k, S, S))
        G = np.zeros((k, 2 * m + n + m, 3 * m))   # constraint gradients by u
        i = np.arange(m)
        for block in range(3):
            G[:, i, block * m + i] = g_x[..., block]
            G[:, m + i, block * m + i] = g_z[..., block]
            G[:, 2 * m + n + i, block * m + i] = g_bound[..., block] * active
        e_z = np.broadcast_to(np.array([0.0, 0.0, 1.0]), self.e_h.shape)
        for block, force in ((0, self.e_h), (1, e_z), (2, -w * e_z)):
            G[:, 2 * m:2 * m + n, block * m:(block + 1) * m] = self._wrench(force)
        grad_f = np.concatenate([g_A[..., 0], g_A[..., 1], g_A[..., 2]], axis=1)
        # Multipliers: least squares of G' lambda = -grad f (inactive bounds' columns 0).
        lam = -np.einsum("krj,kj->kr", np.linalg.pinv(np.swapaxes(G, 1, 2)), grad_f)
        residual = np.abs(np.einsum("kji,kj->ki", G, lam) + grad_f).max(axis=1)
        self.lam = lam
        K[:, :3 * m, :3 * m] = self._hessian(lam, active)
        K[:, :3 * m, 3 * m:] = np.swapaxes(G, 1, 2)
        K[:, 3 * m:, :3 * m] = G
        K[:, 5 * m + n + i, 5 * m + n + i] = (~active).astype(float)
        self.K = K
        lam_b = lam[:, 2 * m + n:]
        binding = np.where(self.kind < 0, -lam_b, np.where(self.kind > 0, lam_b, np.inf))
        strict = (binding > MULTIPLIER_TOL).all(axis=1)
        with np.errstate(all="ignore"):
            cond = np.linalg.cond(K)
        code = np.zeros(k, dtype=np.int8)
        code[~(residual <= STATIONARITY_TOL * np.abs(grad_f).max(axis=1))] = 1
        code[(code == 0) & ~(strict & (cond < 1e12))] = 2
        self.code = code

    def _bounds(self, V_A: FloatArray, g_A: FloatArray, g_B: FloatArray
                ) -> tuple[NDArray[np.int8], FloatArray]:
        """Per cable, -1 on ``t_min``, +1 on ``t_max``, 0 on neither, and the gradient
        (k, m, 3) of the extreme tension that is on it."""
        H, V_B = self.H, self.V_B
        T_A, T_B = np.hypot(H, V_A), np.hypot(H, V_B)
        dip = (V_A < 0) & (V_B > 0)
        low = np.where(dip, H, np.minimum(T_A, T_B))
        high = np.maximum(T_A, T_B)
        t_min, t_max = self.lb, self.ub
        on_min = np.abs(low - t_min) <= BOUND_TOL * np.maximum(t_min, 1.0)
        on_max = np.isfinite(t_max) & (np.abs(high - t_max) <= BOUND_TOL * t_max) & ~on_min
        kind = np.where(on_min, -1, np.where(on_max, 1, 0)).astype(np.int8)
        g_H = np.zeros_like(g_A)
        g_H[..., 0] = 1.0
        low_at_A = (T_A <= T_B)[..., None]
        g_low = np.where(dip[..., None], g_H, np.where(low_at_A, g_A, g_B))
        g_high = np.where(low_at_A, g_B, g_A)
        return kind, np.where(on_min[..., None], g_low, g_high)

    def _wrench(self, force: FloatArray) -> FloatArray:
        """The wrench rows (k, n, m) of per-cable forces (k, m, 3) at the attachments."""
        full = np.concatenate([force, np.cross(self.arms, force)], axis=-1)
        return np.swapaxes(full[..., self.rows_w], 1, 2)

    def _pieces_by(self, which: int, step: FloatArray) -> list[FloatArray]:
        """Central differences of :func:`_first`'s pieces along unknown ``which`` (0 H,
        1 V_B, 2 L0) of every cable, over ``step`` (k, m)."""
        u = [self.H, self.V_B, self.L0]
        plus, minus = list(u), list(u)
        plus[which], minus[which] = u[which] + step, u[which] - step
        hi = _first(plus[0], plus[1], plus[2], self.w, self.c)
        lo = _first(minus[0], minus[1], minus[2], self.w, self.c)
        return [(a - b) / (2 * step[..., None]) for a, b in zip(hi, lo, strict=True)]

    def _weights(self, lam: FloatArray, active: NDArray[np.bool_]) -> list[FloatArray]:
        """The multipliers (k, m) that weigh :func:`_first`'s four pieces in the
        Lagrangian: the spans', and the objective's plus the active bound's on T_A, T_B."""
        m, n = self.m, self.n
        lam_b = np.where(active, lam[:, 2 * m + n:], 0.0)
        V_A = self.V_B - self.w * self.L0
        T_A, T_B = np.hypot(self.H, V_A), np.hypot(self.H, self.V_B)
        lower = (self.kind < 0) & ~((V_A < 0) & (self.V_B > 0))  # a dip bounds H, linear
        upper = self.kind > 0
        on_A = (lower & (T_A <= T_B)) | (upper & (T_A > T_B))
        on_B = (lower & (T_A > T_B)) | (upper & (T_A <= T_B))
        return [lam[:, :m], lam[:, m:2 * m], 1.0 + np.where(on_A, lam_b, 0.0),
                np.where(on_B, lam_b, 0.0)]

    def _hessian(self, lam: FloatArray, active: NDArray[np.bool_]) -> FloatArray:
        """``H_L`` (k, 3m, 3m): block diagonal by cable, by differences of the pieces."""
        k, m = self.H.shape
        out = np.zeros((k, 3 * m, 3 * m))
        weights = self._weights(lam, active)
        i = np.arange(m)
        scales = (np.hypot(self.H, self.V_B), np.hypot(self.H, self.V_B), self.L0)
        for col in range(3):
            diffs = self._pieces_by(col, SECOND_STEP * scales[col])
            block = np.sum([wt[..., None] * d for wt, d in zip(weights, diffs, strict=True)],
                           axis=0)
            for row in range(3):
                out[:, row * m + i, col * m + i] = block[..., row]
        return 0.5 * (out + np.swapaxes(out, 1, 2))

    def rhs(self, wrt: str) -> FloatArray:
        """The right-hand sides (k, S, D): ``d(grad_u L)/dq`` over ``dG/dq``."""
        m, n = self.m, self.n
        k = len(self.H)
        if wrt == "wrench":  # G holds W - b with b = -(w_g + wrench)
            out = np.zeros((k, self.S, n))
            out[:, 5 * m:5 * m + n] = np.eye(n)
            return out
        if wrt == "pose":
            return self._by_pose()
        if wrt in ("drawing_points", "attachment_points"):
            return self._by_points(wrt)
        return self._by_cable(wrt)

    def _by_cable(self, wrt: str) -> FloatArray:
        """By the weight per length or ``EA`` (k, S, 1): central differences of the
        Lagrangian's gradient and of the constraints in the parameter."""
        m, n = self.m, self.n
        k = len(self.H)
        out = np.zeros((k, self.S, 1))
        if wrt == "EA" and self.c == 0.0:
            return out  # an inextensible cable: d/dEA = -c^2 d/dc = 0
        active = self.kind != 0
        weights = self._weights(self.lam, active)
        base = self.w if wrt == "weight_per_length" else self.c
        h = SECOND_STEP * base
        pieces = []
        for value in (base + h, base - h):
            w, c = (value, self.c) if wrt == "weight_per_length" else (self.w, value)
            pieces.append(_first(self.H, self.V_B, self.L0, w, c))
        grad = np.sum([wt[..., None] * (a - b) / (2 * h)
                       for wt, a, b in zip(weights, pieces[0], pieces[1], strict=True)],
                      axis=0)
        y = self.lam[:, 2 * m:2 * m + n]
        part = span_partials(self.H, self.V_B, self.L0, self.w, self.EA)
        if wrt == "weight_per_length":
            # d(dW/dL0)/dw = -[e_z; r x e_z], weighed by y.
            e_z = np.zeros((k, m, 3))
            e_z[..., 2] = -1.0
            grad[..., 2] += np.einsum("knm,kn->km", self._wrench(e_z), y)
            out[:, 3 * m:4 * m, 0], out[:, 4 * m:5 * m, 0] = part.x_w, part.z_w
            e_z[..., 2] = -self.L0
            out[:, 5 * m:5 * m + n, 0] = self._wrench(e_z).sum(axis=2)
            bound = self.K[:, 5 * m + n:, 2 * m:3 * m]  # -w V_A / T_A on end-A rows
            out[:, 5 * m + n:, 0] = np.einsum("krc,kc->kr", bound, self.L0) / self.w
        else:
            grad = grad * (-self.c * self.c)  # d/dEA = -c^2 d/dc
            out[:, 3 * m:4 * m, 0] = -self.c * self.c * part.x_c
            out[:, 4 * m:5 * m, 0] = -self.c * self.c * part.z_c
        out[:, :3 * m, 0] = np.concatenate([grad[..., 0], grad[..., 1], grad[..., 2]], axis=1)
        return out

    def _by_pose(self) -> FloatArray:
        """By the pose (k, S, n)."""
        robot, p = self.robot, self.poses
        dv = vector_derivatives(robot, p)                                 # (k, m, 3, n)
        # The reference point's motion: the vector of an attachment at the origin.
        origin = robot.with_(attachments=np.zeros_like(robot.attachments))
        dpos = -vector_derivatives(origin, p)[:, 0]                       # (k, 3, n)
        _, db = pose_derivatives(robot, p)
        return self._by_geometry(dv, -dv - dpos[:, None], db)

    def _by_points(self, wrt: str) -> FloatArray:
        """By the drawing points (base frame) or the attachment points (platform frame),
        (k, S, 3m), column ``3 i + c`` for coordinate ``c`` of cable ``i``: a cable's
        points move its own chord (and its arm) only."""
        k, m = self.H.shape
        dv = np.zeros((k, m, 3, 3 * m))
        darm = np.zeros_like(dv)
        for i in range(m):
            if wrt == "drawing_points":
                dv[:, i, :, 3 * i:3 * i + 3] = np.eye(3)
            else:  # v = D - p - R a, arm = R a
                dv[:, i, :, 3 * i:3 * i + 3] = -self.rotation
                darm[:, i, :, 3 * i:3 * i + 3] = self.rotation
        return self._by_geometry(dv, darm, np.zeros((k, self.n, 3 * m)))

    def _by_geometry(self, dv: FloatArray, darm: FloatArray, db: FloatArray) -> FloatArray:
        """The right-hand sides (k, S, D) of a motion of the chords ``dv`` (k, m, 3, D),
        of the arms ``darm`` (same shape) and of the load ``db`` (k, n, D): the span
        rows, the forces' and arms' motion in the equilibrium rows and, weighed by
        ``y``, in the gradient rows."""
        m, n = self.m, self.n
        k, D = len(dv), dv.shape[-1]
        e_h, x, arms = self.e_h, self.x, self.arms
        proj = np.eye(3)[None, None] - e_h[..., :, None] * e_h[..., None, :]
        proj[..., 2, :] = 0.0
        proj[..., :, 2] = 0.0
        with np.errstate(all="ignore"):
            de_h = np.nan_to_num(np.einsum("kmab,kmbj->kmaj", proj, dv) / x[..., None, None])
        e_z = np.zeros((k, m, 3))
        e_z[..., 2] = 1.0

        def wrench_rows(force: FloatArray, dforce: FloatArray) -> FloatArray:
            """d[f; r x f] (k, m, n_rows, D) of forces ``force`` (k, m, 3) moving by
            ``dforce`` (k, m, 3, D) with their arms."""
            moment = (np.cross(darm, force[..., :, None], axisa=2, axisb=2, axisc=2)
                      + np.cross(arms[..., :, None], dforce, axisa=2, axisb=2, axisc=2))
            return np.concatenate([dforce, moment], axis=2)[:, :, self.rows_w]

        V_A = self.V_B - self.w * self.L0
        force = self.H[..., None] * e_h
        force[..., 2] += V_A
        out = np.zeros((k, self.S, D))
        y = self.lam[:, 2 * m:2 * m + n]
        # Gradient rows: y . d(dW/du_i)/dq; dW/dL0 = -w dW/dV_B.
        by_H = np.einsum("kmrj,kr->kmj", wrench_rows(e_h, de_h), y)
        by_V = np.einsum("kmrj,kr->kmj", wrench_rows(e_z, np.zeros_like(dv)), y)
        out[:, :3 * m] = np.concatenate([by_H, by_V, -self.w * by_V], axis=1)
        out[:, 3 * m:4 * m] = -np.einsum("kmi,kmij->kmj", e_h, dv)        # -dx_i
        out[:, 4 * m:5 * m] = -dv[:, :, 2, :]                             # -dz_i
        dforce = self.H[..., None, None] * de_h
        out[:, 5 * m:5 * m + n] = wrench_rows(force, dforce).sum(axis=1) - db
        return out
