"""Whole-robot stiffness: straight elastic cables and sagging elastic cables (coupled model).

The stiffness of the platform is ``K = -dW/dq`` (N/m, N m/rad, N/rad), ``W`` the net
wrench on the platform (the cable forces, their moments about the reference point,
gravity and a constant external wrench; the kind's rows) and ``dq`` a pose step in the
convention of :meth:`tension_opt.CableRobot.displace`: a translation and, for rotating
kinds, a rotation about the base axes (left-multiplied). The unstretched cable lengths
are held fixed (the winches are locked).

Per cable, the force on the platform ``f_i`` changes with its attachment point ``b_i``
as ``df_i = -K_i db_i``, ``K_i`` a symmetric 3x3 stiffness:

``"straight"`` (straight elastic cables)
    ``f = T u`` with ``T = EA (L - L0) / L0``, so
    ``K_i = (EA / L0) u u^T + (T / L) (I - u u^T) = (EA / L) u u^T + (T / L) I``:
    the axial stiffness ``EA / L0 = (EA + T) / L`` (``EA / L`` to first order in
    ``T / EA``) plus the geometric term of the tension.
``"coupled"`` (elastic catenaries whose end forces balance the load)
    ``K_i = E K2 E^T + (H / x) (I_xy - e_h e_h^T)`` with ``E = [e_h, e_z]`` and ``K2``
    the analytic 2x2 in-plane stiffness :func:`catenary.stiffness` of the catenary end
    (``d(H, V)/d(x, z)``), plus the out-of-plane term ``H / x``: the cable's vertical
    plane turns about the drawing point. A vertical cable (``x = 0``) has the limit
    ``H / x = 1 / (dx/dH)`` in every horizontal direction. ``H / x`` is taken as
    ``1 / (x/H)`` with ``x/H`` the catenary's own span per unit ``H`` (even in ``H``,
    no rounded ``H`` over a tiny span: :func:`across_stiffness`), continuous into that
    limit.

With the attachment moving as ``db_i = dt - [r_i]x dtheta`` (``r_i = R a_i``), the
spatial stiffness is ``K6 = sum_i J_i^T K_i J_i - G`` with ``J_i = [I, -[r_i]x]`` and
``G`` the load term of the rotating moment arms: ``sum_i [f_i]x [r_i]x + [F_g]x [R c]x``
in the rotation block (``F_g`` the weight, ``c`` the centre of mass). The kind keeps
``K = D^T K6 D``, ``D`` its step maps (:meth:`tension_opt.kinds.MotionPattern.step_maps`).

Symmetry: every ``K_i`` is symmetric (an elastic cable, sagging or not, is conservative:
its end force is the gradient of its strain and gravitational energy). The load term
is not: ``K - K^T = [M]x`` in the rotation block, ``M`` the net moment of the cables
and gravity about the reference point. So the stiffness of a point mass is symmetric
at every pose; that of a rotating platform is symmetric exactly where the cables and
gravity leave no moment about the reference point: at equilibrium under gravity and
forces through the reference point (a constant external moment is not conservative
under 3-D rotations and leaves ``[M]x``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot, TensionProblem
from tension_opt.backends import Backend
from tension_opt.kernels.launch import compiled_for
from tension_opt.problem.form import Objective
from tension_opt.status import Status, status_array

from .elastic import axial_compliance, evaluate, stiffness
from .errors import InvalidCableError
from .geometry import (
    E_Z,
    CablePlanes,
    cable_data,
    cable_planes,
    equilibrium_residual,
    platform_forces,
    straight_planes,
    taut_catenaries,
)
from .inverse import inverse_kinematics
from .pulleys import pulley_cable_stiffness
from .stiffness_compiled import CatenaryState, CompiledBatch, batch_analysis
from .stiffness_kernels import FALLBACK

__all__ = [
    "MODELS",
    "CableState",
    "StiffnessResult",
    "across_stiffness",
    "assemble_stiffness",
    "catenary_cable_stiffness",
    "catenary_state",
    "coupled_state",
    "cross_matrix",
    "given_tensions",
    "platform_stiffness",
    "reference_result",
    "state_result",
    "step_basis",
    "stiffness_analysis",
    "straight_cable_stiffness",
    "straight_state",
]

FloatArray = NDArray[np.float64]
StiffnessModel = Literal["coupled", "straight"]

#: The cable models of the stiffness.
MODELS: tuple[str, ...] = ("coupled", "straight")


# ----------------------------------------------------------------------------- cables
def cross_matrix(v: ArrayLike) -> FloatArray:
    """Cross-product matrices ``[v]x`` (``[v]x y = v x y``) of vectors (..., 3), (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    S = np.zeros((*v.shape, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def straight_cable_stiffness(unit: FloatArray, lengths: FloatArray, tensions: FloatArray,
                             EA: float) -> FloatArray:
    """Stiffness of straight elastic cables at their platform end, (..., 3, 3) (N/m).

    ``K = (EA / L) u u^T + (T / L) I``, the exact derivative of ``T u`` with the
    unstretched length ``L0 = L EA / (EA + T)`` held fixed.

    Parameters
    ----------
    unit : ndarray, shape (..., 3)
        Unit vectors from the attachment points towards the drawing points.
    lengths : ndarray, shape (...)
        Stretched (straight) lengths ``L`` (m), > 0.
    tensions : ndarray, shape (...)
        Tensions ``T`` (N).
    EA : float
        Axial stiffness (N), finite.
    """
    uu = unit[..., :, None] * unit[..., None, :]
    return ((EA / lengths)[..., None, None] * uu
            + (tensions / lengths)[..., None, None] * np.eye(3))


#: Below this ratio of ``H`` to the smaller end's vertical force, ``x/H`` is its vertical
#: limit ``dx/dH`` to rounding (the two differ by a share of order ``(H / V)^2``).
NEAR_VERTICAL = 1e-8


def across_stiffness(H: FloatArray, V_B: FloatArray, L0: FloatArray, w: float,
                     EA: float) -> FloatArray:
    """Sideways stiffness ``H / x`` of catenaries whose plane turns about one end (N/m).

    ``x`` is the catenary's own span of ``(H, V_B, L0)``, which is ``H`` times a
    function of ``H^2`` (:mod:`catenary.elastic`), so ``H / x`` is that function's
    inverse, computed without dividing a rounded ``H`` by a tiny span: the geometric
    span of a cable 1e-14 m from vertical over the ``H`` a solver gives for it was off
    by up to 4 orders of magnitude. Where ``H`` is below :data:`NEAR_VERTICAL` of both
    ends' vertical forces (and at ``H = 0``) the vertical limit ``1 / (dx/dH)`` is
    taken, equal to rounding (not for a folded cable, whose ends pull opposite ways).

    Parameters
    ----------
    H, V_B, L0 : ndarray
        Horizontal tension (N), vertical force at end B (N) and unstretched length (m).
    w, EA : float
        Weight per length (N/m) and axial stiffness (N).

    Returns
    -------
    ndarray
        The shape of ``H``; NaN where ``H`` is.
    """
    with np.errstate(all="ignore"):
        span, _, f_xx, *_ = evaluate(H, V_B, L0, w, axial_compliance(np.asarray(EA, dtype=float)))
        V_A = V_B - w * L0
        ends = np.minimum(np.abs(V_A), np.abs(V_B))
        # Ends pulling the same way (a folded cable's x/H grows like log(V / H) instead).
        limit = ((H <= NEAR_VERTICAL * ends) & (V_A * V_B >= 0.0)) | (H == 0.0)
        return np.asarray(np.where(limit, 1.0 / f_xx, H / span), dtype=float)


def catenary_cable_stiffness(planes: CablePlanes, H: FloatArray, V_B: FloatArray,
                             L0: FloatArray, w: float, EA: float) -> FloatArray:
    """Stiffness of elastic catenaries at their platform end, (N, m, 3, 3) (N/m).

    ``K = E K2 E^T + (H / x) (I_xy - e_h e_h^T)`` (module docstring), ``K2`` from
    :func:`catenary.stiffness` with the unstretched length fixed.

    Parameters
    ----------
    planes : CablePlanes
        The cables' vertical planes (:func:`~catenary.geometry.cable_planes`).
    H, V_B, L0 : ndarray, shape (N, m)
        Horizontal tension (N), vertical force at the drawing point (N) and unstretched
        length (m) of each catenary.
    w, EA : float
        Weight per length (N/m) and axial stiffness (N).
    """
    vertical = planes.x <= 0.0
    with np.errstate(all="ignore"):
        K2 = stiffness(H, V_B, L0, w, EA)  # d(H, V_B)/d(x, z), (N, m, 2, 2)
    # Out-of-plane: the plane turns about the drawing point.
    turn = across_stiffness(H, V_B, L0, w, EA)
    e_z = np.broadcast_to(E_Z, planes.e_h.shape)
    E = np.stack([planes.e_h, e_z], axis=-1)  # (N, m, 3, 2)
    in_plane = E @ K2 @ np.swapaxes(E, -1, -2)
    e_h = planes.e_h
    across = np.diag([1.0, 1.0, 0.0]) - e_h[..., :, None] * e_h[..., None, :]
    # A vertical cable has no plane: its horizontal stiffness is the same all round.
    across = np.where(vertical[..., None, None], np.diag([1.0, 1.0, 0.0]), across)
    return in_plane + turn[..., None, None] * across


# --------------------------------------------------------------------------- platform
def step_basis(robot: CableRobot) -> FloatArray:
    """``D`` (6, n): a pose step ``dq`` moves the platform by ``D dq`` = (translation,
    rotation about the base axes); ``D^T`` keeps the kind's rows of a spatial wrench."""
    translation, rotation = robot.pattern.step_maps()
    return np.vstack([translation, rotation])


def assemble_stiffness(robot: CableRobot, rotation: FloatArray, arms: FloatArray,
                       forces: FloatArray, cable_stiffness: FloatArray) -> FloatArray:
    """Platform stiffness ``K = D^T K6 D`` (N, n, n) from the cables' 3x3 stiffnesses.

    Parameters
    ----------
    robot : CableRobot
    rotation : ndarray, shape (N, 3, 3)
        Platform orientations.
    arms : ndarray, shape (N, m, 3)
        Attachment points relative to the reference point, ``R a_i`` (m).
    forces : ndarray, shape (N, m, 3)
        Force of each cable on the platform (N).
    cable_stiffness : ndarray, shape (N, m, 3, 3)
        ``K_i`` with ``df_i = -K_i db_i`` (N/m).

    Returns
    -------
    ndarray, shape (N, n, n)
        Rows: the kind's wrench components; columns: the pose step's coordinates.
    """
    N = arms.shape[0]
    K6 = np.zeros((N, 6, 6))
    Kc = cable_stiffness
    K6[:, :3, :3] = Kc.sum(axis=1)
    if robot.pattern.rotates:
        r_x = cross_matrix(arms)
        Kr = Kc @ r_x  # K_i [r_i]x
        K6[:, :3, 3:] = -Kr.sum(axis=1)
        K6[:, 3:, :3] = (r_x @ Kc).sum(axis=1)
        load = (cross_matrix(forces) @ r_x).sum(axis=1)
        weight = np.array([0.0, 0.0, -robot.weight])
        com = np.einsum("kij,j->ki", rotation, robot.com)
        load += cross_matrix(weight) @ cross_matrix(com)
        K6[:, 3:, 3:] = -(r_x @ Kr).sum(axis=1) - load
    D = step_basis(robot)
    return np.einsum("ai,kab,bj->kij", D, K6, D)


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class StiffnessResult:
    """Platform stiffness of a batch of poses and the cable state it belongs to.

    Attributes
    ----------
    stiffness : ndarray, shape (N, n, n)
        ``K = -dW/dq`` (N/m, N m/rad; module docstring); NaN where ``status`` is not
        a success.
    cable_stiffness : ndarray, shape (N, m, 3, 3)
        Each cable's stiffness at its platform end (N/m).
    platform_forces : ndarray, shape (N, m, 3)
        Force of each cable on the platform (N), base frame.
    tensions : ndarray, shape (N, m)
        Tension at the drawing point (N).
    lengths : ndarray, shape (N, m)
        Unstretched lengths held fixed (m).
    equilibrium_residual : ndarray, shape (N,)
        Norm of the wrench left on the platform (N, N m): about zero for the model's own
        tensions, not for arbitrary given ones.
    status : ndarray of str, shape (N,)
        ``"converged"`` / ``"optimal"`` where the state was found; else the status of
        the failed inverse kinematics or distribution, ``"catenary_failed"`` (no taut
        catenary carries a given tension) or ``"not_run"`` (a given row with NaN).
    model : str
        ``"coupled"`` or ``"straight"``.
    """

    stiffness: FloatArray
    cable_stiffness: FloatArray
    platform_forces: FloatArray
    tensions: FloatArray
    lengths: FloatArray
    equilibrium_residual: FloatArray
    status: NDArray[np.str_]
    model: str

    @property
    def success(self) -> NDArray[np.bool_]:
        """Poses whose stiffness was computed, shape (N,)."""
        return np.isin(self.status, (Status.CONVERGED, Status.OPTIMAL))

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: status, residual and the stiffness entries."""
        N, n, _ = self.stiffness.shape
        frame = pd.DataFrame({"pose": np.arange(N), "status": self.status,
                              "equilibrium_residual": self.equilibrium_residual})
        for i in range(n):
            for j in range(n):
                frame[f"K{i}{j}"] = self.stiffness[:, i, j]
        return frame


@dataclass(frozen=True)
class CableState:
    """Cable forces (N, m, 3), stiffnesses (N, m, 3, 3), tensions and unstretched
    lengths (N, m) and status (N,) of a batch."""

    forces: FloatArray
    stiffness: FloatArray
    tensions: FloatArray
    lengths: FloatArray
    status: NDArray[np.str_]


def given_tensions(robot: CableRobot, tensions: ArrayLike, N: int) -> FloatArray:
    """Given tensions (N) as an (N, m) array, or the error naming ``tensions``."""
    T = np.asarray(tensions, dtype=float)
    try:
        T = np.broadcast_to(T, (N, robot.m))
    except ValueError:
        raise InvalidCableError(
            f"tensions must have shape ({robot.m},) or ({N}, {robot.m}) (one per cable), "
            f"got {np.shape(tensions)}") from None
    if np.isinf(T).any() or (T < 0).any():
        raise InvalidCableError("tensions must be finite and >= 0 (N): cables only pull "
                                "(NaN marks a pose without tensions)")
    return T


def straight_state(robot: CableRobot, poses: FloatArray, tensions: ArrayLike | None,
                   wrench: ArrayLike | None, solve: dict[str, Any]) -> CableState:
    """Straight elastic cables with the given or the distributed tensions; over guide
    pulleys the whole cable stretches and the free span turns with its wheel
    (:func:`catenary.pulleys.pulley_cable_stiffness`)."""
    _, EA = cable_data(robot, pulleys=True)
    if not np.isfinite(EA):
        raise InvalidCableError(
            "the straight model needs elastic cables (finite EA): inextensible straight "
            "cables are rigid along their length; give the robot cable=CableProperties"
            "(..., EA=...) (e.g. from catenary.cable_properties) or use model='coupled'")
    geometry = robot.cable_geometry(poses)
    N = poses.shape[0]
    if tensions is None:
        sol = tension_opt.distribute(robot, poses, solve["objective"], solve["backend"],
                                     wrench=wrench, **solve["options"])
        T, status = sol.tensions, np.asarray(sol.status).astype(str)
    else:
        T, status = given_tensions(robot, tensions, N), status_array(N, Status.CONVERGED)
        status[np.isnan(T).any(axis=1)] = Status.NOT_RUN
    L, u = geometry.lengths, geometry.unit
    if robot.has_pulleys:
        L = geometry.total_lengths
        K = pulley_cable_stiffness(robot, poses, T, EA, L)
    else:
        K = straight_cable_stiffness(u, L, T, EA)
    return CableState(T[..., None] * u, K, T, L * EA / (EA + T), status)


def coupled_state(robot: CableRobot, poses: FloatArray, planes: CablePlanes,
                  tensions: ArrayLike | None, end: Literal["A", "B"],
                  wrench: ArrayLike | None,
                  solve: dict[str, Any]) -> CableState:
    """Catenaries of the coupled inverse kinematics, or carrying the given tensions."""
    w, EA = cable_data(robot)
    if w == 0.0 and not np.isfinite(EA):
        raise InvalidCableError(
            "weightless inextensible cables are rigid: give the robot a cable weight or a "
            "finite EA")
    N = poses.shape[0]
    if tensions is None:
        ik = inverse_kinematics(robot, poses, "coupled", solve["objective"],
                                solve["backend"], wrench, **solve["options"])
        H, V_A, L0 = ik.horizontal_tensions, ik.platform_forces[..., 2], ik.lengths
        V_B, status = V_A + w * L0, np.asarray(ik.status).astype(str)
    else:
        if end not in ("A", "B"):
            raise InvalidCableError(f'end must be "A" or "B"; got end={end!r}')
        T = given_tensions(robot, tensions, N)
        given = ~np.isnan(T).any(axis=1)
        H, V_A, V_B, L0 = (np.full((N, robot.m), np.nan) for _ in range(4))
        status = status_array(N, Status.NOT_RUN)
        if given.any():
            c = taut_catenaries(planes.x[given], planes.z[given], T[given], w, EA, end)
            H[given], V_A[given], V_B[given], L0[given] = c.H, c.V_A, c.V_B, c.L0
            status[given] = np.where(c.converged.all(axis=1), Status.CONVERGED,
                                     Status.CATENARY_FAILED)
    return catenary_state(planes, H, V_A, V_B, L0, status, w, EA)


def catenary_state(planes: CablePlanes, H: FloatArray, V_A: FloatArray, V_B: FloatArray,
                   L0: FloatArray, status: NDArray[np.str_], w: float, EA: float
                   ) -> CableState:
    """Forces and stiffnesses of catenaries given by their forces (N) and unstretched
    lengths (m), (N, m) each."""
    return CableState(platform_forces(planes, H, V_A),
                       catenary_cable_stiffness(planes, H, V_B, L0, w, EA),
                       np.hypot(H, V_B), L0, status)


def stiffness_analysis(
    robot: CableRobot,
    poses: ArrayLike,
    tensions: ArrayLike | None = None,
    model: StiffnessModel = "coupled",
    *,
    end: Literal["A", "B"] = "B",
    wrench: ArrayLike | None = None,
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str | Backend = "auto",
    **options: Any,
) -> StiffnessResult:
    """Platform stiffness of a batch of poses, with the cable state it comes from.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable``: a finite ``EA`` for ``"straight"``; a weight or a finite
        ``EA`` for ``"coupled"``.
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad).
    tensions : array_like, shape (N, m) or (m,), optional
        Cable tensions (N), >= 0; a row with NaN is skipped (status ``"not_run"``).
        Default: the model's own equilibrium, the straight-line
        distribution (:func:`tension_opt.distribute`) for ``"straight"``, the coupled
        inverse kinematics (:func:`catenary.inverse_kinematics`) for ``"coupled"``.
        Given tensions fix the unstretched lengths; the platform need not be in
        equilibrium with them (see ``equilibrium_residual``).
    model : {"coupled", "straight"}
        Sagging elastic catenaries whose end forces balance the load, or straight
        elastic cables.
    end : {"B", "A"}
        ``"coupled"`` with given tensions: where along the catenary they act, the
        drawing point (default, as :attr:`InverseKinematicsResult.tensions`) or the
        platform.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity at equilibrium (N, N m).
    objective, backend, **options
        How the default tensions are chosen (as :func:`catenary.inverse_kinematics`).

    Returns
    -------
    StiffnessResult

    Raises
    ------
    InvalidCableError
        For an unknown model, a robot without suitable cable properties, or tensions
        of the wrong shape or sign.
    """
    return _analysis(robot, poses, tensions, model, end, wrench, objective, backend,
                     options, full=True)


def _analysis(robot: CableRobot, poses: ArrayLike, tensions: ArrayLike | None,
              model: StiffnessModel, end: Literal["A", "B"], wrench: ArrayLike | None,
              objective: str | Objective | TensionProblem, backend: str | Backend,
              options: dict[str, Any], full: bool) -> StiffnessResult:
    """:func:`stiffness_analysis`; batches of :data:`COMPILED_MIN
    <tension_opt.kernels.launch.COMPILED_MIN>` poses and more through the kernels
    (:func:`catenary.stiffness_compiled.batch_analysis`, where they cover the robot and
    the model; the poses they leave by :func:`reference_result`); unless ``full``,
    ``cable_stiffness``, ``platform_forces``, ``tensions`` and ``lengths`` are scratch."""
    if model not in MODELS:
        raise InvalidCableError(f'model must be "coupled" or "straight"; got model={model!r}')
    p = robot.as_poses(poses)
    solve = {"objective": objective, "backend": backend, "options": options}
    if compiled_for(len(p)):
        T = None if tensions is None else given_tensions(robot, tensions, len(p))
        batch = batch_analysis(robot, p, T, model, end, wrench, solve, full)
        if batch is not None:
            out = batch.out
            result = StiffnessResult(out.stiffness, out.cable_stiffness, out.platform_forces,
                                     out.tensions, out.lengths, out.equilibrium_residual,
                                     batch.status, model)
            left = np.flatnonzero(out.codes == FALLBACK)
            if left.size:
                _reference_into(result, robot, p, left, batch, end, wrench, full)
            return result
    planes = straight_planes(robot, p) if model == "straight" else cable_planes(robot, p)
    if model == "straight":
        state = straight_state(robot, p, tensions, wrench, solve)
    else:
        state = coupled_state(robot, p, planes, tensions, end, wrench, solve)
    return state_result(robot, p, planes, state, wrench, model)


def state_result(robot: CableRobot, p: FloatArray, planes: CablePlanes, state: CableState,
                 wrench: ArrayLike | None, model: str) -> StiffnessResult:
    """The stiffness of validated poses (N, n) from their cable state, by numpy."""
    ok = np.isin(state.status, (Status.CONVERGED, Status.OPTIMAL))
    K = np.full((len(p), robot.dof, robot.dof), np.nan)
    if ok.any():
        with np.errstate(invalid="ignore"):
            K[ok] = assemble_stiffness(robot, planes.rotation[ok], planes.arms[ok],
                                       state.forces[ok], state.stiffness[ok])
    residual = equilibrium_residual(robot, state.forces, planes.arms,
                                    robot.required_wrench(p, wrench))
    return StiffnessResult(K, state.stiffness, state.forces, state.tensions, state.lengths,
                           residual, state.status, model)


def reference_result(robot: CableRobot, p: FloatArray, model: str, status: NDArray[np.str_],
                     given: FloatArray | None, state: CatenaryState | None, end: str,
                     wrench: ArrayLike | None) -> StiffnessResult:
    """The numpy reference of validated poses ``p`` (N, n) from the tensions ``given``
    (N, m) or the catenaries ``state`` (as
    :func:`catenary.stiffness_compiled.compiled_stiffness`) a kernel had, with their
    ``status`` (N,) so far."""
    planes = cable_planes(robot, p)
    if model == "straight":
        assert given is not None
        c = straight_state(robot, p, given, wrench, {})
        cables = CableState(c.forces, c.stiffness, c.tensions, c.lengths, status)
    elif state is None:
        assert given is not None
        cables = coupled_state(robot, p, planes, given, "A" if end == "A" else "B", wrench,
                               {})
    else:
        w, EA = cable_data(robot)
        H, V_A, L0 = state[0], state[1][..., 2], state[2]
        cables = catenary_state(planes, H, V_A, V_A + w * L0, L0, status, w, EA)
    return state_result(robot, p, planes, cables, wrench, model)


def _reference_into(result: StiffnessResult, robot: CableRobot, p: FloatArray,
                    left: NDArray[np.intp], batch: CompiledBatch, end: str,
                    wrench: ArrayLike | None, full: bool) -> None:
    """The poses ``left`` of a compiled batch, by the numpy reference, into ``result``."""
    if wrench is not None and np.ndim(wrench) == 2:
        wrench = np.asarray(wrench, dtype=float)[left]
    given, state = batch.given, batch.state
    ref = reference_result(robot, p[left], result.model, result.status[left],
                           None if given is None else given[left],
                           None if state is None else (state[0][left], state[1][left],
                                                       state[2][left]), end, wrench)
    names = ["stiffness", "equilibrium_residual", "status"]
    if full:
        names += ["cable_stiffness", "platform_forces", "tensions", "lengths"]
    for name in names:
        getattr(result, name)[left] = getattr(ref, name)


def platform_stiffness(
    robot: CableRobot,
    poses: ArrayLike,
    tensions: ArrayLike | None = None,
    model: StiffnessModel = "coupled",
    **kwargs: Any,
) -> FloatArray:
    """Stiffness of the platform at equilibrium (N/m, N m/rad), shape (N, n, n).

    ``K = -dW/dq`` with the unstretched cable lengths held fixed, ``W`` the net wrench
    on the platform (the kind's rows) and ``dq`` a pose step (translation; rotation
    about the base axes for rotating kinds). See the module docstring for the cable
    models and the symmetry, and :func:`stiffness_analysis` for the arguments (``end``,
    ``wrench``, ``objective``, ``backend``) and the cable state.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
    tensions : array_like, shape (N, m) or (m,), optional
        Default: the model's own inverse kinematics.
    model : {"coupled", "straight"}

    Returns
    -------
    ndarray, shape (N, n, n)
        NaN for poses whose tensions or catenaries were not found.

    Examples
    --------
    >>> import tension_opt as to
    >>> robot = to.presets.algae_harvester(EA=3.14e7)
    >>> K = platform_stiffness(robot, [0.0, 0.0, 2.0], model="straight")
    >>> K.shape
    (1, 3, 3)
    """
    end, wrench = kwargs.pop("end", "B"), kwargs.pop("wrench", None)
    objective, backend = kwargs.pop("objective", "min_sum"), kwargs.pop("backend", "auto")
    return _analysis(robot, poses, tensions, model, end, wrench, objective, backend, kwargs,
                     full=False).stiffness
