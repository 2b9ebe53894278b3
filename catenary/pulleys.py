"""Sagging cables over swivel guide pulleys: where a catenary leaves its wheel.

A straight cable leaves its pulley (:mod:`tension_opt.robot.pulleys`) along the line to
the attachment point ``B``. A sagging one leaves it tangentially to the catenary, which
starts more steeply than the chord: its exit point ``T'`` sits further round the wheel,
the wheel may swivel to another angle, and both the wrapped arc and the free span
change.

A wheel's state is its direction ``h`` (unit, perpendicular to the swivel ``axis``, from
the axis towards the wheel's centre) and its wrap angle ``beta``; the cable leaves it at
``T' = A - r sin(beta) axis + r (1 - cos(beta)) h`` travelling along
``-cos(beta) axis + sin(beta) h``. The catenary from ``T'`` to ``B`` lies in the
vertical plane through both and, with the tension ``T`` at ``T'``, travels along
``c = (H e - V_B e_z) / T`` there (``e`` the horizontal unit vector from ``T'`` towards
``B``; ``H``, ``V_B`` its horizontal force and vertical force at ``T'``). Tangency puts
``c`` in the wheel's plane::

    h    = +-(c - (c . axis) axis) / |c - (c . axis) axis|
    beta = atan2(c . h, -c . axis) mod 2 pi

(the sign keeping ``h`` on the straight wheel's side). With a vertical axis the wheel
turns in the catenary's plane: ``h`` is the straight one and only ``beta`` moves.

:func:`settle_wraps` solves it by fixed-point iteration from the straight state: ``T'``
moves on a wheel of radius ``r`` against a span ``l`` of metres, so each step shrinks
the error by about ``r / l`` and a few steps reach rounding.

The arc on the wheel carries the tension at ``T'`` (a frictionless pulley), so its
unstretched length is ``r beta / (1 + T / EA)``.

Straight elastic cables over pulleys have their platform-end stiffness in
:func:`pulley_cable_stiffness`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot
from tension_opt.robot.derivatives import cable_frames
from tension_opt.robot.pulleys import pulley_arrays, pulley_exits

from .geometry import E_Z, CablePlanes, planes_along
from .solve import solve_length

__all__ = ["MAX_WRAP_STEPS", "WRAP_TOL", "PulleySag", "WheelFrames", "pulley_cable_stiffness",
           "settle_wraps"]

FloatArray = NDArray[np.float64]

#: The wrap angles are settled when a step moves them less than this (rad).
WRAP_TOL = 1e-13
#: Steps of the fixed-point iteration before the cable is reported not converged.
MAX_WRAP_STEPS = 60


@dataclass(frozen=True)
class PulleySag:
    """Sagging free spans of a robot with guide pulleys, for a batch of poses.

    Attributes
    ----------
    planes : CablePlanes
        The free spans' planes, from each attachment point to where the cable leaves its
        wheel (or to its fixed drawing point), (N, m) each.
    wrap : ndarray, shape (N, m)
        Wrap angles (rad); 0 for a cable without a pulley, NaN where unsettled.
    radii : ndarray, shape (m,)
        Pulley radii (m); 0 without a pulley.
    directions : ndarray, shape (N, m, 3)
        The wheels' directions ``h`` (module notes); 0 for a cable without a pulley.
    steps : ndarray, shape (N, m)
        Fixed-point steps taken.
    settled : ndarray, shape (N, m)
        Where the wrap angle settled to :data:`WRAP_TOL`.
    """

    planes: CablePlanes
    wrap: FloatArray
    radii: FloatArray
    directions: FloatArray
    steps: NDArray[np.int64]
    settled: NDArray[np.bool_]

    def arcs(self, tensions: FloatArray, EA: float) -> FloatArray:
        """Unstretched lengths on the wheels (N, m) (m) under the tensions (N, m) at the
        exit points (N)."""
        stretch = 1.0 if np.isinf(EA) else 1.0 + tensions / EA
        return np.where(self.radii > 0, self.radii * self.wrap / stretch, 0.0)


class WheelFrames:
    """The pulleys of a robot at a batch of poses (N, n): drawing points, radii, axes,
    and the straight cables' wheel directions ``h`` and wrap angles to start from.

    A wheel's state is its direction ``h`` (N, k, 3) (unit, perpendicular to the axis,
    from the axis towards the wheel's centre) and its wrap angle (N, k).
    """

    def __init__(self, robot: CableRobot, poses: FloatArray) -> None:
        assert robot.pulleys is not None
        self.idx, self.r, self.axes = pulley_arrays(robot.pulleys)
        self.m = robot.m
        self.geometry = robot.cable_geometry(poses)
        self.B = self.geometry.attachment_points[:, self.idx]
        self.A = robot.anchors[self.idx]
        d = self.B - self.A
        h = d - np.einsum("nki,ki->nk", d, self.axes)[..., None] * self.axes
        # cable_geometry refused an attachment point on a swivel axis
        self.straight_h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        self.straight_wrap = pulley_exits(self.A, self.axes, self.r, self.B,
                                          swivel=False).wrap

    def exits(self, h: FloatArray, wrap: FloatArray) -> FloatArray:
        """Exit points (N, k, 3) of wheels in directions ``h`` (N, k, 3) at wrap angles
        (N, k) (m)."""
        return (self.A - (self.r * np.sin(wrap))[..., None] * self.axes
                + (self.r * (1.0 - np.cos(wrap)))[..., None] * h)

    def planes(self, h: FloatArray, wrap: FloatArray) -> CablePlanes:
        """The free spans' planes of wheel states ``h``, ``wrap``; the other cables'
        to their fixed drawing points."""
        g = self.geometry
        vectors = g.vectors.copy()
        vectors[:, self.idx] = self.exits(h, wrap) - self.B
        return planes_along(g.position, np.asarray(g.rotation), g.arms, vectors)

    def tangent(self, planes: CablePlanes, H: FloatArray, V_B: FloatArray,
                h: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Wheel states ``(h, wrap)`` (N, k, 3), (N, k) in which catenaries with forces
        ``H``, ``V_B`` (N, k) at their upper ends, spanning ``planes``, leave the wheels
        tangentially (module notes); ``h`` the current directions, kept where the
        cable runs along the axis."""
        e = -planes.e_h[:, self.idx]  # horizontal, from the exit point towards B
        with np.errstate(invalid="ignore", divide="ignore"):
            c = (H[..., None] * e - V_B[..., None] * E_Z) / np.hypot(H, V_B)[..., None]
            along = np.einsum("nki,ki->nk", c, self.axes)
            perp = c - along[..., None] * self.axes
            size = np.linalg.norm(perp, axis=-1)
            side = np.where(np.einsum("nki,nki->nk", perp, self.straight_h) < 0, -1.0, 1.0)
            turned = (side / size)[..., None] * perp
        new_h = np.where((size > 1e-15)[..., None], turned, h)
        wrap = np.mod(np.arctan2(np.einsum("nki,nki->nk", c, new_h), -along), 2 * np.pi)
        return new_h, wrap

    def full(self, values: NDArray[Any], fill: float = 0.0) -> NDArray[Any]:
        """Per-pulley values (N, k) spread to every cable (N, m), ``fill`` elsewhere."""
        out = np.full((values.shape[0], self.m), fill, dtype=values.dtype)
        out[:, self.idx] = values
        return out

    def sag(self, h: FloatArray, wrap: FloatArray, steps: NDArray[np.int64],
            settled: NDArray[np.bool_]) -> PulleySag:
        """The :class:`PulleySag` of wheel states, steps and settled flags (N, k)."""
        radii = np.zeros(self.m)
        radii[self.idx] = self.r
        full_settled = np.ones((wrap.shape[0], self.m), dtype=bool)
        full_settled[:, self.idx] = settled
        directions = np.zeros((wrap.shape[0], self.m, 3))
        directions[:, self.idx] = h
        return PulleySag(self.planes(h, wrap), self.full(wrap), radii, directions,
                         self.full(steps), full_settled)


