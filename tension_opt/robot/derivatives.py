"""Analytic derivatives of the structure matrix and of the required wrench.

The equilibrium of a pose reads ``A(p) T = b(p, w)`` (:mod:`tension_opt.robot.model`):
column ``i`` of ``A`` is the kind's rows of ``[u_i; r_i x u_i]`` with ``r_i = R a_i`` the
arm of attachment ``a_i``, ``v_i = A_i - p - r_i`` the cable vector to the drawing point
``A_i``, ``L_i = |v_i|`` and ``u_i = v_i / L_i``; ``b = -(w_g + w)`` with gravity
``w_g = [f; (R c) x f]``, ``f = (0, 0, -m g)``. Differentiating:

- ``du = Pi dv`` with ``Pi = (I - u u') / L``;
- ``d(r x u) = dr x u + r x du = -[u]x dr + [r]x du``;
- a pose step moves the platform by ``dp_t = S dp`` (translation) and turns it by a
  small rotation ``omega = W(p) dp`` about the base axes (left-multiplied,
  ``dR = [omega]x R``, so ``dr = omega x r``). For a rotation vector ``theta``
  (``"spatial6"``) ``W`` is the left Jacobian of SO(3),
  ``J_l = I + (1 - cos phi) / phi^2 [theta]x + (phi - sin phi) / phi^3 [theta]x^2``,
  ``phi = |theta|``; for ``"planar3"`` it is the constant map of the angle to the z axis.
- a drawing point moves ``v_i`` by ``dA_i``; an attachment (platform frame) moves
  ``r_i`` by ``R da_i`` and ``v_i`` by ``-R da_i``.

All derivatives are vectorised over poses, in SI units (N per m for a column's force
rows per metre of displacement, and so on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.kinds import PlanarBody, SpatialBody
from tension_opt.robot.model import CableRobot
from tension_opt.robot.pulleys import pulley_arrays, swivel_turn

__all__ = [
    "CableFrames",
    "cable_frames",
    "column_derivatives",
    "left_jacobian",
    "pose_derivatives",
    "skew",
    "vector_derivatives",
]


def skew(v: NDArray) -> NDArray:
    """Cross-product matrices ``[v]x`` of vectors ``v`` (..., 3), shape (..., 3, 3)."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def left_jacobian(theta: NDArray) -> NDArray:
    """Left Jacobians of SO(3) at rotation vectors ``theta`` (N, 3) (rad), shape (N, 3, 3).

    ``exp([theta + d]x) = exp([J_l(theta) d]x) exp([theta]x)`` to first order in ``d``;
    near ``phi = 0`` the coefficients are taken from their Taylor series.
    """
    phi2 = np.einsum("ni,ni->n", theta, theta)
    phi = np.sqrt(phi2)
    small = phi < 1e-4
    safe = np.where(small, 1.0, phi)
    a = np.where(small, 0.5 - phi2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    b = np.where(small, 1.0 / 6.0 - phi2 / 120.0, (safe - np.sin(safe)) / safe**3)
    K = skew(theta)
    return np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)


@dataclass(frozen=True)
class CableFrames:
    """The straight cables of a batch of poses, with what their derivatives need.

    Attributes
    ----------
    A : ndarray, shape (N, n, m)
        Structure matrices.
    unit : ndarray, shape (N, m, 3)
        Unit vectors ``u_i`` from attachment to drawing point.
    arms : ndarray, shape (N, m, 3)
        Arms ``r_i = R a_i`` (m).
    projector : ndarray, shape (N, m, 3, 3)
        ``(I - u u') / L`` (1/m).
    R : ndarray, shape (N, 3, 3)
        Platform rotations.
    rows : list of int
        The kind's rows of the spatial wrench.
    """

    A: NDArray
    unit: NDArray
    arms: NDArray
    projector: NDArray
    R: NDArray
    rows: list[int]


def cable_frames(robot: CableRobot, poses: ArrayLike) -> CableFrames:
    """:class:`CableFrames` of ``poses`` (N, n) from the robot's own geometry.

    Over a guide pulley the cable's direction also turns with the wheel when the
    attachment point moves sideways: the projector takes the rank-one correction of
    :func:`tension_opt.robot.pulleys.swivel_turn`.
    """
    geometry = robot.cable_geometry(poses)
    u = geometry.unit
    eye = np.eye(3)
    projector = (eye - u[..., :, None] * u[..., None, :]) / geometry.lengths[..., None, None]
    if robot.pulleys is not None:
        idx, radii, axes = pulley_arrays(robot.pulleys)
        assert geometry.wrapped is not None
        normal, rate = swivel_turn(robot.anchors[idx], axes, radii,
                                   geometry.attachment_points[:, idx],
                                   geometry.wrapped[:, idx] / radii)
        turn = (rate / geometry.lengths[:, idx])[..., None, None]
        projector[:, idx] -= turn * normal[..., :, None] * normal[..., None, :]
    return CableFrames(
        robot.structure_from(geometry),
        u,
        np.asarray(geometry.arms),
        projector,
        np.asarray(geometry.rotation),
        list(robot.wrench_rows),
    )


