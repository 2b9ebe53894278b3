"""Structure matrix and required wrench of one pose, compiled, for every robot kind.

The reference is :meth:`tension_opt.robot.CableRobot.structure_matrices` and
:meth:`~tension_opt.robot.CableRobot.required_wrench`; the kind codes below stand for
the kinds of :mod:`tension_opt.kinds`. Rotations follow scipy's rotation vectors
(through the unit quaternion, with its series for small angles), so the matrices agree
with the numpy path to rounding.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.kernels.launch import run
from tension_opt.kinds import KINDS

__all__ = [
    "GEOMETRY_DEGENERATE",
    "GEOMETRY_OK",
    "GEOMETRY_OVERFLOW",
    "KIND_CODES",
    "arm_and_vector",
    "compiled_kind",
    "geometry_batch",
    "geometry_into",
    "geometry_serial",
    "kind_code",
    "platform_position",
    "robot_geometry",
    "robot_kind_code",
    "rotation",
]

#: Kind names of :mod:`tension_opt.kinds` and their codes in the kernels.
KIND_CODES = {"point3": 0, "planar_point2": 1, "planar3": 2, "spatial6": 3}
#: Return codes of :func:`geometry_into`.
GEOMETRY_OK, GEOMETRY_DEGENERATE, GEOMETRY_OVERFLOW = 0, 1, 2


def kind_code(kind: str) -> int:
    """The kernels' code of a robot kind name."""
    try:
        return KIND_CODES[kind]
    except KeyError:
        raise InvalidInputError(
            f"no compiled geometry for robot kind {kind!r}; known: {sorted(KIND_CODES)}"
        ) from None


def robot_kind_code(robot: Any) -> int:
    """:func:`kind_code` of a robot's kind; an error for a robot with guide pulleys
    (the kernels draw each cable from a fixed point)."""
    if getattr(robot, "pulleys", None) is not None:
        raise InvalidInputError("the compiled kernels draw each cable from a fixed point: a "
                                "robot with guide pulleys takes the numpy path (backend "
                                "'closed_form' with fewer poses, or another backend)")
    return kind_code(robot.kind)