def settle_wraps(robot: CableRobot, poses: FloatArray, tensions: FloatArray,
                 attempt: NDArray[np.bool_], w: float, EA: float,
                 compiled: bool = False) -> PulleySag:
    """Wheel states in which each sagging cable leaves its wheel tangentially, with the
    tension (N, m) imposed at the exit point (the thesis convention), for the poses
    (N, n) marked in ``attempt`` (N,); the other poses keep the straight exit points.
    ``compiled``: as :func:`catenary.solve_length`'s keyword.
    """
    frames = WheelFrames(robot, poses)
    h, wrap = frames.straight_h.copy(), frames.straight_wrap.copy()
    steps = np.zeros(wrap.shape, np.int64)
    active = np.broadcast_to(attempt[:, None], wrap.shape).copy()
    T = tensions[:, frames.idx]
    for _ in range(MAX_WRAP_STEPS):
        if not active.any():
            break
        planes = frames.planes(h, wrap)
        n, c = np.nonzero(active)
        x, z = planes.x[:, frames.idx][n, c], planes.z[:, frames.idx][n, c]
        sol = solve_length(x, z, T[n, c], w, EA, "B", compiled=compiled)
        new_h, new_wrap = frames.tangent(planes, _at(wrap.shape, n, c, sol.H),
                                         _at(wrap.shape, n, c, sol.V_B), h)
        new_h, new_wrap = new_h[n, c], np.where(sol.converged, new_wrap[n, c], np.nan)
        moved = np.abs(new_wrap - wrap[n, c]) + np.linalg.norm(new_h - h[n, c], axis=-1)
        h[n, c], wrap[n, c] = new_h, new_wrap
        steps[n, c] += 1
        active[n, c] = sol.converged & (moved > WRAP_TOL)
    settled = np.isfinite(wrap) & ~active
    wrap[active] = np.nan
    return frames.sag(h, wrap, steps, settled | ~attempt[:, None])


def _at(shape: tuple[int, ...], n: NDArray[np.intp], c: NDArray[np.intp],
        values: FloatArray) -> FloatArray:
    """An array of ``shape`` holding ``values`` at ``(n, c)``, NaN elsewhere."""
    out = np.full(shape, np.nan)
    out[n, c] = values
    return out


def pulley_cable_stiffness(robot: CableRobot, poses: FloatArray, tensions: FloatArray,
                           EA: float, lengths: FloatArray) -> FloatArray:
    """Stiffness of straight elastic cables over guide pulleys at their platform end,
    (N, m, 3, 3) (N/m): ``K = ((EA + T) / L) u u' + T P``, ``L`` the whole stretched
    cables (arc and free span, ``lengths`` (N, m), m), ``P`` the derivative of the free
    span's direction by the attachment point
    (:func:`tension_opt.robot.derivatives.cable_frames`: ``(I - u u') / l`` less the
    wheel's swivel term); for a cable without a pulley, the same as
    :func:`catenary.robot_stiffness.straight_cable_stiffness`."""
    frames = cable_frames(robot, poses)
    u = frames.unit
    uu = u[..., :, None] * u[..., None, :]
    return ((EA + tensions) / lengths)[..., None, None] * uu + tensions[..., None, None] * (
        frames.projector)
