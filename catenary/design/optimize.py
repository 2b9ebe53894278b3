"""Design optimisation: scipy's gradient methods over a :class:`DesignSpace`, from several
starts, and over a discrete choice of cable materials.

The variables are scaled to the unit box, the objective by its magnitude at each start
and the constraints by their bounds, so that newtons, metres and cubic metres weigh
alike.
Without constraints the method is L-BFGS-B, with them SLSQP; both take the criteria's
analytic gradients (:mod:`catenary.design.criteria`), and central differences (step
1e-4 of each box) for a numeric criterion, and for every criterion of a space over a
robot with guide pulleys (:attr:`~catenary.design.DesignSpace.numeric`). A design
that cannot hold a pose of a criterion (no tensions within its bounds) has the scaled
objective :data:`PENALTY`, its constraints are violated by as much, and its gradient is
zero: a line search that reaches one steps back. A start on such a design does not move and ends
``"infeasible"``; the other starts go on.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import minimize

from tension_opt import CableRobot

from ..errors import InvalidDesignError
from .criteria import Criterion, CriterionValue
from .space import DesignSpace

__all__ = ["DesignConstraint", "DesignResult", "optimize_design"]

FloatArray = NDArray[np.float64]

#: Relative slack within which a constraint counts as met.
CONSTRAINT_TOL = 1e-6
_STEP = 1e-4
#: Evaluations a start keeps (its last points: a line search and a gradient's probes).
CACHE_SIZE = 64
#: Scaled objective (and constraint violation) of a design that cannot hold a pose of a
#: criterion: far worse than any design that can, so that line searches step back.
PENALTY = 1e3


@dataclass(frozen=True)
class DesignConstraint:
    """``lower <= criterion <= upper`` on the smooth value (either bound may be None).

    The smooth value of a maximum is an upper bound of the maximum, so ``upper`` on it
    is conservative (:mod:`catenary.design.criteria`).
    """

    criterion: Criterion
    lower: float | None = None
    upper: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.criterion, Criterion):
            raise InvalidDesignError(f"constraint criterion must be a Criterion, got "
                                     f"{type(self.criterion).__name__}")
        if self.lower is None and self.upper is None:
            raise InvalidDesignError(f"constraint on {self.criterion.name!r} has no bound: "
                                     "give lower= or upper=")
        for b in (self.lower, self.upper):
            if b is not None and not np.isfinite(b):
                raise InvalidDesignError(f"constraint bounds must be finite, got {b!r}")
        if self.lower is not None and self.upper is not None and self.lower > self.upper:
            raise InvalidDesignError(f"constraint on {self.criterion.name!r}: lower "
                                     f"{self.lower!r} is above upper {self.upper!r}")

    @property
    def magnitude(self) -> float:
        """The size of the constraint's bounds (at least 1): its scale."""
        return max(1.0, *(abs(float(b)) for b in (self.lower, self.upper) if b is not None))


@dataclass(frozen=True, eq=False)
class DesignResult:
    """The best design found: of the starts that end on a design meeting the
    constraints, the one with the best plain value (ties: the best smooth value).

    Attributes
    ----------
    x : ndarray, shape (k,)
        The variables (their units), named by ``names``.
    names : list of str
    robot : CableRobot
        The robot of ``x``.
    objective, smooth : float
        The objective's plain and smooth values at ``x``.
    constraints : dict
        Each constraint's plain value at ``x``, by criterion name.
    status : str
        ``"converged"`` (the method's optimality test passed and every constraint is met
        within :data:`CONSTRAINT_TOL`), ``"max_iter"``, ``"time_limit"``,
        ``"infeasible"`` (no start met the constraints) or ``"failed"``.
    material : str or None
        The cable material of the best design.
    starts : pandas.DataFrame
        One row per start (and material): the start, the end, the value, the status,
        the iterations and evaluations.
    evaluations : int
        Criterion evaluations, all starts.
    seconds : float
        Wall time (s).
    """

    x: FloatArray
    names: list[str]
    robot: CableRobot
    objective: float
    smooth: float
    constraints: dict[str, float]
    status: str
    material: str | None
    starts: pd.DataFrame
    evaluations: int
    seconds: float

    def to_frame(self) -> pd.DataFrame:
        """The best design's variables as a tidy table (name, value)."""
        return pd.DataFrame({"variable": self.names, "value": self.x})

    def __repr__(self) -> str:
        design = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.x, strict=True))
        material = f", material={self.material!r}" if self.material else ""
        return (f"DesignResult(status={self.status!r}, objective={self.objective:.6g}, "
                f"{design}{material}, starts={len(self.starts)}, "
                f"evaluations={self.evaluations}, seconds={self.seconds:.3g})")