def _rotation_map(robot: CableRobot, poses: NDArray) -> NDArray | None:
    """``W`` (N, 3, n): small base-frame rotation per pose step; None if nothing turns."""
    pattern = robot.pattern
    if not pattern.rotates:
        return None
    if isinstance(pattern, SpatialBody):
        W = np.zeros((len(poses), 3, robot.dof))
        W[:, :, 3:] = left_jacobian(np.asarray(poses[:, 3:], dtype=float))
        return W
    if isinstance(pattern, PlanarBody):
        return np.broadcast_to(pattern.step_maps()[1], (len(poses), 3, robot.dof))
    raise InvalidInputError(
        f"derivatives with respect to the pose of a {pattern.name!r} robot are not known: "
        "use a kind of tension_opt.kinds.KINDS (point3, planar_point2, planar3, spatial6)"
    )


def _full_columns(frames: CableFrames, du: NDArray, dr: NDArray) -> NDArray:
    """Derivatives of the kind's rows of ``[u; r x u]`` from ``du`` and ``dr``
    (N, m, 3, d), shape (N, m, n, d)."""
    moment = -(skew(frames.unit) @ dr) + skew(frames.arms) @ du
    full = np.concatenate([du, moment], axis=-2)
    return full[..., frames.rows, :]


def _vector_steps(robot: CableRobot, p: NDArray, arms: NDArray, W: NDArray | None
                  ) -> tuple[NDArray, NDArray]:
    """``dv/dp`` of the cable vectors and ``dr/dp`` of the arms, (N, m, 3, n) each."""
    N, n = p.shape
    translation = robot.pattern.step_maps()[0]  # (3, n)
    dv = np.broadcast_to(-translation, (N, robot.m, 3, n)).copy()
    if W is None:
        return dv, np.zeros_like(dv)
    # dr = omega x r = -[r]x W dp, and dv = -dp_t - dr.
    dr = -(skew(arms) @ W[:, None])
    return dv - dr, dr


def vector_derivatives(robot: CableRobot, poses: ArrayLike) -> NDArray:
    """Derivatives of the cable vectors ``v_i = A_i - p - R a_i`` (attachment point to
    drawing point) by the pose, shape (N, m, 3, n) (m per m, m per rad).

    Parameters
    ----------
    robot : CableRobot
        Any; over a guide pulley ``v_i`` still ends on the drawing point, not on the
        exit point.
    poses : array_like, shape (N, n)
        Poses (m, rad), in the robot's own coordinates.
    """
    p = robot.as_poses(poses)
    frames = cable_frames(robot, p)
    return _vector_steps(robot, p, frames.arms, _rotation_map(robot, p))[0]


def pose_derivatives(
    robot: CableRobot, poses: ArrayLike, frames: CableFrames | None = None
) -> tuple[NDArray, NDArray]:
    """Derivatives of the structure matrices and of the required wrench by the pose.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n)
        Poses (m, rad), in the robot's own coordinates (a rotation vector for
        ``"spatial6"``).
    frames : CableFrames, optional
        :func:`cable_frames` of the poses, if at hand.

    Returns
    -------
    dA : ndarray, shape (N, n, m, n)
        ``dA[k, :, i, j] = d A[k, :, i] / d p[k, j]`` (per m or per rad).
    db : ndarray, shape (N, n, n)
        ``d b / d p`` of the required wrench ``b = -(w_g + w)`` (N per m, N m per rad).
    """
    p = robot.as_poses(poses)
    frames = cable_frames(robot, p) if frames is None else frames
    N, n = p.shape
    W = _rotation_map(robot, p)
    dv, dr = _vector_steps(robot, p, frames.arms, W)
    du = frames.projector @ dv
    dcol = _full_columns(frames, du, dr)  # (N, m, n, n)
    db = np.zeros((N, n, n))
    if W is not None and robot.com.any():
        # d((R c) x f) = (omega x R c) x f = [f]x [R c]x omega; b takes it negated.
        force = np.array([0.0, 0.0, -robot.mass * robot.g])
        full = np.zeros((N, 6, n))
        full[:, 3:] = -(skew(force) @ skew(frames.R @ robot.com) @ W)
        db = full[:, frames.rows]
    return np.moveaxis(dcol, 1, 2), db


def column_derivatives(
    robot: CableRobot, poses: ArrayLike, wrt: str, frames: CableFrames | None = None
) -> NDArray:
    """Derivatives of each column of the structure matrices by its own cable's
    drawing point or attachment.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n)
    wrt : {"drawing_points", "attachment_points"}
        Drawing points ``A_i`` in the base frame, or attachments ``a_i`` in the
        platform frame (m).
    frames : CableFrames, optional
        :func:`cable_frames` of the poses, if at hand.

    Returns
    -------
    ndarray, shape (N, m, n, 3)
        ``d A[k, :, i] / d point_i`` (1/m for force rows, dimensionless for moments);
        column ``i`` depends on no other cable's points.
    """
    p = robot.as_poses(poses)
    frames = cable_frames(robot, p) if frames is None else frames
    N, m = len(p), robot.m
    if wrt == "drawing_points":
        du = frames.projector
        dr = np.zeros((N, m, 3, 3))
    elif wrt == "attachment_points":
        R = frames.R[:, None]
        du = -(frames.projector @ R)
        dr = np.broadcast_to(R, (N, m, 3, 3))
    else:
        raise InvalidInputError(f"wrt must be 'drawing_points' or 'attachment_points', got {wrt!r}")
    return _full_columns(frames, du, dr)
