"""The result of a workspace check: :class:`WorkspaceResult`, and criteria combined
(:func:`combine_workspaces`, ``a & b``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.kinds import MotionPattern, get_kind
from tension_opt.robot import CableRobot
from tension_opt.status import Status
from tension_opt.workspace.grid import cell_widths

__all__ = ["WorkspaceResult", "combine_workspaces"]


@dataclass(eq=False)
class WorkspaceResult:
    """Wrench feasibility, capacity margin and minimum-sum tensions of a batch of poses.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        The poses checked (m, rad).
    feasible : ndarray of bool, shape (N,)
        Every wrench of the set can be held with tensions within the bounds (or the
        criterion of ``extras["criterion"]`` holds, :mod:`tension_opt.workspace.criteria`).
    margin : ndarray, shape (N,)
        Capacity margin (N): the smallest over the wrenches of the largest ``s`` with
        tensions in ``[t_min + s, t_max - s]`` in equilibrium; see
        :mod:`tension_opt.workspace.margin`. Other criteria put their own margin here
        (the closure ratio, a clearance excess in m ...).
    tensions : ndarray, shape (N, m)
        Minimum-sum tensions (N) under the critical wrench (the one that sets the
        margin); NaN where infeasible.
    status : ndarray of Status values, shape (N,)
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
    extras : dict
        What a criterion adds: ``"criterion"`` (its name), per-pose arrays (N,) such as
        ``"wrench_space_margin"`` (read by :meth:`quantity`, columns of
        :meth:`to_frame`), and the criterion's own data.

    ``a & b`` is :func:`combine_workspaces` of two results of the same poses.
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
        "wrench_space_margin": "wrench-space margin (N, N m)",
    }

    @property
    def N(self) -> int:
        """Number of poses."""
        return int(self.poses.shape[0])

    @property
    def pattern(self) -> MotionPattern:
        """The robot's motion pattern (a point mass in space without a robot)."""
        return self.robot.pattern if self.robot is not None else get_kind("point3")

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """Names of the pose coordinates (``x, y, z`` ...; ``q0, q1`` ... without a robot)."""
        if self.robot is not None:
            return self.robot.pattern.coordinates
        return tuple(f"q{i}" for i in range(self.poses.shape[1]))

    def fraction(self) -> float:
        """Fraction of the poses that are feasible."""
        return float(np.mean(self.feasible)) if self.N else 0.0

    def quantity(self, name: str) -> NDArray:
        """A per-pose quantity by name, shape (N,).

        ``"margin"`` (N), ``"feasible"`` (0/1), ``"tension_sum"`` (N), ``"max_tension"``
        (N), ``"T1"`` .. ``"Tm"`` (N), a per-pose array of :attr:`extras`
        (``"wrench_space_margin"``, a combined result's ``"<criterion>_margin"``);
        subclasses add their own (``"sag_correction"``).
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
        for value in (self.extras.get(name), getattr(self, name, None)):
            if isinstance(value, np.ndarray) and value.shape == (self.N,):
                return value.astype(float)
        raise InvalidInputError(f"unknown quantity {name!r}; choose one of "
                                f"{[*self.QUANTITIES, 'T1', *self.per_pose_extras()]}")

    def label(self, name: str) -> str:
        """Plot label of a quantity, with its unit (the margin's from
        ``extras["margin_label"]`` where a criterion set one)."""
        if name.startswith("T") and name[1:].isdigit():
            return f"tension {name} (N)"
        if name == "margin" and "margin_label" in self.extras:
            return str(self.extras["margin_label"])
        return self.QUANTITIES.get(name, name)

    def boundary_values(self) -> NDArray:
        """Per-pose values whose zero contour is the workspace's boundary, shape (N,):
        the margin where its sign tells ``feasible`` (negative where infeasible, at
        least ``-1e-6`` of the largest finite margin where feasible), else
        ``feasible - 1/2`` (a closure ratio is 0 outside, a combined result's margin is
        one criterion's)."""
        margin = np.asarray(self.margin, dtype=float)
        feasible = np.asarray(self.feasible, dtype=bool)
        finite = np.abs(margin[np.isfinite(margin)])
        slack = 1e-6 * (float(finite.max()) if finite.size else 1.0)
        with np.errstate(invalid="ignore"):
            told = np.where(feasible, margin >= -slack, margin < 0) | np.isnan(margin)
        return margin if told.all() else feasible - 0.5

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
        pos = self.pattern.positions
        if self.grid_shape is not None and self.axes is not None:
            cells = self._cell_volumes(self.grid_shape, self.axes, pos)
            return float(cells[np.asarray(self.feasible, dtype=bool)].sum())
        if self.bounds is not None:
            lo, hi = self.bounds
        else:
            lo, hi = self.poses.min(axis=0), self.poses.max(axis=0)
        box = float(np.prod([hi[i] - lo[i] for i in pos]))
        return self.fraction() * box

    def _cell_volumes(self, grid_shape: tuple[int, ...], axes: tuple[NDArray, ...],
                      pos: tuple[int, ...]) -> NDArray:
        """Volume (m^3, m^2) of each grid point's cell over the position coordinates
        ``pos``, shape (N,)."""
        others = [i for i in range(len(grid_shape)) if i not in pos]
        if any(grid_shape[i] > 1 for i in others):
            raise InvalidInputError("volume() needs a grid of fixed orientation; use "
                                    "fraction() for a grid over angles")
        cells = np.ones(grid_shape)
        for i in pos:
            if self.bounds is not None:
                w = cell_widths(axes[i], self.bounds[0][i], self.bounds[1][i])
            else:
                w = cell_widths(axes[i])
            if not (w > 0).all():
                raise InvalidInputError(
                    f"volume() needs a grid whose box extends along every position "
                    f"coordinate; {self.coordinate_names[i]} is fixed")
            shape = [1] * len(grid_shape)
            shape[i] = len(w)
            cells = cells * w.reshape(shape)
        return cells.ravel()

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
        for key, value in self.per_pose_extras().items():
            if key not in frame:
                frame[key] = value
        self._extra_columns(frame)
        return frame

    def per_pose_extras(self) -> dict[str, NDArray]:
        """The arrays of :attr:`extras` with one value per pose, shape (N,) each."""
        return {k: v for k, v in self.extras.items()
                if isinstance(v, np.ndarray) and v.shape == (self.N,)}

    def __and__(self, other: object) -> WorkspaceResult:
        if not isinstance(other, WorkspaceResult):
            return NotImplemented
        return combine_workspaces(self, other)

    def _extra_columns(self, frame: pd.DataFrame) -> None:
        """Hook for subclasses: add their own columns."""

    def __repr__(self) -> str:
        name = self.robot.name if self.robot is not None else "robot"
        return (f"{type(self).__name__}({name!r}, N={self.N}, feasible={self.fraction():.3f}, "
                f"grid={self.grid_shape}, K={self.wrenches.shape[0]}, backend={self.backend!r})")



def _parts(result: WorkspaceResult, index: int) -> list[tuple[str, NDArray, NDArray]]:
    """``(criterion, feasible, margin)`` of each criterion a result holds: those it was
    combined from, or its own (named by ``extras["criterion"]``, else by its place)."""
    names = result.extras.get("criteria")
    if names:
        return [(name, result.extras[f"{name}_feasible"], result.extras[f"{name}_margin"])
                for name in names]
    name = str(result.extras.get("criterion") or f"criterion{index}")
    return [(name, np.asarray(result.feasible, dtype=bool), np.asarray(result.margin))]


def combine_workspaces(*results: WorkspaceResult) -> WorkspaceResult:
    """Poses that meet every criterion: the AND of results of the same poses.

    Parameters
    ----------
    *results : WorkspaceResult
        Results of the same poses (equal ``poses`` arrays), from any criteria
        (:func:`~tension_opt.workspace.wrench_feasible_workspace`,
        :func:`~tension_opt.workspace.criteria.wrench_closure_workspace`, ...); a
        combined result may be combined again.

    Returns
    -------
    WorkspaceResult
        ``feasible`` (N,): every criterion holds. Each criterion's own answer is kept in
        ``extras``: ``"criteria"`` (their names, from each result's
        ``extras["criterion"]``; a repeated name gets ``_2``, ``_3`` ...) and per pose
        ``"<name>_feasible"``, ``"<name>_margin"`` (each in its criterion's units, for
        :meth:`WorkspaceResult.quantity` and the plots). ``margin``, ``margins``,
        ``tensions``, ``wrenches`` and the layout are the first result's; ``status`` is
        the first result's, ``INFEASIBLE`` where another criterion fails.

    Raises
    ------
    InvalidInputError
        If no result is given, one is not a WorkspaceResult, or their poses differ.
    """
    if not results:
        raise InvalidInputError("results: give at least one WorkspaceResult to combine")
    first = results[0]
    for i, r in enumerate(results):
        if not isinstance(r, WorkspaceResult):
            raise InvalidInputError(f"results[{i}] must be a WorkspaceResult, got "
                                    f"{type(r).__name__}")
        if r.poses.shape != first.poses.shape or not np.array_equal(r.poses, first.poses):
            raise InvalidInputError(f"results[{i}] has other poses than results[0]: combine "
                                    "results of the same poses (the same grid or array)")
    extras: dict[str, Any] = {"criteria": ()}
    feasible = np.ones(first.N, dtype=bool)
    for i, r in enumerate(results):
        for name, ok, margin in _parts(r, i):
            key, k = name, 2
            while key in extras["criteria"]:
                key, k = f"{name}_{k}", k + 1
            extras["criteria"] += (key,)
            extras[f"{key}_feasible"], extras[f"{key}_margin"] = ok, margin
            feasible &= ok
    extras["criterion"] = "+".join(extras["criteria"])
    extras["margin_label"] = first.label("margin")
    status = np.array(first.status, copy=True)
    status[~feasible & (status == Status.OPTIMAL)] = Status.INFEASIBLE
    backends = dict.fromkeys(b for r in results for b in r.backend.split("+") if b)
    return WorkspaceResult(
        poses=first.poses, feasible=feasible, margin=first.margin, tensions=first.tensions,
        status=status, margins=first.margins, critical_wrench=first.critical_wrench,
        wrenches=first.wrenches, grid_shape=first.grid_shape, axes=first.axes,
        bounds=first.bounds, robot=first.robot, backend="+".join(backends), extras=extras)
