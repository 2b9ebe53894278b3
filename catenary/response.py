"""Linear response of the platform about an equilibrium: free vibration and static deflection.

With the unstretched cable lengths held fixed (winches locked) and the cables treated as
massless springs (their stiffness from :mod:`catenary.robot_stiffness`, straight or
sagging), small motions ``dq`` of the platform about a pose obey
``M ddq + K dq = d_load``:

- :func:`mass_matrix` ``M`` (N, n, n) of the rigid platform in the pose-step
  coordinates of :meth:`tension_opt.CableRobot.displace` (translation of the reference
  point, rotation about the base axes);
- :func:`vibration_modes` / :func:`natural_frequencies`: the generalised eigenproblem
  ``K phi = omega^2 M phi``;
- :func:`deflection`: the static deflection under an added wrench, linear
  (``K dq = load``) or exact (two forward-kinematics solutions with the lengths held).

The cables' own inertia is left out: a heavy cable's mass would add to ``M`` and
give the cable its own (string) modes, which this platform model does not have.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from tension_opt import CableRobot
from tension_opt.robot import CableProperties
from tension_opt.status import Status

from .errors import InvalidCableError
from .forward import forward_kinematics
from .geometry import cable_data
from .robot_stiffness import (
    StiffnessModel,
    StiffnessResult,
    cross_matrix,
    step_basis,
    stiffness_analysis,
)

__all__ = [
    "VibrationModes",
    "deflection",
    "deflection_from",
    "mass_matrix",
    "modes_from",
    "natural_frequencies",
    "vibration_modes",
]

FloatArray = NDArray[np.float64]

#: A stiffness whose condition number exceeds this is treated as singular.
SINGULAR_CONDITION = 1e13


def mass_matrix(robot: CableRobot, poses: ArrayLike) -> FloatArray:
    """Mass matrix of the platform in pose-step coordinates (kg, kg m, kg m^2), (N, n, n).

    With ``v`` the velocity of the reference point, ``omega`` the angular velocity
    (base frame) and ``s = R c`` the centre of mass relative to the reference point,
    the kinetic energy ``(m |v + omega x s|^2 + omega^T R I_c R^T omega) / 2`` gives
    ``M6 = [[m I, -m [s]x], [m [s]x, R I_c R^T - m [s]x [s]x]]``; the kind keeps
    ``D^T M6 D`` (``D`` its step maps). A point mass has ``M = m I``.

    Parameters
    ----------
    robot : CableRobot
        ``mass`` (kg), ``com`` (m) and ``inertia`` (kg m^2, about the centre of mass in
        the platform frame).
    poses : array_like, shape (N, n) or (n,)
    """
    p = robot.as_poses(poses)
    _, R = robot.frames(p)
    m = robot.mass
    M6 = np.zeros((len(p), 6, 6))
    M6[:, :3, :3] = m * np.eye(3)
    if robot.pattern.rotates:
        S = cross_matrix(np.einsum("kij,j->ki", R, robot.com))
        M6[:, :3, 3:] = -m * S
        M6[:, 3:, :3] = m * S
        M6[:, 3:, 3:] = R @ robot.inertia @ np.swapaxes(R, 1, 2) - m * S @ S
    D = step_basis(robot)
    return np.einsum("ai,kab,bj->kij", D, M6, D)


@dataclass(frozen=True, eq=False)
class VibrationModes:
    """Undamped free vibration of the platform about a batch of poses.

    Attributes
    ----------
    frequencies : ndarray, shape (N, n)
        Natural frequencies (Hz), ascending: ``sign(lam) sqrt(|lam|) / (2 pi)``; a
        negative value marks an unstable direction (``lam < 0``). NaN where the
        stiffness is unknown.
    eigenvalues : ndarray, shape (N, n)
        ``lam = omega^2`` ((rad/s)^2), ascending.
    shapes : ndarray, shape (N, n, n)
        Mode shapes as columns (``shapes[k, :, j]`` belongs to ``frequencies[k, j]``),
        in pose-step coordinates, mass-normalised (``phi^T M phi = I``), each with its
        largest component positive.
    stiffness : ndarray, shape (N, n, n)
        The stiffness used (N/m, N m/rad).
    mass : ndarray, shape (N, n, n)
        The mass matrix (:func:`mass_matrix`).
    status : ndarray of str, shape (N,)
        As :attr:`StiffnessResult.status`.
    """

    frequencies: FloatArray
    eigenvalues: FloatArray
    shapes: FloatArray
    stiffness: FloatArray
    mass: FloatArray
    status: NDArray[np.str_]

    @property
    def lowest(self) -> FloatArray:
        """The lowest natural frequency of each pose (Hz), shape (N,)."""
        return self.frequencies[:, 0]

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose and mode: status, frequency (Hz), eigenvalue."""
        N, n = self.frequencies.shape
        return pd.DataFrame({
            "pose": np.repeat(np.arange(N), n), "mode": np.tile(np.arange(n), N),
            "status": np.repeat(self.status, n), "frequency": self.frequencies.ravel(),
            "eigenvalue": self.eigenvalues.ravel()})


