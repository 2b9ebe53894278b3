"""Sag-aware forward kinematics of a cable robot: pose and cable forces from the lengths.

:func:`forward_kinematics` solves, from the unstretched lengths, the square system of
the span equations of every cable and the platform equilibrium
(:class:`ForwardSystem`) for the pose and the cable end forces, by Newton's method
with the analytic flexibility of :mod:`catenary.elastic`. Over guide pulleys
(:mod:`catenary.pulleys`) each free span ends where its cable leaves its wheel: the
Newton solve with those exit points held fixed (the wrapped arcs taken off the
lengths) and the wheels turned tangent to the catenaries take turns, as in the coupled
inverse kinematics, until the wrap angles move less than
:data:`~catenary.pulleys.WRAP_TOL`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot, TensionProblem
from tension_opt.checks import as_float_array
from tension_opt.kernels.launch import compiled_for
from tension_opt.problem.form import Objective
from tension_opt.status import Status, status_array

from .elastic import flexibility, spans
from .errors import InvalidCableError
from .geometry import (
    E_Z,
    CablePlanes,
    cable_data,
    cable_planes,
    cable_wrench,
    check_robot,
    equilibrium_residual,
    planes_along,
    platform_forces,
    straight_planes,
)
from .pulleys import MAX_WRAP_STEPS, WRAP_TOL, WheelFrames
from .solve import solve_forces
from .solve.common import check_settings

__all__ = ["ForwardKinematicsResult", "ForwardSystem", "forward_kinematics"]

FloatArray = NDArray[np.float64]

#: Backtracking steps of Newton's line search.
LINE_SEARCH_STEPS = 30


@dataclass(frozen=True, eq=False)
class ForwardKinematicsResult:
    """Poses and cable forces of a batch of unstretched cable lengths.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        Platform poses (m, rad).
    tensions : ndarray, shape (N, m)
        Tension magnitude at the drawing point, end B (N).
    tensions_platform : ndarray, shape (N, m)
        Tension magnitude at the platform attachment point, end A (N).
    horizontal_tensions : ndarray, shape (N, m)
        Horizontal tension ``H`` of each catenary (N).
    platform_forces : ndarray, shape (N, m, 3)
        Force each cable applies on the platform, base frame (N).
    status : ndarray of str, shape (N,)
        ``Status.CONVERGED``, ``Status.NOT_CONVERGED`` or, for the straight model, the
        status of :meth:`tension_opt.CableRobot.forward_kinematics`
        (``Status.INCONSISTENT`` ...), ``Status.INFEASIBLE`` where no tensions within
        the bounds hold the pose.
    iterations : ndarray of int, shape (N,)
        Newton iterations per pose.
    residual : ndarray, shape (N,)
        Norm of the equilibrium residual at the solution (N, N m).
    span_residual : ndarray, shape (N,)
        Largest mismatch between a catenary's spans and the geometry of the pose (m).
    """

    poses: FloatArray
    tensions: FloatArray
    tensions_platform: FloatArray
    horizontal_tensions: FloatArray
    platform_forces: FloatArray
    status: NDArray[np.str_]
    iterations: NDArray[np.int64]
    residual: FloatArray
    span_residual: FloatArray

    @property
    def success(self) -> NDArray[np.bool_]:
        """Boolean mask of the poses solved, shape (N,)."""
        return np.asarray(self.status == Status.CONVERGED, dtype=bool)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: status, pose coordinates, tensions, residuals."""
        frame = pd.DataFrame(self.poses, columns=[f"q{i}" for i in range(self.poses.shape[1])])
        frame.insert(0, "pose", np.arange(len(self.poses)))
        frame.insert(1, "status", self.status)
        for i in range(self.tensions.shape[1]):
            frame[f"T{i + 1}"] = self.tensions[:, i]
        frame["residual"] = self.residual
        frame["span_residual"] = self.span_residual
        frame["iterations"] = self.iterations
        return frame


