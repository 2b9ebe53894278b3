"""Poses to check: regular grids over a box and uniform samples in it.

A :class:`Grid` keeps its shape, the points along each coordinate and its box, so a
:class:`~tension_opt.workspace.WorkspaceResult` computed on it can weigh each point by
its cell (:func:`cell_widths`) and be drawn as a slice.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_float_array
from tension_opt.errors import InvalidInputError

__all__ = [
    "MAX_GRID_POINTS",
    "Grid",
    "cell_widths",
    "check_bounds",
    "check_box",
    "sample_poses",
    "workspace_grid",
]

#: Largest number of points :func:`workspace_grid` builds.
MAX_GRID_POINTS = 50_000_000


class Grid(NamedTuple):
    """A regular grid of poses.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        Grid points in C order of ``axes`` (the last coordinate varies fastest), so that
        ``values.reshape(shape)`` indexes ``[i0, i1, ...]``.
    shape : tuple of int, length n
        Points along each pose coordinate (1 for a fixed coordinate).
    axes : tuple of ndarray
        The points along each coordinate (m or rad).
    lower, upper : ndarray, shape (n,), optional
        The box the grid covers (m, rad). Each point stands for the cell between the
        midpoints to its neighbours, the outer cells ending at the box (see
        :func:`cell_widths`). None for a grid built without a box: its outer cells then
        reach half a gap beyond the outer points.
    """

    poses: NDArray
    shape: tuple[int, ...]
    axes: tuple[NDArray, ...]
    lower: NDArray | None = None
    upper: NDArray | None = None

    def box(self) -> tuple[NDArray, NDArray]:
        """The box ``(lower, upper)`` each point's cell lies in, shape (n,) each (m, rad).

        The grid's own box, or for a grid without one, its outer points moved out by
        half a gap (a single point stays put).
        """
        if self.lower is not None and self.upper is not None:
            return np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
        lower = [a[0] - 0.5 * (a[1] - a[0]) if len(a) > 1 else a[0] for a in self.axes]
        upper = [a[-1] + 0.5 * (a[-1] - a[-2]) if len(a) > 1 else a[-1] for a in self.axes]
        return np.array(lower), np.array(upper)


def cell_widths(axis: ArrayLike, lower: float | None = None,
                upper: float | None = None) -> NDArray:
    """Width of the cell of each point along one grid coordinate (m, rad).

    The cells are bounded by the midpoints between neighbouring points and, at the
    ends, by ``lower`` and ``upper``: equal cells ``width / k`` for a ``spacing`` grid
    of :func:`workspace_grid`, half cells at both ends for a ``counts`` grid (whose end
    points lie on the box), the whole width for a single point. Without a box the
    outer cells reach half a gap beyond the outer points (0 for a single point).

    Parameters
    ----------
    axis : array_like, shape (k,)
        Increasing points along the coordinate.
    lower, upper : float, optional
        Ends of the coordinate's range, ``lower <= axis[0]``, ``axis[-1] <= upper``.

    Returns
    -------
    ndarray, shape (k,)
        Cell widths; they sum to ``upper - lower`` when a box is given.
    """
    a = np.asarray(axis, dtype=float)
    mid = 0.5 * (a[1:] + a[:-1])
    if lower is None or upper is None:
        gaps = np.diff(a)
        lo = a[0] - 0.5 * gaps[0] if len(gaps) else a[0]
        hi = a[-1] + 0.5 * gaps[-1] if len(gaps) else a[-1]
    else:
        lo, hi = float(lower), float(upper)
    edges = np.concatenate([[lo], mid, [hi]])
    return np.diff(edges)


def _per_axis(value: ArrayLike, n: int, name: str) -> NDArray:
    """``spacing`` / ``counts`` as a float vector of length ``n`` (a scalar is repeated)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be a number or {n} numbers; got {value!r}") from None
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise InvalidInputError(f"{name} must be a number or have shape ({n},) like lower and "
                                f"upper; got shape {arr.shape}")
    return arr


