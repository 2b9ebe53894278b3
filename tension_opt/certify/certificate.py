"""Certificates of optimality: primal residual, dual residual and duality gap per pose.

Every solution is judged on the scaled problem every generic solver is given
(:mod:`tension_opt.certify.scaling`; tensions over a reference tension, equilibrium rows over
their norms, objective of order one)::

    minimise 1/2 x'Px + c'x   s.t.  Aeq x = beq,  G x <= h,  lb <= x <= ub

with multipliers ``y`` (equations), ``mu >= 0`` (rows of ``G``) and ``z`` (bounds:
``z_i > 0`` on an upper bound, ``z_i < 0`` on a lower one), the convention of
qpsolvers: ``P x + c + Aeq'y + G'mu + z = 0`` at an optimum. The three measures are

- **primal residual**: the largest of ``|Aeq x - beq|``, ``(G x - h)+`` and the bound
  violations;
- **dual residual**: ``max |P x + c + Aeq'y + G'mu + z|`` with the multipliers first
  put in their cones (``mu >= 0``; ``z_i >= 0`` only where ``ub_i`` is finite, ``<= 0``
  only where ``lb_i`` is);
- **duality gap**: ``|x'Px + c'x + beq'y + h'mu + ub'z+ + lb'z-|`` over
  ``max(1, |1/2 x'Px + c'x|)``, the primal objective less the dual one, relative.

Together they bound the objective's excess over the optimum: for a convex problem,
``f(x) - f* <= gap + ||dual residual|| ||x*||_1`` in scaled units, whatever the
multipliers. A pose is certified when all three are at most the accuracy target
(:func:`accuracy_target`: ``"default"`` 1e-7, ``"high"`` 1e-10, or a number).

Multipliers come from the solver where it gives them. Where it does not (the closed
form, a fallback, a sequence), :func:`estimate_multipliers` finds them by a cheap dual
solve: a least-squares fit of stationarity in which each bound's multiplier is charged
its complementarity ``|z_i| dist_i``, vectorised over poses; a pose whose fit leaves a
multiplier of the wrong sign gets a sign-constrained fit of its own. For an exact
solution (the closed form) this gives its exact multipliers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tension_opt.certify.scaling import ScaledBatch, scaled_batch
from tension_opt.problem.form import StandardForm
from tension_opt.tolerances import DEFAULT_TARGET, RIDGE

__all__ = [
    "Certificate",
    "Multipliers",
    "certify",
    "certify_form",
    "estimate_multipliers",
    "estimate_multipliers_reference",
    "measures",
    "measures_reference",
    "primal_residual_of",
    "refit_poses",
]


@dataclass
class Multipliers:
    """Multipliers of a scaled batch (see the module docstring); NaN rows are unknown.

    Attributes
    ----------
    y : ndarray, shape (N, n)
        Of the equilibrium rows.
    mu : ndarray, shape (N, g)
        Of the rows of ``G`` (``>= 0``).
    z : ndarray, shape (N, k)
        Of the bounds (``> 0`` upper, ``< 0`` lower).
    """

    y: NDArray
    mu: NDArray
    z: NDArray

    @classmethod
    def unknown(cls, batch: ScaledBatch) -> Multipliers:
        """All NaN, shaped for ``batch``."""
        N = batch.N
        return cls(np.full((N, batch.Aeq.shape[1]), np.nan),
                   np.full((N, batch.G.shape[1]), np.nan), np.full((N, batch.k), np.nan))

    @property
    def known(self) -> NDArray:
        """Poses whose multipliers are all finite, shape (N,)."""
        return (np.isfinite(self.y).all(axis=1) & np.isfinite(self.mu).all(axis=1)
                & np.isfinite(self.z).all(axis=1))

    def fits(self, batch: ScaledBatch) -> bool:
        """Whether the shapes are those of ``batch``."""
        return (self.y.shape == (batch.N, batch.Aeq.shape[1])
                and self.mu.shape == (batch.N, batch.G.shape[1])
                and self.z.shape == (batch.N, batch.k))

    def subset(self, index: NDArray | slice) -> Multipliers:
        """The multipliers of the poses ``index``."""
        return Multipliers(self.y[index], self.mu[index], self.z[index])

    def put(self, index: NDArray | slice, other: Multipliers) -> None:
        """Write ``other`` (the poses ``index``) into these multipliers."""
        self.y[index], self.mu[index], self.z[index] = other.y, other.mu, other.z

    def bound_multipliers(self, m: int) -> NDArray:
        """Multipliers of the tension bounds (N, m) (the epigraph variable's left out)."""
        return self.z[:, :m]


@dataclass
class Certificate:
    """The three measures per pose and the multipliers they were measured with.

    Attributes
    ----------
    primal_residual, dual_residual, duality_gap : ndarray, shape (N,)
        Scaled measures (see the module docstring); NaN where there is no solution.
    target : float
        The accuracy target they are judged against.
    multipliers : Multipliers
    certified : ndarray of bool, shape (N,)
        Poses whose three measures all meet the target (NaN fails); kept up to date by
        :meth:`put` (a field, not a property: the flow reads it without coming back).
    """

    primal_residual: NDArray
    dual_residual: NDArray
    duality_gap: NDArray
    target: float
    multipliers: Multipliers
    certified: NDArray = field(init=False)

    def __post_init__(self) -> None:
        self.certified = self._meets_target()

    def _meets_target(self) -> NDArray:
        t = self.target
        return (self.primal_residual <= t) & (self.dual_residual <= t) & (
            self.duality_gap <= t)

    def put(self, poses: NDArray, other: Certificate) -> None:
        """Write ``other``'s measures and multipliers (of these poses, same target)
        into rows ``poses``."""
        self.primal_residual[poses] = other.primal_residual
        self.dual_residual[poses] = other.dual_residual
        self.duality_gap[poses] = other.duality_gap
        self.multipliers.put(poses, other.multipliers)
        self.certified = self._meets_target()

    def forget(self, poses: NDArray) -> None:
        """Set the measures of rows ``poses`` (indices or mask) to NaN: poses without a
        solution, which the certificate then does not certify."""
        for measure in (self.primal_residual, self.dual_residual, self.duality_gap):
            measure[poses] = np.nan
        self.certified = self._meets_target()


def _cones(batch: ScaledBatch, mult: Multipliers) -> tuple[NDArray, NDArray]:
    """``mu`` and ``z`` put in their cones."""
    lo = np.where(np.isfinite(batch.lb), -np.inf, 0.0)
    hi = np.where(np.isfinite(batch.ub), np.inf, 0.0)
    return np.maximum(mult.mu, 0.0), np.clip(mult.z, lo, hi)


def measures(batch: ScaledBatch, x: NDArray, mult: Multipliers
             ) -> tuple[NDArray, NDArray, NDArray]:
    """Primal residual, dual residual and relative duality gap, each of shape (N,), of
    scaled solutions ``x`` (N, k) with the multipliers ``mult`` as given (put in their
    cones first, never estimated); NaN where ``x`` has no solution.

    Measured by the compiled kernel :func:`tension_opt.kernels.certificate.batch_measures`
    for batches of :data:`~tension_opt.kernels.launch.COMPILED_MIN` poses or more, by its
    numpy reference :func:`measures_reference` below that."""
    from tension_opt.kernels.launch import compiled_for

    if not compiled_for(batch.N):
        return measures_reference(batch, x, mult)
    from tension_opt.kernels.arrays import frozen
    from tension_opt.kernels.certificate import batch_measures
    from tension_opt.kernels.first_use import announce

    announce("certificate", batch_measures)

    # All read: one array type for every call (see tension_opt.kernels.arrays).
    arrays = [frozen(a) for a in (batch.P, batch.c, batch.Aeq, batch.beq, batch.G, batch.h,
                                  batch.lb, batch.ub, x, mult.y, mult.mu, mult.z)]
    return batch_measures(*arrays)


def measures_reference(batch: ScaledBatch, x: NDArray, mult: Multipliers
                       ) -> tuple[NDArray, NDArray, NDArray]:
    """:func:`measures` in numpy (the reference of the compiled kernel)."""
    mu, z = _cones(batch, mult)
    rows = batch.G.shape[1] > 0
    with np.errstate(over="ignore", invalid="ignore"):
        eq = np.abs(_apply(batch.Aeq, x) - batch.beq).max(axis=1, initial=0.0)
        below = np.where(np.isfinite(batch.lb), batch.lb - x, 0.0).max(axis=1, initial=0.0)
        above = np.where(np.isfinite(batch.ub), x - batch.ub, 0.0).max(axis=1, initial=0.0)
        primal = np.maximum(eq, np.maximum(below, above))
        grad = batch.P * x + batch.c
        stationarity = grad + _apply(np.swapaxes(batch.Aeq, 1, 2), mult.y) + z
        gap = (grad * x).sum(axis=1) + (batch.beq * mult.y).sum(axis=1)
        if rows:
            primal = np.maximum(primal, np.maximum(_apply(batch.G, x) - batch.h, 0.0).max(
                axis=1, initial=0.0))
            stationarity += _apply(np.swapaxes(batch.G, 1, 2), mu)
            gap += (batch.h * mu).sum(axis=1)
        dual = np.abs(stationarity).max(axis=1, initial=0.0)
        gap += (np.where(z > 0, batch.ub, 0.0) * np.maximum(z, 0.0)
                + np.where(z < 0, batch.lb, 0.0) * np.minimum(z, 0.0)).sum(axis=1)
        relative = np.abs(gap) / np.maximum(1.0, np.abs(batch.objective(x)))
    unsolved = ~np.isfinite(x).all(axis=1)
    for measure in (primal, dual, relative):
        measure[unsolved] = np.nan
    return primal, dual, relative


def _apply(M: NDArray, v: NDArray) -> NDArray:
    """``M v`` per pose: (N, a, b) times (N, b), shape (N, a)."""
    return (M @ v[..., None])[..., 0]


def _distances(batch: ScaledBatch, x: NDArray) -> tuple[NDArray, NDArray]:
    """Squared distance of each variable to its nearest finite bound (inf if none) and
    distance of each row of ``G`` to equality (>= 0)."""
    with np.errstate(invalid="ignore", over="ignore"):
        to_lb = np.abs(x - batch.lb)  # inf where the bound is infinite
        np.minimum(to_lb, np.abs(batch.ub - x), out=to_lb)
        np.square(to_lb, out=to_lb)
        rows = (np.abs(batch.h - _apply(batch.G, x)) if batch.G.shape[1]
                else np.zeros((batch.N, 0)))
    return to_lb, rows


def estimate_multipliers(batch: ScaledBatch, x: NDArray) -> Multipliers:
    """Multipliers of ``x`` (N, k) by the cheap dual solve (see the module docstring and
    :func:`estimate_multipliers_reference`), by the compiled kernel
    :func:`tension_opt.kernels.certificate.batch_estimate` (by the reference for batches
    under :data:`~tension_opt.kernels.launch.COMPILED_MIN` poses); NaN rows where ``x``
    has no solution."""
    from tension_opt.kernels.launch import compiled_for

    if not compiled_for(batch.N):
        return estimate_multipliers_reference(batch, x)
    from tension_opt.kernels.arrays import frozen
    from tension_opt.kernels.certificate import batch_estimate

    out, idx, sub = _solved_poses(batch, x)
    if sub is not None:
        P, c, Aeq, G, h, lb, ub, xs = (frozen(a) for a in (sub.P, sub.c, sub.Aeq, sub.G, sub.h,
                                                            sub.lb, sub.ub, x[idx]))
        out.put(idx, Multipliers(*batch_estimate(P, c, Aeq, G, h, lb, ub, xs, RIDGE)))
    return out


def _solved_poses(batch: ScaledBatch, x: NDArray
                  ) -> tuple[Multipliers, NDArray | slice, ScaledBatch | None]:
    """Unknown multipliers for ``batch``, the poses of ``x`` with a solution and their
    batch (None if there are none)."""
    out = Multipliers.unknown(batch)
    solved = np.isfinite(x).all(axis=1)
    if not solved.any():
        return out, slice(0, 0), None
    every = bool(solved.all())
    idx = slice(None) if every else np.flatnonzero(solved)
    return out, idx, batch if every else batch.subset(idx)


def estimate_multipliers_reference(batch: ScaledBatch, x: NDArray) -> Multipliers:
    """Multipliers of ``x`` (N, k) by the cheap dual solve, in numpy (the reference of
    :func:`estimate_multipliers`).

    Minimises ``||r||^2 + sum_i (z_i d_i)^2 + sum_j (mu_j e_j)^2`` over ``y``, ``mu``,
    ``z``, with ``r`` the stationarity residual, ``d_i`` the distance of ``x_i`` to its
    nearest bound and ``e_j`` the slack of row ``j``: a multiplier costs what it adds to
    the duality gap. ``z`` is eliminated in closed form (``z_i = -r0_i / (1 + d_i^2)``),
    leaving a weighted least-squares fit in ``(y, mu)`` solved for all poses at once.
    """
    n, g = batch.Aeq.shape[1], batch.G.shape[1]
    out, idx, sub = _solved_poses(batch, x)
    if sub is None:
        return out
    xs = x[idx]
    grad = sub.P * xs + sub.c
    d2, slack = _distances(sub, xs)
    # Row weights after eliminating z: d^2 / (1 + d^2), 1 where no bound may absorb.
    with np.errstate(invalid="ignore", over="ignore"):
        shrink = 1.0 / (1.0 + d2)  # 0 where there is no bound: z_i = 0
        omega2 = 1.0 - shrink
    B = np.swapaxes(sub.Aeq, 1, 2)  # (s, k, n + g)
    if g:
        B = np.concatenate([B, np.swapaxes(sub.G, 1, 2)], axis=2)
    Bt_omega = np.swapaxes(B * omega2[..., None], 1, 2)  # (s, n + g, k)
    H = Bt_omega @ B
    diagonal = np.diagonal(H, axis1=1, axis2=2)
    top = np.maximum(np.abs(diagonal).max(axis=1), 1.0)
    extra = np.concatenate([np.zeros((len(xs), n)), np.minimum(slack, 1e6) ** 2], axis=1)
    H[:, np.arange(n + g), np.arange(n + g)] = diagonal + extra + RIDGE * top[:, None]
    u = np.linalg.solve(H, -(Bt_omega @ grad[..., None]))[..., 0]
    z = -(grad + _apply(B, u)) * shrink
    out.put(idx, Multipliers(u[:, :n], u[:, n:], np.nan_to_num(z, nan=0.0)))
    return out


def _refit_compiled(batch: ScaledBatch, x: NDArray, poses: NDArray, mult: Multipliers,
                    measured: tuple[NDArray, NDArray, NDArray]) -> NDArray:
    """:func:`_refit` by the compiled kernel (:func:`tension_opt.kernels.refit.batch_refit`,
    the same fit) for a batch the compiled kernels take
    (:func:`~tension_opt.kernels.launch.compiled_for`); returns the poses left to
    :func:`_refit` (all of them for a smaller batch, those whose fit is singular)."""
    from tension_opt.kernels.launch import compiled_for

    if not compiled_for(batch.N):
        return poses
    from tension_opt.kernels.arrays import writable
    from tension_opt.kernels.refit import batch_refit

    sub = batch.subset(poses)
    fit = Multipliers(*(writable(a[poses]) for a in (mult.y, mult.mu, mult.z)))
    P, c, Aeq, beq, G, h, lb, ub, xs = (writable(a) for a in (
        sub.P, sub.c, sub.Aeq, sub.beq, sub.G, sub.h, sub.lb, sub.ub, x[poses]))
    measures_now = writable(np.stack([m[poses] for m in measured], axis=1))
    kept = np.asarray(batch_refit(P, c, Aeq, beq, G, h, lb, ub, xs, fit.y, fit.mu, fit.z,
                                  measures_now))
    done = kept >= 0
    mult.put(poses[done], fit.subset(done))
    return poses[~done]


def _refit(batch: ScaledBatch, x: NDArray, poses: NDArray, mult: Multipliers) -> None:
    """Sign-constrained dual fits of single poses (scipy's bounded least squares), where
    the vectorised fit left a multiplier in the wrong cone; kept where they do better."""
    from scipy.optimize import lsq_linear

    n, g, k = batch.Aeq.shape[1], batch.G.shape[1], batch.k
    fitted: list[int] = []
    found: list[NDArray] = []
    for i in poses:
        one = batch.subset(np.array([i]))
        xi = x[i:i + 1]
        d2, slack = _distances(one, xi)
        weight = np.where(np.isfinite(d2[0]), np.sqrt(d2[0]), 0.0)
        # Columns: y (free), mu (>= 0), z (in its cone); rows: stationarity, then the
        # complementarity charges of mu and z.
        M = np.zeros((k + g + k, n + g + k))
        M[:k, :n] = one.Aeq[0].T
        M[:k, n:n + g] = one.G[0].T
        M[:k, n + g:] = np.eye(k)
        M[k:k + g, n:n + g] = np.diag(np.minimum(slack[0], 1e6))
        M[k + g:, n + g:] = np.diag(np.minimum(weight, 1e6))
        rhs = np.concatenate([-(one.P[0] * xi[0] + one.c[0]), np.zeros(g + k)])
        # z_i is the multiplier of the bound its weight charges, the nearer one (either,
        # where equidistant): free in both directions, a z barely charged (x_i a
        # rounding error from its bound) took either sign by the rounding of x, and
        # one of the far bound's sign was charged by that bound's distance in the gap.
        with np.errstate(invalid="ignore"):
            to_lb, to_ub = xi[0] - one.lb[0], one.ub[0] - xi[0]
        lo = np.concatenate([np.full(n, -np.inf), np.zeros(g),
                             np.where(np.isfinite(one.lb[0]) & (to_lb <= to_ub), -np.inf,
                                      0.0)])
        hi = np.concatenate([np.full(n + g, np.inf),
                             np.where(np.isfinite(one.ub[0]) & (to_ub <= to_lb), np.inf,
                                      0.0)])
        free = lo < hi  # a variable pinned to 0 is left out (lsq_linear needs lo < hi)
        try:
            # KKT conditions to rounding (scipy's default stops at 1e-10): the compiled
            # refit (tension_opt.kernels.refit) solves the same problem exactly.
            fit = lsq_linear(M[:, free], rhs, bounds=(lo[free], hi[free]), method="bvls",
                             max_iter=50 * M.shape[1], tol=1e-15)
        except (ValueError, np.linalg.LinAlgError):
            continue
        u = np.zeros(n + g + k)
        u[free] = fit.x
        fitted.append(int(i))
        found.append(u)
    if not fitted:
        return
    # Measured together, the old multipliers and the fits (each pose's own rows).
    idx = np.array(fitted)
    fits = np.array(found)
    candidate = Multipliers(fits[:, :n], fits[:, n:n + g], fits[:, n + g:])
    sub = batch.subset(idx)
    old = measures(sub, x[idx], mult.subset(idx))
    new = measures(sub, x[idx], candidate)
    better = np.maximum(new[1], new[2]) < np.maximum(old[1], old[2])
    mult.put(idx[better], candidate.subset(better))


def _uncertified(primal: NDArray, dual: NDArray, gap: NDArray, target: float) -> NDArray:
    """Poses whose point is primal feasible but whose multipliers do not certify it."""
    return (primal <= target) & ~((dual <= target) & (gap <= target))


def refit_poses(form: StandardForm, tensions: NDArray, target: float = DEFAULT_TARGET
                ) -> NDArray:
    """Which poses of tensions (N, m) on ``form`` the cheap dual solve leaves to the
    sign-constrained refit of :func:`certify` (without multipliers given), (N,) bool.
    Their multipliers are a bounded least-squares fit, which the numpy path and the
    compiled kernels (:mod:`tension_opt.kernels.refit`) solve to the fit's
    conditioning, not to the last bits."""
    batch = scaled_batch(form)
    x = batch.lift(tensions)
    return np.asarray(_uncertified(*measures(batch, x, estimate_multipliers(batch, x)),
                                   target))


def certify(batch: ScaledBatch, x: NDArray, multipliers: Multipliers | None = None,
            target: float = DEFAULT_TARGET) -> Certificate:
    """The certificate of scaled solutions ``x`` (N, k) of ``batch``.

    Parameters
    ----------
    batch : ScaledBatch
    x : ndarray, shape (N, k)
        Scaled solutions (NaN rows: no solution).
    multipliers : Multipliers, optional
        The solver's; rows that are NaN (or all rows, if None) are estimated by the
        cheap dual solve, as are rows whose given multipliers do not certify a point
        that is primal feasible (any multipliers that prove optimality will do).
    target : float
        Accuracy target.

    Returns
    -------
    Certificate
        With the multipliers used (the solver's or the estimate's, in their cones).
    """
    given = multipliers if multipliers is not None and multipliers.fits(batch) else None
    if given is None:
        mult = estimate_multipliers(batch, x)
        primal, dual, gap = measures(batch, x, mult)
        redo = np.zeros(batch.N, dtype=bool)
    else:
        mult = Multipliers(given.y.copy(), given.mu.copy(), given.z.copy())
        primal, dual, gap = measures(batch, x, mult)
        redo = np.isfinite(primal) & ((primal <= target) & ~((dual <= target) & (gap <= target))
                                      | ~mult.known)
    if redo.any():
        idx = np.flatnonzero(redo)
        sub, xs = batch.subset(idx), x[idx]
        estimate = estimate_multipliers(sub, xs)
        mine = measures(sub, xs, estimate)
        theirs = np.maximum(dual[idx], gap[idx])
        better = ~(np.maximum(mine[1], mine[2]) >= theirs)  # NaN theirs: take the estimate
        mult.put(idx[better], estimate.subset(better))
        for measure, new in zip((dual, gap), mine[1:], strict=True):
            measure[idx[better]] = new[better]
    # The vectorised fit cannot see cones: a pose it leaves uncertified, though its point
    # is primal feasible, gets a sign-constrained fit of its own.
    stuck = np.flatnonzero(_uncertified(primal, dual, gap, target))
    if len(stuck):
        left = _refit_compiled(batch, x, stuck, mult, (primal, dual, gap))
        if len(left):
            _refit(batch, x, left, mult)
        primal, dual, gap = measures(batch, x, mult)
    mu, z = _cones(batch, mult)
    return Certificate(primal, dual, gap, float(target), Multipliers(mult.y, mu, z))


def certify_form(form: StandardForm, tensions: NDArray, multipliers: Multipliers | None = None,
                 target: float = DEFAULT_TARGET) -> Certificate:
    """The certificate of tensions (N, m) (N) as solutions of ``form``
    (:func:`certify` on :func:`~tension_opt.certify.scaling.scaled_batch`)."""
    batch = scaled_batch(form)
    return certify(batch, batch.lift(tensions), multipliers, target)


def primal_residual_of(form: StandardForm, tensions: NDArray) -> NDArray:
    """The primal residual alone of tensions (N, m) (N) on ``form``, shape (N,)."""
    batch = scaled_batch(form)
    x = batch.lift(tensions)
    none = Multipliers(np.zeros((batch.N, batch.Aeq.shape[1])), np.zeros((batch.N,
                       batch.G.shape[1])), np.zeros((batch.N, batch.k)))
    return measures(batch, x, none)[0]