def forward_kinematics(
    robot: CableRobot,
    lengths: ArrayLike,
    model: Literal["catenary", "straight"] = "catenary",
    initial_poses: ArrayLike | None = None,
    wrench: ArrayLike | None = None,
    *,
    objective: str | Objective | TensionProblem = "min_sum",
    tol: float = 1e-12,
    max_iter: int = 50,
) -> ForwardKinematicsResult:
    """Pose and cable forces of a batch of unstretched cable lengths.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` for the catenary model, with ``w > 0`` or finite ``EA``.
    lengths : array_like, shape (N, m) or (m,)
        Unstretched cable lengths (m).
    model : {"catenary", "straight"}
        ``"catenary"``: every cable is an elastic catenary and the platform is in
        static equilibrium; see Notes. ``"straight"``: straight cables of the given
        lengths (:meth:`tension_opt.CableRobot.forward_kinematics`); their tensions are
        not fixed by the lengths, so those reported are the straight-line distribution
        with ``objective``.
    initial_poses : array_like, shape (N, n) or (n,), optional
        Starting poses; default: the straight-line solution (see Notes).
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).
    objective : str or TensionProblem
        Straight model only: how to choose the tensions reported.
    tol : float
        Newton stops when the pose step is below ``tol`` times the robot's size and the
        force step below ``tol`` times the forces.
    max_iter : int
        Newton iteration limit.

    Returns
    -------
    ForwardKinematicsResult
        Poses (N, n), tensions at both ends (N, m), platform forces (N, m, 3), status,
        iterations and residuals per pose.

    Notes
    -----
    Unknowns: the pose (n) and the end forces ``(H_i, V_B,i)`` of every cable (2 m).
    Equations: the two span equations of every cable, ``spans(H_i, V_B,i, L_i) =
    (x_i(pose), z_i(pose))`` (2 m), and the balance of the platform (n): square. The
    point-mass robot with 4 cables has 11 unknowns, a 6-DOF robot with 8 cables 22.
    Newton's method runs on all poses at once with the analytic flexibility matrix
    (:func:`catenary.flexibility`) and the exact derivatives of the geometry, with a
    backtracking line search on the scaled residual. The default start is the
    straight-line forward kinematics of the lengths shortened by the first-order sag
    (and stretch) of the straight-line tensions, with the catenary forces of that
    pose (:func:`catenary.solve_forces`).
    """
    if model not in ("catenary", "straight"):
        raise InvalidCableError(f'model must be "catenary" or "straight"; got model={model!r}')
    check_robot(robot, pulleys=True)
    check_settings(tol, max_iter, "tol")
    L = _check_lengths(robot, lengths)
    if model == "straight":
        return _straight(robot, L, initial_poses, wrench, objective)
    w, EA = cable_data(robot, pulleys=True)
    if w == 0.0 and not np.isfinite(EA):
        raise InvalidCableError(
            "weightless inextensible cables do not fix the tensions: use model='straight'"
        )
    if robot.has_pulleys:
        return _over_pulleys(robot, L, initial_poses, wrench, (w, EA), tol, max_iter)
    if initial_poses is None:
        p = _sag_corrected_start(robot, L, w, EA, wrench)
    else:
        p = np.broadcast_to(robot.as_poses(initial_poses), (L.shape[0], robot.dof)).copy()
    system = ForwardSystem(robot, L, wrench, w, EA)
    H, V = system.start_forces(p)
    iterations, converged = _newton(system, p, H, V, tol, max_iter)
    return system.result(p, H, V, iterations, converged)


def _check_lengths(robot: CableRobot, lengths: ArrayLike) -> FloatArray:
    """Lengths as an (N, m) array; raises unless they are positive and finite."""
    L = as_float_array("lengths", lengths)
    if L.ndim == 1:
        L = L[None]
    if L.ndim != 2 or L.shape[1] != robot.m:
        raise InvalidCableError(f"lengths must have shape (N, {robot.m}), got {L.shape}")
    if not np.isfinite(L).all() or (L <= 0).any():
        raise InvalidCableError("lengths must be positive and finite")
    return L


