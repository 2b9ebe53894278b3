"""Angular velocity and acceleration of a rotation-vector pose, and back.

A spatial pose turns the platform by ``R = exp([phi]x)`` (``phi`` the rotation vector,
rad). Its angular velocity in the base frame is ``omega = J(phi) phi'`` with the left
Jacobian of SO(3)::

    J(phi) = I + a(theta) K + b(theta) K^2,   K = [phi]x,  theta = |phi|,
    a = (1 - cos theta) / theta^2,   b = (theta - sin theta) / theta^3,

and its angular acceleration ``alpha = J phi'' + J' phi'`` with::

    J' phi' = a~ (phi . phi') (phi x phi') + b~ (phi . phi') phi x (phi x phi')
              + b phi' x (phi x phi'),          a~ = a'(theta) / theta, b~ = b'(theta) / theta.

Small angles use the Taylor series of ``a, b, a~, b~`` (and of the coefficient of the
inverse Jacobian), so the formulas keep full precision down to ``theta = 0``.

:func:`twist_rates` converts pose-coordinate derivatives of any robot kind into the
velocity coordinates of :mod:`tension_opt.dynamics` (linear velocity along the
position axes, angular velocity about the base axes); for kinds other than
``spatial6`` the two are the same.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.kinds import MotionPattern

__all__ = [
    "angular_acceleration",
    "angular_velocity",
    "jacobian_coefficients",
    "left_jacobian",
    "left_jacobian_inverse",
    "pose_rates",
    "rotation_vector_indices",
    "twist_rates",
]

# Below this angle (rad) the coefficients come from their Taylor series (next term
# below 1e-15 relative); above it the closed forms lose at most ~1e-13 to cancellation.
_SERIES_BELOW = 0.25
# Taylor coefficients in theta^0, theta^2, ..., theta^8.
_A = (1 / 2, -1 / 24, 1 / 720, -1 / 40320, 1 / 3628800)
_B = (1 / 6, -1 / 120, 1 / 5040, -1 / 362880, 1 / 39916800)
_DA = (-1 / 12, 1 / 180, -1 / 6720, 1 / 453600, -1 / 47900160)
_DB = (-1 / 60, 1 / 1260, -1 / 60480, 1 / 4989600, -1 / 622702080)
_INV = (1 / 12, 1 / 720, 1 / 30240, 1 / 1209600, 1 / 47900160)


def _series(coefficients: tuple[float, ...], t2: NDArray) -> NDArray:
    out = np.zeros_like(t2)
    for c in reversed(coefficients):
        out = out * t2 + c
    return out


def jacobian_coefficients(phi: NDArray) -> tuple[NDArray, ...]:
    """Coefficients ``a, b, a~, b~, c`` of the rotation-vector Jacobians, each (N,).

    ``c = 1/theta^2 - (1 + cos theta) / (2 theta sin theta)`` is the coefficient of
    ``K^2`` in the inverse Jacobian ``J^-1 = I - K / 2 + c K^2``.

    Parameters
    ----------
    phi : ndarray, shape (N, 3)
        Rotation vectors (rad).
    """
    t2 = np.einsum("ni,ni->n", phi, phi)
    t = np.sqrt(t2)
    small = t < _SERIES_BELOW
    ts = np.where(small, 1.0, t)  # safe divisor on the series branch
    s, c = np.sin(ts), np.cos(ts)
    exact = (
        (1 - c) / ts**2,
        (ts - s) / ts**3,
        (ts * s - 2 * (1 - c)) / ts**4,
        ((1 - c) * ts - 3 * (ts - s)) / ts**5,
        1 / ts**2 - (1 + c) / (2 * ts * s),
    )
    series = (_A, _B, _DA, _DB, _INV)
    return tuple(np.where(small, _series(k, t2), e) for k, e in zip(series, exact, strict=True))


def _skew(v: NDArray) -> NDArray:
    K = np.zeros((*v.shape[:-1], 3, 3))
    K[..., 0, 1], K[..., 0, 2] = -v[..., 2], v[..., 1]
    K[..., 1, 0], K[..., 1, 2] = v[..., 2], -v[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -v[..., 1], v[..., 0]
    return K


def left_jacobian(phi: NDArray) -> NDArray:
    """Left Jacobian ``J(phi)`` of SO(3), shape (N, 3, 3): ``omega = J phi'``."""
    a, b, *_ = jacobian_coefficients(phi)
    K = _skew(phi)
    return np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)