def modes_from(stiffness: FloatArray, mass: FloatArray,
               status: NDArray[np.str_]) -> VibrationModes:
    """Vibration modes of stiffness (N, n, n) and mass (N, n, n) matrices.

    The symmetric part of the stiffness is used (it is symmetric at equilibrium, see
    :mod:`catenary.robot_stiffness`). ``M = L L^T`` (Cholesky) turns the generalised
    problem into the symmetric ``L^-1 K L^-T y = lam y``, solved for all poses at once.

    Raises
    ------
    InvalidCableError
        If a mass matrix is not positive definite (a rotating platform without inertia).
    """
    N, n, _ = stiffness.shape
    lam = np.full((N, n), np.nan)
    shapes = np.full((N, n, n), np.nan)
    ok = np.isfinite(stiffness).all(axis=(1, 2))
    try:
        chol = np.linalg.cholesky(mass)
    except np.linalg.LinAlgError:
        raise InvalidCableError(
            "the mass matrix is not positive definite: a rotating platform needs a "
            "positive-definite inertia (give the robot inertia=... about its centre of "
            "mass, kg m^2)") from None
    if ok.any():
        Ks = 0.5 * (stiffness[ok] + np.swapaxes(stiffness[ok], 1, 2))
        Li = np.linalg.inv(chol[ok])
        A = Li @ Ks @ np.swapaxes(Li, 1, 2)
        values, vectors = np.linalg.eigh(0.5 * (A + np.swapaxes(A, 1, 2)))
        phi = np.swapaxes(Li, 1, 2) @ vectors
        # Deterministic signs: the largest component of each mode positive.
        big = np.take_along_axis(phi, np.abs(phi).argmax(axis=1)[:, None, :], axis=1)
        lam[ok], shapes[ok] = values, phi * np.where(big < 0, -1.0, 1.0)
    freq = np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)
    return VibrationModes(freq, lam, shapes, stiffness, mass, status)


def vibration_modes(robot: CableRobot, poses: ArrayLike, tensions: ArrayLike | None = None,
                    model: StiffnessModel = "coupled", **kwargs: Any) -> VibrationModes:
    """Natural frequencies and mode shapes of the platform on its cables.

    Parameters
    ----------
    robot : CableRobot
        Its ``mass``, ``com`` and ``inertia`` give the mass matrix; its cables the
        stiffness.
    poses : array_like, shape (N, n) or (n,)
    tensions, model, **kwargs
        As :func:`catenary.robot_stiffness.stiffness_analysis` (default: the model's
        own equilibrium).

    Returns
    -------
    VibrationModes
    """
    result = stiffness_analysis(robot, poses, tensions, model, **kwargs)
    return modes_from(result.stiffness, mass_matrix(robot, poses), result.status)


def natural_frequencies(robot: CableRobot, poses: ArrayLike,
                        tensions: ArrayLike | None = None, model: StiffnessModel = "coupled",
                        **kwargs: Any) -> FloatArray:
    """Natural frequencies of the platform (Hz), ascending, shape (N, n).

    The square roots of the eigenvalues of ``K phi = omega^2 M phi`` over ``2 pi``
    (:func:`vibration_modes`, which also gives the mode shapes); ``K`` from
    :func:`catenary.platform_stiffness` and ``M`` from :func:`mass_matrix`. NaN where
    the stiffness is unknown; negative where the equilibrium is unstable.

    Examples
    --------
    >>> import tension_opt as to
    >>> robot = to.presets.algae_harvester(EA=3.14e7)
    >>> f = natural_frequencies(robot, [0.0, 0.0, 2.0], model="straight")
    >>> f.shape
    (1, 3)
    """
    return vibration_modes(robot, poses, tensions, model, **kwargs).frequencies