def _straight(robot: CableRobot, L: FloatArray, initial_poses: ArrayLike | None,
              wrench: ArrayLike | None, objective: str | Objective | TensionProblem
              ) -> ForwardKinematicsResult:
    """The straight model: straight-line forward kinematics, tensions distributed."""
    fk = robot.forward_kinematics(L, initial_poses)
    sol = tension_opt.distribute(robot, fk.poses, objective, wrench=wrench)
    planes = straight_planes(robot, fk.poses)
    T = sol.tensions
    H = T * planes.x / planes.chord
    V = T * planes.z / planes.chord
    forces = platform_forces(planes, H, V)
    residual = equilibrium_residual(robot, forces, planes.arms,
                                    robot.required_wrench(fk.poses, wrench))
    status = np.where(sol.success, fk.status, Status.INFEASIBLE.value).astype(fk.status.dtype)
    return ForwardKinematicsResult(
        fk.poses, T, T, H, forces, status, fk.iterations, residual, fk.residual
    )


def _over_pulleys(robot: CableRobot, L: FloatArray, initial_poses: ArrayLike | None,
                  wrench: ArrayLike | None, cable: tuple[float, float], tol: float,
                  max_iter: int) -> ForwardKinematicsResult:
    """:func:`forward_kinematics` of a robot with guide pulleys (module notes): from the
    straight forward kinematics of the lengths (arcs and free spans), the Newton solve
    with the exit points held fixed and the wheels turned tangent to its catenaries, in
    turn. A pose whose wheels do not settle, or with a cable shorter than the arc it
    wraps, reads ``NOT_CONVERGED``."""
    w, EA = cable
    N = L.shape[0]
    p = (robot.forward_kinematics(L).poses if initial_poses is None else
         np.broadcast_to(robot.as_poses(initial_poses), (N, robot.dof)).copy())
    robot.required_wrench(p, wrench)  # the package's error for a wrench of another shape
    frames = WheelFrames(robot, p)
    h, wrap = frames.straight_h.copy(), frames.straight_wrap.copy()
    r = frames.full(np.broadcast_to(frames.r, wrap.shape))
    H = V = np.zeros(L.shape)  # the first step's start forces
    iterations = np.zeros(N, np.int64)
    converged, moved = np.zeros(N, bool), np.full(wrap.shape, np.inf)
    for step in range(MAX_WRAP_STEPS):
        T = np.hypot(H, V)
        arcs = r * frames.full(wrap) / (1.0 if np.isinf(EA) else 1.0 + T / EA)
        # A cable shorter than its arc has no free span: held at a sliver, not converged.
        short = (L - arcs <= 1e-9 * L).any(axis=1)
        free = np.maximum(L - arcs, 1e-9 * L)
        system = ForwardSystem(robot, free, wrench, w, EA, frames.planes(h, wrap).upper_ends)
        if step == 0:
            H, V = system.start_forces(p)
        steps, converged = _newton(system, p, H, V, tol, max_iter)
        iterations += steps
        frames = WheelFrames(robot, p)  # the attachment points moved with the poses
        new_h, new = frames.tangent(frames.planes(h, wrap), H[:, frames.idx],
                                    V[:, frames.idx], h)
        moved = np.abs(new - wrap) + np.linalg.norm(new_h - h, axis=-1)
        keep = np.isfinite(new)
        wrap, h = np.where(keep, new, wrap), np.where(keep[..., None], new_h, h)
        if not (moved > WRAP_TOL).any():
            break
    settled = ~(moved > WRAP_TOL).any(axis=1)
    system = ForwardSystem(robot, free, wrench, w, EA, frames.planes(h, wrap).upper_ends)
    return system.result(p, H, V, iterations, converged & settled & ~short)


