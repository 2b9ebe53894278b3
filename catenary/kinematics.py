"""Sag-aware inverse and forward kinematics of a cable robot.

Every cable hangs as an elastic catenary in the vertical plane through its platform
attachment point and its drawing point (anchor). In the terms of
:mod:`catenary.elastic`, end A of cable ``i`` is the attachment point ``b_i`` on the
platform and end B is the drawing point ``P_i``: the horizontal span is
``x_i = |(P_i - b_i)_xy|`` and ``z_i = P_iz - b_iz`` (either sign). The force the cable
applies to the platform is ``f_i = H_i e_i + V_A,i e_z`` (N, base frame) with ``e_i``
the horizontal unit vector from ``b_i`` towards ``P_i``; the tension at the drawing
point is ``T_B = |(H, V_B)|`` and at the platform ``T_A = |(H, V_A)|``.

Inverse kinematics (:func:`inverse_kinematics`) has two models:

``"thesis"``
    The reference study's decoupled convention: tensions from the straight-line
    distribution, each imposed as the tension magnitude at the drawing point of the
    taut catenary. Reproduces the study's lengths; the catenary end forces then do not
    balance the load (see ``equilibrium_residual``).
``"coupled"``
    Physically consistent: the catenary end forces at the platform balance the load
    (forces and moments), with the tensions chosen by the same objectives as
    :func:`tension_opt.distribute`; solved by sequential convex programming.

Forward kinematics (:func:`forward_kinematics`) solves, from the unstretched lengths,
the square system of the span equations of every cable and the platform equilibrium
for the pose and the cable end forces by Newton's method with the analytic
flexibility of :mod:`catenary.elastic`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot, TensionProblem
from tension_opt.backends import Backend, get_backend
from tension_opt.problems import Objective, StandardForm, as_problem
from tension_opt.solution import Status

from .elastic import flexibility, length_derivative, spans
from .errors import InvalidCableError
from .solve import solve_forces, solve_length

__all__ = [
    "ForwardKinematicsResult",
    "InverseKinematicsResult",
    "forward_kinematics",
    "inverse_kinematics",
]

FloatArray = NDArray[np.float64]

_E_Z = np.array([0.0, 0.0, 1.0])


# ----------------------------------------------------------------------------
# results


@dataclass(frozen=True, eq=False)
class InverseKinematicsResult:
    """Sag-aware cable lengths and forces of a batch of poses.

    Attributes
    ----------
    lengths : ndarray, shape (N, m)
        Unstretched cable lengths (m); NaN where a pose failed.
    straight_lengths : ndarray, shape (N, m)
        Distance from attachment point to drawing point (m).
    tensions : ndarray, shape (N, m)
        Tension magnitude at the drawing point, end B (N).
    tensions_platform : ndarray, shape (N, m)
        Tension magnitude at the platform attachment point, end A (N).
    horizontal_tensions : ndarray, shape (N, m)
        Horizontal tension ``H`` of each catenary (N).
    platform_forces : ndarray, shape (N, m, 3)
        Force each cable applies on the platform, base frame (N).
    equilibrium_residual : ndarray, shape (N,)
        Norm of the wrench (cable forces, their moments for rotating platforms, gravity
        and the external wrench) left on the platform, restricted to the robot's
        degrees of freedom (N, N m).
    iterations : ndarray of int, shape (N,)
        Sequential-convex-programming iterations per pose (linearised subproblems
        solved after the straight-line start); 0 for the thesis model.
    catenary_iterations : ndarray of int, shape (N, m)
        Newton (and fallback) iterations of the single-cable solver, summed over the
        SCP iterations.
    status : ndarray of str, shape (N,)
        ``"converged"``; ``"infeasible"`` (no tensions within the bounds balance the
        load); ``"catenary_failed"`` (no taut catenary carries the tension);
        ``"max_iter"`` (the SCP did not settle within its iteration limit).
    model : str
        ``"thesis"`` or ``"coupled"``.
    solve_time : float
        Wall-clock time of the whole call (s).
    """

    lengths: FloatArray
    straight_lengths: FloatArray
    tensions: FloatArray
    tensions_platform: FloatArray
    horizontal_tensions: FloatArray
    platform_forces: FloatArray
    equilibrium_residual: FloatArray
    iterations: NDArray[np.int64]
    catenary_iterations: NDArray[np.int64]
    status: NDArray[np.str_]
    model: str
    solve_time: float

    @property
    def sag(self) -> FloatArray:
        """Length difference ``D = lengths - straight_lengths`` (m), shape (N, m)."""
        return self.lengths - self.straight_lengths

    @property
    def success(self) -> NDArray[np.bool_]:
        """Boolean mask of the poses solved, shape (N,)."""
        return self.status == "converged"


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
        ``"converged"``, ``"not_converged"`` or, for the straight model, the status of
        :meth:`tension_opt.CableRobot.forward_kinematics` (``"inconsistent"`` ...).
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
        return self.status == "converged"


# ----------------------------------------------------------------------------
# geometry shared by both directions


@dataclass(frozen=True)
class _Geometry:
    """Cable geometry of validated poses (all arrays over poses and cables)."""

    position: FloatArray  # (N, 3) platform reference point
    rotation: FloatArray  # (N, 3, 3)
    arm: FloatArray  # (N, m, 3) R a_i
    x: FloatArray  # (N, m) horizontal span
    z: FloatArray  # (N, m) height of the anchor over the attachment
    e_h: FloatArray  # (N, m, 3) horizontal unit vector towards the anchor (0 if vertical)
    chord: FloatArray  # (N, m) straight length


def _geometry(robot: CableRobot, poses: FloatArray) -> _Geometry:
    position, R = robot.frames(poses)
    arm = np.einsum("nij,mj->nmi", R, robot.attachments)
    d = robot.anchors[None] - (position[:, None, :] + arm)
    x = np.hypot(d[..., 0], d[..., 1])
    e_h = np.zeros_like(d)
    with np.errstate(invalid="ignore", divide="ignore"):
        e_h[..., :2] = np.where(x[..., None] > 0, d[..., :2] / x[..., None], 0.0)
    chord = np.sqrt(x * x + d[..., 2] ** 2)
    return _Geometry(position, np.asarray(R), arm, x, d[..., 2], e_h, chord)


def _pose_maps(kind: str) -> tuple[FloatArray, FloatArray]:
    """Matrices (3, n) taking a pose step to a translation and to a small rotation.

    For ``spatial6`` the angular part of a step is a rotation about the base axes
    (left-multiplied), the convention of :meth:`CableRobot.forward_kinematics`.
    """
    if kind == "point3":
        return np.eye(3), np.zeros((3, 3))
    if kind == "planar_point2":
        return np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]]), np.zeros((3, 2))
    if kind == "planar3":
        D_pos = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
        D_rot = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        return D_pos, D_rot
    eye, zero = np.eye(3), np.zeros((3, 3))
    return np.hstack([eye, zero]), np.hstack([zero, eye])


def _cable_wrench(robot: CableRobot, forces: FloatArray, arm: FloatArray) -> FloatArray:
    """Total wrench (N, n) of cable forces (N, m, 3) applied at the arms (N, m, 3)."""
    full = np.concatenate([forces.sum(axis=1), np.cross(arm, forces).sum(axis=1)], axis=-1)
    return full[:, list(robot.wrench_rows)]


def _wrenches(forces: FloatArray, arm: FloatArray, rows: list[int]) -> FloatArray:
    """Wrench of each cable force, (N, m, n): ``[f; (R a) x f]`` restricted to ``rows``."""
    return np.concatenate([forces, np.cross(arm, forces)], axis=-1)[..., rows]


def _platform_forces(geo: _Geometry, H: FloatArray, V_A: FloatArray) -> FloatArray:
    """Force of each cable on the platform, (N, m, 3): ``H e_h + V_A e_z``."""
    return H[..., None] * geo.e_h + V_A[..., None] * _E_Z


def _cable_data(robot: CableRobot) -> tuple[float, float]:
    """Weight per length w (N/m) and axial stiffness EA (N) of the robot's cables."""
    if robot.cable is None:
        raise InvalidCableError(
            f"robot {robot.name!r} has no cable properties: build it with "
            "cable=CableProperties(diameter, linear_mass, EA) to use the catenary model"
        )
    return robot.cable.weight_per_length(robot.g), float(robot.cable.EA)


