"""Platform stiffness of a batch through the compiled kernels
(:mod:`catenary.stiffness_kernels`): the robot's constants packed once
(:func:`pack`), which robots and models the kernels cover (:func:`kernel_model`), and
one batch call (:func:`compiled_stiffness`) that returns the kernel's arrays and a
code per pose, and the batch of :func:`catenary.stiffness_analysis` with its default
tensions and statuses (:func:`batch_analysis`); the poses coded
:data:`~catenary.stiffness_kernels.FALLBACK` are left to the caller's numpy reference
(:func:`catenary.robot_stiffness.reference_result`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot
from tension_opt.kernels.geometry import compiled_kind
from tension_opt.kernels.launch import run
from tension_opt.status import Status, status_array

from .geometry import cable_data
from .inverse import inverse_kinematics
from .stiffness_kernels import (
    COUPLED_A,
    COUPLED_B,
    COUPLED_STATE,
    HEADER,
    NOT_RUN,
    STRAIGHT,
    stiffness_batch,
    stiffness_parallel,
)

__all__ = [
    "CatenaryState",
    "CompiledBatch",
    "CompiledStiffness",
    "batch_analysis",
    "compiled_stiffness",
    "kernel_model",
    "pack",
]

FloatArray = NDArray[np.float64]
#: Catenaries as the coupled inverse kinematics returns them: horizontal tensions (N, m),
#: platform forces (N, m, 3), unstretched lengths (N, m).
CatenaryState = tuple[FloatArray, FloatArray, FloatArray]


def _selection(robot: CableRobot) -> NDArray[np.intp] | None:
    """Which of the six spatial coordinates each pose coordinate moves, or None where a
    step map is not such a selection (:func:`catenary.robot_stiffness.step_basis`)."""
    translation, rotation = robot.pattern.step_maps()
    D = np.vstack([translation, rotation])
    sel = np.argmax(np.abs(D), axis=0)
    chosen = np.zeros_like(D)
    chosen[sel, np.arange(D.shape[1])] = 1.0
    return sel if np.array_equal(D, chosen) else None


def kernel_model(robot: CableRobot, model: str, given: bool, end: str = "B") -> int:
    """The kernels' code of a cable model for ``robot``, or -1 where the numpy reference
    answers.

    Parameters
    ----------
    robot : CableRobot
        With cable properties (checked by the caller).
    model : {"straight", "coupled"}
    given : bool
        Whether the tensions are given (else, for ``"coupled"``, the catenaries come
        from the inverse kinematics: :data:`~catenary.stiffness_kernels.COUPLED_STATE`).
    end : {"B", "A"}
        Where given tensions act along a catenary.

    Returns
    -------
    int
        ``STRAIGHT``, ``COUPLED_B``, ``COUPLED_A``, ``COUPLED_STATE`` or -1: a robot
        kind the kernels do not know, step maps that are not a selection, cables the
        reference treats alone (weightless catenaries, inextensible straight cables).
    """
    if compiled_kind(robot) < 0 or _selection(robot) is None:
        return -1
    w, EA = cable_data(robot)
    if model == "straight":
        return STRAIGHT if math.isfinite(EA) else -1
    if model != "coupled" or not w > 0.0:
        return -1
    if not given:
        return COUPLED_STATE
    return {"B": COUPLED_B, "A": COUPLED_A}.get(end, -1)


def pack(robot: CableRobot) -> FloatArray:
    """The robot's constants as the kernels read them (``data`` of
    :func:`catenary.stiffness_kernels.stiffness_pose`), for a robot
    :func:`kernel_model` covers."""
    w, EA = cable_data(robot)
    sel = _selection(robot)
    assert sel is not None  # kernel_model() checked it
    anchors = np.asarray(robot.anchors, dtype=float)
    zero_length = 1e-12 * max(1.0, float(np.abs(anchors).max()))
    header = [
        float(compiled_kind(robot)),
        float(robot.m),
        float(robot.dof),
        robot.mass * robot.g,
        zero_length,
        w,
        0.0 if math.isinf(EA) else 1.0 / EA,
        EA,
        float(robot.pattern.rotates),
        *np.asarray(robot.com, dtype=float),
    ]
    assert len(header) == HEADER
    return np.concatenate(
        [
            header,
            sel.astype(float),
            anchors.reshape(-1),
            np.asarray(robot.attachments, dtype=float).reshape(-1),
        ]
    )


@dataclass(frozen=True)
class CompiledStiffness:
    """Arrays of a compiled batch (rows of poses not OK are NaN).

    Attributes
    ----------
    stiffness : ndarray, shape (N, n, n)
        ``K = -dW/dq`` (N/m, N m/rad).
    cable_stiffness : ndarray, shape (N, m, 3, 3) or (1, m, 3, 3)
        Each cable's stiffness (N/m); the last pose's scratch unless ``full``.
    platform_forces : ndarray, shape (N, m, 3) or (1, m, 3)
        Force of each cable on the platform (N).
    tensions, lengths : ndarray, shape (N, m) or (1, m)
        Tension at the drawing point (N), unstretched length (m).
    equilibrium_residual : ndarray, shape (N,)
        Norm of the wrench left on the platform (N, N m).
    codes : ndarray of int64, shape (N,)
        :data:`~catenary.stiffness_kernels.OK`, ``FALLBACK`` or ``NOT_RUN``.
    """

    stiffness: FloatArray
    cable_stiffness: FloatArray
    platform_forces: FloatArray
    tensions: FloatArray
    lengths: FloatArray
    equilibrium_residual: FloatArray
    codes: NDArray[np.int64]


def _writable(a: ArrayLike) -> FloatArray:
    """``a`` as a C-contiguous, writable float array (the one array type the kernels are
    compiled for: a read-only array would compile another specialisation)."""
    out = np.ascontiguousarray(a, dtype=float)
    return out if out.flags.writeable else out.copy()


def compiled_stiffness(
    robot: CableRobot,
    data: FloatArray,
    model: int,
    poses: FloatArray,
    wrenches: FloatArray,
    given: FloatArray | None = None,
    state: CatenaryState | None = None,
    full: bool = True,
) -> CompiledStiffness:
    """One batch through :func:`catenary.stiffness_kernels.stiffness_batch` (or its
    parallel twin from :data:`tension_opt.kernels.launch.PARALLEL_MIN` poses).

    Parameters
    ----------
    robot : CableRobot
    data : ndarray
        :func:`pack` of the robot.
    model : int
        :func:`kernel_model` of the robot (not -1).
    poses : ndarray, shape (N, n)
        Validated poses (m, rad).
    wrenches : ndarray, shape (N, n) or (1, n)
        External wrench besides gravity (N, N m), finite.
    given : ndarray, shape (N, m) or (1, m), optional
        Tensions (N), finite and >= 0 or NaN (a row not run): every model but
        ``COUPLED_STATE``.
    state : (ndarray, ndarray, ndarray), optional
        For ``COUPLED_STATE``: horizontal tensions (N, m) (N), platform forces (N, m, 3)
        (N) and unstretched lengths (N, m) (m) of the catenaries, as
        :class:`catenary.InverseKinematicsResult` holds them.
    full : bool
        Keep every pose's cable arrays (else only the stiffness and the residual).

    Returns
    -------
    CompiledStiffness
    """
    N, n, m = poses.shape[0], robot.dof, robot.m
    rows = N if full else 1
    g = np.zeros((1, m)) if given is None else _writable(given)
    if state is None:
        state = (np.zeros((1, m)), np.zeros((1, m, 3)), np.zeros((1, m)))
    H, F, L0 = (_writable(a) for a in state)
    out = CompiledStiffness(
        np.empty((N, n, n)),
        np.empty((rows, m, 3, 3)),
        np.empty((rows, m, 3)),
        np.empty((rows, m)),
        np.empty((rows, m)),
        np.empty(N),
        np.empty(N, dtype=np.int64),
    )
    if N:
        run(
            stiffness_parallel,
            stiffness_batch,
            N,
            data,
            model,
            _writable(poses),
            _writable(wrenches),
            g,
            H,
            F,
            L0,
            out.stiffness,
            out.cable_stiffness,
            out.platform_forces,
            out.tensions,
            out.lengths,
            out.equilibrium_residual,
            out.codes,
        )
    return out


def _wrenches(robot: CableRobot, wrench: ArrayLike | None, N: int) -> FloatArray | None:
    """The external wrench as (1, n) or (N, n), or None where it is not a finite array of
    one of these shapes (the numpy reference raises the error for it)."""
    n = robot.dof
    if wrench is None:
        return np.zeros((1, n))
    try:
        w = np.asarray(wrench, dtype=float)
    except (TypeError, ValueError):
        return None
    if w.shape not in ((n,), (N, n)) or not np.isfinite(w).all():
        return None
    return np.ascontiguousarray(w.reshape(-1, n))


@dataclass(frozen=True)
class CompiledBatch:
    """A batch through the kernels, before the poses they leave
    (:func:`batch_analysis`).

    Attributes
    ----------
    out : CompiledStiffness
        The kernel's arrays and codes (stiffness NaN where ``status`` is no success).
    status : ndarray of str, shape (N,)
        ``"converged"`` (``"not_run"``) for given tensions, else the status of the
        distribution or of the coupled inverse kinematics.
    given : ndarray, shape (N, m), or None
        The tensions the kernel had (N).
    state : CatenaryState or None
        The catenaries the kernel had (the coupled model's own equilibrium).
    """

    out: CompiledStiffness
    status: NDArray[np.str_]
    given: FloatArray | None
    state: CatenaryState | None


def batch_analysis(
    robot: CableRobot,
    p: FloatArray,
    tensions: FloatArray | None,
    model: str,
    end: str,
    wrench: ArrayLike | None,
    solve: dict[str, Any],
    full: bool,
) -> CompiledBatch | None:
    """:func:`catenary.stiffness_analysis` of validated poses ``p`` (N, n) through the
    kernels, or None where they do not cover the robot, the model or the wrench.

    ``tensions`` (N, m) are validated (:func:`catenary.robot_stiffness.given_tensions`)
    or None: then they come as in the reference (the distribution for ``"straight"``,
    the coupled inverse kinematics for ``"coupled"``), and so do the statuses. The
    poses the kernel leaves (:data:`~catenary.stiffness_kernels.FALLBACK`) are the
    caller's, for the numpy reference. Unless ``full``, the cable arrays are one pose's
    scratch (for :func:`catenary.platform_stiffness`).
    """
    code = kernel_model(robot, model, tensions is not None, end)
    wrenches = _wrenches(robot, wrench, len(p))
    if code < 0 or wrenches is None:
        return None
    N = len(p)
    given, state = tensions, None
    if tensions is not None:
        status = status_array(N, Status.CONVERGED)
    elif code == STRAIGHT:
        sol = tension_opt.distribute(
            robot, p, solve["objective"], solve["backend"], wrench=wrench, **solve["options"]
        )
        given, status = sol.tensions, np.asarray(sol.status).astype(str)
    else:
        ik = inverse_kinematics(
            robot, p, "coupled", solve["objective"], solve["backend"], wrench, **solve["options"]
        )
        state = (ik.horizontal_tensions, ik.platform_forces, ik.lengths)
        status = np.asarray(ik.status).astype(str)
    out = compiled_stiffness(robot, pack(robot), code, p, wrenches, given, state, full)
    if tensions is not None:
        status[out.codes == NOT_RUN] = Status.NOT_RUN
    out.stiffness[~np.isin(status, (Status.CONVERGED, Status.OPTIMAL))] = np.nan
    return CompiledBatch(out, status, given, state)
