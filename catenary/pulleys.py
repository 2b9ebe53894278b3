"""Sagging cables over swivel guide pulleys: where a catenary leaves its wheel.

A straight cable leaves its pulley (:mod:`tension_opt.robot.pulleys`) along the line to
the attachment point ``B``. A sagging one leaves it tangentially to the catenary, which
starts more steeply than the chord: its exit point ``T'`` sits further round the wheel,
and both the wrapped arc and the free span change.

With a vertical swivel axis (``axis = -e_z``, the winch below, or ``+e_z``) the wheel
turns in the vertical plane through ``B``, which is the catenary's plane, so only the
wrap angle ``beta`` is unknown. In the wheel's coordinates (``axis``, ``h``: the
horizontal unit vector from the axis towards ``B``) the cable travels along
``-cos(beta) axis + sin(beta) h`` at ``T'``; the catenary from ``T'`` down to ``B``
travels along ``(H e - V_B e_z) / T``, ``e`` the horizontal unit vector from ``T'``
towards ``B``, ``H`` and ``V_B`` its horizontal force and vertical force at ``T'``. Both
agree when::

    beta = atan2(H (e . h), s V_B) mod 2 pi,     s = axis . e_z = +-1

:func:`settle_wraps` solves it by fixed-point iteration from the straight wrap angle:
``T'`` moves on a wheel of radius ``r`` against a span ``l`` of metres, so each step
shrinks the error by about ``r / l`` and a few steps reach rounding.

The arc on the wheel carries the tension at ``T'`` (a frictionless pulley), so its
unstretched length is ``r beta / (1 + T / EA)``.

A pulley whose axis is not vertical would turn out of the catenary's plane: that needs
the swivel angle as a second unknown, and is refused here with an error.

Straight elastic cables over pulleys (any axis) have their platform-end stiffness in
:func:`pulley_cable_stiffness`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot
from tension_opt.robot.derivatives import cable_frames
from tension_opt.robot.pulleys import pulley_exits

from .errors import InvalidCableError
from .geometry import E_Z, CablePlanes, planes_along
from .solve import solve_length

__all__ = ["MAX_WRAP_STEPS", "WRAP_TOL", "PulleySag", "WheelFrames", "pulley_cable_stiffness",
           "settle_wraps", "vertical_pulleys"]

FloatArray = NDArray[np.float64]

#: The wrap angles are settled when a step moves them less than this (rad).
WRAP_TOL = 1e-13
#: Steps of the fixed-point iteration before the cable is reported not converged.
MAX_WRAP_STEPS = 60


def vertical_pulleys(robot: CableRobot) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """Indices (k,) of the cables with a pulley, their radii (k,) and axis signs
    ``s = axis . e_z`` (k,).

    Raises
    ------
    InvalidCableError
        For a pulley whose swivel axis is not vertical (the sag model turns the wheel
        in the catenary's vertical plane only).
    """
    assert robot.pulleys is not None
    idx = np.array([i for i, q in enumerate(robot.pulleys) if q is not None], dtype=np.intp)
    axes = np.array([robot.pulleys[i].axis for i in idx])  # type: ignore[union-attr]
    tilted = np.abs(axes[:, :2]).max(axis=1) > 1e-12
    if tilted.any():
        i = int(idx[np.argmax(tilted)])
        raise InvalidCableError(
            f"cable {i}'s pulley axis {axes[np.argmax(tilted)].tolist()} is not vertical: "
            "with sag, a pulley turns in the cable's vertical plane only when its swivel "
            "axis is vertical ([0, 0, -1] or [0, 0, 1]); the straight kinematics "
            "(robot.inverse_kinematics) take any axis")
    radii = np.array([robot.pulleys[i].radius for i in idx])  # type: ignore[union-attr]
    return idx, radii, np.sign(axes[:, 2])


@dataclass(frozen=True)
class PulleySag:
    """Sagging free spans of a robot with vertical-axis pulleys, for a batch of poses.

    Attributes
    ----------
    planes : CablePlanes
        The free spans' planes, from each attachment point to where the cable leaves its
        wheel (or to its fixed drawing point), (N, m) each.
    wrap : ndarray, shape (N, m)
        Wrap angles (rad); 0 for a cable without a pulley, NaN where unsettled.
    radii : ndarray, shape (m,)
        Pulley radii (m); 0 without a pulley.
    steps : ndarray, shape (N, m)
        Fixed-point steps taken.
    settled : ndarray, shape (N, m)
        Where the wrap angle settled to :data:`WRAP_TOL`.
    """

    planes: CablePlanes
    wrap: FloatArray
    radii: FloatArray
    steps: NDArray[np.int64]
    settled: NDArray[np.bool_]

    def arcs(self, tensions: FloatArray, EA: float) -> FloatArray:
        """Unstretched lengths on the wheels (N, m) (m) under the tensions (N, m) at the
        exit points (N)."""
        stretch = 1.0 if np.isinf(EA) else 1.0 + tensions / EA
        return np.where(self.radii > 0, self.radii * self.wrap / stretch, 0.0)


class WheelFrames:
    """The vertical-axis pulleys of a robot at a batch of poses (N, n): drawing points,
    radii, axis signs and the horizontal directions ``h`` towards the attachment points,
    and the straight exit points' wrap angles to start from.

    Raises
    ------
    InvalidCableError
        For a pulley whose axis is not vertical (:func:`vertical_pulleys`).
    """

    def __init__(self, robot: CableRobot, poses: FloatArray) -> None:
        self.idx, self.r, self.s = vertical_pulleys(robot)
        self.m = robot.m
        self.geometry = robot.cable_geometry(poses)
        self.B = self.geometry.attachment_points[:, self.idx]
        self.A = robot.anchors[self.idx]
        d = self.B - self.A
        h = d - d[..., 2:3] * E_Z
        # cable_geometry refused an attachment point on a swivel axis
        self.h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        self.straight_wrap = pulley_exits(self.A, self.s[:, None] * E_Z, self.r,
                                          self.B).wrap

    def exits(self, wrap: FloatArray) -> FloatArray:
        """Exit points (N, k, 3) at wrap angles (N, k) (m)."""
        axis = self.s[:, None] * E_Z
        return (self.A - (self.r * np.sin(wrap))[..., None] * axis
                + (self.r * (1.0 - np.cos(wrap)))[..., None] * self.h)

    def planes(self, wrap: FloatArray) -> CablePlanes:
        """The free spans' planes at wrap angles (N, k); the other cables' to their
        fixed drawing points."""
        g = self.geometry
        vectors = g.vectors.copy()
        vectors[:, self.idx] = self.exits(wrap) - self.B
        return planes_along(g.position, np.asarray(g.rotation), g.arms, vectors)

    def tangent_wraps(self, planes: CablePlanes, H: FloatArray, V_B: FloatArray) -> FloatArray:
        """Wrap angles (N, k) at which catenaries with forces ``H``, ``V_B`` (N, k) at
        their upper ends, spanning ``planes``, leave the wheels tangentially."""
        e = -planes.e_h[:, self.idx]  # horizontal, from the exit point towards B
        along = np.sign(np.einsum("nki,nki->nk", e, self.h))
        return np.mod(np.arctan2(H * np.where(along == 0, 1.0, along), self.s * V_B),
                      2 * np.pi)

    def full(self, values: NDArray[Any], fill: float = 0.0) -> NDArray[Any]:
        """Per-pulley values (N, k) spread to every cable (N, m), ``fill`` elsewhere."""
        out = np.full((values.shape[0], self.m), fill, dtype=values.dtype)
        out[:, self.idx] = values
        return out

    def sag(self, wrap: FloatArray, steps: NDArray[np.int64],
            settled: NDArray[np.bool_]) -> PulleySag:
        """The :class:`PulleySag` of wrap angles (N, k), steps and settled flags (N, k)."""
        radii = np.zeros(self.m)
        radii[self.idx] = self.r
        full_settled = np.ones((wrap.shape[0], self.m), dtype=bool)
        full_settled[:, self.idx] = settled
        return PulleySag(self.planes(wrap), self.full(wrap), radii, self.full(steps),
                         full_settled)


def settle_wraps(robot: CableRobot, poses: FloatArray, tensions: FloatArray,
                 attempt: NDArray[np.bool_], w: float, EA: float,
                 compiled: bool = False) -> PulleySag:
    """Wrap angles at which each sagging cable leaves its wheel tangentially, with the
    tension (N, m) imposed at the exit point (the thesis convention), for the poses
    (N, n) marked in ``attempt`` (N,); the other poses keep the straight exit points.
    ``compiled``: as :func:`catenary.solve_length`'s keyword.

    Raises
    ------
    InvalidCableError
        For a pulley whose axis is not vertical (:func:`vertical_pulleys`).
    """
    frames = WheelFrames(robot, poses)
    wrap = frames.straight_wrap.copy()
    steps = np.zeros(wrap.shape, np.int64)
    active = np.broadcast_to(attempt[:, None], wrap.shape).copy()
    T = tensions[:, frames.idx]
    for _ in range(MAX_WRAP_STEPS):
        if not active.any():
            break
        planes = frames.planes(wrap)
        n, c = np.nonzero(active)
        x, z = planes.x[:, frames.idx][n, c], planes.z[:, frames.idx][n, c]
        sol = solve_length(x, z, T[n, c], w, EA, "B", compiled=compiled)
        both = frames.tangent_wraps(planes, _at(wrap.shape, n, c, sol.H),
                                    _at(wrap.shape, n, c, sol.V_B))[n, c]
        new = np.where(sol.converged, both, np.nan)
        moved = np.abs(new - wrap[n, c])
        wrap[n, c] = new
        steps[n, c] += 1
        active[n, c] = sol.converged & (moved > WRAP_TOL)
    settled = np.isfinite(wrap) & ~active
    wrap[active] = np.nan
    return frames.sag(wrap, steps, settled | ~attempt[:, None])


def _at(shape: tuple[int, ...], n: NDArray[np.intp], c: NDArray[np.intp],
        values: FloatArray) -> FloatArray:
    """An array of ``shape`` holding ``values`` at ``(n, c)``, NaN elsewhere."""
    out = np.full(shape, np.nan)
    out[n, c] = values
    return out


def pulley_cable_stiffness(robot: CableRobot, poses: FloatArray, tensions: FloatArray,
                           EA: float) -> FloatArray:
    """Stiffness of straight elastic cables over guide pulleys at their platform end,
    (N, m, 3, 3) (N/m): ``K = ((EA + T) / L) u u' + T P``, ``L`` the whole stretched
    cable (arc and free span), ``P`` the derivative of the free span's direction by the
    attachment point (:func:`tension_opt.robot.derivatives.cable_frames`: ``(I - u u')
    / l`` less the wheel's swivel term); for a cable without a pulley, the same as
    :func:`catenary.robot_stiffness.straight_cable_stiffness`."""
    frames = cable_frames(robot, poses)
    u, L = frames.unit, robot.cable_geometry(poses).total_lengths
    uu = u[..., :, None] * u[..., None, :]
    return ((EA + tensions) / L)[..., None, None] * uu + tensions[..., None, None] * (
        frames.projector)