def _extreme_tensions(
    H: FloatArray, V_A: FloatArray, V_B: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Lowest and highest tension along each cable (N).

    The tension ``sqrt(H^2 + V^2)`` is smallest where ``V = 0``: at the lowest point of
    the cable when it lies between the ends, otherwise at an end.
    """
    T_A, T_B = np.hypot(H, V_A), np.hypot(H, V_B)
    dip = (V_A < 0) & (V_B > 0)
    return np.where(dip, H, np.minimum(T_A, T_B)), np.maximum(T_A, T_B)


# ----------------------------------------------------------------------------
# inverse kinematics


def inverse_kinematics(
    robot: CableRobot,
    poses: ArrayLike,
    model: Literal["thesis", "coupled"] = "thesis",
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str | Backend = "auto",
    wrench: ArrayLike | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = 50,
    initial_tensions: ArrayLike | None = None,
    **options: Any,
) -> InverseKinematicsResult:
    """Unstretched cable lengths and cable forces of a batch of poses, with sag.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (weight per length ``linear_mass * g`` and ``EA``).
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad); see :mod:`tension_opt.robot`.
    model : {"thesis", "coupled"}
        ``"thesis"``: the reference study's decoupled convention. The straight-line
        distribution (``objective``) gives each tension, imposed as the tension
        magnitude at the drawing point of the taut catenary through both ends.
        ``"coupled"``: the catenary end forces at the platform balance the load; see
        Notes.
    objective : str or TensionProblem
        As in :func:`tension_opt.distribute` (``"min_sum"``, ``"min_norm"``, ...).
        In the coupled model it is applied to the platform-end tensions; smoothing
        and rate limits are not supported there.
    backend : str or Backend
        As in :func:`tension_opt.distribute`; ``"auto"`` picks the fastest exact one.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).
    tol : float
        Coupled model: stop when the tensions change less than ``tol`` relative to
        the largest tension of the pose.
    max_iter : int
        Coupled model: iteration limit of the sequential convex programming.
    initial_tensions : array_like, shape (N, m), optional
        Coupled model: platform-end tensions (N) to start from instead of the
        straight-line distribution, for the poses whose row is finite; such poses are
        attempted even where the straight-line distribution is infeasible. Without it,
        poses whose straight-line distribution is infeasible start from the coupled
        capacity-margin search (sag can make them feasible).
    **options
        Passed to the backend.

    Returns
    -------
    InverseKinematicsResult
        Lengths (N, m), tensions at both ends (N, m), platform forces (N, m, 3),
        equilibrium residual (N,), iteration counts and per-pose status.

    Notes
    -----
    The coupled model parameterises cable ``i`` by its tension ``t_i`` at the
    platform and the direction ``d_i`` of its end force there, so that the wrench
    balance is linear in ``t`` for fixed directions: ``A(d) t = b``, with column
    ``[d_i; (R a_i) x d_i]``. Starting from the straight-line distribution (``d_i``
    along the chords), every iteration, for all unconverged poses at once,

    1. solves the catenary of every cable through its attachment and anchor with
       platform-end tension ``t_i`` (:func:`catenary.solve_length`, ``end="A"``) and
       takes the direction of its platform-end force as the new column ``d_i``;
    2. maps the tension bounds to the platform end: ``t_min`` bounds the lowest
       tension along the cable, ``t_max`` the highest, so the bounds on ``t_i`` are
       shifted by ``t_i - T_low,i`` and ``t_i - T_high,i`` of the current catenary
       (for an inextensible cable ``T_B - T_A = w (z_B - z_A)`` exactly);
    3. solves the linear distribution problem ``A(d) t = b`` with ``objective``
       through the chosen ``tension_opt`` backend.

    It stops when ``t`` changes less than ``tol`` (relative). At that fixed point the
    catenaries carrying ``t`` have the directions used in the balance, so their end
    forces balance the load exactly, within the bounds, and ``t`` is optimal for the
    objective among the tensions with those end-force directions.
    """
    t0 = time.perf_counter()
    if model not in ("thesis", "coupled"):
        raise InvalidCableError(f'model must be "thesis" or "coupled"; got model={model!r}')
    w, EA = _cable_data(robot)
    p = robot.as_poses(poses)
    geo = _geometry(robot, p)
    N, m = geo.x.shape
    sol = tension_opt.distribute(robot, p, objective, backend, wrench=wrench, **options)
    ok = sol.success.copy()
    start = None
    if initial_tensions is not None and model == "coupled" and w > 0.0:
        start = np.broadcast_to(np.asarray(initial_tensions, dtype=float), (N, m))
    elif model == "coupled" and w > 0.0 and not ok.all():
        # Sag can widen the workspace: where no straight-line tensions fit the bounds,
        # the coupled capacity-margin search may still find catenaries in equilibrium.
        start = _margin_start(robot, p, ~ok, wrench, backend, tol, max_iter, options)
    if start is not None:
        given = np.isfinite(start).all(axis=1)
        sol.tensions = np.where(given[:, None], start, sol.tensions)
        ok |= given
    T_straight = sol.tensions
    status = np.where(ok, "converged", "infeasible").astype("<U15")
    iterations = np.zeros(N, np.int64)
    cat_its = np.zeros((N, m), np.int64)

    if model == "coupled" and w > 0.0:
        H, V_A, V_B, L0, ok = _scp(
            robot,
            p,
            geo,
            w,
            EA,
            sol,
            objective,
            backend,
            wrench,
            tol,
            max_iter,
            options,
            ok,
            status,
            iterations,
            cat_its,
        )
    else:
        # The thesis convention; weightless cables are straight, so the straight-line
        # distribution is then also the coupled solution.
        H, V_A, V_B, L0 = (np.full((N, m), np.nan) for _ in range(4))
        idx = np.flatnonzero(ok)
        if idx.size:
            h, va, vb, l0, its, conv = _catenary(geo.x[idx], geo.z[idx], T_straight[idx], w,
                                                 EA, "B")
            cat_its[idx] += its
            status[idx[~conv.all(axis=1)]] = "catenary_failed"
            H[idx], V_A[idx], V_B[idx], L0[idx] = h, va, vb, l0
    failed = (status != "converged") & (status != "max_iter")
    for arr in (H, V_A, V_B, L0):
        arr[failed] = np.nan
    forces = _platform_forces(geo, H, V_A)
    residual = np.linalg.norm(
        _cable_wrench(robot, forces, geo.arm) - robot.required_wrench(p, wrench), axis=1
    )
    return InverseKinematicsResult(
        lengths=L0,
        straight_lengths=geo.chord,
        tensions=np.hypot(H, V_B),
        tensions_platform=np.hypot(H, V_A),
        horizontal_tensions=H,
        platform_forces=forces,
        equilibrium_residual=residual,
        iterations=iterations,
        catenary_iterations=cat_its,
        status=status,
        model=model,
        solve_time=time.perf_counter() - t0,
    )


def _margin_start(robot: CableRobot, poses: FloatArray, missing: NDArray[np.bool_],
                  wrench: ArrayLike | None, backend: str | Backend, tol: float,
                  max_iter: int, options: dict[str, Any]) -> FloatArray:
    """Platform-end tensions of catenaries in equilibrium within the bounds, (N, m).

    From the coupled capacity-margin search (:func:`catenary.workspace.coupled_margin`)
    of the poses ``missing``; NaN rows where it finds none.
    """
    from .workspace import coupled_margin  # builds on this module; imported when needed

    idx = np.flatnonzero(missing)
    start = np.full((poses.shape[0], robot.m), np.nan)
    wk = None
    if wrench is not None:
        wr = np.asarray(wrench, dtype=float)
        wk = wr[idx] if wr.ndim == 2 else wr
    margin, T_m, m_status, _, _ = coupled_margin(robot, poses[idx], wk, backend, tol=tol,
                                                 max_iter=max_iter, **options)
    slack = 1e-9 * np.nanmax(np.abs(T_m), axis=1, initial=0.0)
    found = (m_status == "converged") & (margin >= -slack)
    start[idx[found]] = T_m[found]
    return start


def _scp(
    robot: CableRobot,
    p: FloatArray,
    geo: _Geometry,
    w: float,
    EA: float,
    straight: tension_opt.TensionSolution,
    objective: str | Objective | TensionProblem,
    backend: str | Backend,
    wrench: ArrayLike | None,
    tol: float,
    max_iter: int,
    options: dict[str, Any],
    ok: NDArray[np.bool_],
    status: NDArray[np.str_],
    iterations: NDArray[np.int64],
    cat_its: NDArray[np.int64],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Sequential convex programming of the coupled model (see inverse_kinematics).

    Returns the catenaries of the final tensions, ``H, V_A, V_B, L0`` (each (N, m)),
    and the success mask; updates ``status``, ``iterations`` and ``cat_its`` in place.
    """
    problem = as_problem(objective)
    if problem.is_sequential:
        raise InvalidCableError(
            "the coupled model solves poses independently: smoothing and rate limits are "
            "not supported (use a problem without them)"
        )
    solver = backend if isinstance(backend, Backend) else get_backend(straight.backend)
    bounded = problem.objective is not Objective.PINV
    lb0, ub0 = problem.bounds(robot, p.shape[0])
    b = robot.required_wrench(p, wrench)
    rows = list(robot.wrench_rows)
    N, m = geo.x.shape
    T = straight.tensions.copy()
    H, V_A, V_B, L0 = (np.full((N, m), np.nan) for _ in range(4))

    def catenaries(sel: NDArray[np.intp], tens: FloatArray) -> NDArray[np.bool_]:
        """Solve the cables of poses ``sel`` at platform tensions ``tens``; True where all
        of a pose's cables have a taut catenary (stored in H, V_A, V_B, L0)."""
        h, va, vb, l0, its, conv = _catenary(geo.x[sel], geo.z[sel], tens, w, EA, "A")
        cat_its[sel] += its
        good: NDArray[np.bool_] = np.all(conv, axis=1)
        g = sel[good]
        H[g], V_A[g], V_B[g], L0[g] = h[good], va[good], vb[good], l0[good]
        return good

    idx = np.flatnonzero(ok)
    good = catenaries(idx, T[idx])
    status[idx[~good]] = "catenary_failed"
    status[idx[good]] = "max_iter"
    active = idx[good]
    # Multipliers of the equilibrium rows, first from the straight-line problem.
    lam = np.zeros((N, len(rows)))
    if active.size:
        form0 = problem.standard_form_from(robot, robot.structure_matrices(p[active]), b[active])
        lam[active] = _multipliers(form0, T[active])
    restarts = np.zeros(N, np.int64)
    max_restarts = 6
    pending: list[NDArray[np.intp]] = []
    for _ in range(max_iter):
        if active.size == 0:
            break
        Ta = T[active]
        sub = _Geometry(*(getattr(geo, f)[active] for f in geo.__dataclass_fields__))
        h, va, vb, l0 = H[active], V_A[active], V_B[active], L0[active]
        # Linearised platform force of each cable in its platform-end tension:
        # f(t) ~ f(Ta) + f'(Ta) (t - Ta). Equilibrium: sum f'(Ta) t = b - sum (f - f' Ta).
        force = _platform_forces(sub, h, va)
        slope = _force_slope(sub, h, va, vb, l0, w, EA)
        W1 = _wrenches(slope, sub.arm, rows)  # (k, m, n)
        A = np.ascontiguousarray(np.swapaxes(W1, 1, 2))
        offset = _wrenches(force - slope * Ta[..., None], sub.arm, rows).sum(axis=1)
        if bounded:
            low, high = _extreme_tensions(h, va, vb)
            prob = problem.with_(t_min=lb0[active] + (Ta - low), t_max=ub0[active] + (Ta - high))
        else:
            prob = problem
        form = prob.standard_form_from(robot, A, b[active] - offset)
        # Curvature of the Lagrangian along each tension (the constraint's second
        # derivative by a forward difference of the slope): a diagonal SQP Hessian,
        # kept convex. Without it the LP steps of min-sum can cycle between vertices
        # when the optimum of the curved problem is not at a vertex.
        dT = 1e-6 * Ta
        near = _catenary(sub.x, sub.z, Ta + dT, w, EA, "A")
        with np.errstate(invalid="ignore"):
            slope2 = _force_slope(sub, *near[:4], w, EA)
            W2 = (_wrenches(slope2, sub.arm, rows) - W1) / dT[..., None]
            curv = np.einsum("kn,kmn->km", lam[active], W2)
        curv = np.where(np.isfinite(curv), np.maximum(curv, 0.0), 0.0)
        # Curvature too small to change the objective at the scale of the tensions is
        # dropped (keeps LPs linear where the cables are nearly straight).
        scale = form.scale()[:, None]
        size = (np.abs(form.c) * scale + form.q * scale**2).max(axis=1, keepdims=True)
        curv = np.where(curv * scale**2 > 1e-12 * size, curv, 0.0)
        form.q = form.q + curv
        form.c = form.c - curv * Ta
        raw = solver.solve(form, **options)
        iterations[active] += 1
        solved = (raw.status == Status.OPTIMAL) | (raw.status == Status.INACCURATE)
        if not solved.all():
            # A linearisation far from the solution (low tensions, deep sag) may have no
            # feasible point although the pose has one: restart those poses from doubled
            # tensions (straighter cables), a few times before declaring them infeasible.
            fail = active[~solved]
            retry = fail[restarts[fail] < max_restarts]
            restarts[retry] += 1
            good = catenaries(retry, 2.0 * T[retry])
            T[retry[good]] *= 2.0
            hopeless = np.setdiff1d(fail, retry[good])
            status[hopeless] = "infeasible"
            ok[hopeless] = False
            pending.append(retry[good])
        lam[active[solved]] = _multipliers(
            form.subset(np.flatnonzero(solved)), raw.tensions[solved]
        )
        active, Ta, step = active[solved], Ta[solved], raw.tensions[solved] - Ta[solved]
        # Safeguard: halve the step where the new tension cannot hold a taut catenary.
        trial = np.ones(active.size, bool)
        for _half in range(30):
            sel = np.flatnonzero(trial)
            if sel.size == 0:
                break
            good = catenaries(active[sel], Ta[sel] + step[sel])
            trial[sel[good]] = False
            step[sel[~good]] *= 0.5
        failed = trial
        status[active[failed]] = "catenary_failed"
        ok[active[failed]] = False
        active, Ta, step = active[~failed], Ta[~failed], step[~failed]
        T[active] = Ta + step
        change = np.abs(step).max(axis=1) / np.abs(Ta).max(axis=1)
        done = change <= tol
        status[active[done]] = "converged"
        active = np.sort(np.concatenate([active[~done], *pending]))
        pending.clear()
    return H, V_A, V_B, L0, ok & (status == "converged")


