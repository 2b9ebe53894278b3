"""Random wrench-feasible poses: uniform draws in a box, kept where tensions exist.

:func:`random_feasible_poses` draws poses uniformly in a box (by default one derived
from the drawing points, :func:`default_box`) and keeps those where the minimum-sum
problem is optimal, i.e. the platform's weight can be held with every tension within
the robot's bounds (tightened by ``margin``). Poses are drawn and checked in rounds of
``batch`` poses, each round checked in vectorised :func:`tension_opt.distribute` calls of
:data:`tension_opt.distribution.entry.CHUNK_SIZE` poses (only the mask is kept, so memory grows
with ``batch`` and ``n`` by a pose's coordinates only).

The same seed, box and batch always give the same poses: each position coordinate is
drawn as one column of ``batch`` values, in pose order, then the angle coordinates as
one ``(batch, r)`` block.
"""

from __future__ import annotations

import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.distribution.entry import CHUNK_SIZE, distribute
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import TensionProblem
from tension_opt.robot import CableRobot

__all__ = ["DEFAULT_ANGLE", "ROUNDS", "default_box", "feasible_mask", "random_feasible_poses"]

#: Half-range of each angle coordinate of the default box (rad).
DEFAULT_ANGLE = 0.1
#: Default number of rounds: ``max_draws`` is ``ROUNDS * batch`` unless given.
ROUNDS = 100
# An axis along which the drawing points spread less than this fraction of their
# largest spread counts as level (e.g. every drawing point at one height).
_LEVEL = 0.1


def default_box(robot: CableRobot) -> tuple[NDArray, NDArray]:
    """A box of poses around the robot's drawing points.

    Along each position axis the box spans the drawing points. Where they are about
    level (spread below a tenth of their largest spread ``s``), the vertical axis
    reaches ``s / 2`` below the highest point (the platform hangs under its drawing
    points) and any other axis spans ``s / 2`` around their middle. Angle coordinates
    span ``+-DEFAULT_ANGLE`` rad.

    Parameters
    ----------
    robot : CableRobot

    Returns
    -------
    low, high : ndarray, shape (n,)
        Corners of the box (m, rad), ``low <= high``.
    """
    pattern = robot.pattern
    axes = list(pattern.position_axes)
    lo, hi = robot.anchors.min(axis=0)[axes], robot.anchors.max(axis=0)[axes]
    spread = float((hi - lo).max())
    level = (hi - lo) < _LEVEL * spread
    vertical = np.array(axes) == 2
    mid = 0.5 * (lo + hi)
    lo = np.where(level, np.where(vertical, hi - 0.5 * spread, mid - 0.25 * spread), lo)
    hi = np.where(level & ~vertical, mid + 0.25 * spread, hi)
    low = np.full(pattern.pose_size, -DEFAULT_ANGLE)
    high = np.full(pattern.pose_size, DEFAULT_ANGLE)
    low[list(pattern.positions)], high[list(pattern.positions)] = lo, hi
    return low, high


def feasible_mask(robot: CableRobot, poses: ArrayLike, backend: str = "closed_form",
                  margin: float = 0.0) -> NDArray:
    """Poses where the platform's weight can be held within the tension bounds.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n)
        Poses (m, rad).
    backend : str
        Backend of the minimum-sum problem (``"closed_form"``: exact; ``"auto"``).
    margin : float
        Tension margin (N), >= 0: the bounds are tightened to
        ``[t_min + margin, t_max - margin]``.

    Returns
    -------
    ndarray of bool, shape (N,)
        True where the minimum-sum problem is optimal.
    """
    margin = _check_margin(margin)
    problem: str | TensionProblem = "min_sum"
    if margin > 0:
        t_min = np.asarray(robot.t_min, dtype=float) + margin
        t_max = np.asarray(robot.t_max, dtype=float) - margin
        if (t_min > t_max).any():
            raise InvalidInputError(
                f"margin={margin:g} N leaves no tension between the bounds "
                f"(t_max - t_min is {float(np.min(t_max - t_min + 2 * margin)):g} N)")
        problem = TensionProblem("min_sum", t_min=t_min, t_max=t_max)
    p = robot.as_poses(poses)
    # Chunk by chunk, keeping only the mask: a solution holds ~200 bytes per pose.
    mask = np.zeros(len(p), dtype=bool)
    for start in range(0, len(p), CHUNK_SIZE):
        sl = slice(start, start + CHUNK_SIZE)
        mask[sl] = distribute(robot, p[sl], problem, backend=backend).success
    return mask


