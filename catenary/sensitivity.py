"""Sensitivities of the sag-compensated cable lengths (the thesis convention).

In the thesis convention (:func:`catenary.inverse_kinematics`, ``model="thesis"``) each
cable's unstretched length ``L0`` solves, with its end forces ``u = (H, V_B, L0)``,

    G(u, q) = ( x(H, V_B, L0; w, c) - x_t,
                z(H, V_B, L0; w, c) - z_t,
                H^2 + V_B^2 - T^2 )                 = 0

for its spans ``x_t, z_t`` (the chord's horizontal and vertical extent), the tension
``T`` imposed at the drawing point, the weight per length ``w`` and the axial
compliance ``c = 1 / EA``. By the implicit function theorem
``du/dq = -(dG/du)^-1 dG/dq``, where

- ``dG/du = [[F_xx, F_xz, x_L], [F_xz, F_zz, z_L], [2H, 2V_B, 0]]``: the catenary's
  analytic flexibility (:func:`catenary.flexibility`) and ``d(x, z)/dL0``
  (:func:`catenary.elastic.length_derivative`);
- at fixed end forces and length, with ``x_c, z_c`` the inextensible spans and ``V_A =
  V_B - w L0``: ``dx/dw = -x_c / w + L0 H / (w T_A)``, ``dz/dw = -z_c / w + L0 V_A /
  (w T_A) - c L0^2 / 2``, ``dx/dc = H L0``, ``dz/dc = V_B L0 - w L0^2 / 2``.

With respect to the pose the spans move with the cable vector ``v`` (``dx = e_h . dv``,
``dz = dv_z``, :func:`tension_opt.robot.derivatives.vector_derivatives`) and the
tension with the straight-line optimum (:meth:`tension_opt.TensionSolution.jacobian`),
so ``dL0/dp = L_x dx/dp + L_z dz/dp + L_T dT/dp``; where that optimum has no
derivative (a face of optima, a degenerate active set) the pose gets its status and NaN.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot
from tension_opt.robot.derivatives import vector_derivatives

from .elastic import axial_compliance, evaluate, length_derivative
from .errors import InvalidCableError
from .geometry import cable_planes, check_robot, sagging_cable_data
from .solve import solve_length

__all__ = ["LENGTH_WRT", "LengthPartials", "LengthSensitivity", "SpanPartials",
           "length_jacobian", "length_partials", "span_partials"]

FloatArray = NDArray[np.float64]

#: What :func:`length_jacobian` differentiates by.
LENGTH_WRT = ("pose", "tensions", "weight_per_length", "EA")


@dataclass(frozen=True)
class LengthPartials:
    """Partial derivatives of each cable's unstretched length ``L0`` in the thesis
    convention, shape S each (module notes).

    Attributes
    ----------
    L0 : ndarray
        The lengths (m).
    d_x, d_z : ndarray
        By the horizontal and vertical spans (m/m).
    d_T : ndarray
        By the tension at the drawing point (m/N).
    d_w : ndarray
        By the weight per length (m per N/m).
    d_EA : ndarray
        By the axial stiffness (m/N); 0 for an inextensible cable.
    converged : ndarray of bool
        Where the catenary was solved; NaN derivatives elsewhere.
    """

    L0: FloatArray
    d_x: FloatArray
    d_z: FloatArray
    d_T: FloatArray
    d_w: FloatArray
    d_EA: FloatArray
    converged: NDArray[np.bool_]


@dataclass(frozen=True)
class SpanPartials:
    """Derivatives of an elastic catenary's spans at fixed end forces ``(H, V_B)`` and
    unstretched length ``L0`` (module notes), each of the cables' shape.

    Attributes
    ----------
    x_w, z_w : ndarray
        By the weight per length (m per N/m).
    x_c, z_c : ndarray
        By the axial compliance ``c = 1 / EA`` (m per 1/N).
    """

    x_w: FloatArray
    z_w: FloatArray
    x_c: FloatArray
    z_c: FloatArray


def span_partials(H: ArrayLike, V_B: ArrayLike, L0: ArrayLike, w: float,
                  EA: float = np.inf) -> SpanPartials:
    """:class:`SpanPartials` of catenaries with end forces ``H``, ``V_B`` (N), length
    ``L0`` (m), weight per length ``w`` (N/m, > 0) and axial stiffness ``EA`` (N)."""
    H, V_B, L0 = (np.asarray(a, dtype=float) for a in (H, V_B, L0))
    c = float(axial_compliance(np.asarray(EA, dtype=float)))
    _, z, _, _, _, x_inext, T_A, _ = evaluate(H, V_B, L0, w, c)
    V_A = V_B - w * L0
    with np.errstate(all="ignore"):
        z_inext = z - c * (V_B * L0 - 0.5 * w * L0 * L0)
        x_w = -x_inext / w + L0 * H / (w * T_A)
        z_w = -z_inext / w + L0 * V_A / (w * T_A) - 0.5 * c * L0 * L0
    return SpanPartials(x_w, z_w, H * L0, V_B * L0 - 0.5 * w * L0 * L0)


def length_partials(x: ArrayLike, z: ArrayLike, T: ArrayLike, w: float,
                    EA: float = np.inf) -> LengthPartials:
    """:class:`LengthPartials` of taut catenaries with spans ``x`` (>= 0), ``z`` (m) and
    the tension ``T`` (N) at the upper end B, weight per length ``w`` (N/m, > 0) and
    axial stiffness ``EA`` (N), all broadcast to a shape S."""
    x, z, T = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (x, z, T)))
    sol = solve_length(x, z, T, w, EA, "B", compiled=False)
    H, V_B, L0 = sol.H, sol.V_B, sol.L0
    c = float(axial_compliance(np.asarray(EA, dtype=float)))
    F_xx, F_xz, F_zz = evaluate(H, V_B, L0, w, c)[2:5]
    x_L, z_L = length_derivative(H, V_B, L0, w, EA)
    part = span_partials(H, V_B, L0, w, EA)
    J_u = np.stack([np.stack([F_xx, F_xz, x_L], -1), np.stack([F_xz, F_zz, z_L], -1),
                    np.stack([2 * H, 2 * V_B, np.zeros_like(H)], -1)], -2)
    zero = np.zeros_like(H)
    # Columns: x_t, z_t, T, w, c.
    J_q = np.stack([np.stack([-np.ones_like(H), zero, zero, part.x_w, part.x_c], -1),
                    np.stack([zero, -np.ones_like(H), zero, part.z_w, part.z_c], -1),
                    np.stack([zero, zero, -2 * T, zero, zero], -1)], -2)
    ok = np.asarray(sol.converged, dtype=bool) & np.isfinite(J_u).all(axis=(-2, -1))
    du = np.full(J_q.shape, np.nan)
    with np.errstate(all="ignore"):
        if ok.any():
            du[ok] = -np.linalg.solve(J_u[ok], J_q[ok])
    dL = du[..., 2, :]
    d_EA = -c * c * dL[..., 4]  # d/dEA = -c^2 d/dc
    return LengthPartials(L0, dL[..., 0], dL[..., 1], dL[..., 2], dL[..., 3],
                          np.where(c == 0.0, 0.0, d_EA), ok)


def _partials_where(rows: NDArray[np.bool_], x: FloatArray, z: FloatArray, T: FloatArray,
                    w: float, EA: float) -> LengthPartials:
    """:func:`length_partials` of the poses in ``rows`` (N,); NaN (not converged) in
    the others, whose tensions the straight-line distribution did not find."""
    N, m = x.shape
    out = [np.full((N, m), np.nan) for _ in range(6)]
    converged = np.zeros((N, m), dtype=bool)
    if rows.any():
        part = length_partials(x[rows], z[rows], T[rows], w, EA)
        for arr, got in zip(out, (part.L0, part.d_x, part.d_z, part.d_T, part.d_w,
                                  part.d_EA), strict=True):
            arr[rows] = got
        converged[rows] = part.converged
    L0, d_x, d_z, d_T, d_w, d_EA = out
    return LengthPartials(L0, d_x, d_z, d_T, d_w, d_EA, converged)


@dataclass(frozen=True, eq=False)
class LengthSensitivity:
    """Jacobians of the thesis convention's unstretched lengths, with a status per pose.

    Attributes
    ----------
    jacobian : ndarray
        ``d L0 / d wrt``: (N, m, n) for ``"pose"`` (m per m, m per rad); (N, m) for
        ``"tensions"`` (each cable's own tension at its drawing point, geometry fixed,
        m/N), ``"weight_per_length"`` (m per N/m) and ``"EA"`` (m/N). NaN where the
        status is not ``"ok"``.
    status : ndarray of str, shape (N,)
        ``"ok"``; ``"not_optimal"`` (no straight-line tensions within the bounds);
        ``"catenary_failed"`` (no length); or, for ``"pose"``, the status of the
        straight-line optimum's derivative (``"non_unique"``, ``"degenerate"``;
        :class:`tension_opt.distribution.sensitivity.Sensitivity`).
    wrt : str
    lengths : ndarray, shape (N, m)
        The lengths differentiated (m).
    """

    jacobian: FloatArray
    status: NDArray[np.str_]
    wrt: str
    lengths: FloatArray

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Poses whose Jacobian exists, shape (N,) of bool."""
        return np.asarray(self.status == "ok", dtype=bool)


