"""Wrench-feasible workspace over grids or random samples, with the capacity margin.

A pose is *wrench-feasible* when tensions within ``[t_min, t_max]`` hold the platform's
weight plus every external wrench of a given set (each on its own). Beside the yes/no
answer every pose gets its **capacity margin** (N)::

    margin = max s  such that  A T = b,  t_min + s <= T <= t_max - s      (one wrench)

the largest uniform distance that the tensions can keep from the nearest bound. It is
positive inside the workspace, zero on its boundary, negative outside, where ``-margin``
is the smallest largest bound violation of any tensions in equilibrium (the
infeasibility distance that :func:`tension_opt.distribute` reports for the closed
form), ``+inf`` when the tensions can grow without bound (no finite ``t_max`` and a
strictly positive null vector of ``A``), and ``-inf`` when no tensions at all satisfy
``A T = b`` (a singular pose whose structure matrix cannot produce the wrench). With
several wrenches the margin is the smallest over them. A pose is reported feasible when
``margin >= -FEAS_TOL * scale``, ``scale`` being the pose's typical tension (as in the
closed-form backend).

How the margin is computed
--------------------------
Tensions in equilibrium are ``T = T0 + Z z`` (minimum-norm particular solution and an
orthonormal null-space basis, from a batched SVD), so the margin is the small linear
program ``max s : a_l . z + s <= beta_l`` over the bound lines ``l``. Its dual is
``min sum_l lambda_l beta_l`` over ``lambda >= 0``, ``sum lambda = 1``,
``sum lambda_l a_l = 0``, whose vertices have at most ``d + 1`` nonzeros (``d`` the
null-space dimension). For ``d = 0, 1, 2`` all vertices are enumerated at once for
every pose (pairs of lines of opposite slope in 1-D, triangles around the origin in
2-D): exact, no iteration. Otherwise, or when a backend other than ``"closed_form"``
is named, the same LP with one extra variable goes to a :mod:`tension_opt.backends`
solver, pose by pose.

Large batches are cut into chunks of poses run through
:func:`tension_opt.executors.run_chunks` (in-process, a process pool or Dask); the
chunks are the same whatever the executor, so the result is too.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend
from tension_opt.backends.registry import available_backends, get_backend
from tension_opt.distribute import distribute
from tension_opt.errors import InvalidInputError, UnsupportedProblemError
from tension_opt.executors import Executor, chunk_slices, run_chunks
from tension_opt.problems import StandardForm
from tension_opt.robot import CableRobot
from tension_opt.solution import Status, status_array

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = [
    "FEAS_TOL",
    "MAX_GRID_POINTS",
    "Grid",
    "WorkspaceResult",
    "capacity_margin",
    "cell_widths",
    "on_drawing_point",
    "plot_slice",
    "plot_workspace_3d",
    "sample_poses",
    "workspace_grid",
    "wrench_feasible_workspace",
]

#: Relative tolerance (of the pose's typical tension) below zero still counted feasible.
FEAS_TOL = 1e-9
#: Singular values below this fraction of the largest count as zero (rank of ``A``).
RANK_TOL = 1e-10
#: ``b`` is outside the range of a singular ``A`` when its residual exceeds this fraction.
CONSISTENCY_TOL = 1e-9
#: Without a finite ``t_max`` the LP caps the margin at this many typical tensions.
LP_CAP = 1e6
#: Default number of poses per chunk.
CHUNK_SIZE = 16384
#: Poses per block of the two-dimensional vertex enumeration (bounds its memory).
_BLOCK_2D = 1024
# LP-capable backends tried by backend="auto" where the closed form does not apply.
_LP_ORDER = ("qpsolvers:daqp", "qpsolvers:highs", "scipy:highs", "qpsolvers:piqp",
             "cvxpy:CLARABEL", "cvxpy")

_COORDS = {
    "point3": ("x", "y", "z"),
    "planar_point2": ("x", "z"),
    "planar3": ("x", "y", "theta"),
    "spatial6": ("x", "y", "z", "rx", "ry", "rz"),
}
# Pose coordinates that are positions (m); the others are angles (rad).
_POSITIONS = {"point3": (0, 1, 2), "planar_point2": (0, 1), "planar3": (0, 1),
              "spatial6": (0, 1, 2)}


# ----------------------------------------------------------------------------- poses
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


#: Largest number of points :func:`workspace_grid` builds.
MAX_GRID_POINTS = 50_000_000


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
    lo, hi = _box(lower, upper)
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
        shape = "x".join(f"{k:.0f}" for k in k_float)
        raise InvalidInputError(f"the grid would have {total:.3g} points ({shape}), more than "
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
    mesh = np.meshgrid(*axes, indexing="ij")
    poses = np.stack([g.ravel() for g in mesh], axis=1)
    return Grid(poses, tuple(len(a) for a in axes), tuple(axes), lo.copy(), hi.copy())


def _box(lower: ArrayLike, upper: ArrayLike) -> tuple[NDArray, NDArray]:
    """Checked corners of a box: finite vectors of one length with lower <= upper."""
    lo = np.atleast_1d(np.asarray(lower, dtype=float))
    hi = np.atleast_1d(np.asarray(upper, dtype=float))
    if lo.shape != hi.shape or lo.ndim != 1:
        raise InvalidInputError(f"lower and upper must be vectors of one length; got "
                                f"{lo.shape} and {hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or (hi < lo).any():
        raise InvalidInputError(f"the box needs finite lower <= upper; got {lo} and {hi}")
    return lo, hi


def sample_poses(lower: ArrayLike, upper: ArrayLike, count: int,
                 seed: int | np.random.Generator | None = None) -> NDArray:
    """Poses drawn uniformly in the box ``lower <= pose <= upper``.

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        Corners of the box (m, rad), finite.
    count : int
        Number of poses N >= 1 (a whole number).
    seed : int or numpy.random.Generator, optional

    Returns
    -------
    ndarray, shape (N, n)
    """
    lo, hi = _box(lower, upper)
    try:
        whole = (not isinstance(count, (bool, np.bool_)) and float(count).is_integer()
                 and count >= 1)
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole:
        raise InvalidInputError(f"count must be a whole number >= 1; got {count!r}")
    rng = np.random.default_rng(seed)
    return lo + (hi - lo) * rng.random((int(count), lo.size))


# ---------------------------------------------------------------------------- result
@dataclass(eq=False)
class WorkspaceResult:
    """Wrench feasibility, capacity margin and minimum-sum tensions of a batch of poses.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        The poses checked (m, rad).
    feasible : ndarray of bool, shape (N,)
        Every wrench of the set can be held with tensions within the bounds.
    margin : ndarray, shape (N,)
        Capacity margin (N): the smallest over the wrenches of the largest ``s`` with
        tensions in ``[t_min + s, t_max - s]`` in equilibrium; see the module docstring.
    tensions : ndarray, shape (N, m)
        Minimum-sum tensions (N) under the critical wrench (the one that sets the
        margin); NaN where infeasible.
    status : ndarray of Status, shape (N,)
        ``OPTIMAL`` where feasible and the tensions were found, ``INFEASIBLE``, or the
        status of a failed solve.
    margins : ndarray, shape (N, K)
        Capacity margin under each wrench (N).
    critical_wrench : ndarray of int, shape (N,)
        Index of the wrench with the smallest margin.
    wrenches : ndarray, shape (K, n)
        External wrenches besides gravity (N, N m); a zero row for the weight alone.
    grid_shape : tuple of int, optional
        Shape of the grid the poses came from (C order), None for samples.
    axes : tuple of ndarray, optional
        Grid points along each pose coordinate.
    bounds : tuple of ndarray, optional
        ``(lower, upper)`` of the sampled box or of the grid's box, shape (n,) each
        (m, rad), for :meth:`volume`.
    robot : CableRobot, optional
        The robot (anchors are drawn by the plots).
    backend : str
        How the margins were computed: ``"closed_form"``, a backend name, or both.
    """

    poses: NDArray
    feasible: NDArray
    margin: NDArray
    tensions: NDArray
    status: NDArray
    margins: NDArray
    critical_wrench: NDArray
    wrenches: NDArray
    grid_shape: tuple[int, ...] | None = None
    axes: tuple[NDArray, ...] | None = None
    bounds: tuple[NDArray, NDArray] | None = None
    robot: CableRobot | None = None
    backend: str = ""
    extras: dict[str, Any] = field(default_factory=dict)

    #: Quantities of :meth:`quantity` with their plot labels (units).
    QUANTITIES: ClassVar[dict[str, str]] = {
        "margin": "capacity margin (N)",
        "feasible": "wrench-feasible",
        "tension_sum": "sum of min-sum tensions (N)",
        "max_tension": "largest min-sum tension (N)",
    }

    @property
    def N(self) -> int:
        """Number of poses."""
        return int(self.poses.shape[0])

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """Names of the pose coordinates (``x, y, z`` ...)."""
        kind = self.robot.kind if self.robot is not None else None
        if kind is not None:
            return _COORDS[kind]
        return tuple(f"q{i}" for i in range(self.poses.shape[1]))

    def fraction(self) -> float:
        """Fraction of the poses that are feasible."""
        return float(np.mean(self.feasible)) if self.N else 0.0

    def quantity(self, name: str) -> NDArray:
        """A per-pose quantity by name, shape (N,).

        ``"margin"`` (N), ``"feasible"`` (0/1), ``"tension_sum"`` (N), ``"max_tension"``
        (N), ``"T1"`` .. ``"Tm"`` (N); subclasses add their own (``"sag_correction"``).
        """
        if name == "margin":
            return self.margin
        if name == "feasible":
            return self.feasible.astype(float)
        if name == "tension_sum":
            return self.tensions.sum(axis=1)
        if name == "max_tension":
            return self.tensions.max(axis=1)
        if name.startswith("T") and name[1:].isdigit():
            i = int(name[1:]) - 1
            if 0 <= i < self.tensions.shape[1]:
                return self.tensions[:, i]
        value = getattr(self, name, None)
        if isinstance(value, np.ndarray) and value.shape == (self.N,):
            return value.astype(float)
        raise InvalidInputError(f"unknown quantity {name!r}; choose one of "
                                f"{[*self.QUANTITIES, 'T1']}")

    def label(self, name: str) -> str:
        """Plot label of a quantity, with its unit."""
        if name.startswith("T") and name[1:].isdigit():
            return f"tension {name} (N)"
        return self.QUANTITIES.get(name, name)

    def volume(self) -> float:
        """Measure of the feasible positions: m^3 (m^2 for planar robots).

        On a grid: the sum of the cells ``dx dy dz`` of the feasible points, each point
        standing for its cell in the grid's box (``bounds``; see :func:`cell_widths`:
        equal cells on a ``spacing`` grid, half cells at the ends of a ``counts``
        grid), so a feasible box gives its own volume either way. The grid must keep
        the orientation fixed and its box must extend along every position coordinate
        (one point across a nonzero width is fine). For samples: the feasible fraction
        times the volume of the sampled box (``bounds``; else the bounding box of the
        poses) over the position coordinates.
        """
        kind = self.robot.kind if self.robot is not None else "point3"
        pos = _POSITIONS[kind]
        if self.grid_shape is not None and self.axes is not None:
            others = [i for i in range(len(self.grid_shape)) if i not in pos]
            if any(self.grid_shape[i] > 1 for i in others):
                raise InvalidInputError("volume() needs a grid of fixed orientation; use "
                                        "fraction() for a grid over angles")
            cells = np.ones(self.grid_shape)
            for i in pos:
                if self.bounds is not None:
                    w = cell_widths(self.axes[i], self.bounds[0][i], self.bounds[1][i])
                else:
                    w = cell_widths(self.axes[i])
                if not (w > 0).all():
                    raise InvalidInputError(
                        f"volume() needs a grid whose box extends along every position "
                        f"coordinate; {self.coordinate_names[i]} is fixed")
                shape = [1] * len(self.grid_shape)
                shape[i] = len(w)
                cells = cells * w.reshape(shape)
            return float(cells.ravel()[np.asarray(self.feasible, dtype=bool)].sum())
        if self.bounds is not None:
            lo, hi = self.bounds
        else:
            lo, hi = self.poses.min(axis=0), self.poses.max(axis=0)
        box = float(np.prod([hi[i] - lo[i] for i in pos]))
        return self.fraction() * box

    def reshape(self, values: ArrayLike) -> NDArray:
        """Per-pose values (N, ...) reshaped to the grid, shape ``grid_shape + (...)``."""
        if self.grid_shape is None:
            raise InvalidInputError("these poses are not a grid")
        arr = np.asarray(values)
        return arr.reshape(*self.grid_shape, *arr.shape[1:])

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: coordinates, feasible, margin, status, tensions."""
        frame = pd.DataFrame(self.poses, columns=list(self.coordinate_names))
        frame["feasible"] = self.feasible
        frame["margin"] = self.margin
        frame["status"] = [str(s) for s in self.status]
        for i in range(self.tensions.shape[1]):
            frame[f"T{i + 1}"] = self.tensions[:, i]
        if self.margins.shape[1] > 1:
            for k in range(self.margins.shape[1]):
                frame[f"margin_w{k}"] = self.margins[:, k]
            frame["critical_wrench"] = self.critical_wrench
        self._extra_columns(frame)
        return frame

    def _extra_columns(self, frame: pd.DataFrame) -> None:
        """Hook for subclasses: add their own columns."""

    def __repr__(self) -> str:
        name = self.robot.name if self.robot is not None else "robot"
        return (f"{type(self).__name__}({name!r}, N={self.N}, feasible={self.fraction():.3f}, "
                f"grid={self.grid_shape}, K={self.wrenches.shape[0]}, backend={self.backend!r})")