def _sag_corrected_start(
    robot: CableRobot, L: FloatArray, w: float, EA: float, wrench: ArrayLike | None
) -> FloatArray:
    """A start pose for the catenary forward kinematics, shape (N, n).

    The straight-line forward kinematics of the lengths (a least-squares fit: sagging
    lengths are not consistent with straight cables), refitted twice to the chords the
    straight-line minimum-norm tensions would give (stretch minus first-order sag).
    Inextensible cables where that fails (no feasible tensions, or a chord longer than
    its cable): the fit raised along z (up to the lowest drawing point) to where the
    smallest relative slack ``(L - chord) / L`` of the cables is largest, so that every
    catenary exists (for the usual suspended robot, raising shortens every chord).
    """
    p = robot.forward_kinematics(L).poses
    valid = np.ones(len(p), bool)
    # Chords ~ stretched lengths minus the parabolic sag excess, with the tensions of the
    # straight-line minimum-norm distribution.
    q = p
    for _ in range(2):
        planes = cable_planes(robot, q)
        T = tension_opt.distribute(robot, q, "min_norm", wrench=wrench).tensions
        valid &= np.isfinite(T).all(axis=1)
        T = np.where(np.isfinite(T) & (T > 0), T, robot.weight)
        excess = (w * planes.x) ** 2 * planes.chord / (24.0 * T * T)
        chord = np.maximum(L * (1.0 + T / EA) - excess, 1e-3 * L)
        q = robot.forward_kinematics(chord, q).poses
    if np.isfinite(EA):
        return q
    valid &= (cable_planes(robot, q).chord < L).all(axis=1)
    zcol = robot.pattern.vertical_coordinate
    if valid.all() or zcol is None:
        return q
    top = robot.anchors[:, 2].min()
    k = 65
    frac = np.linspace(0.0, 1.0, k)[:, None]
    rise = np.maximum(top - p[:, zcol], 0.0)[None, :] * frac * 0.999  # (k, N)
    trial = np.repeat(p[None], k, axis=0)
    trial[..., zcol] += rise
    chords = cable_planes(robot, trial.reshape(-1, p.shape[1])).chord
    slack = ((L[None] - chords.reshape(k, *L.shape)) / L[None]).min(axis=2)  # (k, N)
    best = np.argmax(slack, axis=0)
    # Keep the fit where its chords are already all shorter than the cables.
    best = np.where(slack[0] > 1e-6, 0, best)
    return np.where(valid[:, None], q, trial[best, np.arange(len(p))])