class _Stop(Exception):
    """A start ends early (time limit, a design that cannot hold a pose)."""

    def __init__(self, status: str, message: str) -> None:
        super().__init__(message)
        self.status = status


@dataclass
class _Problem:
    """One material's scaled problem: cached evaluations of every criterion."""

    space: DesignSpace
    criteria: list[Criterion]
    signs: FloatArray              # objective sign (+1 minimise, -1 maximise) first
    deadline: float
    evaluations: int = 0
    unholdable: int = 0
    cache: dict[bytes, list[CriterionValue]] = field(default_factory=dict)
    pinned: dict[bytes, list[CriterionValue]] = field(default_factory=dict)

    def x_of(self, u: FloatArray) -> FloatArray:
        lo, up = self.space.lower, self.space.upper
        return lo + np.clip(u, 0.0, 1.0) * (up - lo)

    def values(self, u: FloatArray) -> list[CriterionValue]:
        key = np.asarray(u, dtype=float).tobytes()
        if key in self.pinned:
            return self.pinned[key]
        if key not in self.cache:
            if time.monotonic() > self.deadline:
                raise _Stop("time_limit", "the time limit was reached")
            robot = self.space.robot_at(self.x_of(u))
            self.evaluations += 1
            got = [c.evaluate(robot) for c in self.criteria]
            if not all(np.isfinite(v.value) for v in got):
                self.unholdable += 1
            if len(self.cache) >= CACHE_SIZE:
                self.cache.clear()
            self.cache[key] = got
        return self.cache[key]

    def value(self, u: FloatArray, i: int) -> float:
        return self.values(u)[i].value

    def pin(self, u: FloatArray) -> None:
        """Keep the values at ``u`` past any cache clearing and the deadline (the best
        point a start met, which its result reports)."""
        self.pinned[np.asarray(u, dtype=float).tobytes()] = self.values(u)

    def holds(self, u: FloatArray) -> bool:
        """Whether every criterion has a value at ``u`` (the design holds its poses)."""
        return all(np.isfinite(v.value) for v in self.values(u))

    def gradient(self, u: FloatArray, i: int) -> FloatArray:
        """d value_i / du (k,); zero where the design does not hold its poses."""
        width = self.space.upper - self.space.lower
        got = self.values(u)[i]
        if not self.holds(u):
            return np.zeros(self.space.k)
        if got.gradient is not None and not self.space.numeric:
            return self.space.chain(got.gradient) * width
        out = np.empty(self.space.k)
        for j in range(self.space.k):
            step = np.zeros(self.space.k)
            step[j] = _STEP
            lo, hi = np.clip(u - step, 0, 1), np.clip(u + step, 0, 1)
            out[j] = (self.value(hi, i) - self.value(lo, i)) / (hi[j] - lo[j])
        return out


def _check(space: DesignSpace, objective: Criterion,
           constraints: Sequence[DesignConstraint]) -> None:
    if not isinstance(space, DesignSpace):
        raise InvalidDesignError(f"space must be a DesignSpace, got {type(space).__name__}")
    if not isinstance(objective, Criterion):
        raise InvalidDesignError(f"objective must be a Criterion (PeakTension, "
                                 f"WorkspaceCoverage, ...), got {type(objective).__name__}")
    for c in constraints:
        if not isinstance(c, DesignConstraint):
            raise InvalidDesignError(f"constraints must be DesignConstraint(criterion, "
                                     f"lower=..., upper=...), got {type(c).__name__}")


