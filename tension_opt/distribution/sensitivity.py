"""Sensitivities of optimal tensions: implicit differentiation of the KKT conditions.

Every pose of a :class:`~tension_opt.distribution.solution.TensionSolution` solves the
scaled problem of its form (:mod:`tension_opt.certify.scaling`)::

    minimise 1/2 x'diag(P)x + c'x   s.t.  Aeq x = beq,  G x <= h,  lb <= x <= ub

with ``x`` the tensions over the pose's reference tension ``s`` (and, for ``min_max``,
the epigraph variable with its rows ``G``). Its certificate holds the multipliers
``y`` (equations), ``mu >= 0`` (rows of ``G``) and ``z`` (bounds: ``< 0`` lower,
``> 0`` upper), with ``P x + c + Aeq'y + G'mu + z = 0``.

**Active set.** A bound or row is *active* where the point is on it (within
:data:`ACTIVE_TOL`, scaled) and its multiplier is nonzero (beyond :data:`MULTIPLIER_TOL`),
*inactive* where neither holds. Anything else (a point on a bound whose multiplier is
zero, a multiplier without its bound) fails strict complementarity: the pose is
``"degenerate"``.

**Derivative.** With the active set fixed, the KKT conditions are linear in
``(x, y, mu, z)``::

    [ diag(P)  Aeq'  G'         I       ] [dx ]   [ -(dc + dAeq' y) ]
    [ Aeq      0     0          0       ] [dy ] = [ dbeq - dAeq x   ]
    [ a_G G    0     diag(1-a_G) 0      ] [dmu]   [ 0               ]
    [ diag(a)  0     0          diag(1-a)] [dz ]   [ a * dbound      ]

(``a``, ``a_G``: the active masks; an inactive constraint keeps a zero multiplier). The
scaling factors are held fixed (a positive scaling leaves the minimiser unchanged), so
``dT = s dx``. The matrix is the same for every parameter: it is inverted once per pose
(``numpy.linalg.inv`` on the stacked matrices) and applied to each parameter's
right-hand side. Solving it with the problem's own right-hand side first gives the
exact KKT point of the active set, whose multipliers ``y`` enter ``dAeq' y`` (and whose
point must be the solution's: else the pose is ``"not_optimal"``).

The derivative exists where the matrix is nonsingular (condition number below
:data:`COND_MAX`) and strict complementarity holds. For a linear objective
(``min_sum``, ``min_max``) that is a unique vertex (as many active constraints as
variables) with nonzero reduced costs; too few active constraints is a face of optima
(``"non_unique"``), too many a degenerate vertex (``"degenerate"``).

Parameters (``wrt``): the external ``"wrench"`` (``b = -(w_g + w)``), the ``"pose"``
(through the structure matrix and the gravity wrench of a turning platform, by the
analytic derivatives of :mod:`tension_opt.robot.derivatives`), the bounds ``"t_min"``
and ``"t_max"`` (the bounds, and the target of ``centered``), and the robot's
``"drawing_points"`` (base frame) and ``"attachment_points"`` (platform frame), and the
``"previous"`` tensions a smoothed or rate-limited pose was solved against: the
smoothing term ``smoothing ||T - T_prev||^2`` moves the cost by ``-2 smoothing dT_prev``,
and a rate limit's band ``T_prev -+ rate``, where it is the active bound, moves with
them. Any other parameter is differentiated with the previous tensions held fixed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.certify.scaling import compiled_scaling, scaled_batch
from tension_opt.distribution.compiled_sensitivity import compiled_jacobian
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.robot.derivatives import cable_frames, column_derivatives, pose_derivatives
from tension_opt.tolerances import (
    SENSITIVITY_ACTIVE_TOL,
    SENSITIVITY_COND_MAX,
    SENSITIVITY_MULTIPLIER_TOL,
)

if TYPE_CHECKING:
    from tension_opt.problem.form import StandardForm

__all__ = [
    "ACTIVE_TOL",
    "COND_MAX",
    "MULTIPLIER_TOL",
    "NEEDS_ROBOT",
    "SENSITIVITY_STATUSES",
    "WRT",
    "KktSystem",
    "Sensitivity",
    "checked_form",
    "jacobian_shape",
    "tension_jacobian",
]

#: What a Jacobian may be taken with respect to.
WRT = ("wrench", "pose", "t_min", "t_max", "drawing_points", "attachment_points",
       "previous")
#: Per-pose statuses of a :class:`Sensitivity`, in the order of their codes.
SENSITIVITY_STATUSES = ("ok", "non_unique", "degenerate", "not_optimal")
_OK, _NON_UNIQUE, _DEGENERATE, _NOT_OPTIMAL = range(4)
#: Distance (scaled: reference tensions) within which a point is on a bound or row.
ACTIVE_TOL = SENSITIVITY_ACTIVE_TOL
#: Size (scaled) beyond which a multiplier counts as nonzero.
MULTIPLIER_TOL = SENSITIVITY_MULTIPLIER_TOL
#: Largest 1-norm condition number of a KKT matrix taken as nonsingular.
COND_MAX = SENSITIVITY_COND_MAX
#: Poses per chunk of KKT systems (bounds the memory of large batches).
CHUNK = 16384
NEEDS_ROBOT = ("pose", "drawing_points", "attachment_points")


@dataclass(frozen=True, eq=False)
class Sensitivity:
    """Jacobians of the optimal tensions of a batch, with a status per pose.

    Attributes
    ----------
    jacobian : ndarray
        ``d T / d wrt``: shape (N, m, n) for ``"wrench"`` (1 per N, or per m for a
        moment) and ``"pose"`` (N per m, N per rad); (N, m, m) for ``"t_min"`` and
        ``"t_max"`` (dimensionless); (N, m, m, 3) for ``"drawing_points"`` and
        ``"attachment_points"`` (N per m; ``[k, a, i, c]`` is ``dT_a / dX_ic`` at pose
        ``k``). NaN rows where the status is not ``"ok"``.
    status : ndarray of str, shape (N,)
        ``"ok"``; ``"non_unique"`` (a face of optima: the solution says it is not
        unique, or too few active constraints fix the point); ``"degenerate"`` (strict
        complementarity fails, or the active constraints are dependent: only one-sided
        derivatives exist); ``"not_optimal"`` (no certified optimum to differentiate).
    wrt : str
        What the derivative is taken with respect to.
    """

    jacobian: NDArray
    status: NDArray
    wrt: str

    @property
    def ok(self) -> NDArray:
        """Poses whose Jacobian exists, shape (N,) of bool."""
        return np.asarray(self.status == "ok", dtype=bool)

    def __repr__(self) -> str:
        names, counts = np.unique(self.status, return_counts=True)
        summary = {str(k): int(v) for k, v in zip(names, counts, strict=True)}
        return f"Sensitivity(wrt={self.wrt!r}, shape={self.jacobian.shape}, status={summary})"


def tension_jacobian(
    solution: Any,
    wrt: str,
    *,
    robot: CableRobot | None = None,
    poses: ArrayLike | None = None,
    wrench: ArrayLike | None = None,
    previous: ArrayLike | None = None,
) -> Sensitivity:
    """Jacobian of the optimal tensions of ``solution`` (see the module docstring).

    Parameters
    ----------
    solution : TensionSolution
        A result of :func:`tension_opt.distribute`, with its certificate's multipliers.
    wrt : {"wrench", "pose", "t_min", "t_max", "drawing_points", "attachment_points"}
    robot : CableRobot, optional
        The robot solved; needed for ``"pose"`` and the points, and where the solution
        keeps no form (a batch solved in chunks).
    poses : array_like, shape (N, n), optional
        The poses solved, with ``robot``.
    wrench, previous : array_like, optional
        The external wrench and previous tensions of the call, to rebuild a form the
        solution does not keep.

    Returns
    -------
    Sensitivity

    Raises
    ------
    InvalidInputError
        For an unknown ``wrt``, a solution without multipliers, or a missing or
        mismatched ``robot`` / ``poses``.
    """
    if wrt not in WRT:
        raise InvalidInputError(f"wrt must be one of {list(WRT)}, got {wrt!r}")
    compiled = compiled_jacobian(solution, wrt, robot, poses, wrench)
    if compiled is not None:
        return Sensitivity(compiled[0], np.asarray(SENSITIVITY_STATUSES)[compiled[1]], wrt)
    form, p = checked_form(solution, wrt, robot, poses, wrench, previous)
    N, m = solution.N, form.m
    batch = scaled_batch(form)
    mult = solution.multipliers
    if not mult.fits(batch):
        raise InvalidInputError(
            "the solution's multipliers do not fit its problem: differentiate the "
            "solution tension_opt.distribute returned, unchanged"
        )
    code = np.full(N, _NOT_OPTIMAL, dtype=np.int8)
    solved = solution.success & mult.known & np.isfinite(solution.tensions).all(axis=1)
    idx = np.flatnonzero(solved)
    shape = jacobian_shape(wrt, N, m, form.n)
    jac = np.full(shape, np.nan)
    # In chunks: a pose's KKT matrix and its inverse hold 2 (2k + n + g)^2 numbers.
    for chunk in np.array_split(idx, -(-len(idx) // CHUNK)) if len(idx) else []:
        frames = None
        if wrt in NEEDS_ROBOT:
            assert robot is not None and p is not None
            frames = cable_frames(robot, p[chunk])
            if not np.allclose(frames.A, form.A[chunk], rtol=1e-9, atol=1e-12):
                raise InvalidInputError(
                    "robot and poses do not give the structure matrices of the solution: "
                    "pass the robot and poses that were solved"
                )
        sub = slice(None) if len(chunk) == N else chunk
        kkt = KktSystem(form, batch, solution, sub)
        extra: Any = None
        if wrt == "pose":
            assert robot is not None and p is not None
            extra = pose_derivatives(robot, p[chunk], frames)
        elif wrt in ("drawing_points", "attachment_points"):
            assert robot is not None and p is not None
            extra = column_derivatives(robot, p[chunk], wrt, frames)
        local, status = kkt.derivative(wrt, extra, ~solution.unique[sub])
        jac[sub] = local.reshape((len(chunk), *shape[1:]))
        code[sub] = status
    jac[code != _OK] = np.nan
    return Sensitivity(jac, np.asarray(SENSITIVITY_STATUSES)[code], wrt)


def checked_form(
    solution: Any,
    wrt: str,
    robot: CableRobot | None,
    poses: ArrayLike | None,
    wrench: ArrayLike | None,
    previous: ArrayLike | None,
) -> tuple[StandardForm, NDArray | None]:
    """The arguments of :func:`tension_jacobian` checked: the solution's form (rebuilt
    from ``robot`` and ``poses`` where it keeps none) and the validated poses (None
    where not needed)."""
    if wrt not in WRT:
        raise InvalidInputError(f"wrt must be one of {list(WRT)}, got {wrt!r}")
    if solution.multipliers is None:
        raise InvalidInputError(
            "the solution holds no multipliers: differentiate a solution that "
            "tension_opt.distribute returned (its certificate keeps them)"
        )
    needs_robot = wrt in NEEDS_ROBOT or solution.form is None
    if needs_robot and (not isinstance(robot, CableRobot) or poses is None):
        why = (
            f"wrt={wrt!r} moves the geometry"
            if wrt in NEEDS_ROBOT
            else "the solution keeps no form (a batch solved in chunks)"
        )
        raise InvalidInputError(
            f"{why}: pass robot= (a CableRobot) and poses= (the poses solved), e.g. "
            f"solution.jacobian({wrt!r}, robot=robot, poses=poses)"
        )
    form = solution.form
    p = None
    if needs_robot:
        assert robot is not None and poses is not None
        p = robot.as_poses(poses)
        if len(p) != solution.N:
            raise InvalidInputError(
                f"poses has {len(p)} rows, the solution {solution.N}: pass the poses solved"
            )
    if form is None:
        assert robot is not None and p is not None
        form = solution.problem.standard_form(robot, p, wrench, previous)
    return form, p


def jacobian_shape(wrt: str, N: int, m: int, n: int) -> tuple[int, ...]:
    """Shape of the Jacobian of ``N`` poses by ``wrt``."""
    if wrt in ("wrench", "pose"):
        return (N, m, n)
    if wrt in ("t_min", "t_max", "previous"):
        return (N, m, m)
    return (N, m, m, 3)


class KktSystem:
    """The KKT matrices of the certified poses ``sub`` of a form at their active sets.

    ``near=True`` takes every bound the point is on as active, whatever its multiplier
    (the matrices of a degenerate pose's directional derivatives,
    :mod:`tension_opt.distribution.directional`); ``near_lo`` / ``near_hi`` (M, k) keep
    where the point is on a bound and ``K`` (M, S, S) the matrices.
    """

    def __init__(self, form: StandardForm, batch: Any, solution: Any, sub: NDArray | slice,
                 near: bool = False) -> None:
        self.form, self.sub = form, sub
        scaling = batch.scaling if batch.scaling is not None else compiled_scaling(form)
        self.s = batch.scale[sub]
        self.rows = scaling.rows[sub]
        self.unit_c = (scaling.top * np.where(scaling.quadratic, scaling.tension, 1.0))[sub]
        P, c, Aeq, beq = batch.P[sub], batch.c[sub], batch.Aeq[sub], batch.beq[sub]
        G, h, lb, ub = batch.G[sub], batch.h[sub], batch.lb[sub], batch.ub[sub]
        mult = solution.multipliers
        assert mult is not None
        x = solution.tensions[sub] / self.s[:, None]
        if batch.epigraph is not None:
            x = np.concatenate([x, (x * batch.epigraph).max(axis=1, keepdims=True)], axis=1)
        z, mu = mult.z[sub], mult.mu[sub]
        M, n, k = Aeq.shape
        g = G.shape[1]
        self.M, self.n, self.k, self.g, self.m = M, n, k, g, form.m
        with np.errstate(invalid="ignore"):
            near_lo, near_hi = x - lb <= ACTIVE_TOL, ub - x <= ACTIVE_TOL
            self.near_lo, self.near_hi = near_lo, near_hi
            self.lo = near_lo & ((z < -MULTIPLIER_TOL) | near)
            self.hi = near_hi & ((z > MULTIPLIER_TOL) | near) & ~self.lo
            active = self.lo | self.hi
            weak = ((near_lo | near_hi) & ~active) | ((np.abs(z) > MULTIPLIER_TOL) & ~active)
            weak |= near_lo & near_hi
            slack = h - (G @ x[..., None])[..., 0]
            near_g, strong_g = slack <= ACTIVE_TOL, mu > MULTIPLIER_TOL
        self.aG = near_g & strong_g
        bad = weak.any(axis=1) | (near_g != strong_g).any(axis=1)
        self.count = n + self.aG.sum(axis=1) + active.sum(axis=1)
        aB = active.astype(float)
        S = 2 * k + n + g
        K = np.zeros((M, S, S))
        ak, ag = np.arange(k), np.arange(g)
        o_mu, o_z = k + n, k + n + g
        K[:, ak, ak] = P
        K[:, :k, k:o_mu] = np.swapaxes(Aeq, 1, 2)
        K[:, :k, o_mu:o_z] = np.swapaxes(G, 1, 2)
        K[:, ak, o_z + ak] = 1.0
        K[:, k:o_mu, :k] = Aeq
        K[:, o_mu:o_z, :k] = G * self.aG[..., None]
        K[:, o_mu + ag, o_mu + ag] = 1.0 - self.aG
        K[:, o_z + ak, ak] = aB
        K[:, o_z + ak, o_z + ak] = 1.0 - aB
        Kinv, singular = _inverse(K)
        self.K, self.Kinv = K, Kinv
        # The KKT point of the active set: its multipliers enter dAeq'y.
        bound = np.where(self.lo, lb, np.where(self.hi, ub, 0.0))
        rhs = np.concatenate([-c, beq, np.zeros((M, g)), bound], axis=1)
        point = (Kinv @ rhs[..., None])[..., 0]
        self.x, self.y = point[:, :k], point[:, k:o_mu]
        zp, mup = point[:, o_z:], point[:, o_mu:o_z]
        with np.errstate(invalid="ignore"):
            moved = ~(np.abs(self.x - x).max(axis=1) <= 10 * ACTIVE_TOL)
            signs = ((self.lo & ~(zp < 0)) | (self.hi & ~(zp > 0))).any(axis=1)
            signs |= (self.aG & ~(mup > 0)).any(axis=1)
        free_flat = ((P <= 0) & ~active).any(axis=1)  # a free direction without curvature
        status = np.full(M, _OK, dtype=np.int8)
        status[bad | signs] = _DEGENERATE
        status[singular & (self.count >= k)] = _DEGENERATE
        status[singular & (self.count < k) & free_flat] = _NON_UNIQUE
        status[singular & (self.count < k) & ~free_flat] = _DEGENERATE
        status[(status == _OK) & moved] = _NOT_OPTIMAL
        self.status = status

    def derivative(self, wrt: str, extra: Any, non_unique: NDArray) -> tuple[NDArray, NDArray]:
        """``dT`` of every pose, shape (M, m, D), and the statuses (M,) of int8."""
        rhs = self.rhs(wrt, extra)
        dx = self.Kinv[:, : self.m, :] @ rhs
        status = self.status.copy()
        status[non_unique] = _NON_UNIQUE
        return dx * self.s[:, None, None], status

    def rhs(self, wrt: str, extra: Any) -> NDArray:
        """Right-hand sides (M, S, D) of the parameters ``wrt``."""
        M, n, k, g, m = self.M, self.n, self.k, self.g, self.m
        S, o_eq, o_z = 2 * k + n + g, k, k + n + g
        D = {"wrench": n, "pose": n, "t_min": m, "t_max": m, "previous": m}.get(wrt, 3 * m)
        rhs = np.zeros((M, S, D))
        an, am = np.arange(n), np.arange(m)
        s = self.s
        if wrt == "wrench":  # b = -(w_g + w): dbeq = -D e_j / s
            rhs[:, o_eq + an, an] = -self.rows / s[:, None]
        elif wrt in ("t_min", "t_max"):
            side = self.lo if wrt == "t_min" else self.hi
            rhs[:, o_z + am, am] = side[:, :m] * self._follows(wrt) / s[:, None]
            problem = self.form.problem
            if problem is not None and problem.objective.name == "centered":
                # c = -w (lb + ub): -dc / (top per_s) on the cable's own row.
                w = problem.cable_weights(m)
                rhs[:, am, am] = w[None, :] / self.unit_c[:, None]
        elif wrt == "previous":
            self._previous_rhs(rhs)
        elif wrt == "pose":
            dA, db = extra
            dAs = dA * self.rows[:, :, None, None]  # (M, n, m, D)
            rhs[:, :m] = -np.einsum("anid,an->aid", dAs, self.y)
            rhs[:, o_eq : o_eq + n] = db * (self.rows / s[:, None])[..., None] - np.einsum(
                "anid,ai->and", dAs, self.x[:, :m]
            )
        else:  # the points of one cable move its own column only
            dcs = extra * self.rows[:, None, :, None]  # (M, m, n, 3)
            stat = np.zeros((M, m, m, 3))
            stat[:, am, am] = -np.einsum("aint,an->ait", dcs, self.y)
            rhs[:, :m] = stat.reshape(M, m, 3 * m)
            eq = -(dcs * self.x[:, :m, None, None])  # (M, m, n, 3)
            rhs[:, o_eq : o_eq + n] = np.swapaxes(eq, 1, 2).reshape(M, n, 3 * m)
        return rhs

    def _previous_rhs(self, rhs: NDArray) -> None:
        """Right-hand sides (M, S, m) of the previous tensions, in place: the smoothing
        term's cost ``-2 smoothing T_prev`` and the active rate-limit bands."""
        problem, m, o_z = self.form.problem, self.m, self.k + self.n + self.g
        am = np.arange(m)
        if problem is None or self.form.previous is None:
            return
        if problem.smoothing:  # -dc, scaled as the form's c
            rhs[:, am, am] = 2.0 * problem.smoothing / self.unit_c[:, None]
        if problem.rate_limit is not None:
            band = (self.lo[:, :m] * (1.0 - self._follows("t_min"))
                    + self.hi[:, :m] * (1.0 - self._follows("t_max")))
            rhs[:, o_z + am, am] = band / self.s[:, None]

    def _follows(self, wrt: str) -> NDArray:
        """Where the form's bound is the problem's ``wrt`` bound (M, m) (a rate limit
        may have tightened it to the previous tension's band)."""
        form = self.form
        problem = form.problem
        if problem is None or problem.rate_limit is None or form.previous is None:
            return np.ones((self.M, self.m))
        rate = np.broadcast_to(problem.rate_limit, (self.m,))
        prev = form.previous[self.sub]
        bound = form.lb[self.sub] if wrt == "t_min" else form.ub[self.sub]
        band = prev - rate if wrt == "t_min" else prev + rate
        return (bound != band).astype(float)


def _inverse(K: NDArray) -> tuple[NDArray, NDArray]:
    """Inverses of the stacked matrices ``K`` (M, S, S) and the mask of the singular
    ones (1-norm condition number above :data:`COND_MAX`; their inverse is garbage)."""
    try:
        Kinv = np.linalg.inv(K)
    except np.linalg.LinAlgError:  # some matrix exactly singular: set those apart
        sv = np.linalg.svd(K, compute_uv=False)
        exact = ~(sv[:, -1] > 1e-14 * sv[:, 0])
        K = K.copy()
        K[exact] = np.eye(K.shape[1])
        Kinv = np.linalg.inv(K)
        Kinv[exact] = np.nan
    with np.errstate(invalid="ignore", over="ignore"):
        cond = np.abs(K).sum(axis=1).max(axis=1) * np.abs(Kinv).sum(axis=1).max(axis=1)
    return Kinv, ~(cond <= COND_MAX)