def random_feasible_poses(
    robot: CableRobot,
    n: int,
    seed: int | np.random.Generator | None = None,
    *,
    low: ArrayLike | None = None,
    high: ArrayLike | None = None,
    backend: str = "closed_form",
    margin: float = 0.0,
    batch: int | None = None,
    max_draws: int | None = None,
) -> NDArray:
    """``n`` poses drawn uniformly in a box, each one wrench-feasible.

    Parameters
    ----------
    robot : CableRobot
    n : int
        Number of poses wanted, >= 0.
    seed : int or numpy.random.Generator, optional
        Seed of the draws (None: fresh entropy).
    low, high : array_like, shape (n_dof,), optional
        Corners of the box (m, rad); default :func:`default_box`. Give both or neither.
    backend : str
        Backend of the feasibility check (:func:`feasible_mask`): ``"closed_form"``
        (exact, default) or ``"auto"``.
    margin : float
        Tension margin (N), >= 0: keep poses whose weight can be held with tensions in
        ``[t_min + margin, t_max - margin]``.
    batch : int, optional
        Poses drawn and checked per round, >= 1 (default ``2 * n``).
    max_draws : int, optional
        Most poses drawn in all (default ``ROUNDS * batch``); rounds stop once it is
        reached.

    Returns
    -------
    ndarray, shape (n, n_dof)
        The first ``n`` feasible poses in the order drawn (m, rad).

    Raises
    ------
    InvalidInputError
        For a bad argument, or when ``max_draws`` draws give fewer than ``n`` feasible
        poses (the message says how many were found).
    """
    count = _whole("n", n, minimum=0)
    lo, hi = _box(robot, low, high)
    size = _whole("batch", max(2 * count, 1) if batch is None else batch, minimum=1)
    limit = _whole("max_draws", ROUNDS * size if max_draws is None else max_draws,
                   minimum=1)
    margin = _check_margin(margin)
    rng = np.random.default_rng(seed)
    groups = _draw_groups(robot)
    kept: list[NDArray] = []
    found = drawn = 0
    while found < count and drawn < limit:
        poses = _draw(rng, lo, hi, size, groups)
        ok = feasible_mask(robot, poses, backend=backend, margin=margin)
        kept.append(poses[ok][:count - found])  # no more than asked for
        found += len(kept[-1])
        drawn += size
    if found < count:
        raise InvalidInputError(
            f"found only {found} of n={count} feasible poses in {drawn} draws "
            f"(max_draws={limit}); raise max_draws, lower margin, or give a box (low, "
            "high) where more poses are feasible")
    if not kept:
        return np.zeros((0, robot.dof))
    return np.concatenate(kept)[:count]


def _draw_groups(robot: CableRobot) -> list[list[int]]:
    """Columns drawn together: each position alone, then all angles as one block."""
    positions = list(robot.pattern.positions)
    angles = [i for i in range(robot.dof) if i not in positions]
    return [[i] for i in positions] + ([angles] if angles else [])


def _draw(rng: np.random.Generator, low: NDArray, high: NDArray, size: int,
          groups: list[list[int]]) -> NDArray:
    poses = np.empty((size, low.size))
    for group in groups:
        poses[:, group] = rng.uniform(low[group], high[group], (size, len(group)))
    return poses


def _box(robot: CableRobot, low: ArrayLike | None,
         high: ArrayLike | None) -> tuple[NDArray, NDArray]:
    if (low is None) != (high is None):
        raise InvalidInputError("give both low and high, or neither (the default box)")
    if low is None or high is None:
        return default_box(robot)
    lo = np.asarray(low, dtype=float)
    hi = np.asarray(high, dtype=float)
    shape = (robot.dof,)
    if lo.shape != shape or hi.shape != shape:
        raise InvalidInputError(f"low and high must have shape {shape}; got {lo.shape} and "
                                f"{hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or (lo > hi).any():
        raise InvalidInputError(f"low and high must be finite with low <= high; got {lo} "
                                f"and {hi}")
    return lo, hi


def _whole(name: str, value: object, minimum: int) -> int:
    try:
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidInputError(f"{name} must be a whole number; got {value!r}") from None
    if number < minimum:
        raise InvalidInputError(f"{name} must be >= {minimum}; got {number}")
    return number


def _check_margin(margin: float) -> float:
    value = float(margin)
    if not (np.isfinite(value) and value >= 0):
        raise InvalidInputError(f"margin must be a finite number >= 0 (N); got {margin!r}")
    return value