def left_jacobian_inverse(phi: NDArray) -> NDArray:
    """Inverse left Jacobian, shape (N, 3, 3): ``phi' = J^-1 omega`` (|phi| < 2 pi)."""
    *_, c = jacobian_coefficients(phi)
    K = _skew(phi)
    return np.eye(3) - 0.5 * K + c[:, None, None] * (K @ K)


def angular_velocity(phi: NDArray, phi_dot: NDArray) -> NDArray:
    """Base-frame angular velocity ``J(phi) phi'`` (rad/s), shape (N, 3)."""
    a, b, *_ = jacobian_coefficients(phi)
    cross = np.cross(phi, phi_dot)
    return phi_dot + a[:, None] * cross + b[:, None] * np.cross(phi, cross)


def angular_acceleration(phi: NDArray, phi_dot: NDArray, phi_ddot: NDArray) -> NDArray:
    """Base-frame angular acceleration ``J phi'' + J' phi'`` (rad/s^2), shape (N, 3).

    ``J' phi'`` is quadratic in ``phi'``: it is also the coefficient of ``s'^2`` along
    a path ``phi(s)`` with ``phi'`` the path derivative.
    """
    _, b, da, db, _ = jacobian_coefficients(phi)
    cross = np.cross(phi, phi_dot)
    dot = np.einsum("ni,ni->n", phi, phi_dot)[:, None]
    quadratic = (da[:, None] * dot * cross + db[:, None] * dot * np.cross(phi, cross)
                 + b[:, None] * np.cross(phi_dot, cross))
    return angular_velocity(phi, phi_ddot) + quadratic


def rotation_vector_indices(pattern: MotionPattern) -> list[int] | None:
    """Pose indices of a rotation vector (three angles), or None for other kinds."""
    angles = [i for i in range(pattern.pose_size) if i not in pattern.positions]
    return angles if len(angles) == 3 else None


def twist_rates(pattern: MotionPattern, poses: NDArray, rates: NDArray,
                rate_derivatives: NDArray) -> tuple[NDArray, NDArray]:
    """Velocities and accelerations (N, n) from pose-coordinate derivatives (N, n).

    Position coordinates are unchanged; a rotation vector's derivatives become the
    angular velocity and acceleration in the base frame. For kinds without a rotation
    vector the derivatives are returned as they are.
    """
    idx = rotation_vector_indices(pattern)
    if idx is None:
        return rates, rate_derivatives
    v, a = np.array(rates, dtype=float), np.array(rate_derivatives, dtype=float)
    phi = poses[:, idx]
    v[:, idx] = angular_velocity(phi, rates[:, idx])
    a[:, idx] = angular_acceleration(phi, rates[:, idx], rate_derivatives[:, idx])
    return v, a


def pose_rates(pattern: MotionPattern, poses: NDArray, velocities: NDArray) -> NDArray:
    """Pose-coordinate derivatives (N, n) of velocities (N, n) (inverse of
    :func:`twist_rates` for the first derivative)."""
    idx = rotation_vector_indices(pattern)
    if idx is None:
        return velocities
    out = np.array(velocities, dtype=float)
    J_inv = left_jacobian_inverse(poses[:, idx])
    out[:, idx] = np.einsum("nij,nj->ni", J_inv, velocities[:, idx])
    return out