# ------------------------------------------------------------------ margin: geometry
def _typical(A: NDArray, b: NDArray, lb: NDArray) -> NDArray:
    """Typical tension per pose (N), as :meth:`StandardForm.scale`."""
    col = np.linalg.norm(A, axis=1).max(axis=1)
    s = np.linalg.norm(b, axis=1) / np.maximum(col, 1e-300)
    finite_lb = np.where(np.isfinite(lb), np.abs(lb), 0.0).max(axis=1)
    return np.maximum(np.maximum(s, finite_lb), 1e-12)


def _affine(A: NDArray, b: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Solutions of ``A T = b``: minimum-norm ``T0`` (N, m), right singular vectors
    ``Vt`` (N, m, m), rank (N,) and whether ``b`` is in the range of ``A`` (N,)."""
    U, S, Vt = np.linalg.svd(A, full_matrices=True)
    top = S[:, :1]
    rank = (S > RANK_TOL * np.maximum(top, 1e-300)).sum(axis=1)
    r_max = S.shape[1]
    keep = np.arange(r_max)[None, :] < rank[:, None]
    Utb = np.einsum("nij,ni->nj", U, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.where(keep, Utb[:, :r_max] / S, 0.0)
    T0 = np.einsum("nk,nkm->nm", coef, Vt[:, :r_max, :])
    outside = np.where(np.arange(Utb.shape[1])[None, :] < rank[:, None], 0.0, Utb)
    consistent = np.linalg.norm(outside, axis=1) <= CONSISTENCY_TOL * np.linalg.norm(b, axis=1)
    return T0, Vt, rank, consistent


def _lines(T0: NDArray, Z: NDArray, lo_c: NDArray, lo_g: NDArray, hi_c: NDArray,
           hi_g: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Bound lines ``a_l . z + gamma_l s <= beta_l`` of ``T = T0 + Z z`` (T0 (N, m), Z
    (N, m, d)): normals (N, L, d), gamma (N, L), beta (N, L) and validity (N, L).

    Lower bounds ``T_i >= lo_c_i + lo_g_i s`` and upper bounds ``T_i <= hi_c_i - hi_g_i s``;
    infinite ``lo_c`` / ``hi_c`` give no line. Lines absent for every pose are dropped.
    """
    a = np.concatenate([-Z, Z], axis=1)
    gamma = np.concatenate([lo_g, hi_g], axis=1)
    with np.errstate(invalid="ignore"):
        beta = np.concatenate([T0 - lo_c, hi_c - T0], axis=1)
    valid = np.isfinite(beta)
    keep = valid.any(axis=0)
    a, gamma, beta, valid = a[:, keep], gamma[:, keep], beta[:, keep], valid[:, keep]
    return a, np.where(valid, gamma, 1.0), np.where(valid, beta, 0.0), valid


def _maxmin_0d(beta: NDArray, gamma: NDArray, valid: NDArray) -> NDArray:
    """Margin when the tensions are unique: the smallest ``beta / gamma``, shape (N,)."""
    return np.where(valid, beta / gamma, np.inf).min(axis=1, initial=np.inf)


def _maxmin_1d(a: NDArray, gamma: NDArray, beta: NDArray, valid: NDArray,
               z_ref: NDArray | None = None, z_box: tuple[NDArray, NDArray] | None = None
               ) -> tuple[NDArray, NDArray | None]:
    """``max s : a_l z + gamma_l s <= beta_l`` over scalar ``z``, for all poses at once.

    The dual optimum is a pair of lines of opposite slope (the crossing of a rising and
    a falling line of ``s(z)``) or a single line with zero slope.

    Parameters
    ----------
    a, gamma, beta, valid : ndarray, shape (N, L)
        ``gamma > 0``.
    z_ref : ndarray, shape (N,), optional
        Also return the maximiser closest to ``z_ref`` (the maximisers form an interval).
    z_box : (ndarray, ndarray), each shape (N,), optional
        Keep ``z`` in ``[lower, upper]`` (non-empty): the maximum of the concave ``s(z)``
        there is at the free maximiser, or at the end nearest to it.

    Returns
    -------
    s : ndarray, shape (N,)
        ``+inf`` where unbounded.
    z : ndarray, shape (N,) or None
    """
    amax = np.abs(np.where(valid, a, 0.0)).max(axis=1, keepdims=True)
    flat = valid & (np.abs(a) <= 1e-14 * amax)
    a = np.where(flat | ~valid, 0.0, a)
    rise, fall = valid & (a > 0), valid & (a < 0)
    ai, aj = a[:, :, None], a[:, None, :]
    bi, bj = beta[:, :, None], beta[:, None, :]
    gi, gj = gamma[:, :, None], gamma[:, None, :]
    pair = rise[:, :, None] & fall[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        value = (ai * bj - aj * bi) / (ai * gj - aj * gi)
    s_pair = np.where(pair, value, np.inf).min(axis=(1, 2), initial=np.inf)
    s_flat = np.where(flat, beta / gamma, np.inf).min(axis=1, initial=np.inf)
    s = np.minimum(s_pair, s_flat)
    if z_ref is None and z_box is None:
        return s, None
    with np.errstate(divide="ignore", invalid="ignore"):
        rhs = beta - gamma * s[:, None]
        hi = np.where(rise, rhs / a, np.inf).min(axis=1, initial=np.inf)
        lo = np.where(fall, rhs / a, -np.inf).max(axis=1, initial=-np.inf)
    inverted = lo > hi  # a single point, up to rounding
    mid = 0.5 * (lo + hi)
    lo, hi = np.where(inverted, mid, lo), np.where(inverted, mid, hi)
    ref = np.zeros(len(s)) if z_ref is None else z_ref
    z = np.where(np.isfinite(s), np.clip(ref, lo, hi), ref)
    if z_box is not None:
        zb_lo, zb_hi = z_box
        z = np.clip(z, zb_lo, zb_hi)
        moved = (z < lo) | (z > hi)
        with np.errstate(invalid="ignore"):
            s_at = np.where(valid, (beta - a * z[:, None]) / gamma, np.inf).min(
                axis=1, initial=np.inf)
        s = np.where(moved | ~np.isfinite(s), s_at, s)
    return s, z


def _cross(u: NDArray, v: NDArray) -> NDArray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _maxmin_2d(a: NDArray, gamma: NDArray, beta: NDArray, valid: NDArray) -> NDArray:
    """``max s : a_l . z + gamma_l s <= beta_l`` over ``z`` in R^2, shape (N,).

    Dual vertices: triangles of normals around the origin (``lambda`` from the cross
    products), antiparallel pairs, and lines with zero normal. ``+inf`` if none.
    """
    N, L, _ = a.shape
    out = np.empty(N)
    norm = np.linalg.norm(a, axis=2)
    nmax = np.where(valid, norm, 0.0).max(axis=1, keepdims=True)
    flat = valid & (norm <= 1e-14 * nmax)
    moving = valid & ~flat
    tri = np.array(list(itertools.combinations(range(L), 3)), dtype=int).reshape(-1, 3)
    duo = np.array(list(itertools.combinations(range(L), 2)), dtype=int).reshape(-1, 2)
    for start in range(0, N, _BLOCK_2D):
        sl = slice(start, min(start + _BLOCK_2D, N))
        aa, gg, bb, mv, nn = a[sl], gamma[sl], beta[sl], moving[sl], norm[sl]
        best = np.where(flat[sl], bb / gg, np.inf).min(axis=1, initial=np.inf)
        if len(tri):
            i, j, k = tri.T
            ai, aj, ak = aa[:, i], aa[:, j], aa[:, k]
            c = np.stack([_cross(aj, ak), _cross(ak, ai), _cross(ai, aj)], axis=-1)
            det = c.sum(axis=-1)
            size = nn[:, i] * nn[:, j] + nn[:, j] * nn[:, k] + nn[:, k] * nn[:, i]
            ok = mv[:, i] & mv[:, j] & mv[:, k] & (np.abs(det) > 1e-12 * size)
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = c / det[..., None]
                ok &= (lam >= -1e-12).all(axis=-1)
                g3 = np.stack([gg[:, i], gg[:, j], gg[:, k]], axis=-1)
                b3 = np.stack([bb[:, i], bb[:, j], bb[:, k]], axis=-1)
                val = (lam * b3).sum(axis=-1) / (lam * g3).sum(axis=-1)
            best = np.minimum(best, np.where(ok, val, np.inf).min(axis=1, initial=np.inf))
        if len(duo):
            i, j = duo.T
            ai, aj = aa[:, i], aa[:, j]
            ni, nj = nn[:, i], nn[:, j]
            anti = (mv[:, i] & mv[:, j] & (np.abs(_cross(ai, aj)) <= 1e-12 * ni * nj)
                    & ((ai * aj).sum(axis=-1) < 0))
            with np.errstate(divide="ignore", invalid="ignore"):
                val = (nj * bb[:, i] + ni * bb[:, j]) / (nj * gg[:, i] + ni * gg[:, j])
            best = np.minimum(best, np.where(anti, val, np.inf).min(axis=1, initial=np.inf))
        out[sl] = best
    return out


# -------------------------------------------------------------------- margin: solvers
def _lp_backend(backend: str | Backend, probe: StandardForm) -> Backend:
    """The backend for the LP path: the one named, or the first installed that can."""
    if isinstance(backend, Backend):
        chosen = backend
    elif backend != "auto":
        chosen = get_backend(backend)
    else:
        installed = set(available_backends())
        for name in _LP_ORDER:
            if name in installed and get_backend(name).unsupported(probe) is None:
                return get_backend(name)
        raise UnsupportedProblemError("no installed backend solves the margin LP; "
                                      "pip install 'tension-opt[solvers]'")
    if chosen.name == "closed_form":
        raise UnsupportedProblemError(
            "the closed form covers null spaces of dimension 0, 1 and 2 only; name an LP "
            f"backend (installed: {[n for n in available_backends() if n != 'closed_form']})")
    reason = chosen.unsupported(probe)
    if reason is not None:
        raise UnsupportedProblemError(f"{reason}: the margin is a linear program")
    return chosen


def _margin_form(A: NDArray, b: NDArray, lo_c: NDArray, lo_g: NDArray, hi_c: NDArray,
                 hi_g: NDArray, floor: NDArray | None = None
                 ) -> tuple[StandardForm, NDArray, NDArray]:
    """The margin LP as a :class:`StandardForm` in ``(y, s)``; the cap on ``s`` (N,) and
    whether each pose has a finite upper bound (N,). See :func:`margin_lp`."""
    N, _, m = A.shape
    typical = _typical(A, b, lo_c)
    finite_hi = np.isfinite(hi_c)
    cols = np.flatnonzero(finite_hi.any(axis=0))
    big = lo_c + LP_CAP * typical[:, None]
    hi_fill = np.where(finite_hi, hi_c, big)
    A_aug = np.concatenate([A, np.einsum("nim,nm->ni", A, lo_g)[..., None]], axis=2)
    any_hi = finite_hi.any(axis=1)
    cap = np.where(any_hi, np.inf, LP_CAP * typical)
    lb = np.concatenate([lo_c, np.full((N, 1), -np.inf)], axis=1)
    ub = np.concatenate([np.full((N, m), np.inf), cap[:, None]], axis=1)
    c = np.zeros((N, m + 1))
    c[:, m] = -1.0
    G = h = None
    if len(cols):
        G = np.zeros((N, len(cols), m + 1))
        G[:, np.arange(len(cols)), cols] = 1.0
        G[:, :, m] = (lo_g + hi_g)[:, cols]
        h = hi_fill[:, cols]
    if floor is not None:  # T = y + lo_g s >= floor, whatever s
        F = np.zeros((N, m, m + 1))
        F[:, np.arange(m), np.arange(m)] = -1.0
        F[:, :, m] = -lo_g
        G = F if G is None else np.concatenate([G, F], axis=1)
        h = -floor if h is None else np.concatenate([h, -floor], axis=1)
    form = StandardForm(A_aug, b, lb, ub, np.zeros((N, m + 1)), c, G=G, h=h)
    return form, cap, any_hi


def margin_lp(backend: str | Backend, A: NDArray, b: NDArray, lo_c: NDArray,
              lo_g: NDArray, hi_c: NDArray, hi_g: NDArray, *, floor: NDArray | None = None,
              _probe: bool = False, **options: Any) -> tuple[NDArray, NDArray, NDArray]:
    """The margin LP ``max s : A T = b, lo_c + lo_g s <= T <= hi_c - hi_g s`` by a backend.

    Written for the backend with ``y = T - lo_g s`` (a box bound ``y >= lo_c``), one
    extra column ``A lo_g`` for ``s`` and rows ``y_i + (lo_g_i + hi_g_i) s <= hi_c_i``
    for finite upper bounds. Without any finite upper bound ``s`` is capped at
    ``LP_CAP`` typical tensions; a pose at the cap is reported ``+inf`` when ``A`` has
    a strictly positive null vector (then the margin is unbounded).

    Parameters
    ----------
    backend : str or Backend
        An LP-capable backend name or ``"auto"``.
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lo_c, lo_g, hi_c, hi_g : ndarray, shape (N, m)
        ``lo_c`` finite; ``lo_g, hi_g > 0`` (N/N).
    floor : ndarray, shape (N, m), optional
        Lower bounds on ``T`` that do not move with ``s`` (N).

    Returns
    -------
    margin : ndarray, shape (N,)
        ``-inf`` where no tensions satisfy ``A T = b`` (and ``floor``); NaN where the
        solver failed.
    tensions : ndarray, shape (N, m)
        A maximiser (N).
    status : ndarray of Status, shape (N,)
    """
    _, n, m = A.shape
    form, cap, any_hi = _margin_form(A, b, lo_c, lo_g, hi_c, hi_g, floor)
    solver = _lp_backend(backend, form)
    raw = solver.solve_stage(form, **options)
    x = np.asarray(raw.tensions, dtype=float)
    status = np.asarray(raw.status, dtype=object).copy()
    ok = (status == Status.OPTIMAL) | (status == Status.INACCURATE)
    s = np.where(ok, x[:, m], np.nan)
    T = x[:, :m] + lo_g * x[:, m:]
    T[~ok] = np.nan
    infeasible = status == Status.INFEASIBLE
    s[infeasible] = -np.inf
    capped = ok & ~any_hi & (s >= cap * (1 - 1e-6))
    if capped.any() and not _probe:
        idx = np.flatnonzero(capped)
        ones = np.ones((len(idx), m))
        sig, _, _ = margin_lp(solver, A[idx], np.zeros((len(idx), n)), ones, ones,
                               np.full((len(idx), m), np.inf), ones, _probe=True, **options)
        # With b = 0 and t_min = 1 the margin is -1 (T = 0) unless a positive null
        # vector lets it grow to the cap.
        unbounded = sig > 0
        s[idx[unbounded]] = np.inf
        status[idx[~unbounded]] = Status.INACCURATE
    return s, T, status


def margin_solve(A: NDArray, b: NDArray, lo_c: NDArray, lo_g: NDArray, hi_c: NDArray,
                 hi_g: NDArray, backend: str | Backend = "auto", *, argmax: bool = False,
                 reference: NDArray | None = None, floor: NDArray | None = None,
                 **options: Any) -> tuple[NDArray, NDArray | None, NDArray, str]:
    """``max s : A T = b, lo_c + lo_g s <= T <= hi_c - hi_g s`` for a batch of poses.

    The capacity margin for ``lo_c = t_min, hi_c = t_max, lo_g = hi_g = 1``; other
    ``lo_g, hi_g`` serve linearised bounds (the sag-aware margin of
    :mod:`catenary.workspace`).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lo_c, hi_c : ndarray, shape (N, m)
        Bounds at ``s = 0`` (N); ``lo_c`` finite, ``hi_c`` may be ``inf``.
    lo_g, hi_g : ndarray, shape (N, m)
        Positive rates at which the bounds close in with ``s`` (N/N).
    backend : str or Backend
        ``"auto"``: closed form where the null space has dimension <= 2 (<= 1 with
        ``argmax``), the first installed LP solver elsewhere; ``"closed_form"``: closed
        form only; an LP backend name: that solver for every pose.
    argmax : bool
        Also return a maximiser.
    reference : ndarray, shape (N, m), optional
        With ``argmax``, where the maximisers form a set (null-space dimension 1): the
        one closest to ``reference`` (default: the minimum-norm solution ``T0``).
    floor : ndarray, shape (N, m), optional
        Lower bounds on ``T`` (N) that do not move with ``s`` (closed form for null
        spaces of dimension 0 and 1, LP otherwise).
    **options
        Passed to the LP backend.

    Returns
    -------
    margin : ndarray, shape (N,)
        ``+inf`` unbounded, ``-inf`` where ``A T = b`` has no solution, NaN where a
        solver failed.
    tensions : ndarray, shape (N, m), or None
        A maximiser (N) if ``argmax``.
    status : ndarray of Status, shape (N,)
        ``OPTIMAL`` where the margin was found (also when negative or infinite), else
        the solver's status.
    method : str
        ``"closed_form"``, an LP backend name, or both joined by ``+``.
    """
    N, _, m = A.shape
    exact = isinstance(backend, str) and backend in ("auto", "closed_form")
    T0, Vt, rank, consistent = _affine(A, b)
    dim = m - rank
    margin = np.full(N, np.nan)
    margin[~consistent] = -np.inf
    T = np.full((N, m), np.nan) if argmax else None
    handled = ~consistent
    status = status_array(N)
    used: list[str] = []
    for d in (0, 1, 2) if exact else ():
        sel = np.flatnonzero(consistent & (dim == d))
        if not len(sel) or (d == 2 and (argmax or floor is not None)):
            continue
        Z = np.swapaxes(Vt[sel, m - d:, :], 1, 2)
        a, g, beta, valid = _lines(T0[sel], Z, lo_c[sel], lo_g[sel], hi_c[sel], hi_g[sel])
        if d == 0:
            margin[sel] = _maxmin_0d(beta, g, valid)
            if floor is not None:
                below = (T0[sel] < floor[sel]).any(axis=1)
                margin[sel[below]] = -np.inf
            if T is not None:
                T[sel] = T0[sel]
        elif d == 1:
            n_vec = Z[..., 0]
            z_ref = z_box = None
            if argmax:
                ref = T0[sel] if reference is None else reference[sel]
                z_ref = np.einsum("nm,nm->n", ref - T0[sel], n_vec)
            if floor is not None:  # T0 + n z >= floor: an interval of z
                with np.errstate(divide="ignore", invalid="ignore"):
                    r = (floor[sel] - T0[sel]) / n_vec
                up, down = n_vec > 0, n_vec < 0
                z_lo = np.where(up, r, -np.inf).max(axis=1)
                z_hi = np.where(down, r, np.inf).min(axis=1)
                stuck = ((n_vec == 0) & (T0[sel] < floor[sel])).any(axis=1)
                empty = stuck | (z_lo > z_hi)
                z_box = (np.where(empty, 0.0, z_lo), np.where(empty, 0.0, z_hi))
            margin[sel], z = _maxmin_1d(a[..., 0], g, beta, valid, z_ref, z_box)
            if z_box is not None:
                margin[sel[empty]] = -np.inf
            if T is not None and z is not None:
                T[sel] = T0[sel] + z[:, None] * n_vec
        else:
            margin[sel] = _maxmin_2d(a, g, beta, valid)
        handled[sel] = True
    if exact and handled.any():
        used.append("closed_form")
    rest = np.flatnonzero(~handled)
    if len(rest):
        probe = _margin_form(A[rest[:1]], b[rest[:1]], lo_c[rest[:1]], lo_g[rest[:1]],
                             hi_c[rest[:1]], hi_g[rest[:1]])[0]
        solver = _lp_backend(backend, probe)
        s, T_lp, st = margin_lp(solver, A[rest], b[rest], lo_c[rest], lo_g[rest],
                                hi_c[rest], hi_g[rest],
                                floor=None if floor is None else floor[rest], **options)
        margin[rest] = s
        if T is not None:
            T[rest] = T_lp
        failed = ~((st == Status.OPTIMAL) | (st == Status.INACCURATE)
                   | (st == Status.INFEASIBLE))
        status[rest[failed]] = st[failed]
        used.append(solver.name)
    return margin, T, status, "+".join(used)


def _bounds(robot: CableRobot, N: int) -> tuple[NDArray, NDArray]:
    lb = np.broadcast_to(np.asarray(robot.t_min, dtype=float), (N, robot.m))
    ub = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (N, robot.m))
    return np.array(lb), np.array(ub)


def _margins(robot: CableRobot, poses: NDArray, wrench: ArrayLike | None,
             backend: str | Backend, options: dict[str, Any]
             ) -> tuple[NDArray, NDArray, NDArray, str]:
    """Capacity margin of validated poses (N, n) under a wrench (n,) or (N, n), or None.

    Returns margin (N,), status (N,), typical tension (N,) and the method used.
    """
    N = poses.shape[0]
    A = robot.structure_matrices(poses)
    b = robot.required_wrench(poses, wrench)
    lb, ub = _bounds(robot, N)
    ones = np.ones_like(lb)
    margin, _, status, method = margin_solve(A, b, lb, ones, ub, ones, backend, **options)
    return margin, status, _typical(A, b, lb), method


def capacity_margin(robot: CableRobot, poses: ArrayLike, wrench: ArrayLike | None = None,
                    backend: str | Backend = "auto", **options: Any) -> NDArray:
    """Capacity margin of each pose under one wrench (see the module docstring).

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    backend : str or Backend
        ``"auto"``/``"closed_form"``: exact enumeration where the null space has
        dimension <= 2 (LP elsewhere, for ``"auto"``); an LP backend name: that solver.
    **options
        Passed to the LP backend.

    Returns
    -------
    ndarray, shape (N,)
        Margin (N): positive inside, negative outside, ``+inf`` unbounded, ``-inf`` where
        no tensions are in equilibrium, NaN where a solver failed.
    """
    p = robot.as_poses(poses)
    return _margins(robot, p, wrench, backend, options)[0]


# ------------------------------------------------------------------------ workspace
def _as_wrenches(robot: CableRobot, wrenches: ArrayLike | None) -> NDArray:
    if wrenches is None:
        return np.zeros((1, robot.dof))
    W = np.asarray(wrenches, dtype=float)
    if W.ndim == 1:
        W = W[None]
    if W.ndim != 2 or W.shape[1] != robot.dof or W.shape[0] < 1:
        raise InvalidInputError(f"wrenches must have shape ({robot.dof},) or (K, {robot.dof}); "
                                f"got {np.shape(wrenches)}")
    if not np.isfinite(W).all():
        raise InvalidInputError("wrenches must be finite")
    return W


@dataclass(frozen=True)
class _Task:
    """One chunk of a workspace check (picklable for process pools and Dask)."""

    robot: CableRobot
    poses: NDArray
    wrenches: NDArray
    backend: str | Backend
    options: dict[str, Any]


def on_drawing_point(robot: CableRobot, poses: NDArray) -> NDArray:
    """Poses that put some cable on its drawing point (zero length), shape (N,) of bool.

    The same test as the robot's own (:meth:`CableRobot.structure_matrices` raises
    there): a cable shorter than ``1e-12`` times the largest anchor coordinate (at
    least 1 m). Such a pose has no cable direction, so the workspace functions report
    it infeasible instead of computing it.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Validated poses (m, rad).
    """
    position, R = robot.frames(poses)
    if robot.kind in ("point3", "planar_point2"):
        arm = np.broadcast_to(robot.attachments, (len(poses), *robot.attachments.shape))
    else:
        arm = np.einsum("nij,mj->nmi", R, robot.attachments)
    vec = robot.anchors[None] - (position[:, None, :] + arm)
    lengths = np.sqrt(np.einsum("nmi,nmi->nm", vec, vec))
    scale = np.maximum(1.0, np.abs(robot.anchors).max())
    return np.asarray((lengths <= 1e-12 * scale).any(axis=1), dtype=bool)


def _chunk(task: _Task) -> dict[str, Any]:
    """Margins, feasibility and minimum-sum tensions of one chunk of poses.

    Poses on a drawing point (:func:`on_drawing_point`) are not computed: infeasible,
    margin ``-inf``, NaN tensions, status ``INFEASIBLE``; so are no poses at all.
    """
    robot, P, W = task.robot, task.poses, task.wrenches
    N, K = P.shape[0], W.shape[0]
    out: dict[str, Any] = {
        "margins": np.full((N, K), -np.inf), "margin": np.full(N, -np.inf),
        "crit": np.zeros(N, dtype=np.intp), "feasible": np.zeros(N, dtype=bool),
        "tensions": np.full((N, robot.m), np.nan), "status": status_array(N, Status.INFEASIBLE),
        "method": ""}
    ok = ~on_drawing_point(robot, P) if N else np.zeros(0, dtype=bool)
    if ok.any():
        part = _chunk_poses(task, P[ok])
        for key, value in part.items():
            if key == "method":
                out[key] = value
            else:
                out[key][ok] = value
    return out


def _chunk_poses(task: _Task, P: NDArray) -> dict[str, Any]:
    """:func:`_chunk` of poses ``P`` (N, n) that keep every cable off its drawing point."""
    robot, W = task.robot, task.wrenches
    N, K = P.shape[0], W.shape[0]
    margins = np.empty((N, K))
    typical = np.empty((N, K))
    status_k = np.empty((N, K), dtype=object)
    method = ""
    for k in range(K):  # a handful of wrenches; every pose at once inside
        wk = W[k] if W[k].any() else None
        margins[:, k], status_k[:, k], typical[:, k], method = _margins(
            robot, P, wk, task.backend, task.options)
    with np.errstate(invalid="ignore"):
        crit = np.argmin(np.where(np.isnan(margins), -np.inf, margins), axis=1)
    rows = np.arange(N)
    margin = margins[rows, crit]
    solved = (status_k == Status.OPTIMAL).all(axis=1)
    margin = np.where(solved, margin, np.nan)
    feasible = solved & (margin >= -FEAS_TOL * typical.max(axis=1))
    status = status_array(N, Status.INFEASIBLE)
    for k in range(K):
        bad = ~(status_k[:, k] == Status.OPTIMAL)
        status[bad] = status_k[bad, k]
    tensions = np.full((N, robot.m), np.nan)
    idx = np.flatnonzero(feasible)
    if len(idx):
        Wc = W[crit[idx]]
        sol = distribute(robot, P[idx], "min_sum",
                         "auto" if task.backend == "closed_form" else task.backend,
                         wrench=Wc if Wc.any() else None, **task.options)
        tensions[idx] = sol.tensions
        status[idx] = sol.status
    return {"margins": margins, "margin": margin, "crit": crit, "feasible": feasible,
            "tensions": tensions, "status": status, "method": method}


def _merge(parts: Sequence[dict[str, Any]], keys: Sequence[str]) -> dict[str, NDArray]:
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


def _check_bounds(bounds: Any, n: int) -> tuple[NDArray, NDArray]:
    """``bounds`` as two finite vectors of shape (n,) with ``lower <= upper``."""
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


def prepare(robot: CableRobot, poses: ArrayLike | Grid, wrenches: ArrayLike | None,
            bounds: tuple[ArrayLike, ArrayLike] | None
            ) -> tuple[NDArray, NDArray, dict[str, Any]]:
    """Checked poses (N, n), wrenches (K, n) and the layout fields of a result.

    The layout is ``grid_shape``, ``axes`` (from a :class:`Grid`) and ``bounds``: as
    given (checked: shape (n,) each, finite, ``lower <= upper``, around the grid's
    points), else the grid's box (for a :class:`Grid` without one, its outer cells
    reaching half a gap beyond the outer points); as keyword arguments of
    :class:`WorkspaceResult`.
    """
    grid = poses if isinstance(poses, Grid) else None
    P = robot.as_poses(poses.poses if isinstance(poses, Grid) else poses)
    W = _as_wrenches(robot, wrenches)
    box = None
    if bounds is not None:
        box = _check_bounds(bounds, robot.dof)
        if grid is not None and any(a[0] < box[0][i] or a[-1] > box[1][i]
                                    for i, a in enumerate(grid.axes)):
            raise InvalidInputError("bounds must contain the grid's points")
    elif grid is not None and grid.lower is not None and grid.upper is not None:
        box = (np.asarray(grid.lower, dtype=float), np.asarray(grid.upper, dtype=float))
    elif grid is not None:
        box = (np.array([a[0] - 0.5 * (a[1] - a[0]) if len(a) > 1 else a[0]
                         for a in grid.axes]),
               np.array([a[-1] + 0.5 * (a[-1] - a[-2]) if len(a) > 1 else a[-1]
                         for a in grid.axes]))
    layout = {"grid_shape": grid.shape if grid is not None else None,
              "axes": grid.axes if grid is not None else None, "bounds": box}
    return P, W, layout


def wrench_feasible_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
    backend: str | Backend = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    **options: Any,
) -> WorkspaceResult:
    """Which poses hold the weight and every external wrench with tensions in bounds.

    Parameters
    ----------
    robot : CableRobot
        Bounds ``robot.t_min`` / ``robot.t_max`` (N); change them with ``robot.with_``.
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad); a :class:`Grid` from :func:`workspace_grid` keeps its
        shape for :meth:`WorkspaceResult.volume` and the plots.
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches besides gravity (N, N m), each of which must be held on its
        own; include a zero row to also require the weight alone. Default: the weight
        alone.
    backend : str or Backend
        ``"auto"`` (exact enumeration where the null space has dimension <= 2, the
        first installed LP solver elsewhere), ``"closed_form"`` (exact only; error
        where it does not apply) or an LP backend (``"qpsolvers:daqp"``,
        ``"scipy:highs"``, ``"cvxpy:CLARABEL"`` ...) for every pose. The minimum-sum
        tensions come from :func:`tension_opt.distribute` with the same backend.
    executor : str, Executor or dask.distributed.Client, optional
        Where the chunks run: None (this process), ``"processes:N"``,
        ``"dask:tcp://host:port"`` or a Dask client; see :mod:`tension_opt.executors`.
    chunk_size : int
        Poses per chunk. The chunks do not depend on the executor, so neither does
        the result.
    progress : bool
        Show a progress bar over the chunks.
    bounds : (array_like, array_like), optional
        The box the poses were sampled from, shape (n,) each, finite, ``lower <=
        upper`` (m, rad), for :meth:`WorkspaceResult.volume` of samples. Default for a
        :class:`Grid`: its box.
    **options
        Passed to the LP backend and to :func:`tension_opt.distribute`.

    Returns
    -------
    WorkspaceResult
        ``feasible`` (N,), ``margin`` (N,) in N, min-sum ``tensions`` (N, m), ``status``.
        A pose that puts a cable on its drawing point (zero length,
        :func:`on_drawing_point`) does not stop the batch: it is reported infeasible
        with margin ``-inf``, NaN tensions and status ``INFEASIBLE``. No poses (N = 0)
        give an empty result.

    Raises
    ------
    InvalidInputError
        On bad poses, wrenches, bounds or backend.
    """
    P, W, layout = prepare(robot, poses, wrenches, bounds)
    if not isinstance(backend, Backend) and backend not in ("auto", "closed_form"):
        get_backend(backend)  # fail early on an unknown name
    # No poses: one empty chunk, so that the result has the right (empty) shapes.
    tasks = [_Task(robot, P[sl], W, backend, dict(options))
             for sl in chunk_slices(len(P), chunk_size)] or [
                 _Task(robot, P, W, backend, dict(options))]
    parts = run_chunks(_chunk, tasks, executor, progress=progress,
                       description="workspace")
    out = _merge(parts, ("margins", "margin", "crit", "feasible", "tensions", "status"))
    methods = sorted({p["method"] for p in parts if p["method"]})
    return WorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["margin"], tensions=out["tensions"],
        status=out["status"], margins=out["margins"], critical_wrench=out["crit"],
        wrenches=W, robot=robot, backend="+".join(methods), **layout)