def _check_settings(starts: int, max_iter: int, materials: Sequence[str] | None,
                    time_limit: float) -> None:
    for name, value in (("starts", starts), ("max_iter", max_iter)):
        if not (isinstance(value, int | np.integer) and value >= 1):
            raise InvalidDesignError(f"{name} must be an int >= 1, got {value!r}")
    if materials is not None and (isinstance(materials, str) or not len(materials)
                                  or not all(isinstance(m, str) for m in materials)):
        raise InvalidDesignError(f"materials must be a non-empty list of catalogue names, "
                                 f"e.g. ['steel', 'dyneema'], got {materials!r}")
    if not (np.isfinite(time_limit) and time_limit > 0):
        raise InvalidDesignError(f"time_limit must be a finite number of seconds > 0, got "
                                 f"{time_limit!r}")


def optimize_design(
    space: DesignSpace,
    objective: Criterion,
    *,
    maximize: bool = False,
    constraints: Sequence[DesignConstraint] = (),
    starts: int = 4,
    seed: int = 0,
    materials: Sequence[str] | None = None,
    max_iter: int = 60,
    time_limit: float = 600.0,
    progress: bool = False,
) -> DesignResult:
    """Optimise a design over ``space`` (module notes).

    Parameters
    ----------
    space : DesignSpace
    objective : Criterion
        Minimised, or maximised with ``maximize=True``.
    constraints : sequence of DesignConstraint
    starts : int
        Starts per material: the base design and ``starts - 1`` uniform random points of
        the box (``seed``).
    materials : sequence of str, optional
        Catalogue materials to choose from (each optimised in turn); default: the
        space's cable.
    max_iter : int
        Iterations per start.
    time_limit : float
        Seconds for the whole call; a start still running then ends with
        ``"time_limit"`` and the best point it met.
    progress : bool
        A tqdm bar over the starts.

    Returns
    -------
    DesignResult

    Raises
    ------
    InvalidDesignError
        For a malformed argument or a criterion that cannot take the space's variables.
    """
    constraints = list(constraints)
    _check(space, objective, constraints)
    _check_settings(starts, max_iter, materials, time_limit)
    t0 = time.monotonic()
    spaces = ([space] if materials is None else [space.with_material(m) for m in materials])
    rng = np.random.default_rng(seed)
    unit_starts = [(space.x0 - space.lower) / (space.upper - space.lower)] + [
        rng.uniform(0.0, 1.0, space.k) for _ in range(starts - 1)]
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=len(spaces) * starts, desc="design starts", unit="start")
    rows: list[dict[str, Any]] = []
    evaluations = 0
    for sp in spaces:
        prob = _Problem(sp, [c.with_material(sp.material)
                             for c in (objective, *(k.criterion for k in constraints))],
                        np.array([-1.0 if maximize else 1.0]), t0 + time_limit)
        for j, u0 in enumerate(unit_starts):
            rows.append(_run_start(prob, constraints, u0, j, max_iter))
            if bar is not None:
                bar.update()
        evaluations += prob.evaluations
    if bar is not None:
        bar.close()
    return _result(space, objective, constraints, rows, maximize, evaluations,
                   time.monotonic() - t0)


def _scales(prob: _Problem, constraints: Sequence[DesignConstraint], u0: FloatArray
            ) -> FloatArray:
    """Magnitudes of the objective and of each constraint's bound."""
    try:
        f0 = abs(prob.value(u0, 0))
    except _Stop:
        f0 = 1.0
    out = [f0 if np.isfinite(f0) and f0 > 0 else 1.0]
    out += [c.magnitude for c in constraints]
    return np.array(out)


