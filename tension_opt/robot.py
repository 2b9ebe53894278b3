"""Cable robot model: geometry, structure (wrench) matrices, straight-line kinematics.

Conventions
-----------
Base frame: z up, gravity along -z. A pose is

==================  ==========  =======================================
kind                pose shape  pose coordinates
==================  ==========  =======================================
``"point3"``        (N, 3)      x, y, z of a point mass (all attachments at the origin)
``"planar_point2"`` (N, 2)      x, z of a point mass moving in the xz plane
``"planar3"``       (N, 3)      x, y, rotation about z (rad) in the xy plane
``"spatial6"``      (N, 6)      x, y, z, rotation vector (rad)
==================  ==========  =======================================

Cable ``i`` runs from the attachment point ``b_i = p + R a_i`` on the platform to
its drawing point (anchor) ``A_i`` in the base frame. Its unit vector
``u_i = (A_i - b_i) / |A_i - b_i|`` points from the platform to the anchor, so a
tension ``T_i >= 0`` pulls the platform along ``u_i``. The structure matrix
column is ``[u_i; (R a_i) x u_i]`` restricted to the rows of the kind's degrees of
freedom, and static equilibrium reads ``A T + w_g + w_ext = 0``; moments are taken
about the platform reference point ``p``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from tension_opt.errors import InvalidInputError

RobotKind = Literal["point3", "planar_point2", "planar3", "spatial6"]

# Rows of the full spatial wrench (fx, fy, fz, mx, my, mz) kept for each kind.
_WRENCH_ROWS: dict[str, tuple[int, ...]] = {
    "point3": (0, 1, 2),
    "planar_point2": (0, 2),
    "planar3": (0, 1, 5),
    "spatial6": (0, 1, 2, 3, 4, 5),
}
_POSE_SIZE = {"point3": 3, "planar_point2": 2, "planar3": 3, "spatial6": 6}


@dataclass(frozen=True)
class CableProperties:
    """Mechanical properties shared by all cables of a robot.

    Parameters
    ----------
    diameter : float
        Cable diameter (m).
    linear_mass : float
        Mass per unit length (kg/m).
    EA : float
        Axial stiffness (N); ``inf`` for an inextensible cable.
    """

    diameter: float
    linear_mass: float
    EA: float = float("inf")

    @classmethod
    def from_density(
        cls, diameter: float, density: float, EA: float = float("inf")
    ) -> CableProperties:
        """Cable of a solid circular section: ``linear_mass = density * pi/4 * d^2``."""
        _check_positive("cable diameter", diameter)
        _check_positive("cable density", density)
        return cls(diameter, density * np.pi / 4.0 * diameter**2, EA)

    def weight_per_length(self, g: float = 9.81) -> float:
        """Weight per unit length ``w = linear_mass * g`` (N/m)."""
        return self.linear_mass * g


def _check_positive(name: str, value: float) -> None:
    if not np.isfinite(value) or value <= 0:
        raise InvalidInputError(f"{name} must be a positive finite number, got {value!r}")


def _as_finite(name: str, value: ArrayLike, shape: tuple[int, ...] | None = None) -> NDArray:
    arr = np.asarray(value, dtype=float)
    if shape is not None and arr.shape != shape:
        raise InvalidInputError(f"{name} must have shape {shape}, got {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InvalidInputError(f"{name} has a non-finite value {arr[idx]!r} at index {idx}")
    return arr


@dataclass(frozen=True, eq=False)
class CableRobot:
    """A cable-driven parallel robot with ``m`` cables.

    Parameters
    ----------
    anchors : array_like, shape (m, 3)
        Drawing points (cable exit points) in the base frame (m).
    attachments : array_like, shape (m, 3)
        Attachment points in the platform frame (m). All zero for a point mass.
    mass : float
        Platform (end-effector) mass (kg), > 0.
    kind : {"point3", "planar_point2", "planar3", "spatial6"}
        Degrees of freedom of the platform; see the module docstring.
    com : array_like, shape (3,)
        Centre of mass in the platform frame (m).
    g : float
        Gravitational acceleration (m/s^2), acting along -z. ``0`` for a robot
        whose plane is horizontal.
    t_min, t_max : float or array_like, shape (m,)
        Tension bounds per cable (N); ``t_max`` may be ``inf``.
    cable : CableProperties, optional
        Cable diameter, linear mass and axial stiffness (for the sag model).
    home : array_like, optional
        A central pose in the workspace, used as the start of forward kinematics.
    name : str
        Label used in tables and plots.
    """

    anchors: NDArray
    attachments: NDArray
    mass: float
    kind: RobotKind = "point3"
    com: NDArray = field(default_factory=lambda: np.zeros(3))
    g: float = 9.81
    t_min: NDArray | float = 0.0
    t_max: NDArray | float = np.inf
    cable: CableProperties | None = None
    home: NDArray | None = None
    name: str = "cable robot"

    def __post_init__(self) -> None:
        if self.kind not in _WRENCH_ROWS:
            raise InvalidInputError(
                f"kind must be one of {sorted(_WRENCH_ROWS)}, got {self.kind!r}"
            )
        anchors = _as_finite("anchors", self.anchors)
        if anchors.ndim != 2 or anchors.shape[1] != 3 or anchors.shape[0] < 1:
            raise InvalidInputError(f"anchors must have shape (m, 3), got {anchors.shape}")
        m = anchors.shape[0]
        attachments = _as_finite("attachments", self.attachments, (m, 3))
        _check_positive("mass", self.mass)
        if not np.isfinite(self.g) or self.g < 0:
            raise InvalidInputError(f"g must be finite and >= 0, got {self.g!r}")
        com = _as_finite("com", self.com, (3,))
        t_min = np.broadcast_to(np.asarray(self.t_min, dtype=float), (m,)).copy()
        t_max = np.broadcast_to(np.asarray(self.t_max, dtype=float), (m,)).copy()
        if np.isnan(t_min).any() or np.isinf(t_min).any():
            raise InvalidInputError(f"t_min must be finite, got {t_min}")
        if np.isnan(t_max).any() or np.isneginf(t_max).any():
            raise InvalidInputError(f"t_max must be a number or +inf, got {t_max}")
        if (t_min < 0).any():
            i = int(np.argmax(t_min < 0))
            raise InvalidInputError(f"t_min[{i}] = {t_min[i]} is negative: cables can only pull")
        if (t_min > t_max).any():
            i = int(np.argmax(t_min > t_max))
            raise InvalidInputError(f"t_min[{i}] = {t_min[i]} exceeds t_max[{i}] = {t_max[i]}")
        # Two cables leaving one drawing point is almost always a typo in the data.
        gap = np.linalg.norm(anchors[:, None] - anchors[None], axis=-1)
        pairs = np.argwhere(np.triu(gap < 1e-9 * max(1.0, np.abs(anchors).max()), k=1))
        if len(pairs):
            i, j = (int(v) for v in pairs[0])
            raise InvalidInputError(
                f"anchors {i} and {j} coincide at {anchors[i].tolist()}: each cable needs "
                "its own drawing point"
            )
        home = None if self.home is None else _as_finite("home", self.home, (self.dof,))
        object.__setattr__(self, "anchors", anchors)
        object.__setattr__(self, "attachments", attachments)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "t_min", t_min)
        object.__setattr__(self, "t_max", t_max)
        object.__setattr__(self, "home", home)
        for arr in (anchors, attachments, com, t_min, t_max):
            arr.setflags(write=False)

    # ------------------------------------------------------------------ sizes
    @property
    def m(self) -> int:
        """Number of cables."""
        return int(self.anchors.shape[0])

    @property
    def dof(self) -> int:
        """Degrees of freedom ``n`` (rows of the structure matrix and size of a pose)."""
        return _POSE_SIZE[self.kind]

    @property
    def redundancy(self) -> int:
        """``m - n``: dimension of the null space of a full-rank structure matrix."""
        return self.m - self.dof

    @property
    def wrench_rows(self) -> tuple[int, ...]:
        """Rows of the spatial wrench (fx, fy, fz, mx, my, mz) that the kind keeps."""
        return _WRENCH_ROWS[self.kind]

    @property
    def weight(self) -> float:
        """Platform weight ``mass * g`` (N)."""
        return self.mass * self.g

    def with_(self, **changes: object) -> CableRobot:
        """Copy of the robot with some fields replaced (validated again)."""
        return replace(self, **changes)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ poses
    def as_poses(self, poses: ArrayLike) -> NDArray:
        """Validate poses and return them as a float array of shape (N, n).

        A single pose of shape (n,) becomes a batch of one.
        """
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise InvalidInputError(
                f"poses of a {self.kind} robot must have shape (N, {self.dof}), got "
                f"{np.shape(poses)}"
            )
        return _as_finite("poses", arr)

    def frames(self, poses: NDArray) -> tuple[NDArray, NDArray]:
        """Platform position (N, 3) and rotation matrices (N, 3, 3) of validated poses (N, n)."""
        N = poses.shape[0]
        position = np.zeros((N, 3))
        if self.kind == "point3":
            position[:] = poses
            return position, np.broadcast_to(np.eye(3), (N, 3, 3))
        if self.kind == "planar_point2":
            position[:, 0] = poses[:, 0]
            position[:, 2] = poses[:, 1]
            return position, np.broadcast_to(np.eye(3), (N, 3, 3))
        if self.kind == "planar3":
            position[:, :2] = poses[:, :2]
            c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
            R = np.zeros((N, 3, 3))
            R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
            return position, R
        position[:] = poses[:, :3]
        return position, Rotation.from_rotvec(poses[:, 3:]).as_matrix().reshape(N, 3, 3)

    def attachment_points(self, poses: ArrayLike) -> NDArray:
        """Attachment points in the base frame, shape (N, m, 3) (m)."""
        p = self.as_poses(poses)
        position, R = self.frames(p)
        return position[:, None, :] + np.einsum("nij,mj->nmi", R, self.attachments)

    # ------------------------------------------------------------- kinematics
    def inverse_kinematics(self, poses: ArrayLike) -> tuple[NDArray, NDArray]:
        """Straight-line cable lengths and unit vectors.

        Parameters
        ----------
        poses : array_like, shape (N, n) or (n,)

        Returns
        -------
        lengths : ndarray, shape (N, m)
            Distance from attachment point to drawing point (m).
        unit_vectors : ndarray, shape (N, m, 3)
            Unit vectors from the attachment point toward the drawing point.

        Raises
        ------
        InvalidInputError
            If a pose puts an attachment point on its drawing point (zero-length cable).
        """
        p = self.as_poses(poses)
        lengths, unit, _ = self._cables(p)
        return lengths, unit

    def _cables(self, p: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        position, R = self.frames(p)
        if self.kind in ("point3", "planar_point2"):  # no rotation: arms are the attachments
            arm = np.broadcast_to(self.attachments, (len(p), *self.attachments.shape))
        else:
            arm = np.einsum("nij,mj->nmi", R, self.attachments)  # R a_i, (N, m, 3)
        vec = self.anchors[None] - (position[:, None, :] + arm)
        lengths = np.sqrt(np.einsum("nmi,nmi->nm", vec, vec))
        scale = np.maximum(1.0, np.abs(self.anchors).max())
        if (lengths <= 1e-12 * scale).any():
            k, i = (int(v) for v in np.argwhere(lengths <= 1e-12 * scale)[0])
            raise InvalidInputError(
                f"pose {k} ({p[k].tolist()}) puts cable {i} on its drawing point "
                f"{self.anchors[i].tolist()}: zero-length cable"
            )
        return lengths, vec / lengths[..., None], arm

    def structure_matrices(self, poses: ArrayLike) -> NDArray:
        """Structure (wrench) matrices, shape (N, n, m).

        Column ``i`` is the wrench a unit tension in cable ``i`` applies to the platform,
        restricted to the robot's degrees of freedom.
        """
        p = self.as_poses(poses)
        _, unit, arm = self._cables(p)
        return self._structure_from(unit, arm)

    def _structure_from(self, unit: NDArray, arm: NDArray) -> NDArray:
        rows = _WRENCH_ROWS[self.kind]
        if self.kind in ("point3", "planar_point2"):
            return np.ascontiguousarray(np.swapaxes(unit[..., list(rows)], 1, 2))
        full = np.concatenate([unit, np.cross(arm, unit)], axis=-1)  # (N, m, 6)
        return np.ascontiguousarray(np.swapaxes(full[..., list(rows)], 1, 2))

    def gravity_wrench(self, poses: ArrayLike) -> NDArray:
        """Wrench of gravity on the platform about its reference point, shape (N, n)."""
        p = self.as_poses(poses)
        N = p.shape[0]
        force = np.array([0.0, 0.0, -self.mass * self.g])
        full = np.zeros((N, 6))
        full[:, :3] = force
        if self.kind in ("planar3", "spatial6"):
            _, R = self.frames(p)
            full[:, 3:] = np.cross(R @ self.com, force)
        return full[:, list(_WRENCH_ROWS[self.kind])]

    def required_wrench(self, poses: ArrayLike, wrench: ArrayLike | None = None) -> NDArray:
        """Right-hand side ``b = -(w_g + w_ext)`` of the equilibrium ``A T = b``, shape (N, n).

        Parameters
        ----------
        wrench : array_like, shape (n,) or (N, n), optional
            External wrench applied to the platform besides gravity (N, N m).
        """
        p = self.as_poses(poses)
        b = -self.gravity_wrench(p)
        if wrench is not None:
            w = _as_finite("wrench", wrench)
            try:
                w = np.broadcast_to(w, b.shape)
            except ValueError:
                raise InvalidInputError(
                    f"wrench must have shape ({self.dof},) or ({p.shape[0]}, {self.dof}), "
                    f"got {np.shape(wrench)}"
                ) from None
            b = b - w
        return b

    def forward_kinematics(
        self,
        lengths: ArrayLike,
        initial_poses: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iter: int = 50,
        consistency_tol: float = 1e-6,
    ) -> ForwardKinematicsResult:
        """Straight-line forward kinematics by batched Gauss-Newton least squares.

        Parameters
        ----------
        lengths : array_like, shape (N, m) or (m,)
            Straight-line cable lengths (m).
        initial_poses : array_like, shape (N, n) or (n,), optional
            Starting poses; default: the robot's ``home`` pose (or the anchors' centroid).
        tol : float
            Stop when the pose step is below ``tol`` (m or rad).
        consistency_tol : float
            Lengths whose RMS residual at the solution exceeds this (m) are flagged
            ``"inconsistent"``.

        Returns
        -------
        ForwardKinematicsResult
            ``poses`` (N, n), ``residual`` (N,) RMS length residual (m), ``iterations``
            (N,), ``status`` (N,) among ``"converged"``, ``"inconsistent"``,
            ``"not_converged"``.
        """
        L = _as_finite("lengths", lengths)
        if L.ndim == 1:
            L = L[None]
        if L.ndim != 2 or L.shape[1] != self.m:
            raise InvalidInputError(
                f"lengths must have shape (N, {self.m}), got {np.shape(lengths)}"
            )
        if (L <= 0).any():
            raise InvalidInputError("lengths must be positive")
        N = L.shape[0]
        if initial_poses is None:
            start = self.home if self.home is not None else self._default_home()
            x = np.tile(start, (N, 1))
        else:
            x = self.as_poses(initial_poses)
            x = np.broadcast_to(x, (N, self.dof)).copy()
        iterations = np.zeros(N, dtype=int)
        active = np.ones(N, dtype=bool)
        for _ in range(max_iter):
            if not active.any():
                break
            idx = np.flatnonzero(active)
            lk, unit, arm = self._cables(x[idx])
            J = -np.swapaxes(self._structure_from(unit, arm), 1, 2)  # dL/dpose, (k, m, n)
            r = lk - L[idx]
            # Normal equations of the Gauss-Newton step, with a tiny damping for safety.
            JtJ = np.einsum("kmi,kmj->kij", J, J) + 1e-12 * np.eye(self.dof)
            step = -np.linalg.solve(JtJ, np.einsum("kmi,km->ki", J, r)[..., None])[..., 0]
            x[idx] = self.displace(x[idx], step)
            iterations[idx] += 1
            done = np.abs(step).max(axis=1) < tol
            active[idx[done]] = False
        lk, _, _ = self._cables(x)
        residual = np.sqrt(np.mean((lk - L) ** 2, axis=1))
        met = np.where(residual > consistency_tol, "inconsistent", "converged")
        status = np.where(active, "not_converged", met)
        return ForwardKinematicsResult(x, residual, iterations, status)

    def displace(self, x: NDArray, step: NDArray) -> NDArray:
        """Poses (N, n) moved by steps (N, n); the angular part of a spatial step is a
        rotation vector applied in the base frame (left-multiplied)."""
        if self.kind != "spatial6":
            return x + step
        # The angular part of the step is a rotation in the base frame (left-multiplied).
        rot = Rotation.from_rotvec(step[:, 3:]) * Rotation.from_rotvec(x[:, 3:])
        return np.concatenate([x[:, :3] + step[:, :3], rot.as_rotvec().reshape(-1, 3)], axis=1)

    def _default_home(self) -> NDArray:
        centre = self.anchors.mean(axis=0)
        return {
            "point3": centre,
            "planar_point2": centre[[0, 2]],
            "planar3": np.array([centre[0], centre[1], 0.0]),
            "spatial6": np.concatenate([centre, np.zeros(3)]),
        }[self.kind]


@dataclass(frozen=True)
class ForwardKinematicsResult:
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
        return self.status == "converged"