def _multipliers(form: StandardForm, T: FloatArray) -> FloatArray:
    """Multipliers ``lam`` (k, n) of the equilibrium rows at a solution ``T`` (k, m).

    From the stationarity of the free tensions (not at a bound, not at the maximum of a
    min-max objective): ``q T + c + A^T lam = 0`` on those cables, in the least-squares
    sense (minimum norm when they are fewer than the rows).
    """
    scale = form.scale()[:, None]
    tol = 1e-7 * scale
    free = ~((T <= form.lb + tol) | (T >= form.ub - tol))
    if form.minmax is not None:
        vals = T * form.minmax
        free &= vals < vals.max(axis=1, keepdims=True) - tol
    grad = form.q * T + form.c
    AF = form.A * free[:, None, :]
    M = np.einsum("kim,kjm->kij", AF, AF)
    reg = 1e-12 * np.trace(M, axis1=1, axis2=2)[:, None, None] + 1e-300
    M = M + reg * np.eye(M.shape[1])
    rhs = -np.einsum("kim,km->ki", AF, np.where(free, grad, 0.0))
    return np.linalg.solve(M, rhs[..., None])[..., 0]


def _catenary(
    x: FloatArray, z: FloatArray, T: FloatArray, w: float, EA: float, end: Literal["A", "B"]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64],
           NDArray[np.bool_]]:
    """Taut catenaries with tension ``T`` at ``end``: ``H, V_A, V_B, L0``, iterations, ok."""
    res = solve_length(x, z, T, w, EA, end=end)
    return res.H, res.V_A, res.V_B, res.L0, res.iterations, res.converged


