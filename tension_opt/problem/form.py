"""Tension-distribution problems as data.

A :class:`TensionProblem` says *what* to optimise (an objective from
:mod:`tension_opt.problem.objectives`, weights, bounds, smoothing terms);
:meth:`TensionProblem.standard_form` turns it, for a robot and a batch of poses, into a
frozen :class:`StandardForm` that every backend understands::

    minimise   1/2 sum_i q_i T_i^2 + c^T T  [+ max_i v_i T_i]
    subject to A T = b,  lb <= T <= ub,  G T <= h

with a diagonal Hessian ``q >= 0``. Smoothing for sequences adds
``smoothing * ||T - T_prev||^2`` to the objective; a rate limit
``|T - T_prev| <= rate_limit`` tightens the bounds.

The tension scale. A pose has one: its typical tension (:func:`typical_tension`,
:meth:`StandardForm.typical_tension`), the tension that holds the wrench (``||b||`` over
the longest column of ``A``) or the largest lower bound if larger. Tolerances on
tensions are relative to it, and the scaled problem's reference tension is derived
from it. (The feasibility check of a solution is relative to the load instead,
:meth:`StandardForm.load_scale`: its residual is a wrench.)

Scaling. The form stays in newtons; every generic backend solves it nondimensionalised,
pose by pose (:func:`tension_opt.certify.scaling.scaling_reference`, the one
definition, and its kernel; the closed form is exact and needs none):

- tensions in units of a reference tension ``s`` of the pose, the typical tension but
  at least :data:`~tension_opt.tolerances.UB_SHARE` of the largest finite upper bound
  (an unloaded pose keeps its box of order 1e3 wide): ``T = s x``;
- each equilibrium row divided by its norm, so that forces and moments weigh alike:
  ``D A x = D b / s`` with ``D = diag(1 / ||A_i||)`` (a row shorter than
  :data:`~tension_opt.tolerances.ROW_FLOOR` of the longest, such as a moment the cables
  cannot make that is zero but for rounding, is scaled up by ``1 / ROW_FLOOR`` at
  most);
- the objective divided by its own size, ``s^2 max_i q_i`` for a QP and
  ``s max(max_i |c_i|, max_i v_i)`` for an LP, so that the largest Hessian entry or
  cost is 1 and the optimum is of order one.

Dividing a row or the objective by a positive number leaves the minimiser unchanged,
and every scale is a property of the pose alone (a subset of poses scales as in the
whole batch). Solver tolerances, the accuracy target and the certificate of a solution
(primal residual, dual residual, duality gap: :mod:`tension_opt.certify.certificate`) are all
measured in these units, so ``1e-7`` means the same on every robot and every solver.
The scaled, lifted matrices are built by :func:`tension_opt.certify.scaling.scaled_batch`.

A form also measures any tensions against itself in newtons (equilibrium residual,
bound violation, objective), which is how a solution's diagnostics are computed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import is_number
from tension_opt.errors import InvalidInputError
from tension_opt.problem.objectives import Objective, get_objective
from tension_opt.robot import CableRobot

__all__ = ["Objective", "StandardForm", "TensionProblem", "as_problem", "safe_norm",
           "typical_tension", "unit_minmax"]

if TYPE_CHECKING:

    class _ObjectiveField:
        """How a type checker sees :attr:`TensionProblem.objective`: given as a name or
        an :class:`Objective`, read as the Objective that ``__post_init__`` made of it."""

        def __get__(self, obj: object, owner: type | None = None) -> Objective: ...

        def __set__(self, obj: object, value: Objective | str) -> None: ...


def typical_tension(A: NDArray, b: NDArray, lb: NDArray) -> NDArray:
    """Typical tension per pose (N), the unit of the solvers' tolerances, shape (N,).

    The larger of ``||b||`` over the longest column of ``A`` (the tension that holds
    the wrench) and the largest finite lower bound, at least ``1e-12``.

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
        Structure matrices.
    b : ndarray, shape (N, n)
        Wrenches to hold (N, N m).
    lb : ndarray, shape (N, m)
        Lower tension bounds (N); ``-inf`` where absent.
    """
    col = safe_norm(A, axis=1).max(axis=1)
    with np.errstate(over="ignore"):  # a quotient beyond the float range is inf
        s = safe_norm(b, axis=1) / np.maximum(col, 1e-300)
    finite_lb = np.where(np.isfinite(lb), np.abs(lb), 0.0).max(axis=1)
    return np.maximum(np.maximum(s, finite_lb), 1e-12)


def safe_norm(x: NDArray, axis: int) -> NDArray:
    """Euclidean norms of ``x`` along ``axis`` without overflow or underflow of the
    squares: norms of entries beyond about 1e154 (or below 1e-154) are taken of the
    entries divided by their largest magnitude, then scaled back.

    Parameters
    ----------
    x : ndarray
        Finite entries (a non-finite entry gives an infinite or NaN norm).
    axis : int

    Returns
    -------
    ndarray
        ``x``'s shape without ``axis``; ``inf`` only where the norm itself exceeds the
        float range.
    """
    with np.errstate(over="ignore", under="ignore"):
        r = np.asarray(np.linalg.norm(x, axis=axis))
        # Squares that overflowed, or that may have underflowed (rare: measured again).
        redo = np.isinf(r) | (r < 1e-150)
        if redo.any():
            moved = np.moveaxis(x, axis, -1)[redo]
            top = np.abs(moved).max(axis=-1, initial=0.0)
            fine = np.isfinite(top) & (top > 0)
            again = r[redo]
            again[fine] = top[fine] * np.linalg.norm(moved[fine] / top[fine, None], axis=-1)
            r[redo] = again
    return r


@dataclass(frozen=True, eq=False)
class TensionProblem:
    """A tension-distribution problem (objective, bounds and smoothing terms).

    Parameters
    ----------
    objective : Objective or str
        A name from :data:`tension_opt.problem.objectives.OBJECTIVES` (``"min_sum"``,
        ``"min_norm"``, ``"pinv"``, ``"min_max"``, ``"centered"``) or an objective.
    weights : array_like, shape (m,), optional
        Positive per-cable weights of the objective (default ones).
    reference : array_like, shape (m,) or (N, m), optional
        Reference tension of ``min_norm`` (N): minimise the distance to it.
    t_min, t_max : float or array_like, shape (m,) or (N, m), optional
        Bounds (N) replacing the robot's own; scalar, per cable or per pose.
    smoothing : float
        Weight of the penalty ``||T - T_prev||^2`` (dimensionless, relative to the
        objective's own quadratic weight; for ``min_sum`` it is in 1/N).
    rate_limit : float or array_like, shape (m,), optional
        Largest change of each tension from the previous one (N).
    tie_break : bool
        Break non-unique optima (LP objectives) to the minimum 2-norm among the optima.
    """

    if TYPE_CHECKING:
        objective: _ObjectiveField = _ObjectiveField()
    else:
        objective: Objective | str = "min_sum"
    weights: NDArray | None = None
    reference: NDArray | None = None
    t_min: NDArray | float | None = None
    t_max: NDArray | float | None = None
    smoothing: float = 0.0
    rate_limit: NDArray | float | None = None
    tie_break: bool = True

    def __post_init__(self) -> None:
        objective = get_objective(self.objective)
        object.__setattr__(self, "objective", objective)
        if self.weights is not None:
            weights = _as_array("weights", self.weights)
            if weights.ndim != 1:
                raise InvalidInputError(
                    f"weights must have shape (m,), one per cable, got shape {weights.shape}")
            if not np.isfinite(weights).all() or (weights <= 0).any():
                raise InvalidInputError(f"weights must be positive and finite, got {weights}")
            object.__setattr__(self, "weights", weights)
        if self.reference is not None:
            object.__setattr__(self, "reference", _check_reference(self.reference, objective))
        if (not is_number(self.smoothing) or not np.isfinite(self.smoothing)
                or self.smoothing < 0):
            raise InvalidInputError(f"smoothing must be a number >= 0, got {self.smoothing!r}")
        if self.rate_limit is not None:
            rate = _as_array("rate_limit", self.rate_limit)
            if rate.ndim > 1 or np.isnan(rate).any() or (rate <= 0).any():
                raise InvalidInputError(
                    f"rate_limit must be positive, a number or one per cable, got {rate}")
            object.__setattr__(self, "rate_limit", rate)
        if not isinstance(self.tie_break, bool | np.bool_):
            raise InvalidInputError(f"tie_break must be True or False, got {self.tie_break!r}")
        if not objective.bounded and (
            self.t_min is not None or self.t_max is not None or self.rate_limit is not None
        ):
            raise InvalidInputError("the pseudo-inverse takes no bounds (t_min, t_max, "
                                    "rate_limit): use min_norm with bounds")
        for name in ("t_min", "t_max"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _check_bound(name, getattr(self, name)))
        if self.t_min is not None and self.t_max is not None:
            _check_order(self.t_min, self.t_max)

    # ----------------------------------------------------------------- naming
    @property
    def name(self) -> str:
        """Short label, e.g. ``"min_sum"`` or ``"min_sum+smooth(1e-3)"``."""
        label = self.objective.name
        if self.smoothing:
            label += f"+smooth({self.smoothing:g})"
        if self.rate_limit is not None:
            label += f"+rate({np.max(self.rate_limit):g})"
        return label

    @property
    def is_sequential(self) -> bool:
        """True if the problem couples a pose to the previous solution."""
        return bool(self.smoothing) or self.rate_limit is not None

    @property
    def has_pose_rows(self) -> bool:
        """True if bounds or the reference are given per pose (a row each, (N, m))."""
        return any(np.ndim(getattr(self, name)) == 2 for name in ("t_min", "t_max", "reference"))

    @property
    def is_linear(self) -> bool:
        """True if the problem is an LP (its optimum may be non-unique)."""
        return self.objective.linear and not self.smoothing

    def with_(self, **changes: Any) -> TensionProblem:
        """Copy with some fields replaced."""
        return replace(self, **changes)

    # ---------------------------------------------------------------- bounds
    def bounds(self, robot: CableRobot, N: int) -> tuple[NDArray, NDArray]:
        """Lower and upper tension bounds per pose, each of shape (N, m) (N)."""
        m = robot.m
        if not self.objective.bounded:
            return np.full((N, m), -np.inf), np.full((N, m), np.inf)
        lb = _per_pose("t_min", robot.t_min if self.t_min is None else self.t_min, N, m)
        ub = _per_pose("t_max", robot.t_max if self.t_max is None else self.t_max, N, m)
        if np.isnan(lb).any() or np.isinf(lb).any():
            raise InvalidInputError("t_min must be finite")
        if (lb < 0).any():
            k, i = (int(v) for v in np.argwhere(lb < 0)[0])
            raise InvalidInputError(
                f"t_min = {lb[k, i]} for cable {i} at pose {k} is negative: cables can only "
                "pull; give t_min >= 0")
        if np.isnan(ub).any() or np.isneginf(ub).any():
            raise InvalidInputError("t_max must be a number or +inf")
        if (lb > ub).any():
            k, i = (int(v) for v in np.argwhere(lb > ub)[0])
            raise InvalidInputError(
                f"t_min = {lb[k, i]} exceeds t_max = {ub[k, i]} for cable {i} at pose {k}"
            )
        return lb, ub

    def cable_weights(self, m: int) -> NDArray:
        """Per-cable weights of the objective, shape (m,) (ones by default)."""
        if self.weights is None:
            return np.ones(m)
        if self.weights.shape != (m,):
            raise InvalidInputError(f"weights must have shape ({m},), got {self.weights.shape}")
        return self.weights

    # --------------------------------------------------------- standard form
    def standard_form(
        self,
        robot: CableRobot,
        poses: ArrayLike,
        wrench: ArrayLike | None = None,
        previous: ArrayLike | None = None,
    ) -> StandardForm:
        """Instantiate the problem for a batch of poses.

        Parameters
        ----------
        robot : CableRobot
        poses : array_like, shape (N, n)
        wrench : array_like, shape (n,) or (N, n), optional
            External wrench on the platform besides gravity.
        previous : array_like, shape (m,) or (N, m), optional
            Previous tensions of each pose (N), needed by smoothing and rate limits.
        """
        p = robot.as_poses(poses)
        A = robot.structure_matrices(p)
        b = robot.required_wrench(p, wrench)
        return self.standard_form_from(robot, A, b, previous)

    def standard_form_from(
        self,
        robot: CableRobot,
        A: NDArray,
        b: NDArray,
        previous: ArrayLike | None = None,
    ) -> StandardForm:
        """Like :meth:`standard_form` from structure matrices ``A`` (N, n, m) and ``b`` (N, n)."""
        N, _, m = A.shape
        lb, ub = self.bounds(robot, N)
        w = self.cable_weights(m)
        self.objective.check(lb, ub)
        reference = None
        if self.objective.uses_reference and self.reference is not None:
            reference = _per_pose("reference", self.reference, N, m)
        terms = self.objective.terms(w, lb, ub, reference)
        q, c = terms.q.copy(), terms.c.copy()
        prev = None
        if self.is_sequential:
            if previous is None:
                raise InvalidInputError(
                    f"problem {self.name} needs the previous tensions (argument 'previous')"
                )
            prev = _per_pose("previous", previous, N, m)
            if not np.isfinite(prev).all():
                raise InvalidInputError("previous tensions must be finite")
            if self.smoothing:
                with np.errstate(over="ignore"):  # an overflow is reported below
                    q += 2.0 * self.smoothing
                    c += -2.0 * self.smoothing * prev
            if self.rate_limit is not None:
                rate = _per_pose("rate_limit", self.rate_limit, 1, m)[0]
                lb = np.maximum(lb, prev - rate)
                ub = np.minimum(ub, prev + rate)
        if not (np.isfinite(q).all() and np.isfinite(c).all()):
            raise InvalidInputError(
                "the objective overflows: weights, smoothing or reference too large "
                f"(weights={self.weights}, smoothing={self.smoothing:g})")
        return StandardForm(A=A, b=b, lb=lb, ub=ub, q=q, c=c, minmax=unit_minmax(terms.minmax),
                            problem=self, previous=prev, reference=reference)

    def evaluate(self, tensions: NDArray, lb: NDArray, ub: NDArray,
                 previous: NDArray | None = None,
                 reference: NDArray | None = None) -> NDArray:
        """Objective value of tensions (N, m) as the problem defines it (no constants dropped).

        ``previous`` (N, m) adds the smoothing term; ``reference`` (N, m) overrides the
        problem's own reference.
        """
        T = np.asarray(tensions, dtype=float)
        N, m = T.shape
        if reference is None and self.objective.uses_reference and self.reference is not None:
            reference = _per_pose("reference", self.reference, N, m)
        value = self.objective.evaluate(T, self.cable_weights(m), lb, ub, reference)
        if self.smoothing and previous is not None:
            value = value + self.smoothing * ((T - previous) ** 2).sum(axis=1)
        return value


def _as_array(name: str, value: ArrayLike) -> NDArray:
    if isinstance(value, str | bytes):
        raise InvalidInputError(f"{name} must be a number or an array of numbers, got "
                                f"{value!r}")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"{name} must be a number or an array of numbers, got {value!r}"[:300]) from None


def _check_bound(name: str, value: ArrayLike) -> NDArray | float:
    """A tension bound (scalar, (m,) or (N, m)), checked as the robot checks its own:
    cables only pull, ``t_min`` finite, ``t_max`` a number or ``+inf``."""
    arr = _as_array(name, value)
    if arr.ndim > 2:
        raise InvalidInputError(
            f"{name} must be a scalar or have shape (m,) or (N, m), got {arr.shape}")
    if np.isnan(arr).any() or np.isneginf(arr).any() or (
            name == "t_min" and np.isinf(arr).any()):
        raise InvalidInputError(
            f"{name} must be finite{' or +inf' if name == 't_max' else ''}, got {arr}"[:300])
    if (arr < 0).any():
        raise InvalidInputError(
            f"{name} = {arr.min()} is negative: cables can only pull; give {name} >= 0")
    return float(arr) if arr.ndim == 0 else arr


def _check_order(t_min: ArrayLike, t_max: ArrayLike) -> None:
    try:
        above = np.asarray(t_min) > np.asarray(t_max)
    except ValueError:
        raise InvalidInputError(
            f"t_min and t_max have shapes {np.shape(t_min)} and {np.shape(t_max)} that do "
            "not broadcast") from None
    if np.any(above):
        raise InvalidInputError("t_min exceeds t_max for some cable")


def _check_reference(value: ArrayLike, objective: Objective) -> NDArray:
    if not objective.uses_reference:
        raise InvalidInputError(
            f"objective {objective.name} takes no reference tension (min_norm does)")
    reference = _as_array("reference", value)
    if reference.ndim > 2:
        raise InvalidInputError(
            f"reference must have shape (m,) or (N, m), got {reference.shape}")
    if not np.isfinite(reference).all():
        raise InvalidInputError("reference tensions must be finite")
    if (reference < 0).any():
        raise InvalidInputError(
            f"reference tension {reference.min()} is negative: cables can only pull")
    return reference


def _per_pose(name: str, value: ArrayLike, N: int, m: int) -> NDArray:
    arr = _as_array(name, value)
    try:
        return np.broadcast_to(arr, (N, m)).astype(float, copy=True)
    except ValueError:
        raise InvalidInputError(
            f"{name} must be a scalar or have shape ({m},) or ({N}, {m}), got {arr.shape}"
        ) from None


def unit_minmax(weights: NDArray | None) -> NDArray | None:
    """Min-max weights over their largest. The minimiser of ``max_i v_i T_i`` does not
    change with a common factor of ``v``, and the solvers' tolerances, which mix
    ``v T`` with tensions, want ``v`` of order one (weights of 1e-6 moved the closed
    form's min-norm tie-break by newtons)."""
    if weights is None:
        return None
    v = np.asarray(weights, dtype=float)
    top = float(np.abs(v).max(initial=0.0))
    return v / top if top > 0 and np.isfinite(top) else v


@dataclass(frozen=True, eq=False)
class StandardForm:
    """A batch of problems in the form every backend solves (see the module docstring).

    Frozen: a stage that needs another form (the tie-break's optimal face, one pose of
    a sequence) builds a new one.

    Attributes
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lb, ub : ndarray, shape (N, m)
        Bounds; ``-inf`` / ``inf`` where absent.
    q, c : ndarray, shape (N, m)
        Diagonal Hessian and linear cost.
    minmax : ndarray, shape (m,), optional
        Weights ``v`` of the ``max_i v_i T_i`` term.
    problem : TensionProblem, optional
        The problem the form was made from (for labels and the objective's value).
    previous : ndarray, shape (N, m), optional
        Previous tensions of a smoothed or rate-limited problem (N); NaN rows where a
        pose of a sequence had none.
    G, h : ndarray, shapes (N, k, m) and (N, k), optional
        Extra inequality rows (used by the tie-break stage).
    reference : ndarray, shape (N, m), optional
        Reference tensions of an objective that uses one (N).
    """

    A: NDArray
    b: NDArray
    lb: NDArray
    ub: NDArray
    q: NDArray
    c: NDArray
    minmax: NDArray | None = None
    problem: TensionProblem | None = None
    previous: NDArray | None = None
    G: NDArray | None = None
    h: NDArray | None = None
    reference: NDArray | None = None

    #: Number of poses, rows of the structure matrix, number of cables.
    N: int = field(init=False, repr=False)
    n: int = field(init=False, repr=False)
    m: int = field(init=False, repr=False)
    #: ``"lp"``, ``"minmax"`` (LP in epigraph form), ``"minmax_qp"`` or ``"qp"`` (for an
    #: empty batch, what its problem would give).
    kind: str = field(init=False, repr=False)
    #: True for LPs, whose optimum may be non-unique.
    is_linear: bool = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # Read at every step of a solve: set once, as fields (the form is frozen).
        N, n, m = (int(size) for size in self.A.shape)
        quadratic = bool(self.q.any())
        if N == 0 and self.problem is not None:
            quadratic = not self.problem.is_linear
        if self.minmax is not None:
            kind = "minmax_qp" if quadratic else "minmax"
        else:
            kind = "qp" if quadratic else "lp"
        for name, value in (("N", N), ("n", n), ("m", m), ("kind", kind),
                            ("is_linear", kind in ("lp", "minmax"))):
            object.__setattr__(self, name, value)

    def subset(self, index: NDArray | slice) -> StandardForm:
        """The problems of the poses ``index`` (indices, mask or slice) only."""
        pick = lambda a: None if a is None else a[index]  # noqa: E731
        return StandardForm(self.A[index], self.b[index], self.lb[index], self.ub[index],
                            self.q[index], self.c[index], self.minmax, self.problem,
                            pick(self.previous), pick(self.G), pick(self.h),
                            pick(self.reference))

    @classmethod
    def stack(cls, forms: Sequence[StandardForm]) -> StandardForm:
        """One form of the poses of several forms of one problem, in order.

        Forms without previous tensions (the first pose of a sequence) get NaN rows;
        extra inequality rows are not stacked (a tie-break stage is never stacked).
        """
        first = forms[0]
        cat = lambda name: np.concatenate([getattr(f, name) for f in forms])  # noqa: E731
        previous = None
        if any(f.previous is not None for f in forms):
            previous = np.concatenate([np.full((f.N, f.m), np.nan) if f.previous is None
                                       else f.previous for f in forms])
        reference = None
        if any(f.reference is not None for f in forms):
            reference = np.concatenate([np.zeros((f.N, f.m)) if f.reference is None
                                        else f.reference for f in forms])
        return cls(cat("A"), cat("b"), cat("lb"), cat("ub"), cat("q"), cat("c"),
                   first.minmax, first.problem, previous, None, None, reference)

    # ------------------------------------------------------- measuring tensions
    def equilibrium_residual(self, tensions: NDArray) -> NDArray:
        """``||A T - b||_2`` of tensions (N, m), shape (N,) (N, N m)."""
        return safe_norm(np.einsum("nij,nj->ni", self.A, tensions) - self.b, axis=1)

    def bound_violation(self, tensions: NDArray) -> NDArray:
        """Largest violation of ``lb <= T <= ub`` (N), shape (N,); 0 where they hold."""
        over = np.maximum(self.lb - tensions, tensions - self.ub)
        return np.maximum(np.nanmax(over, axis=1, initial=0.0), 0.0)

    def objective_value(self, tensions: NDArray) -> NDArray:
        """The problem's objective at tensions (N, m), shape (N,), smoothing included
        where previous tensions are known; NaN without a problem."""
        if self.problem is None:
            return np.full(len(tensions), np.nan)
        previous = None
        if self.previous is not None:
            previous = np.where(np.isfinite(self.previous), self.previous, tensions)
        return self.problem.evaluate(tensions, self.lb, self.ub, previous, self.reference)

    def load_scale(self) -> NDArray:
        """Size of the load per pose, the unit of the feasibility check of a solution
        (its equilibrium residual, a wrench, and its bound violation), shape (N,): the
        larger of ``||b||`` and the largest finite lower bound, at least ``1e-12`` (the
        floor of :meth:`typical_tension`, so that a pose with nothing to hold and no
        lower bound is not held to zero). Not a tension scale: for a point robot (unit
        columns) it is the typical tension, for a turning platform ``||b||`` counts
        moments in N m."""
        finite_lb = np.where(np.isfinite(self.lb), np.abs(self.lb), 0.0)
        return np.maximum(np.maximum(safe_norm(self.b, axis=1), finite_lb.max(axis=1, initial=0.0)),
                          1e-12)

    def typical_tension(self) -> NDArray:
        """The tension scale of each pose (N), shape (N,): :func:`typical_tension` of the
        form. Every tolerance on a tension is relative to it, and the reference tension
        of the scaled problem (:class:`tension_opt.certify.scaling.Scaling`) is it,
        floored by :data:`~tension_opt.tolerances.UB_SHARE` of the box. Read-only,
        computed once (a solve and its tie-break ask for it several times)."""
        known = self.__dict__.get("_typical")
        if known is None:
            known = typical_tension(self.A, self.b, self.lb)
            known.flags.writeable = False
            object.__setattr__(self, "_typical", known)  # a cache, not a field
        return known


def as_problem(objective: str | Objective | TensionProblem, **fields: Any) -> TensionProblem:
    """Turn an objective name (or a problem) into a :class:`TensionProblem`."""
    if isinstance(objective, TensionProblem):
        return objective.with_(**fields) if fields else objective
    return TensionProblem(objective=objective, **fields)


def min_sum(**fields: Any) -> TensionProblem:
    """Minimum weighted sum of tensions (LP)."""
    return TensionProblem("min_sum", **fields)


def min_norm(**fields: Any) -> TensionProblem:
    """Minimum weighted 2-norm (QP), optionally toward ``reference``."""
    return TensionProblem("min_norm", **fields)


def pinv(**fields: Any) -> TensionProblem:
    """Moore-Penrose pseudo-inverse: minimum 2-norm, no bounds."""
    return TensionProblem("pinv", **fields)


def min_max(**fields: Any) -> TensionProblem:
    """Minimise the largest (weighted) tension."""
    return TensionProblem("min_max", **fields)


def centered(**fields: Any) -> TensionProblem:
    """Closest to the middle of [t_min, t_max] (needs finite t_max)."""
    return TensionProblem("centered", **fields)