def _newton(system: ForwardSystem, p: FloatArray, H: FloatArray, V: FloatArray,
            tol: float, max_iter: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Newton's method with backtracking on all poses at once.

    Updates the poses ``p`` (N, n) and end forces ``H``, ``V`` (N, m) in place; returns
    the iterations and the convergence of each pose (N,).
    """
    N = p.shape[0]
    iterations = np.zeros(N, np.int64)
    converged = np.zeros(N, bool)
    active = np.arange(N)
    for _ in range(max_iter):
        if active.size == 0:
            break
        pa, Ha, Va = p[active], H[active], V[active]
        r, J = system.linearised(active, pa, Ha, Va)
        with np.errstate(all="ignore"):
            step = -np.linalg.solve(J, r[..., None])[..., 0]
        step = np.where(np.isfinite(step), step, 0.0)
        dp, dH, dV = system.unscale(step)
        merit = np.linalg.norm(r, axis=1)
        # Keep H positive (at most a 90 % drop per step), then backtrack on the residual.
        with np.errstate(all="ignore"):
            ratio = np.where(dH < 0, -0.9 * Ha / dH, np.inf).min(axis=1)
        alpha = np.minimum(1.0, ratio)
        accepted = _line_search(system, active, (pa, Ha, Va), (dp, dH, dV), alpha, merit)
        # Where no step reduces the residual it is at rounding level (or stuck): stop.
        stuck = ~accepted
        p[active], H[active], V[active] = pa, Ha, Va
        iterations[active] += 1
        small = (np.abs(step) * alpha[:, None]).max(axis=1) <= tol
        fine = merit <= 1e-9
        done = (small & fine) | (stuck & fine)
        converged[active[done]] = True
        active = active[~done & ~(stuck & ~fine)]
    return iterations, converged


def _line_search(system: ForwardSystem, active: NDArray[np.intp],
                 state: tuple[FloatArray, FloatArray, FloatArray],
                 steps: tuple[FloatArray, FloatArray, FloatArray], alpha: FloatArray,
                 merit: FloatArray) -> NDArray[np.bool_]:
    """Backtracking along Newton steps until the scaled residual drops enough.

    ``state`` (poses, H, V of the ``active`` poses) is updated in place to the accepted
    points and ``alpha`` to the step fractions taken; returns where a step was accepted.
    """
    pa, Ha, Va = state
    dp, dH, dV = steps
    x0 = (pa.copy(), Ha.copy(), Va.copy())
    accepted = np.zeros(active.size, bool)
    for _ in range(LINE_SEARCH_STEPS):
        todo = ~accepted
        if not todo.any():
            break
        a = alpha[todo][:, None]
        tp = system.robot.displace(x0[0][todo], a * dp[todo])
        tH, tV = x0[1][todo] + a * dH[todo], x0[2][todo] + a * dV[todo]
        rt = system.residual(active[todo], tp, tH, tV)
        better = np.isfinite(rt).all(axis=1) & (
            np.linalg.norm(rt, axis=1) <= (1 - 1e-4 * alpha[todo]) * merit[todo]
        )
        sel = np.flatnonzero(todo)[better]
        pa[sel], Ha[sel], Va[sel] = tp[better], tH[better], tV[better]
        accepted[sel] = True
        alpha[todo] = np.where(better, alpha[todo], 0.5 * alpha[todo])
    return accepted


def _skew(v: FloatArray) -> FloatArray:
    """Cross-product matrices ``[v]x`` of vectors (..., 3), shape (..., 3, 3)."""
    S = np.zeros((*v.shape, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


class ForwardSystem:
    """The square system of the catenary forward kinematics of a batch of lengths.

    Unknowns per pose: the pose (n, scaled by ``scale_len``), ``H`` (m) and ``V_B`` (m)
    (scaled by ``scale_f``). Residual: equilibrium (n rows, / ``scale_f``), horizontal
    spans (m, / ``scale_len``), vertical spans (m, / ``scale_len``).

    Parameters
    ----------
    robot : CableRobot
    lengths : ndarray, shape (N, m)
        Unstretched lengths (m).
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    w, EA : float
        Weight per length (N/m) and axial stiffness (N) of the cables.
    ends : ndarray, shape (N, m, 3), optional
        Each cable's upper end per pose, held fixed (m): where it leaves its guide
        pulley; default the drawing points.

    Attributes
    ----------
    scale_len : float
        The robot's size: the largest extent of its drawing points (m).
    scale_f : float
        The platform's weight (N).
    """

    def __init__(self, robot: CableRobot, lengths: FloatArray, wrench: ArrayLike | None,
                 w: float, EA: float, ends: FloatArray | None = None) -> None:
        self.robot, self.lengths, self.w, self.EA = robot, lengths, w, EA
        self.ends = ends
        N = lengths.shape[0]
        self.wrench = (None if wrench is None
                       else np.broadcast_to(as_float_array("wrench", wrench), (N, robot.dof)))
        self.scale_len = float(np.ptp(robot.anchors, axis=0).max()) or 1.0
        self.scale_f = robot.weight
        self.translation, self.rotation = robot.pattern.step_maps()

    def start_forces(self, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        """End forces ``H``, ``V_B`` (N, m) of the catenaries at poses ``p`` (N, n).

        Where a pose is out of reach of its cables: a straight cable carrying a share of
        the load.
        """
        planes = self.planes(slice(None), p)
        L = self.lengths
        start = solve_forces(planes.x, planes.z, L, self.w, self.EA,
                             compiled=compiled_for(planes.x.size))  # the size rule
        H, V = start.H.copy(), start.V_B.copy()
        fallback = ~np.isfinite(H) | ~np.isfinite(V) | (H <= 0)
        if fallback.any():
            T0 = np.full(L.shape, self.scale_f)
            H = np.where(fallback, T0 * planes.x / planes.chord, H)
            V = np.where(fallback, T0 * planes.z / planes.chord + 0.5 * self.w * L, V)
        return H, V

    def planes(self, sel: NDArray[np.intp] | slice, p: FloatArray) -> CablePlanes:
        """The cables' planes at poses ``p`` of the batch's poses ``sel``: to the drawing
        points, or to the upper ends held fixed."""
        if self.ends is None:
            return cable_planes(self.robot, p)
        position, rotation = self.robot.frames(p)
        arms = np.einsum("nij,mj->nmi", rotation, np.asarray(self.robot.attachments))
        return planes_along(position, rotation, arms,
                            self.ends[sel] - (position[:, None, :] + arms))

    def unscale(self, step: NDArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """A scaled step (k, n + 2m) as pose (k, n), ``H`` (k, m) and ``V_B`` (k, m)
        steps in SI units."""
        n, m = self.robot.dof, self.robot.m
        return (step[:, :n] * self.scale_len, step[:, n:n + m] * self.scale_f,
                step[:, n + m:] * self.scale_f)

    def residual(self, sel: NDArray[np.intp], p: FloatArray, H: FloatArray,
                 V: FloatArray) -> FloatArray:
        """Scaled residual (k, n + 2m) of poses ``sel`` of the batch at ``p``, ``H``, ``V``."""
        return self._evaluate(sel, p, H, V)[0]

    def linearised(self, sel: NDArray[np.intp], p: FloatArray, H: FloatArray,
                   V: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Scaled residual (k, n + 2m) and its Jacobian (k, n + 2m, n + 2m)."""
        r, planes, forces = self._evaluate(sel, p, H, V)
        return r, self._jacobian(planes, forces, H, V, self.lengths[sel])

    def _evaluate(self, sel: NDArray[np.intp], p: FloatArray, H: FloatArray,
                  V: FloatArray) -> tuple[FloatArray, CablePlanes, FloatArray]:
        robot, L = self.robot, self.lengths[sel]
        planes = self.planes(sel, p)
        with np.errstate(all="ignore"):
            xs, zs = spans(H, V, L, self.w, self.EA)
        forces = platform_forces(planes, H, V - self.w * L)
        wrench = None if self.wrench is None else self.wrench[sel]
        eq = cable_wrench(robot, forces, planes.arms) - robot.required_wrench(p, wrench)
        r = np.concatenate([eq / self.scale_f, (xs - planes.x) / self.scale_len,
                            (zs - planes.z) / self.scale_len], axis=1)
        return r, planes, forces

    def _pose_derivative(self, planes: CablePlanes, forces: FloatArray, H: FloatArray
                         ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Derivatives in the pose (k, ., n) of the platform wrench (k, 6, n, at fixed
        end forces) and of the horizontal and vertical spans (k, m, n)."""
        D_pos, D_rot = self.translation, self.rotation
        arm_x = _skew(planes.arms)  # (k, m, 3, 3)
        # d b_i / d pose, (k, m, 3, n): translation plus small rotation of the arm.
        db = D_pos[None, None] - arm_x @ D_rot
        # Spans: x = |(P - b)_xy|, z = P_z - b_z  ->  dx = -e_h . db, dz = -db_z.
        dx_dp = -np.einsum("kmi,kmij->kmj", planes.e_h, db)
        dz_dp = -db[..., 2, :]
        # Cable force on the platform at fixed (H, V): only e_h turns, df = -S db with
        # S = (H / x) (I_xy - e_h e_h^T).
        with np.errstate(all="ignore"):
            hx = np.where(planes.x > 0, H / planes.x, 0.0)
        I_xy = np.diag([1.0, 1.0, 0.0])
        S = hx[..., None, None] * (I_xy - planes.e_h[..., :, None] * planes.e_h[..., None, :])
        df = -S @ db  # (k, m, 3, n)
        # Moments (R a) x f: d = [f]x [a]x dtheta + [a]x df.
        dmom = _skew(forces) @ arm_x @ D_rot + arm_x @ df
        dW = np.concatenate([df.sum(axis=1), dmom.sum(axis=1)], axis=1)  # (k, 6, n)
        if self.robot.pattern.rotates:
            # Gravity moment (R c) x F_g about the reference point turns with the platform.
            Fg = np.array([0.0, 0.0, -self.robot.mass * self.robot.g])
            Rc = np.einsum("kij,j->ki", planes.rotation, self.robot.com)
            dW[:, 3:] += _skew(Fg)[None] @ _skew(Rc) @ D_rot
        return dW, dx_dp, dz_dp

    def _jacobian(self, planes: CablePlanes, forces: FloatArray, H: FloatArray, V: FloatArray,
                  L: FloatArray) -> FloatArray:
        """Jacobian (k, n + 2m, n + 2m) of the scaled residual in the scaled unknowns."""
        n, m = self.robot.dof, self.robot.m
        rows = list(self.robot.wrench_rows)
        with np.errstate(all="ignore"):
            F = flexibility(H, V, L, self.w, self.EA)  # (k, m, 2, 2)
        dW, dx_dp, dz_dp = self._pose_derivative(planes, forces, H)
        # Wrench columns of (H_i, V_i): [e_h; a x e_h] and [e_z; a x e_z].
        e_z = np.broadcast_to(E_Z, planes.e_h.shape)
        cH = np.concatenate([planes.e_h, np.cross(planes.arms, planes.e_h)], axis=-1)
        cV = np.concatenate([e_z, np.cross(planes.arms, e_z)], axis=-1)  # (k, m, 6)
        size = n + 2 * m
        J = np.zeros((H.shape[0], size, size))
        sH, sV = slice(n, n + m), slice(n + m, size)
        J[:, :n, :n] = dW[:, rows, :] * (self.scale_len / self.scale_f)
        J[:, :n, sH] = np.swapaxes(cH[..., rows], 1, 2)
        J[:, :n, sV] = np.swapaxes(cV[..., rows], 1, 2)
        J[:, sH, :n] = -dx_dp
        J[:, sV, :n] = -dz_dp
        diag = np.arange(m)
        f = self.scale_f / self.scale_len
        J[:, n + diag, n + diag] = F[..., 0, 0] * f
        J[:, n + diag, n + m + diag] = F[..., 0, 1] * f
        J[:, n + m + diag, n + diag] = F[..., 1, 0] * f
        J[:, n + m + diag, n + m + diag] = F[..., 1, 1] * f
        return J

    def result(self, p: FloatArray, H: FloatArray, V: FloatArray,
               iterations: NDArray[np.int64], converged: NDArray[np.bool_]
               ) -> ForwardKinematicsResult:
        """The result at poses ``p`` (N, n) with end forces ``H``, ``V_B`` (N, m)."""
        L, robot = self.lengths, self.robot
        planes = self.planes(slice(None), p)
        xs, zs = spans(H, V, L, self.w, self.EA)
        V_A = V - self.w * L
        forces = platform_forces(planes, H, V_A)
        residual = equilibrium_residual(robot, forces, planes.arms,
                                        robot.required_wrench(p, self.wrench))
        span_res = np.maximum(np.abs(xs - planes.x), np.abs(zs - planes.z)).max(axis=1)
        status = status_array(len(p), Status.NOT_CONVERGED)
        status[converged] = Status.CONVERGED
        return ForwardKinematicsResult(
            poses=p,
            tensions=np.hypot(H, V),
            tensions_platform=np.hypot(H, V_A),
            horizontal_tensions=H,
            platform_forces=forces,
            status=status,
            iterations=iterations,
            residual=residual,
            span_residual=span_res,
        )
