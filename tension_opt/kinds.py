"""Robot kinds (motion patterns) as value objects.

A kind says how a platform moves and which wrench components its cables must
balance: the size of a pose and the names of its coordinates, the rows of the
spatial wrench ``(fx, fy, fz, mx, my, mz)`` it keeps, how a pose places and turns
the platform frame, how a small step moves a pose, and a home pose. Everything that
depends on the kind asks it here; a new kind is one new subclass of
:class:`MotionPattern`, listed in :data:`KINDS`.

==================  ==========  =======================================
kind                pose shape  pose coordinates
==================  ==========  =======================================
``"point3"``        (N, 3)      x, y, z of a point mass (all attachments at the origin)
``"planar_point2"`` (N, 2)      x, z of a point mass moving in the xz plane
``"planar3"``       (N, 3)      x, y, rotation about z (rad) in the xy plane
``"spatial6"``      (N, 6)      x, y, z, rotation vector (rad)
==================  ==========  =======================================
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tension_opt.errors import InvalidInputError


class MotionPattern:
    """How a platform moves: pose coordinates, wrench rows, frames and steps.

    Subclasses set the class attributes and override :meth:`frames` (and
    :meth:`displace` where a step is not a plain sum). Instances hold no state, so one
    instance per kind is shared.
    """

    #: Registry name, e.g. ``"point3"``.
    name: ClassVar[str] = ""
    #: Names of the pose coordinates, in order.
    coordinates: ClassVar[tuple[str, ...]] = ()
    #: Pose coordinates that are positions (m); the others are angles (rad).
    positions: ClassVar[tuple[int, ...]] = ()
    #: Rows of the spatial wrench (fx, fy, fz, mx, my, mz) the kind keeps.
    wrench_rows: ClassVar[tuple[int, ...]] = ()
    #: Whether a pose turns the platform (attachment arms depend on the pose).
    rotates: ClassVar[bool] = False
    #: Base-frame axis (0, 1, 2) of each position coordinate.
    position_axes: ClassVar[tuple[int, ...]] = ()

    @property
    def pose_size(self) -> int:
        """Number of pose coordinates ``n`` (equal to the number of wrench rows)."""
        return len(self.coordinates)

    @property
    def vertical_coordinate(self) -> int | None:
        """Index of the pose coordinate along the base z axis, or None if there is none."""
        for index, axis in zip(self.positions, self.position_axes, strict=True):
            if axis == 2:
                return index
        return None

    def frames(self, poses: NDArray) -> tuple[NDArray, NDArray]:
        """Platform position (N, 3) (m) and rotation matrices (N, 3, 3) of poses (N, n)."""
        position = np.zeros((poses.shape[0], 3))
        position[:, list(self.position_axes)] = poses[:, list(self.positions)]
        return position, np.broadcast_to(np.eye(3), (poses.shape[0], 3, 3))

    def displace(self, poses: NDArray, step: NDArray) -> NDArray:
        """Poses (N, n) moved by small steps (N, n) (m, rad)."""
        return poses + step

    def home(self, centre: NDArray) -> NDArray:
        """A home pose (n,) with the platform at ``centre`` (3,) (m), not rotated."""
        pose = np.zeros(self.pose_size)
        pose[list(self.positions)] = centre[list(self.position_axes)]
        return pose

    def step_maps(self) -> tuple[NDArray, NDArray]:
        """Matrices (3, n) taking a pose step to a translation and to a small rotation.

        The angular part of a step is a rotation about the base axes (left-multiplied),
        the convention of :meth:`displace`.
        """
        n = self.pose_size
        translation = np.zeros((3, n))
        translation[list(self.position_axes), list(self.positions)] = 1.0
        rotation = np.zeros((3, n))
        angles = [i for i in range(n) if i not in self.positions]
        rotation[self._rotation_axes(), angles] = 1.0
        return translation, rotation

    def _rotation_axes(self) -> list[int]:
        return []

    def select(self, full: NDArray) -> NDArray:
        """Keep the kind's rows of spatial wrenches (..., 6), giving (..., n)."""
        return full[..., list(self.wrench_rows)]

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class PointMass(MotionPattern):
    """A point mass in space: pose ``(x, y, z)``; all cables meet at the point."""

    name = "point3"
    coordinates = ("x", "y", "z")
    positions = (0, 1, 2)
    position_axes = (0, 1, 2)
    wrench_rows = (0, 1, 2)


class PlanarPoint(MotionPattern):
    """A point mass in the vertical xz plane: pose ``(x, z)``."""

    name = "planar_point2"
    coordinates = ("x", "z")
    positions = (0, 1)
    position_axes = (0, 2)
    wrench_rows = (0, 2)


class PlanarBody(MotionPattern):
    """A rigid body in the xy plane: pose ``(x, y, theta)``, theta about z (rad)."""

    name = "planar3"
    coordinates = ("x", "y", "theta")
    positions = (0, 1)
    position_axes = (0, 1)
    wrench_rows = (0, 1, 5)
    rotates = True

    def frames(self, poses: NDArray) -> tuple[NDArray, NDArray]:
        position, _ = super().frames(poses)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        R = np.zeros((poses.shape[0], 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
        return position, R

    def _rotation_axes(self) -> list[int]:
        return [2]


class SpatialBody(MotionPattern):
    """A rigid body in space: pose ``(x, y, z, rx, ry, rz)`` with a rotation vector (rad).

    The angular part of a step is a rotation vector applied in the base frame
    (left-multiplied).
    """

    name = "spatial6"
    coordinates = ("x", "y", "z", "rx", "ry", "rz")
    positions = (0, 1, 2)
    position_axes = (0, 1, 2)
    wrench_rows = (0, 1, 2, 3, 4, 5)
    rotates = True

    def frames(self, poses: NDArray) -> tuple[NDArray, NDArray]:
        N = poses.shape[0]
        position = np.ascontiguousarray(poses[:, :3], dtype=float)
        # A copy: scipy's Rotation refuses read-only arrays.
        rotvec = np.array(poses[:, 3:], dtype=float)
        return position, Rotation.from_rotvec(rotvec).as_matrix().reshape(N, 3, 3)

    def displace(self, poses: NDArray, step: NDArray) -> NDArray:
        rot = Rotation.from_rotvec(np.array(step[:, 3:])) * Rotation.from_rotvec(
            np.array(poses[:, 3:]))
        return np.concatenate(
            [poses[:, :3] + step[:, :3], rot.as_rotvec().reshape(-1, 3)], axis=1
        )

    def _rotation_axes(self) -> list[int]:
        return [0, 1, 2]


#: Every robot kind by name; a new kind is one class added here.
KINDS: dict[str, MotionPattern] = {
    kind.name: kind() for kind in (PointMass, PlanarPoint, PlanarBody, SpatialBody)
}


def get_kind(kind: str | MotionPattern) -> MotionPattern:
    """The motion pattern of a kind name (or the pattern itself).

    Raises
    ------
    InvalidInputError
        For an unknown name, listing the known ones.
    """
    if isinstance(kind, MotionPattern):
        return kind
    try:
        return KINDS[kind]
    except (KeyError, TypeError):
        raise InvalidInputError(
            f"kind must be one of {sorted(KINDS)} or a MotionPattern, got {kind!r}"
        ) from None