def length_jacobian(robot: CableRobot, poses: ArrayLike, wrt: str,
                    objective: Any = "min_sum", backend: Any = "auto",
                    wrench: ArrayLike | None = None, **options: Any) -> LengthSensitivity:
    """Jacobian of the sag-compensated lengths of the thesis convention
    (:func:`catenary.inverse_kinematics` with ``model="thesis"``), by the implicit
    function theorem on the catenary equations (module notes).

    Parameters
    ----------
    robot : CableRobot
        With cable properties, weight per length > 0, no guide pulleys.
    poses : array_like, shape (N, n) or (n,)
        Poses (m, rad).
    wrt : {"pose", "tensions", "weight_per_length", "EA"}
        What to differentiate by (:class:`LengthSensitivity`).
    objective, backend, wrench, **options
        As in :func:`catenary.inverse_kinematics`: the straight-line distribution.

    Returns
    -------
    LengthSensitivity

    Raises
    ------
    InvalidCableError
        For an unknown ``wrt``, weightless cables or a robot with pulleys.
    """
    if wrt not in LENGTH_WRT:
        raise InvalidCableError(f"wrt must be one of {LENGTH_WRT}, got {wrt!r}")
    check_robot(robot)
    w, EA = sagging_cable_data(robot, "their lengths are the straight ones "
                                      "(robot.inverse_kinematics)")
    p = robot.as_poses(poses)
    straight = tension_opt.distribute(robot, p, objective, backend, wrench=wrench, **options)
    planes = cable_planes(robot, p)
    solved = np.asarray(straight.success, dtype=bool)
    part = _partials_where(solved, planes.x, planes.z, straight.tensions, w, EA)
    status = np.where(solved, np.where(part.converged.all(axis=1), "ok", "catenary_failed"),
                      "not_optimal")
    if wrt == "pose":
        dv = vector_derivatives(robot, p)  # (N, m, 3, n)
        dx = np.einsum("nmi,nmij->nmj", planes.e_h, dv)
        dz = dv[:, :, 2, :]
        sens = straight.jacobian("pose", robot=robot, poses=p)
        status = np.where((status == "ok") & (sens.status != "ok"), sens.status, status)
        jac = (part.d_x[..., None] * dx + part.d_z[..., None] * dz
               + part.d_T[..., None] * sens.jacobian)
    else:
        jac = {"tensions": part.d_T, "weight_per_length": part.d_w, "EA": part.d_EA}[wrt]
    jac = np.where((status == "ok").reshape((-1,) + (1,) * (jac.ndim - 1)), jac, np.nan)
    return LengthSensitivity(jac, status.astype(str), wrt, part.L0)