def _force_slope(
    geo: _Geometry,
    H: FloatArray,
    V_A: FloatArray,
    V_B: FloatArray,
    L0: FloatArray,
    w: float,
    EA: float,
) -> FloatArray:
    """Derivative of each cable's platform force with its platform-end tension, (k, m, 3).

    At fixed end points the catenary is a one-parameter family in ``L0``: the spans
    stay put if ``(dH, dV_B) = -F^-1 (dx/dL0, dz/dL0) dL0`` (``F`` the flexibility).
    With ``q = F^-1 (dx/dL0, dz/dL0)`` and ``D = -dT_A/dL0 = (H q_x + V_A (q_z + w))
    / T_A``, ``dH/dT_A = q_x / D`` and ``dV_A/dT_A = (q_z + w) / D``. A vertical cable
    (``H = 0``) has ``f = V_A e_z`` and slope ``sign(V_A) e_z``.
    """
    with np.errstate(all="ignore"):
        F = flexibility(H, V_B, L0, w, EA)
        lx, lz = length_derivative(H, V_B, L0, w, EA)
        a, bb, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 1]
        det = a * d - bb * bb
        qx = (d * lx - bb * lz) / det
        qz = (a * lz - bb * lx) / det
        T_A = np.hypot(H, V_A)
        D = (H * qx + V_A * (qz + w)) / T_A
        dH = qx / D
        dV = (qz + w) / D
    vertical = geo.x == 0
    dH = np.where(vertical, 0.0, dH)
    dV = np.where(vertical, np.sign(V_A), dV)
    # Cables with sag below rounding (see _catenary): the end tangent leaves the chord by
    # delta = w x / (2 T), so f = T (cos, sin)(theta - delta) and
    # f' = (cos, sin)(phi) + delta (-sin, cos)(phi) with phi = theta - delta.
    with np.errstate(all="ignore"):
        light = (w * geo.chord < 1e-7 * T_A) & ~vertical
        phi = np.arctan2(V_A, H)
        delta = w * geo.x / (2.0 * T_A)
    dH = np.where(light, np.cos(phi) - delta * np.sin(phi), dH)
    dV = np.where(light, np.sin(phi) + delta * np.cos(phi), dV)
    return dH[..., None] * geo.e_h + dV[..., None] * _E_Z


