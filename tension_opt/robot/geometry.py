"""What a batch of poses makes of a robot's cables: :class:`CableGeometry`, and the
result of the straight forward kinematics (:class:`StraightForwardKinematicsResult`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from tension_opt.status import Status

__all__ = ["CableGeometry", "StraightForwardKinematicsResult"]


@dataclass(frozen=True)
class CableGeometry:
    """Straight cables of a batch of poses (:meth:`CableRobot.cable_geometry`).

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        The validated poses.
    position : ndarray, shape (N, 3)
        Platform reference point in the base frame (m).
    rotation : ndarray, shape (N, 3, 3)
        Platform orientation.
    arms : ndarray, shape (N, m, 3)
        Attachment points relative to the reference point, ``R a_i`` (m).
    vectors : ndarray, shape (N, m, 3)
        From each attachment point to its drawing point, or to the point where the
        cable leaves its guide pulley (:mod:`tension_opt.robot.pulleys`) (m).
    lengths : ndarray, shape (N, m)
        Straight free spans ``|vectors|`` (m).
    zero_length : float
        Length (m) at or below which a cable counts as on its drawing point.
    wrapped : ndarray, shape (N, m), optional
        Length wrapped on each cable's pulley, radius times wrap angle (m); None
        without pulleys. NaN where the pulley has no exit point.
    """

    poses: NDArray
    position: NDArray
    rotation: NDArray
    arms: NDArray
    vectors: NDArray
    lengths: NDArray
    zero_length: float
    wrapped: NDArray | None = None

    @property
    def total_lengths(self) -> NDArray:
        """Cable lengths from drawing point to attachment point, pulley arcs included,
        (N, m) (m)."""
        return self.lengths if self.wrapped is None else self.lengths + self.wrapped

    @property
    def unit(self) -> NDArray:
        """Unit vectors from the attachment points toward the drawing points, (N, m, 3)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.vectors / self.lengths[..., None]

    @property
    def attachment_points(self) -> NDArray:
        """Attachment points in the base frame, (N, m, 3) (m)."""
        return self.position[:, None, :] + self.arms

    @property
    def degenerate(self) -> NDArray:
        """Poses that put some cable on its drawing point (or on its pulley's swivel
        axis or wheel), (N,) of bool."""
        on_point = self.lengths <= self.zero_length
        if self.wrapped is not None:
            on_point |= np.isnan(self.wrapped)
        return np.asarray(on_point.any(axis=1), dtype=bool)


@dataclass(frozen=True)
class StraightForwardKinematicsResult:
    """Result of :meth:`CableRobot.forward_kinematics`.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
    residual : ndarray, shape (N,)
        RMS of the cable-length residuals at the solution (m).
    iterations : ndarray, shape (N,)
    status : ndarray of str, shape (N,)
        ``"converged"``, ``"inconsistent"`` (least-squares residual above tolerance:
        the lengths cannot all be met) or ``"not_converged"``.
    """

    poses: NDArray
    residual: NDArray
    iterations: NDArray
    status: NDArray

    @property
    def success(self) -> NDArray:
        """Boolean mask of poses whose lengths were met."""
        return np.asarray(self.status == Status.CONVERGED, dtype=bool)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: status, pose coordinates, residual, iterations."""
        frame = pd.DataFrame(self.poses, columns=[f"q{i}" for i in range(self.poses.shape[1])])
        frame.insert(0, "pose", np.arange(len(self.poses)))
        frame.insert(1, "status", self.status)
        return frame.assign(residual=self.residual, iterations=self.iterations)