# -------------------------------------------------------------------------- deflection
def deflection_from(stiffness: FloatArray, load: FloatArray) -> FloatArray:
    """Linear deflection ``K^-1 load`` (N, n) of stiffness matrices (N, n, n) under loads
    (N, n); NaN where the stiffness is unknown or singular (condition number above
    :data:`SINGULAR_CONDITION`)."""
    N, n, _ = stiffness.shape
    out = np.full((N, n), np.nan)
    ok = np.asarray(np.isfinite(stiffness).all(axis=(1, 2)), dtype=bool)
    ok[ok] = np.linalg.cond(stiffness[ok]) < SINGULAR_CONDITION
    if ok.any():
        out[ok] = np.linalg.solve(stiffness[ok], load[ok][..., None])[..., 0]
    return out


def _pose_step(robot: CableRobot, start: FloatArray, end: FloatArray) -> FloatArray:
    """Pose steps (N, n) from ``start`` to ``end`` poses, in the convention of
    :meth:`~tension_opt.CableRobot.displace` (rotation about the base axes)."""
    p0, R0 = robot.frames(start)
    p1, R1 = robot.frames(end)
    turn = Rotation.from_matrix(R1 @ np.swapaxes(R0, 1, 2)).as_rotvec().reshape(-1, 3)
    return np.concatenate([p1 - p0, turn], axis=1) @ step_basis(robot)


def _exact_deflection(robot: CableRobot, poses: FloatArray, result: StiffnessResult,
                      load: FloatArray, wrench: ArrayLike | None) -> FloatArray:
    """Deflection by the catenary forward kinematics with the lengths held, (N, n)."""
    if result.model == "straight":
        # Straight elastic cables are weightless catenaries.
        c = robot.cable
        assert c is not None  # the straight model checked it
        robot = robot.with_(cable=CableProperties(c.diameter, 0.0, c.EA))
    base = np.zeros_like(load) if wrench is None else np.broadcast_to(
        np.asarray(wrench, dtype=float), load.shape)
    out = np.full(load.shape, np.nan)
    ok = result.success
    if ok.any():
        L = result.lengths[ok]
        before = forward_kinematics(robot, L, "catenary", poses[ok], base[ok])
        after = forward_kinematics(robot, L, "catenary", before.poses, base[ok] + load[ok])
        step = _pose_step(robot, before.poses, after.poses)
        done = (before.status == Status.CONVERGED) & (after.status == Status.CONVERGED)
        out[ok] = np.where(done[:, None], step, np.nan)
    return out


def deflection(
    robot: CableRobot,
    poses: ArrayLike,
    load: ArrayLike,
    tensions: ArrayLike | None = None,
    model: StiffnessModel = "coupled",
    *,
    method: Literal["linear", "exact"] = "linear",
    wrench: ArrayLike | None = None,
    **kwargs: Any,
) -> FloatArray:
    """Static deflection of the platform under an added wrench, lengths held (N, n).

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
        Equilibrium poses (m, rad).
    load : array_like, shape (n,) or (N, n)
        Wrench added on the platform (N, N m; the kind's rows, moments about the
        reference point), e.g. ``[100, 0, 0]``: a 100 N push along x.
    tensions, model, **kwargs
        As :func:`catenary.robot_stiffness.stiffness_analysis`.
    method : {"linear", "exact"}
        ``"linear"``: ``K^-1 load`` (NaN where ``K`` is singular). ``"exact"``: the
        pose change between the catenary forward kinematics
        (:func:`catenary.forward_kinematics`) under ``wrench + load`` and under
        ``wrench`` with the unstretched lengths of the equilibrium (weightless
        catenaries for ``"straight"``); NaN where either does not converge.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench already on the platform besides gravity (N, N m).

    Returns
    -------
    ndarray, shape (N, n)
        Pose step (m, rad; rotation about the base axes), NaN where the stiffness or
        the forward kinematics failed.
    """
    if method not in ("linear", "exact"):
        raise InvalidCableError(f'method must be "linear" or "exact"; got method={method!r}')
    p = robot.as_poses(poses)
    try:
        added = np.broadcast_to(np.asarray(load, dtype=float), p.shape)
    except ValueError:
        raise InvalidCableError(f"load must have shape ({robot.dof},) or ({len(p)}, "
                                f"{robot.dof}), got {np.shape(load)}") from None
    if not np.isfinite(added).all():
        raise InvalidCableError("load must be finite (N, N m)")
    cable_data(robot)
    result = stiffness_analysis(robot, p, tensions, model, wrench=wrench, **kwargs)
    if method == "linear":
        return deflection_from(result.stiffness, added)
    return _exact_deflection(robot, p, result, added, wrench)