@njit(cache=True, error_model="numpy", inline="always")
def rotation(kind: int, pose: NDArray) -> tuple[float, float, float, float, float, float,
                                                float, float, float]:
    """Rotation matrix of a pose, row by row (identity if the kind does not rotate).
    One return (see :mod:`tension_opt.kernels`)."""
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    if kind == 2:
        c, s = math.cos(pose[2]), math.sin(pose[2])
        R = (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    elif kind == 3:
        rx, ry, rz = pose[3], pose[4], pose[5]
        angle = math.sqrt(rx * rx + ry * ry + rz * rz)
        if angle <= 1e-3:  # scipy's series of sin(angle / 2) / angle
            a2 = angle * angle
            scale = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
        else:
            scale = math.sin(0.5 * angle) / angle
        x, y, z, w = scale * rx, scale * ry, scale * rz, math.cos(0.5 * angle)
        x2, y2, z2, w2 = x * x, y * y, z * z, w * w
        xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
        R = (x2 - y2 - z2 + w2, 2.0 * (xy - zw), 2.0 * (xz + yw),
             2.0 * (xy + zw), -x2 + y2 - z2 + w2, 2.0 * (yz - xw),
             2.0 * (xz - yw), 2.0 * (yz + xw), -x2 - y2 + z2 + w2)
    if pose.size < 0:  # never: the pose read after the branches (tension_opt.kernels)
        R = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return R


@njit(cache=True, error_model="numpy", inline="always")
def platform_position(kind: int, pose: NDArray) -> tuple[float, float, float]:
    """Reference point of a pose in the base frame (m): ``(x, y, z)``, ``(x, 0, z)`` for
    the vertical-plane point, ``(x, y, 0)`` for the planar platform."""
    y = pose[1] if kind != 1 else 0.0
    z = pose[1] if kind == 1 else (0.0 if kind == 2 else pose[2])
    return pose[0], y, z  # pose read last outside the branches (tension_opt.kernels)


@njit(cache=True, error_model="numpy", inline="always")
def arm_and_vector(R: tuple, position: tuple, anchors: NDArray, attachments: NDArray,
                   i: int) -> tuple[float, float, float, float, float, float]:
    """Cable ``i``'s arm ``r = R a_i`` and vector ``v = A_i - (p + r)`` (attachment to
    drawing point) at a pose of rotation ``R`` (row by row) and ``position``."""
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = R
    a0, a1, a2 = attachments[i, 0], attachments[i, 1], attachments[i, 2]
    r0 = R00 * a0 + R01 * a1 + R02 * a2
    r1 = R10 * a0 + R11 * a1 + R12 * a2
    r2 = R20 * a0 + R21 * a1 + R22 * a2
    v0 = anchors[i, 0] - (position[0] + r0)
    v1 = anchors[i, 1] - (position[1] + r1)
    v2 = anchors[i, 2] - (position[2] + r2)
    return r0, r1, r2, v0, v1, v2


@njit(cache=True, error_model="numpy", inline="always")
def _put(kind: int, M: NDArray, i: int, f0: float, f1: float, f2: float, f3: float,
         f4: float, f5: float) -> None:
    """Write the rows of a full wrench ``(f, m)`` that the kind keeps into column ``i``
    of ``M`` (rows x, y, z for point3; x, z for planar_point2; x, y, moment z for
    planar3; all six for spatial6). Row 0, x for every kind, is written last, outside
    the branches (see :mod:`tension_opt.kernels`)."""
    if kind == 1:
        M[1, i] = f2
    elif kind == 2:
        M[1, i], M[2, i] = f1, f5
    else:
        M[1, i], M[2, i] = f1, f2
        if kind == 3:
            M[3, i], M[4, i], M[5, i] = f3, f4, f5
    M[0, i] = f0


@njit(cache=True, error_model="numpy", inline="always")
def geometry_into(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                  weight: float, zero_length: float, pose: NDArray, wrench: NDArray,
                  A: NDArray, b: NDArray) -> int:
    """Structure matrix ``A`` (n, m) and required wrench ``b`` (n,) of one pose
    (allocates nothing).

    Parameters
    ----------
    kind : int
        :data:`KIND_CODES` of the robot.
    anchors, attachments : ndarray, shape (m, 3)
        Drawing points (base frame) and attachment points (platform frame) (m).
    com : ndarray, shape (3,)
        Centre of mass in the platform frame (m).
    weight : float
        Platform weight ``mass * g`` (N).
    zero_length : float
        Cable length (m) at or below which a cable is on its drawing point.
    pose : ndarray, shape (n,)
    wrench : ndarray, shape (n,)
        External wrench besides gravity (N, N m); zeros for none.
    A, b : ndarray, shapes (n, m) and (n,)
        Written.

    Returns
    -------
    int
        :data:`GEOMETRY_OK`, :data:`GEOMETRY_DEGENERATE` (a zero-length cable) or
        :data:`GEOMETRY_OVERFLOW` (cable lengths, or the wrench added to gravity,
        beyond the float range).
    """
    R = rotation(kind, pose)
    R00, R01, R02, R10, R11, R12 = R[:6]
    position = platform_position(kind, pose)
    code = GEOMETRY_OK
    for i in range(anchors.shape[0]):
        r0, r1, r2, v0, v1, v2 = arm_and_vector(R, position, anchors, attachments, i)
        length = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        if not math.isfinite(length):
            code = GEOMETRY_OVERFLOW
        elif length <= zero_length and code == GEOMETRY_OK:
            code = GEOMETRY_DEGENERATE
        u0, u1, u2 = v0 / length, v1 / length, v2 / length
        _put(kind, A, i, u0, u1, u2, r1 * u2 - r2 * u1, r2 * u0 - r0 * u2, r0 * u1 - r1 * u0)
    # Gravity (0, 0, -weight) at the centre of mass R com; b = -(w_gravity + wrench).
    c0 = R00 * com[0] + R01 * com[1] + R02 * com[2]
    c1 = R10 * com[0] + R11 * com[1] + R12 * com[2]
    m0 = c1 * weight if kind >= 2 else 0.0
    m1 = -c0 * weight if kind >= 2 else 0.0
    if kind == 0:
        b[0], b[1], b[2] = 0.0, 0.0, weight
    elif kind == 1:
        b[0], b[1] = 0.0, weight
    elif kind == 2:
        b[0], b[1], b[2] = 0.0, 0.0, 0.0
    else:
        b[0], b[1], b[2], b[3], b[4], b[5] = 0.0, 0.0, weight, m0, m1, 0.0
    for k in range(b.size):
        b[k] = b[k] - wrench[k] + 0.0
        if not math.isfinite(b[k]):
            code = GEOMETRY_OVERFLOW
    return code


@njit(cache=True, error_model="numpy", parallel=True)
def geometry_batch(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                   weight: float, zero_length: float, poses: NDArray, wrenches: NDArray,
                   A: NDArray, b: NDArray, codes: NDArray) -> None:
    """:func:`geometry_into` over poses (N, n) in parallel: ``A`` (N, n, m), ``b`` (N, n)
    and the return codes (N,) written; ``wrenches`` (N, n), or (1, n) for one wrench
    on every pose."""
    for k in prange(poses.shape[0]):
        w = wrenches[k] if wrenches.shape[0] > 1 else wrenches[0]
        codes[k] = geometry_into(kind, anchors, attachments, com, weight, zero_length,
                                 poses[k], w, A[k], b[k])


@njit(cache=True, nogil=True, error_model="numpy")
def geometry_serial(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                    weight: float, zero_length: float, poses: NDArray, wrenches: NDArray,
                    A: NDArray, b: NDArray, codes: NDArray) -> None:
    """:func:`geometry_batch` in the calling thread (the same arithmetic per pose)."""
    for k in range(poses.shape[0]):
        w = wrenches[k] if wrenches.shape[0] > 1 else wrenches[0]
        codes[k] = geometry_into(kind, anchors, attachments, com, weight, zero_length,
                                 poses[k], w, A[k], b[k])


def compiled_kind(robot: Any) -> int:
    """The kernels' code of a robot's kind (:data:`KIND_CODES`), or -1 where the
    kernels do not know it (another kind, or a pattern of its own under a known
    name, or a robot with guide pulleys)."""
    code = KIND_CODES.get(robot.kind, -1)
    if code < 0 or type(robot.pattern) is not type(KINDS[robot.kind]):
        return -1
    if getattr(robot, "pulleys", None) is not None:  # the kernels draw from fixed points
        return -1
    return code


def robot_geometry(robot: Any, poses: NDArray, wrench: ArrayLike | None
                   ) -> tuple[NDArray, NDArray] | None:
    """Structure matrices (N, n, m) and required wrenches (N, n) of a robot's validated
    poses (N, n), compiled; None where the numpy path must answer (and raise).

    That is: a robot kind this module does not know (or a pattern of its own under a
    known name), a wrench that is not a finite array of shape (n,) or (N, n), and a
    batch with a pose the kernel flags (a cable on its drawing point, lengths or
    wrench beyond the float range): the numpy path raises the package's error for
    these, naming the pose.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Validated poses (:meth:`CableRobot.as_poses`).
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    """
    code = compiled_kind(robot)
    if code < 0:
        return None
    N, n = poses.shape
    if wrench is None:
        w = np.zeros((1, n))
    else:
        try:
            w = np.asarray(wrench, dtype=float)
        except (TypeError, ValueError):
            return None
        if w.shape not in ((n,), (N, n)) or not np.isfinite(w).all():
            return None
        w = np.ascontiguousarray(w.reshape(-1, n))
    anchors, m = robot.anchors, robot.anchors.shape[0]
    A, b, codes = np.empty((N, n, m)), np.empty((N, n)), np.empty(N, dtype=np.int64)
    run(geometry_batch, geometry_serial, N, code, anchors, robot.attachments, robot.com,
        robot.mass * robot.g, 1e-12 * max(1.0, float(np.abs(anchors).max())),
        np.ascontiguousarray(poses), w, A, b, codes)
    return (A, b) if not codes.any() else None