# ----------------------------------------------------------------------------- plots
def plot_slice(result: WorkspaceResult, z: float | None = None, quantity: str = "margin",
               *, ax: Axes | None = None, cmap: str | None = None,
               show_anchors: bool = True, boundary: bool = True) -> Axes:
    """Heat map of a quantity over a slice of a grid workspace, with a colour bar.

    Parameters
    ----------
    result : WorkspaceResult
        From a :class:`Grid`.
    z : float, optional
        Height of the x-y slice (m); the nearest grid layer is drawn (default: the
        middle one). The plotted plane is spanned by the first two position coordinates
        with more than one grid point: x-y, or y-z / x-z for a vertical slice (a grid
        with one point in x or y), where ``z`` is ignored, as it is by planar robots
        (x-y, or x-z for ``planar_point2``). Other coordinates must be fixed on the
        grid (except z, whose layer is picked).
    quantity : str
        ``"margin"`` (N), ``"feasible"``, ``"tension_sum"``, ``"max_tension"``,
        ``"T1"``.., or a subclass's own (``"sag_correction"``, m). Infinite values are
        left blank.
    ax : matplotlib Axes, optional
    cmap : str, optional
    show_anchors : bool
        Mark the drawing points (tower tops) projected on the plane.
    boundary : bool
        Draw the workspace boundary (zero-margin contour).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if result.grid_shape is None or result.axes is None:
        raise InvalidInputError("plot_slice needs a result computed on a Grid")
    kind = result.robot.kind if result.robot is not None else "point3"
    names = _COORDS[kind]
    pos = _POSITIONS[kind]
    varying = [i for i in pos if result.grid_shape[i] > 1]
    if len(varying) < 2:
        raise InvalidInputError(
            f"plot_slice needs a grid with several points along two position coordinates; "
            f"it has {dict(zip(names, result.grid_shape, strict=True))}")
    h, v = varying[0], varying[1]
    index: list[int | slice] = [slice(None)] * len(result.grid_shape)
    at: list[str] = []  # the fixed position coordinates, for the title
    for i in range(len(result.grid_shape)):
        if i in (h, v):
            continue
        axis = result.axes[i]
        if names[i] == "z" and z is not None:
            j = int(np.argmin(np.abs(axis - z)))
        elif len(axis) == 1:
            j = 0
        elif names[i] == "z":
            j = len(axis) // 2
        else:
            raise InvalidInputError(f"plot_slice needs {names[i]} fixed on the grid; it has "
                                    f"{len(axis)} values")
        index[i] = j
        if i in pos:
            at.append(f"{names[i]} = {float(axis[j]):.3g} m")
    values = result.reshape(result.quantity(quantity))[tuple(index)]
    feasible = result.reshape(result.feasible)[tuple(index)]
    margin = result.reshape(result.margin)[tuple(index)]
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5))
    xs, ys = result.axes[h], result.axes[v]
    data = np.ma.masked_invalid(np.asarray(values, dtype=float).T)
    if quantity == "feasible":
        from matplotlib.colors import ListedColormap

        mesh = ax.pcolormesh(xs, ys, data, shading="nearest",
                             cmap=ListedColormap(["#d9d9d9", "#2b8cbe"]), vmin=0, vmax=1)
        bar = ax.figure.colorbar(mesh, ax=ax, ticks=[0.25, 0.75])
        bar.ax.set_yticklabels(["infeasible", "feasible"])
    else:
        mesh = ax.pcolormesh(xs, ys, data, shading="nearest", cmap=cmap or "viridis")
        bar = ax.figure.colorbar(mesh, ax=ax)
        bar.set_label(result.label(quantity))
    if boundary and np.any(feasible) and not np.all(feasible):
        level = np.asarray(margin, dtype=float)
        top = float(np.nanmax(np.abs(np.where(np.isfinite(level), level, np.nan)), initial=1.0))
        level = np.nan_to_num(level, nan=-2 * top, posinf=2 * top, neginf=-2 * top)
        ax.contour(xs, ys, level.T, levels=[0.0], colors="k", linewidths=1.0)
    if show_anchors and result.robot is not None:
        # Columns of the anchors (x, y, z) of the plotted pose coordinates.
        space = (0, 2) if kind == "planar_point2" else (0, 1, 2)
        ch, cv = space[h], space[v]
        anchors = result.robot.anchors
        ax.scatter(anchors[:, ch], anchors[:, cv], marker="^", s=60, c="crimson",
                   edgecolors="k", zorder=3, label="drawing points", clip_on=False)
        # Room for the drawing points, which often sit on the edge of the grid's box.
        span = [np.concatenate([xs, anchors[:, ch]]), np.concatenate([ys, anchors[:, cv]])]
        for lim, vals, cur in ((ax.set_xlim, span[0], ax.get_xlim()),
                               (ax.set_ylim, span[1], ax.get_ylim())):
            lo, hi = min(cur[0], vals.min()), max(cur[1], vals.max())
            pad = 0.03 * (hi - lo)
            lim(lo - pad, hi + pad)
    unit = {"theta": "rad"}
    ax.set_xlabel(f"{names[h]} ({unit.get(names[h], 'm')})")
    ax.set_ylabel(f"{names[v]} ({unit.get(names[v], 'm')})")
    ax.set_aspect("equal")
    title = result.label(quantity)
    if at:
        title += " at " + ", ".join(at)
    if show_anchors and result.robot is not None:
        title += "  (\u25b2 drawing points)"
    ax.set_title(title, fontsize="medium")
    return ax


def plot_workspace_3d(result: WorkspaceResult, quantity: str = "margin", *,
                      ax: Any = None, max_points: int = 20000,
                      cmap: str | None = None, seed: int = 0) -> Any:
    """3-D scatter of the feasible positions, coloured by a quantity, anchors marked.

    Parameters
    ----------
    result : WorkspaceResult
        Of a ``point3`` or ``spatial6`` robot.
    quantity : str
        Colour (see :meth:`WorkspaceResult.quantity`).
    ax : matplotlib 3-D Axes, optional
    max_points : int
        At most this many feasible poses are drawn (a random subset).

    Returns
    -------
    mpl_toolkits.mplot3d.Axes3D
    """
    import matplotlib.pyplot as plt

    kind = result.robot.kind if result.robot is not None else "point3"
    if kind not in ("point3", "spatial6"):
        raise InvalidInputError("plot_workspace_3d draws robots that move in x, y, z")
    idx = np.flatnonzero(result.feasible)
    if len(idx) > max_points:
        idx = np.sort(np.random.default_rng(seed).choice(idx, max_points, replace=False))
    if ax is None:
        fig = plt.figure(figsize=(7, 6))
        ax = fig.add_subplot(projection="3d")
    values = np.asarray(result.quantity(quantity), dtype=float)[idx]
    values = np.where(np.isfinite(values), values, np.nan)
    pts = result.poses[idx]
    sc = ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], c=values, s=4, cmap=cmap or "viridis",
                    depthshade=False)
    ax.figure.colorbar(sc, ax=ax, shrink=0.7, label=result.label(quantity))
    if result.robot is not None:
        anchors = result.robot.anchors
        ax.scatter(anchors[:, 0], anchors[:, 1], anchors[:, 2], marker="^", s=60,
                   c="crimson", edgecolors="k", label="drawing points")
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(f"wrench-feasible workspace ({len(idx)} poses shown)")
    return ax
