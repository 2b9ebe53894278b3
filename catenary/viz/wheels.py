"""Guide pulleys in a view: the wheels' states where the free spans end, the wrapped
arcs and the wheels' outlines (:mod:`catenary.viz.scene` draws them).

A cable over a swivel pulley (:mod:`catenary.pulleys`) leaves its wheel at
``T = A - r sin(beta) axis + r (1 - cos(beta)) h``; from ``T`` alone the wheel's
direction ``h`` is the part of ``T - A`` across the axis and the wrap angle ``beta``
follows from its two parts, so a view needs only where each free span ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot
from tension_opt.robot.pulleys import pulley_arrays, swivel_basis

from ..geometry import CablePlanes

__all__ = ["ARC_SAMPLES", "WHEEL_SAMPLES", "Wheels", "wheels_at"]

FloatArray = NDArray[np.float64]

#: Points along the arc a cable wraps on its guide pulley, and around a wheel's outline.
ARC_SAMPLES, WHEEL_SAMPLES = 16, 49


@dataclass(frozen=True)
class Wheels:
    """A robot's guide pulleys at a batch of poses, read from where the free spans end:
    radii (m,) (0 without a pulley), axes (m, 3), drawing points (m, 3), directions
    ``h`` (N, m, 3) and wrap angles (N, m) (:mod:`catenary.pulleys`)."""

    radii: FloatArray
    axes: FloatArray
    anchors: FloatArray
    h: FloatArray
    wrap: FloatArray

    def arcs(self, tensions: FloatArray, EA: float) -> FloatArray:
        """Unstretched lengths on the wheels (N, m) (m) under the tensions (N, m) (N)."""
        stretch = 1.0 if np.isinf(EA) else 1.0 + tensions / EA
        return np.where(self.radii > 0, self.radii * self.wrap / stretch, 0.0)

    def along(self, k: int, angles: FloatArray) -> FloatArray:
        """Points (m, a, 3) of pose ``k``'s wheels at the angles (m, a) round from the
        drawing point: ``A - r sin(phi) axis + r (1 - cos(phi)) h``."""
        r = self.radii[:, None, None]
        return (self.anchors[:, None, :] - r * np.sin(angles)[..., None] * self.axes[:, None, :]
                + r * (1.0 - np.cos(angles))[..., None] * self.h[k][:, None, :])

    def arc_points(self, k: int) -> FloatArray:
        """The wrapped arcs of pose ``k`` (m, ARC_SAMPLES, 3), from where each cable
        leaves its wheel to the drawing point (the drawing point repeated without a
        pulley)."""
        t = np.linspace(1.0, 0.0, ARC_SAMPLES)
        return self.along(k, np.nan_to_num(self.wrap[k])[:, None] * t[None, :])

    def outlines(self, k: int) -> FloatArray:
        """Pose ``k``'s wheels as closed outlines (m, WHEEL_SAMPLES, 3); NaN without a
        pulley."""
        phi = np.linspace(0.0, 2 * np.pi, WHEEL_SAMPLES)
        out = self.along(k, np.broadcast_to(phi, (len(self.radii), WHEEL_SAMPLES)))
        out[self.radii == 0] = np.nan
        return out


def wheels_at(robot: CableRobot, planes: CablePlanes) -> Wheels | None:
    """The pulleys' states where the free spans of ``planes`` end (None without
    pulleys): from ``T - A = -r sin(beta) axis + r (1 - cos(beta)) h``."""
    if robot.pulleys is None:
        return None
    idx, r, axes = pulley_arrays(robot.pulleys)
    m = robot.m
    radii, all_axes = np.zeros(m), np.zeros((m, 3))
    radii[idx], all_axes[idx] = r, axes
    anchors = np.asarray(robot.anchors, dtype=float)
    d = planes.upper_ends[:, idx] - anchors[idx]
    along = np.einsum("nki,ki->nk", d, axes)
    perp = d - along[..., None] * axes
    size = np.linalg.norm(perp, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        # No wrap (the cable leaves along the axis): any direction across it.
        h = np.where((size > 1e-12 * r)[..., None], perp / size[..., None],
                     swivel_basis(axes)[0])
        wrap = np.mod(np.arctan2(-along / r, 1.0 - size / r), 2 * np.pi)
    full_h, full_wrap = np.zeros(planes.arms.shape), np.zeros(planes.x.shape)
    full_h[:, idx], full_wrap[:, idx] = h, wrap
    return Wheels(radii, all_axes, anchors, full_h, full_wrap)