# ----------------------------------------------------------------------------
# forward kinematics


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
    L = np.asarray(lengths, dtype=float)
    if L.ndim == 1:
        L = L[None]
    if L.ndim != 2 or L.shape[1] != robot.m:
        raise InvalidCableError(f"lengths must have shape (N, {robot.m}), got {L.shape}")
    if not np.isfinite(L).all() or (L <= 0).any():
        raise InvalidCableError("lengths must be positive and finite")
    N, m = L.shape
    if model == "straight":
        fk = robot.forward_kinematics(L, initial_poses)
        sol = tension_opt.distribute(robot, fk.poses, objective, wrench=wrench)
        geo = _geometry(robot, fk.poses)
        T = sol.tensions
        H = T * geo.x / geo.chord
        V = T * geo.z / geo.chord
        forces = _platform_forces(geo, H, V)
        residual = np.linalg.norm(
            _cable_wrench(robot, forces, geo.arm) - robot.required_wrench(fk.poses, wrench), axis=1
        )
        status = np.where(sol.success, fk.status, "infeasible")
        return ForwardKinematicsResult(
            fk.poses, T, T, H, forces, status, fk.iterations, residual, fk.residual
        )

    w, EA = _cable_data(robot)
    if w == 0.0 and not np.isfinite(EA):
        raise InvalidCableError(
            "weightless inextensible cables do not fix the tensions: use model='straight'"
        )
    scale_len = float(np.ptp(robot.anchors, axis=0).max()) or 1.0
    scale_f = robot.weight
    if initial_poses is None:
        p = _sag_corrected_start(robot, L, w, EA, wrench)
    else:
        p = np.broadcast_to(robot.as_poses(initial_poses), (N, robot.dof)).copy()
    geo = _geometry(robot, p)
    start = solve_forces(geo.x, geo.z, L, w, EA)
    H, V = start.H.copy(), start.V_B.copy()
    # Where the start pose is out of reach, a straight cable carrying a share of the load.
    fallback = ~np.isfinite(H) | ~np.isfinite(V) | (H <= 0)
    if fallback.any():
        T0 = np.full((N, m), scale_f)
        H = np.where(fallback, T0 * geo.x / geo.chord, H)
        V = np.where(fallback, T0 * geo.z / geo.chord + 0.5 * w * L, V)

    iterations = np.zeros(N, np.int64)
    converged = np.zeros(N, bool)
    active = np.arange(N)
    for _ in range(max_iter):
        if active.size == 0:
            break
        pa, Ha, Va, La = p[active], H[active], V[active], L[active]
        wr = (
            None
            if wrench is None
            else np.broadcast_to(np.asarray(wrench, float), (N, robot.dof))[active]
        )
        r, J = _fk_system(robot, pa, Ha, Va, La, w, EA, wr, scale_len, scale_f, jac=True)
        assert J is not None  # jac=True
        with np.errstate(all="ignore"):
            step = -np.linalg.solve(J, r[..., None])[..., 0]
        step = np.where(np.isfinite(step), step, 0.0)
        dp = step[:, : robot.dof] * scale_len
        dH = step[:, robot.dof : robot.dof + m] * scale_f
        dV = step[:, robot.dof + m :] * scale_f
        merit = np.linalg.norm(r, axis=1)
        # Keep H positive (at most a 90 % drop per step), then backtrack on the residual.
        with np.errstate(all="ignore"):
            ratio = np.where(dH < 0, -0.9 * Ha / dH, np.inf).min(axis=1)
        alpha = np.minimum(1.0, ratio)
        accepted = np.zeros(active.size, bool)
        newp, newH, newV = pa.copy(), Ha.copy(), Va.copy()
        for _ls in range(30):
            todo = ~accepted
            if not todo.any():
                break
            a = alpha[todo][:, None]
            tp = robot.displace(pa[todo], a * dp[todo])
            tH, tV = Ha[todo] + a * dH[todo], Va[todo] + a * dV[todo]
            wt = None if wr is None else wr[todo]
            rt, _ = _fk_system(
                robot, tp, tH, tV, La[todo], w, EA, wt, scale_len, scale_f, jac=False
            )
            better = np.isfinite(rt).all(axis=1) & (
                np.linalg.norm(rt, axis=1) <= (1 - 1e-4 * alpha[todo]) * merit[todo]
            )
            sel = np.flatnonzero(todo)[better]
            newp[sel], newH[sel], newV[sel] = tp[better], tH[better], tV[better]
            accepted[sel] = True
            alpha[todo] = np.where(better, alpha[todo], 0.5 * alpha[todo])
        # Where no step reduces the residual it is at rounding level (or stuck): stop.
        stuck = ~accepted
        p[active], H[active], V[active] = newp, newH, newV
        iterations[active] += 1
        small = (np.abs(step) * alpha[:, None]).max(axis=1) <= tol
        fine = merit <= 1e-9
        done = (small & fine) | (stuck & fine)
        converged[active[done]] = True
        active = active[~done & ~(stuck & ~fine)]

    geo = _geometry(robot, p)
    xs, zs = spans(H, V, L, w, EA)
    V_A = V - w * L
    forces = _platform_forces(geo, H, V_A)
    residual = np.linalg.norm(
        _cable_wrench(robot, forces, geo.arm) - robot.required_wrench(p, wrench), axis=1
    )
    span_res = np.maximum(np.abs(xs - geo.x), np.abs(zs - geo.z)).max(axis=1)
    status = np.where(converged, "converged", "not_converged")
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
        geo = _geometry(robot, q)
        T = tension_opt.distribute(robot, q, "min_norm", wrench=wrench).tensions
        valid &= np.isfinite(T).all(axis=1)
        T = np.where(np.isfinite(T) & (T > 0), T, robot.weight)
        excess = (w * geo.x) ** 2 * geo.chord / (24.0 * T * T)
        chord = np.maximum(L * (1.0 + T / EA) - excess, 1e-3 * L)
        q = robot.forward_kinematics(chord, q).poses
    if np.isfinite(EA):
        return q
    valid &= (_geometry(robot, q).chord < L).all(axis=1)
    if valid.all() or robot.kind not in ("point3", "spatial6", "planar_point2"):
        return q
    zcol = 1 if robot.kind == "planar_point2" else 2
    top = robot.anchors[:, 2].min()
    k = 65
    frac = np.linspace(0.0, 1.0, k)[:, None]
    rise = np.maximum(top - p[:, zcol], 0.0)[None, :] * frac * 0.999  # (k, N)
    trial = np.repeat(p[None], k, axis=0)
    trial[..., zcol] += rise
    geo = _geometry(robot, trial.reshape(-1, p.shape[1]))
    slack = ((L[None] - geo.chord.reshape(k, *L.shape)) / L[None]).min(axis=2)  # (k, N)
    best = np.argmax(slack, axis=0)
    # Keep the fit where its chords are already all shorter than the cables.
    best = np.where(slack[0] > 1e-6, 0, best)
    return np.where(valid[:, None], q, trial[best, np.arange(len(p))])