def _run_start(prob: _Problem, constraints: Sequence[DesignConstraint], u0: FloatArray,
               index: int, max_iter: int) -> dict[str, Any]:
    scale = _scales(prob, constraints, u0)
    sign = prob.signs[0]
    best: dict[str, Any] = {"u": None, "f": np.inf}

    def f(u: FloatArray) -> float:
        if not prob.holds(u):
            return PENALTY
        v = sign * prob.value(u, 0) / scale[0]
        if v < best["f"] and _met(prob, constraints, u):
            best.update(u=np.array(u), f=v)
            prob.pin(best["u"])
        return v

    def df(u: FloatArray) -> FloatArray:
        return sign * prob.gradient(u, 0) / scale[0]

    cons = []
    for i, c in enumerate(constraints, start=1):
        for bound, s in ((c.upper, -1.0), (c.lower, 1.0)):
            if bound is not None:
                cons.append({"type": "ineq",
                             "fun": lambda u, i=i, b=bound, s=s:
                                 s * (prob.value(u, i) - b) / scale[i] if prob.holds(u)
                                 else -PENALTY,
                             "jac": lambda u, i=i, s=s: s * prob.gradient(u, i) / scale[i]})
    method = "SLSQP" if cons else "L-BFGS-B"
    row: dict[str, Any] = {"material": prob.space.material, "start": index,
                           "x0": prob.x_of(u0)}
    try:
        res = minimize(f, u0, jac=df, method=method, bounds=[(0.0, 1.0)] * len(u0),
                       constraints=cons, options={"maxiter": max_iter})
        u = np.clip(res.x, 0.0, 1.0)
        met = prob.holds(u) and _met(prob, constraints, u)
        status = ("converged" if res.success and met else
                  "max_iter" if res.nit >= max_iter else "failed" if met else "infeasible")
        row.update(u=u, status=status, message=str(res.message), iterations=int(res.nit))
        if status != "converged" and best["u"] is not None:
            # The best design met on the way meets the constraints, unconverged.
            row["u"] = best["u"]
            row["status"] = "max_iter" if res.nit >= max_iter else "failed"
    except _Stop as stop:
        u = best["u"]
        row.update(u=u, status=stop.status, message=str(stop), iterations=-1)
    if row["u"] is not None:
        vals = prob.values(row["u"])
        row.update(x=prob.x_of(row["u"]), smooth=vals[0].value, objective=vals[0].plain,
                   feasible=_met(prob, constraints, row["u"]),
                   **{f"constraint {label}": v.plain
                      for label, v in zip(_labels(constraints), vals[1:], strict=True)})
    else:
        row.update(x=None, smooth=np.nan, objective=np.nan, feasible=False)
    return row


def _labels(constraints: Sequence[DesignConstraint]) -> list[str]:
    """Each constraint's criterion name, numbered where two share a name."""
    names = [c.criterion.name for c in constraints]
    return [f"{n} ({names[:i].count(n) + 1})" if names.count(n) > 1 else n
            for i, n in enumerate(names)]


def _met(prob: _Problem, constraints: Sequence[DesignConstraint], u: FloatArray) -> bool:
    vals = prob.values(u)
    if not prob.holds(u):
        return False
    for c, v in zip(constraints, vals[1:], strict=True):
        slack = CONSTRAINT_TOL * c.magnitude
        if c.upper is not None and not v.value <= c.upper + slack:
            return False
        if c.lower is not None and not v.value >= c.lower - slack:
            return False
    return True


def _result(space: DesignSpace, objective: Criterion, constraints: Sequence[DesignConstraint],
            rows: list[dict[str, Any]], maximize: bool, evaluations: int,
            seconds: float) -> DesignResult:
    table = pd.DataFrame(rows).drop(columns=["u"])
    usable = [r for r in rows if r["x"] is not None and r["feasible"]]
    if not usable:
        status = ("time_limit" if any(r["status"] == "time_limit" for r in rows)
                  else "infeasible")
        x = space.x0
        return DesignResult(x, space.names, space.robot_at(x), np.nan, np.nan, {}, status,
                            space.material, table, evaluations, seconds)
    # The plain value is what the design is worth; the smooth one breaks its ties.
    sign = -1.0 if maximize else 1.0
    best = min(usable, key=lambda r: (sign * r["objective"], sign * r["smooth"]))
    chosen = space.with_material(best["material"]) if best["material"] else space
    return DesignResult(np.asarray(best["x"]), space.names, chosen.robot_at(best["x"]),
                        float(best["objective"]), float(best["smooth"]),
                        {label: float(best[f"constraint {label}"])
                         for label in _labels(constraints)},
                        best["status"], best["material"], table, evaluations, seconds)