def workspace_grid(lower: ArrayLike, upper: ArrayLike, spacing: ArrayLike | None = None,
                   counts: ArrayLike | None = None) -> Grid:
    """Regular grid of poses in the box ``lower <= pose <= upper``.

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        Corners of the box (m, rad), finite. A coordinate with ``lower == upper`` is
        fixed.
    spacing : float or array_like, shape (n,), optional
        Largest distance between neighbouring points (m, rad), > 0. Each coordinate's
        range is cut into ``k = ceil(width / spacing)`` equal cells of size
        ``width / k`` (exactly ``spacing`` when it divides the width) and the points are
        the cell centres, so the cells tile the box.
    counts : int or array_like of int, shape (n,), optional
        Points along each coordinate instead of ``spacing``, whole numbers >= 1 (1 for a
        fixed coordinate), from ``lower`` to ``upper`` inclusive (``numpy.linspace``;
        the end points then stand for half cells, so the cells again tile the box). Give
        exactly one of ``spacing`` and ``counts``.

    Returns
    -------
    Grid
        ``poses`` (N, n), ``shape``, ``axes`` and the box ``lower``, ``upper``;
        :meth:`WorkspaceResult.volume` weighs each point by its cell
        (:func:`cell_widths`).

    Raises
    ------
    InvalidInputError
        On a bad box, ``spacing`` or ``counts`` (wrong length, not positive, counts not
        whole), or a grid of more than ``MAX_GRID_POINTS`` (5e7) points.
    """
    lo, hi = check_box(lower, upper)
    if (spacing is None) == (counts is None):
        raise InvalidInputError("give exactly one of spacing and counts")
    width = hi - lo
    if spacing is not None:
        step = _per_axis(spacing, lo.size, "spacing")
        if not np.isfinite(step).all() or ((step <= 0) & (width > 0)).any():
            raise InvalidInputError(f"spacing must be positive and finite; got {spacing}")
        with np.errstate(divide="ignore", invalid="ignore"):
            k_float = np.where(width > 0, np.ceil(width / np.where(step > 0, step, 1.0)
                                                  * (1 - 1e-12)), 1.0)
        k_float = np.maximum(k_float, 1.0)
    elif counts is not None:
        k_float = _per_axis(counts, lo.size, "counts")
        if (not np.isfinite(k_float).all() or (k_float < 1).any()
                or not np.all(np.mod(k_float, 1) == 0)):
            raise InvalidInputError(f"counts must be positive whole numbers; got {counts!r}")
        if ((k_float > 1) & (width == 0)).any():
            raise InvalidInputError("a fixed coordinate (lower == upper) takes count 1")
    total = float(np.prod(k_float))
    if not total <= MAX_GRID_POINTS:
        sizes = "x".join(f"{k:.0f}" for k in k_float)
        raise InvalidInputError(f"the grid would have {total:.3g} points ({sizes}), more than "
                                f"{MAX_GRID_POINTS:.0e}; use a coarser spacing, fewer counts "
                                f"or sample_poses")
    axes: list[NDArray] = []
    for a, b, w, k in zip(lo, hi, width, k_float.astype(int), strict=True):
        if w == 0:
            axes.append(np.array([a]))
        elif spacing is not None:
            axes.append(a + (w / k) * (np.arange(k) + 0.5))
        else:
            axes.append(np.linspace(a, b, k))
    shape = tuple(len(a) for a in axes)
    # The poses of numpy.meshgrid(*axes, indexing="ij"), raveled, written in place: the
    # mesh and a stack of it took three times the poses' memory at once.
    poses = np.empty((int(np.prod(shape)), len(axes)))
    cube = poses.reshape(*shape, len(axes))
    for j, axis in enumerate(axes):
        cube[..., j] = axis.reshape([-1 if i == j else 1 for i in range(len(axes))])
    return Grid(poses, shape, tuple(axes), lo.copy(), hi.copy())


def check_box(lower: ArrayLike, upper: ArrayLike) -> tuple[NDArray, NDArray]:
    """Checked corners of a box: finite vectors of one length with ``lower <= upper``.

    Returns
    -------
    lower, upper : ndarray, shape (n,)

    Raises
    ------
    InvalidInputError
        On corners of different lengths, non-finite values or ``upper < lower``.
    """
    lo = np.atleast_1d(as_float_array("lower", lower))
    hi = np.atleast_1d(as_float_array("upper", upper))
    if lo.shape != hi.shape or lo.ndim != 1:
        raise InvalidInputError(f"lower and upper must be vectors of one length; got "
                                f"{lo.shape} and {hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or (hi < lo).any():
        raise InvalidInputError(f"the box needs finite lower <= upper; got {lo} and {hi}")
    return lo, hi


def check_bounds(bounds: Any, n: int) -> tuple[NDArray, NDArray]:
    """``bounds`` as two finite vectors of shape (n,) with ``lower <= upper``.

    Parameters
    ----------
    bounds : (array_like, array_like)
        A box around poses (m, rad), as given to a workspace function.
    n : int
        Pose size.

    Raises
    ------
    InvalidInputError
        On anything but a pair of finite vectors of shape (n,) with ``lower <= upper``.
    """
    try:
        lo_raw, hi_raw = bounds
        lo, hi = np.asarray(lo_raw, dtype=float), np.asarray(hi_raw, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(f"bounds must be a pair (lower, upper) of shape ({n},) "
                                f"each; got {bounds!r}") from None
    if lo.shape != (n,) or hi.shape != (n,):
        raise InvalidInputError(f"bounds must be (lower, upper) of shape ({n},) each, like "
                                f"the poses; got {lo.shape} and {hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise InvalidInputError(f"bounds must be finite; got {lo} and {hi}")
    if (hi < lo).any():
        raise InvalidInputError(f"bounds need lower <= upper; got {lo} and {hi}")
    return lo, hi


def sample_poses(lower: ArrayLike, upper: ArrayLike, count: int,
                 seed: int | np.random.Generator | None = None) -> NDArray:
    """Poses drawn uniformly in the box ``lower <= pose <= upper``.

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        Corners of the box (m, rad), finite.
    count : int
        Number of poses N, a whole number from 1 to ``MAX_GRID_POINTS`` (5e7).
    seed : int or numpy.random.Generator, optional

    Returns
    -------
    ndarray, shape (N, n)

    Raises
    ------
    InvalidInputError
        Naming the box or ``count``.
    """
    lo, hi = check_box(lower, upper)
    try:
        whole = (not isinstance(count, (bool, np.bool_)) and float(count).is_integer()
                 and 1 <= count <= MAX_GRID_POINTS)
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole:
        raise InvalidInputError(f"count must be a whole number from 1 to "
                                f"{MAX_GRID_POINTS:.0e}; got {count!r}")
    rng = np.random.default_rng(seed)
    return lo + (hi - lo) * rng.random((int(count), lo.size))