def _skew(v: FloatArray) -> FloatArray:
    """Cross-product matrices ``[v]x`` of vectors (..., 3), shape (..., 3, 3)."""
    S = np.zeros((*v.shape, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def _fk_system(
    robot: CableRobot,
    p: FloatArray,
    H: FloatArray,
    V: FloatArray,
    L: FloatArray,
    w: float,
    EA: float,
    wrench: FloatArray | None,
    scale_len: float,
    scale_f: float,
    jac: bool,
) -> tuple[FloatArray, FloatArray | None]:
    """Scaled residual (k, n + 2m) of the forward system and its Jacobian.

    Residual order: equilibrium (n rows, / scale_f), horizontal spans (m, / scale_len),
    vertical spans (m, / scale_len). Unknown order: pose (n, * scale_len), H (m) and
    V_B (m) (* scale_f).
    """
    k = p.shape[0]
    n, m = robot.dof, robot.m
    rows = list(robot.wrench_rows)
    geo = _geometry(robot, p)
    with np.errstate(all="ignore"):
        xs, zs = spans(H, V, L, w, EA)
    V_A = V - w * L
    forces = _platform_forces(geo, H, V_A)
    eq = _cable_wrench(robot, forces, geo.arm) - robot.required_wrench(p, wrench)
    r = np.concatenate([eq / scale_f, (xs - geo.x) / scale_len, (zs - geo.z) / scale_len], axis=1)
    if not jac:
        return r, None

    with np.errstate(all="ignore"):
        F = flexibility(H, V, L, w, EA)  # (k, m, 2, 2)
    D_pos, D_rot = _pose_maps(robot.kind)
    arm_x = _skew(geo.arm)  # (k, m, 3, 3)
    # d b_i / d pose, (k, m, 3, n): translation plus small rotation of the arm.
    db = D_pos[None, None] - arm_x @ D_rot
    # Spans: x = |(P - b)_xy|, z = P_z - b_z  ->  dx = -e_h . db, dz = -db_z.
    dx_dp = -np.einsum("kmi,kmij->kmj", geo.e_h, db)
    dz_dp = -db[..., 2, :]
    # Cable force on the platform at fixed (H, V): only e_h turns, df = -S db with
    # S = (H / x) (I_xy - e_h e_h^T).
    with np.errstate(all="ignore"):
        hx = np.where(geo.x > 0, H / geo.x, 0.0)
    I_xy = np.diag([1.0, 1.0, 0.0])
    S = hx[..., None, None] * (I_xy - geo.e_h[..., :, None] * geo.e_h[..., None, :])
    df = -S @ db  # (k, m, 3, n)
    # Moments (R a) x f: d = [f]x [a]x dtheta + [a]x df.
    dmom = _skew(forces) @ arm_x @ D_rot + arm_x @ df
    dW = np.concatenate([df.sum(axis=1), dmom.sum(axis=1)], axis=1)  # (k, 6, n)
    if robot.kind in ("planar3", "spatial6"):
        # Gravity moment (R c) x F_g about the reference point turns with the platform.
        Fg = np.array([0.0, 0.0, -robot.mass * robot.g])
        Rc = np.einsum("kij,j->ki", geo.rotation, robot.com)
        dW[:, 3:] += _skew(Fg)[None] @ _skew(Rc) @ D_rot
    # Wrench columns of (H_i, V_i): [e_h; a x e_h] and [e_z; a x e_z].
    cH = np.concatenate([geo.e_h, np.cross(geo.arm, geo.e_h)], axis=-1)  # (k, m, 6)
    cV = np.concatenate(
        [
            np.broadcast_to(_E_Z, geo.e_h.shape),
            np.cross(geo.arm, np.broadcast_to(_E_Z, geo.e_h.shape)),
        ],
        axis=-1,
    )

    size = n + 2 * m
    J = np.zeros((k, size, size))
    sH, sV = slice(n, n + m), slice(n + m, size)
    J[:, :n, :n] = dW[:, rows, :] * (scale_len / scale_f)
    J[:, :n, sH] = np.swapaxes(cH[..., rows], 1, 2)
    J[:, :n, sV] = np.swapaxes(cV[..., rows], 1, 2)
    J[:, sH, :n] = -dx_dp
    J[:, sV, :n] = -dz_dp
    diag = np.arange(m)
    f = scale_f / scale_len
    J[:, n + diag, n + diag] = F[..., 0, 0] * f
    J[:, n + diag, n + m + diag] = F[..., 0, 1] * f
    J[:, n + m + diag, n + diag] = F[..., 1, 0] * f
    J[:, n + m + diag, n + m + diag] = F[..., 1, 1] * f
    return r, J
