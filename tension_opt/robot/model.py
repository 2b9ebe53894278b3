"""Cable robot model: geometry, structure (wrench) matrices, straight-line kinematics.

Conventions
-----------
Base frame: z up, gravity along -z. A pose's coordinates depend on the robot's kind
(its motion pattern, :mod:`tension_opt.kinds`).

Cable ``i`` runs from the attachment point ``b_i = p + R a_i`` on the platform to
its drawing point (anchor) ``A_i`` in the base frame. Its unit vector
``u_i = (A_i - b_i) / |A_i - b_i|`` points from the platform to the anchor, so a
tension ``T_i >= 0`` pulls the platform along ``u_i``. The structure matrix
column is ``[u_i; (R a_i) x u_i]`` restricted to the rows of the kind's degrees of
freedom, and static equilibrium reads ``A T + w_g + w_ext = 0``; moments are taken
about the platform reference point ``p``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from os import PathLike
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import (
    as_finite,
    as_float_array,
    check_positive,
    check_reach,
    inertia_tensor,
    is_number,
    label,
    per_cable,
)
from tension_opt.errors import InvalidInputError
from tension_opt.kernels.first_use import announce
from tension_opt.kernels.launch import compiled_for
from tension_opt.kinds import MotionPattern, get_kind
from tension_opt.robot.geometry import CableGeometry, StraightForwardKinematicsResult
from tension_opt.robot.pulleys import Pulley, check_pulleys, pulley_arrays, pulley_exits
from tension_opt.status import STATUS_DTYPE, Status

RobotKind = Literal["point3", "planar_point2", "planar3", "spatial6"]


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

    def __post_init__(self) -> None:
        check_positive("cable diameter", self.diameter)
        if not is_number(self.linear_mass) or not np.isfinite(self.linear_mass) or (
                self.linear_mass < 0):
            raise InvalidInputError(
                f"cable linear_mass must be a finite number >= 0 (kg/m), got {self.linear_mass!r}")
        if not is_number(self.EA) or np.isnan(self.EA) or self.EA <= 0:
            raise InvalidInputError(
                f"cable EA must be a positive number or inf (N), got {self.EA!r}")

    @classmethod
    def from_density(
        cls, diameter: float, density: float, EA: float = float("inf")
    ) -> CableProperties:
        """Cable of a solid circular section: ``linear_mass = density * pi/4 * d^2``."""
        check_positive("cable diameter", diameter)
        check_positive("cable density", density)
        return cls(diameter, density * np.pi / 4.0 * diameter**2, EA)

    def weight_per_length(self, g: float = 9.81) -> float:
        """Weight per unit length ``w = linear_mass * g`` (N/m)."""
        return self.linear_mass * g


def box_inertia(mass: float, attachments: ArrayLike) -> NDArray:
    """Inertia tensor (kg m^2, shape (3, 3)) of a uniform solid box of ``mass`` (kg)
    whose edges span the attachment points (m, shape (m, 3)) along each platform axis.

    ``mass / 12 * diag(b^2 + c^2, a^2 + c^2, a^2 + b^2)`` for edges ``a, b, c``; zero
    when the attachments coincide (a point mass).
    """
    points = np.asarray(attachments, dtype=float).reshape(-1, 3)
    a, b, c = np.ptp(points, axis=0)
    with np.errstate(over="ignore"):  # beyond the float range: refused by name below
        inertia = float(mass) / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    return as_finite("box_inertia (mass / 12 * edge^2; give the inertia instead)", inertia)


@dataclass(frozen=True, eq=False)
class CableRobot:
    """A cable-driven parallel robot with ``m`` cables.

    Parameters
    ----------
    anchors : array_like, shape (m, 3)
        Drawing points (cable exit points) in the base frame (m), all within 1e6 m, as
        attachments and ``com`` are. Cables may share one (NIST RoboCrane): the rank of
        the structure matrix decides what the robot can hold.
    attachments : array_like, shape (m, 3)
        Attachment points in the platform frame (m). All zero for a point mass.
    mass : float
        Platform (end-effector) mass (kg), > 0.
    kind : {"point3", "planar_point2", "planar3", "spatial6"} or MotionPattern
        How the platform moves (:mod:`tension_opt.kinds`); stored as the kind's name,
        its pattern as :attr:`pattern`.
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
        Label used in tables and plots: non-empty text (as in a robot file).
    inertia : array_like, shape (3, 3), optional
        Inertia tensor of the platform about its centre of mass, in the platform frame
        (kg m^2), symmetric positive semi-definite. By default that of a uniform solid
        box spanning the attachment points (:func:`box_inertia`); zero for a point mass.
        Used by the dynamics (:mod:`tension_opt.dynamics`) and the natural frequencies.
    platform_hull : array_like, shape (k, 3), optional
        Platform polyhedron's vertices, platform frame (m); None: the attachments' hull.
    pulleys : sequence of Pulley or None, length m, optional
        A swivel guide pulley at each cable's drawing point, or None for a cable drawn
        from a fixed point (:mod:`tension_opt.robot.pulleys`). Stored as a tuple, or
        None when no cable has one (a robot without pulleys answers as before).
    """

    anchors: NDArray
    attachments: NDArray
    mass: float
    kind: RobotKind | str = "point3"
    com: NDArray = field(default_factory=lambda: np.zeros(3))
    g: float = 9.81
    t_min: NDArray | float = 0.0
    t_max: NDArray | float = np.inf
    cable: CableProperties | None = None
    home: NDArray | None = None
    name: str = "cable robot"
    inertia: NDArray | None = None
    platform_hull: NDArray | None = None
    pulleys: Sequence[Pulley | None] | None = None
    pattern: MotionPattern = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pattern = get_kind(self.kind)
        object.__setattr__(self, "pattern", pattern)
        object.__setattr__(self, "kind", pattern.name)
        object.__setattr__(self, "name", label("name", self.name))
        anchors = as_finite("anchors", self.anchors)
        if anchors.ndim != 2 or anchors.shape[1] != 3 or anchors.shape[0] < 1:
            raise InvalidInputError(f"anchors must have shape (m, 3), got {anchors.shape}")
        m = anchors.shape[0]
        attachments = as_finite("attachments", self.attachments, (m, 3))
        check_positive("mass", self.mass)
        if not is_number(self.g) or not np.isfinite(self.g) or self.g < 0:
            raise InvalidInputError(f"g must be finite and >= 0, got {self.g!r}")
        com = as_finite("com", self.com, (3,))
        check_reach(anchors=anchors, attachments=attachments, com=com)
        if not np.isfinite(self.mass * self.g):
            raise InvalidInputError(
                f"the platform's weight mass * g = {self.mass!r} * {self.g!r} overflows")
        if self.cable is not None and not isinstance(self.cable, CableProperties):
            raise InvalidInputError(
                f"cable must be CableProperties or None, got {type(self.cable).__name__}")
        t_min = per_cable("t_min", self.t_min, m)
        t_max = per_cable("t_max", self.t_max, m)
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
        home = None if self.home is None else as_finite("home", self.home, (self.dof,))
        object.__setattr__(self, "pulleys", check_pulleys(self.pulleys, m))
        hull = None if (ph := self.platform_hull) is None else as_finite("platform_hull", ph)
        if hull is not None and (hull.ndim != 2 or hull.shape[1:] != (3,) or not len(hull)):
            raise InvalidInputError(f"platform_hull must have shape (k, 3), got {hull.shape}")
        inertia = (box_inertia(self.mass, attachments) if self.inertia is None
                   else inertia_tensor(self.inertia))
        # The robot's own copies: the caller's arrays stay theirs, and writeable.
        anchors, attachments, com = anchors.copy(), attachments.copy(), com.copy()
        home, hull = (None if a is None else a.copy() for a in (home, hull))
        owned = {"anchors": anchors, "attachments": attachments, "com": com, "t_min": t_min,
                 "t_max": t_max, "home": home, "inertia": inertia, "platform_hull": hull}
        for key, arr in owned.items():
            object.__setattr__(self, key, arr)
            if arr is not None:
                arr.setflags(write=False)

    # ------------------------------------------------------------------ sizes
    @property
    def m(self) -> int:
        """Number of cables."""
        return int(self.anchors.shape[0])

    @property
    def dof(self) -> int:
        """Degrees of freedom ``n`` (rows of the structure matrix and size of a pose)."""
        return self.pattern.pose_size

    @property
    def redundancy(self) -> int:
        """``m - n``: dimension of the null space of a full-rank structure matrix."""
        return self.m - self.dof

    @property
    def wrench_rows(self) -> tuple[int, ...]:
        """Rows of the spatial wrench (fx, fy, fz, mx, my, mz) that the kind keeps."""
        return self.pattern.wrench_rows

    @property
    def has_pulleys(self) -> bool:
        """Whether some cable leaves over a guide pulley (:attr:`pulleys`)."""
        return self.pulleys is not None

    @property
    def weight(self) -> float:
        """Platform weight ``mass * g`` (N)."""
        return self.mass * self.g

    def with_(self, **changes: object) -> CableRobot:
        """Copy of the robot with some fields replaced (validated again)."""
        return replace(self, **changes)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ files
    @classmethod
    def from_file(cls, path: str | PathLike[str]) -> CableRobot:
        """The robot described in a YAML (``.yaml``/``.yml``) or JSON (``.json``) file.

        The format is that of :mod:`tension_opt.robot.files` (``docs/robot_files.md``).

        Raises
        ------
        RobotFileError
            Naming each bad field, its line in the file and the fix.
        """
        from tension_opt.robot import files as robot_files  # pydantic, yaml only when needed

        return robot_files.read_robot_file(path, cls, CableProperties)

    def to_file(self, path: str | PathLike[str]) -> None:
        """Write the robot as YAML or JSON (by the suffix of ``path``); :meth:`from_file`
        reads it back bit for bit."""
        from tension_opt.robot import files as robot_files

        robot_files.write_robot_file(path, self)

    # ------------------------------------------------------------------ poses
    def as_poses(self, poses: ArrayLike) -> NDArray:
        """Validate poses and return them as a float array of shape (N, n).

        A single pose of shape (n,) becomes a batch of one.
        """
        arr = as_float_array("poses", poses)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise InvalidInputError(
                f"poses of a {self.kind} robot must have shape (N, {self.dof}), got "
                f"{np.shape(poses)}"
            )
        return as_finite("poses", arr)

    def frames(self, poses: NDArray) -> tuple[NDArray, NDArray]:
        """Platform position (N, 3) and rotation matrices (N, 3, 3) of validated poses (N, n)."""
        return self.pattern.frames(poses)

    def attachment_points(self, poses: ArrayLike) -> NDArray:
        """Attachment points in the base frame, shape (N, m, 3) (m)."""
        return self.cable_geometry(poses, check=False).attachment_points

    # ------------------------------------------------------------- kinematics
    def inverse_kinematics(self, poses: ArrayLike) -> tuple[NDArray, NDArray]:
        """Straight-line cable lengths and unit vectors.

        Parameters
        ----------
        poses : array_like, shape (N, n) or (n,)

        Returns
        -------
        lengths : ndarray, shape (N, m)
            Distance from attachment point to drawing point (m); over a guide pulley,
            the wrapped arc plus the free span ``|B - T|``.
        unit_vectors : ndarray, shape (N, m, 3)
            Unit vectors from the attachment point toward the drawing point (over a
            pulley: toward the point ``T`` where the cable leaves it).

        Raises
        ------
        InvalidInputError
            If a pose puts an attachment point on its drawing point (zero-length cable).
        """
        geometry = self.cable_geometry(poses)
        return geometry.total_lengths, geometry.unit

    def cable_geometry(self, poses: ArrayLike, *, check: bool = True) -> CableGeometry:
        """Straight cables of a batch of poses: the one place cable vectors are computed.

        Parameters
        ----------
        poses : array_like, shape (N, n) or (n,)
        check : bool
            Raise on a pose that puts an attachment point on its drawing point (a
            zero-length cable has no direction). With ``check=False`` such poses are
            returned and flagged in :attr:`CableGeometry.degenerate`.

        Returns
        -------
        CableGeometry

        Raises
        ------
        InvalidInputError
            For invalid poses, or (``check=True``) a zero-length cable.
        """
        p = self.as_poses(poses)
        position, R = self.pattern.frames(p)
        if self.pattern.rotates:
            arms = np.einsum("nij,mj->nmi", R, self.attachments)  # R a_i, (N, m, 3)
        else:  # no rotation: the arms are the attachments
            arms = np.broadcast_to(self.attachments, (len(p), *self.attachments.shape))
        vectors = self.anchors[None] - (position[:, None, :] + arms)
        lengths = np.sqrt(np.einsum("nmi,nmi->nm", vectors, vectors))
        if not np.isfinite(lengths).all():
            k = int(np.argmax(~np.isfinite(lengths).all(axis=1)))
            raise InvalidInputError(
                f"pose {k} ({p[k].tolist()}) is too far from the drawing points: its cable "
                "lengths overflow")
        wrapped = None
        if self.pulleys is not None:
            vectors, lengths, wrapped = self._over_pulleys(position[:, None, :] + arms,
                                                           vectors, lengths)
        geometry = CableGeometry(p, position, R, arms, vectors, lengths,
                                 1e-12 * max(1.0, float(np.abs(self.anchors).max())), wrapped)
        if check and geometry.degenerate.any():
            k = int(np.argmax(geometry.degenerate))
            if wrapped is not None and np.isnan(wrapped[k]).any():
                i = int(np.argmax(np.isnan(wrapped[k])))
                raise InvalidInputError(
                    f"pose {k} ({p[k].tolist()}) puts cable {i}'s attachment point on its "
                    "pulley's swivel axis or wheel: the pulley has no exit point")
            i = int(np.argmax(lengths[k] <= geometry.zero_length))
            raise InvalidInputError(
                f"pose {k} ({p[k].tolist()}) puts cable {i} on its drawing point "
                f"{self.anchors[i].tolist()}: zero-length cable"
            )
        return geometry

    def _over_pulleys(self, points: NDArray, vectors: NDArray, lengths: NDArray
                      ) -> tuple[NDArray, NDArray, NDArray]:
        """Free-span vectors and lengths (N, m, 3), (N, m) of cables over their
        pulleys, and the wrapped lengths (N, m) (zero without a pulley, NaN where a
        pulley has no exit point)."""
        assert self.pulleys is not None
        idx, radii, axes = pulley_arrays(self.pulleys)
        every = len(idx) == self.m  # then whole arrays, no gathers and scatters
        at = slice(None) if every else idx
        exits = pulley_exits(self.anchors[idx], axes, radii,
                             points if every else points[:, idx], swivel=False)
        if not every:
            vectors, lengths = vectors.copy(), lengths.copy()
        vectors[:, at] = exits.exit_points - (points if every else points[:, idx])
        lengths[:, at] = exits.spans
        wrapped = np.zeros_like(lengths)
        wrapped[:, at] = radii * exits.wrap
        return vectors, lengths, wrapped

    def cable_wrenches(self, forces: NDArray, arms: NDArray) -> NDArray:
        """Wrench of each cable force on the platform, shape (N, m, n).

        Parameters
        ----------
        forces : ndarray, shape (N, m, 3)
            Force of each cable on the platform (N), in the base frame.
        arms : ndarray, shape (N, m, 3)
            Attachment points relative to the platform reference point, ``R a_i`` (m).
        """
        if not self.pattern.rotates and not self.attachments.any():
            return self.pattern.select(np.concatenate([forces, np.zeros_like(forces)], -1))
        return self.pattern.select(np.concatenate([forces, np.cross(arms, forces)], axis=-1))

    def structure_matrices(self, poses: ArrayLike) -> NDArray:
        """Structure (wrench) matrices, shape (N, n, m).

        Column ``i`` is the wrench a unit tension in cable ``i`` applies to the platform,
        restricted to the robot's degrees of freedom.
        """
        return self.structure_from(self.cable_geometry(poses))

    def structure_from(self, geometry: CableGeometry) -> NDArray:
        """Structure matrices (N, n, m) of a :class:`CableGeometry`."""
        unit = geometry.unit
        if not self.pattern.rotates:
            rows = [r for r in self.pattern.wrench_rows if r < 3]
            if len(rows) == self.dof:
                return np.ascontiguousarray(np.swapaxes(unit[..., rows], 1, 2))
        return np.ascontiguousarray(np.swapaxes(self.cable_wrenches(unit, geometry.arms), 1, 2))

    def gravity_wrench(self, poses: ArrayLike) -> NDArray:
        """Wrench of gravity on the platform about its reference point, shape (N, n)."""
        p = self.as_poses(poses)
        N = p.shape[0]
        force = np.array([0.0, 0.0, -self.mass * self.g])
        full = np.zeros((N, 6))
        full[:, :3] = force
        if self.pattern.rotates:
            _, R = self.pattern.frames(p)
            full[:, 3:] = np.cross(R @ self.com, force)
        return self.pattern.select(full)

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
            w = as_finite("wrench", wrench)
            try:
                w = np.broadcast_to(w, b.shape)
            except ValueError:
                raise InvalidInputError(
                    f"wrench must have shape ({self.dof},) or ({p.shape[0]}, {self.dof}), "
                    f"got {np.shape(wrench)}"
                ) from None
            with np.errstate(over="ignore", invalid="ignore"):  # the error below says it
                b = b - w
            if not np.isfinite(b).all():
                raise InvalidInputError(f"wrench overflows when added to gravity: {wrench!r}"[:300])
        return b

    def equilibrium(self, poses: ArrayLike, wrench: ArrayLike | None = None
                    ) -> tuple[NDArray, NDArray]:
        """:meth:`structure_matrices` (N, n, m) and :meth:`required_wrench` (N, n) at once,
        compiled (:func:`tension_opt.kernels.geometry.robot_geometry`) for batches from
        ``COMPILED_MIN`` poses, else by those methods: the same values to rounding."""
        p = self.as_poses(poses)
        if compiled_for(len(p)) and not self.has_pulleys:
            from tension_opt.kernels.geometry import robot_geometry  # loads numba

            announce("robot geometry", robot_geometry)
            if compiled := robot_geometry(self, p, wrench):
                return compiled
        return self.structure_matrices(p), self.required_wrench(p, wrench)

    def forward_kinematics(
        self,
        lengths: ArrayLike,
        initial_poses: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iter: int = 50,
        consistency_tol: float = 1e-6,
    ) -> StraightForwardKinematicsResult:
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
        StraightForwardKinematicsResult
            ``poses`` (N, n), ``residual`` (N,) RMS length residual (m), ``iterations``
            (N,), ``status`` (N,) among ``"converged"``, ``"inconsistent"``,
            ``"not_converged"``.
        """
        L = as_finite("lengths", lengths)
        if L.ndim == 1:
            L = L[None]
        if L.ndim != 2 or L.shape[1] != self.m:
            raise InvalidInputError(
                f"lengths must have shape (N, {self.m}), got {np.shape(lengths)}"
            )
        if (L <= 0).any():
            raise InvalidInputError("lengths must be positive")
        if not isinstance(max_iter, int | np.integer) or isinstance(max_iter, bool) or (
                max_iter < 0):
            raise InvalidInputError(f"max_iter must be a whole number >= 0, got {max_iter!r}")
        for name, value in (("tol", tol), ("consistency_tol", consistency_tol)):
            if not is_number(value) or not np.isfinite(value) or value < 0:
                raise InvalidInputError(f"{name} must be a finite number >= 0, got {value!r}")
        N = L.shape[0]
        if initial_poses is None:
            start = self.default_home()
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
            geometry = self.cable_geometry(x[idx])
            lk = geometry.total_lengths
            J = -np.swapaxes(self.structure_from(geometry), 1, 2)  # dL/dpose, (k, m, n)
            r = lk - L[idx]
            # Normal equations of the Gauss-Newton step, with a tiny damping for safety.
            JtJ = np.einsum("kmi,kmj->kij", J, J) + 1e-12 * np.eye(self.dof)
            step = -np.linalg.solve(JtJ, np.einsum("kmi,km->ki", J, r)[..., None])[..., 0]
            x[idx] = self.displace(x[idx], step)
            iterations[idx] += 1
            done = np.abs(step).max(axis=1) < tol
            active[idx[done]] = False
        lk = self.cable_geometry(x).total_lengths
        residual = np.sqrt(np.mean((lk - L) ** 2, axis=1))
        met = np.where(residual > consistency_tol, Status.INCONSISTENT, Status.CONVERGED)
        status = np.where(active, Status.NOT_CONVERGED, met).astype(STATUS_DTYPE)
        return StraightForwardKinematicsResult(x, residual, iterations, status)

    def displace(self, x: NDArray, step: NDArray) -> NDArray:
        """Poses (N, n) moved by steps (N, n); the angular part of a spatial step is a
        rotation vector applied in the base frame (left-multiplied)."""
        return self.pattern.displace(x, step)

    def default_home(self) -> NDArray:
        """The robot's ``home`` pose, or the anchors' centroid unrotated, shape (n,)."""
        if self.home is not None:
            return self.home
        return self.pattern.home(self.anchors.mean(axis=0))
