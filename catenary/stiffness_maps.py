"""Maps of the platform's stiffness over a workspace: lowest natural frequency and deflection.

:func:`stiffness_map` evaluates, on a grid of poses (or any batch), the lowest natural
frequency of the platform (:func:`catenary.natural_frequencies`) and its linear
deflection under a given load (:func:`catenary.deflection`), both from one stiffness
per pose (:func:`catenary.robot_stiffness.stiffness_analysis`), in chunks of poses over
an executor (:func:`tension_opt.workspace.executors.run_chunks`; the result does not depend on
it). :func:`plot_stiffness_map` draws a slice of a grid result as a heat map.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.distribution.chunks import chunk_slices
from tension_opt.workspace import Grid
from tension_opt.workspace.executors import Executor, merge_chunks, run_chunks

from .errors import InvalidCableError
from .response import deflection_from, mass_matrix, modes_from
from .robot_stiffness import MODELS, StiffnessModel, stiffness_analysis

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["CHUNK_SIZE", "StiffnessMap", "plot_stiffness_map", "stiffness_map"]

#: Default poses per chunk.
CHUNK_SIZE = 2048


@dataclass(eq=False)
class StiffnessMap:
    """Lowest natural frequency and deflection under a load over a batch of poses.

    Attributes
    ----------
    poses : ndarray, shape (N, n)
        The poses (m, rad).
    frequencies : ndarray, shape (N, n)
        Natural frequencies (Hz), ascending (:func:`catenary.natural_frequencies`).
    deflection : ndarray, shape (N, n)
        Linear deflection under ``load`` (m, rad) (:func:`catenary.deflection`).
    status : ndarray of str, shape (N,)
        Status of the stiffness (:attr:`StiffnessResult.status`); NaN values elsewhere.
    load : ndarray, shape (n,)
        The added wrench (N, N m).
    model : str
        ``"coupled"`` or ``"straight"``.
    robot : CableRobot
    grid_shape : tuple of int, optional
        Shape of the grid the poses came from (C order), None for other batches.
    axes : tuple of ndarray, optional
        Grid points along each pose coordinate.
    """

    poses: NDArray
    frequencies: NDArray
    deflection: NDArray
    status: NDArray
    load: NDArray
    model: str
    robot: CableRobot = field(repr=False)
    grid_shape: tuple[int, ...] | None = None
    axes: tuple[NDArray, ...] | None = None

    #: Plottable quantities and their labels.
    QUANTITIES: ClassVar[dict[str, str]] = {
        "lowest_frequency": "lowest natural frequency (Hz)",
        "deflection": "deflection under the load (mm)",
    }

    @property
    def lowest_frequency(self) -> NDArray:
        """The lowest natural frequency of each pose (Hz), shape (N,)."""
        return self.frequencies[:, 0]

    @property
    def translation(self) -> NDArray:
        """Length of the translation part of the deflection (m), shape (N,)."""
        positions = list(self.robot.pattern.positions)
        return np.linalg.norm(self.deflection[:, positions], axis=1)

    def quantity(self, name: str) -> NDArray:
        """Values of a plottable quantity (:attr:`QUANTITIES`), shape (N,); the
        deflection in mm."""
        if name == "lowest_frequency":
            return self.lowest_frequency
        if name == "deflection":
            return 1e3 * self.translation
        raise InvalidCableError(f"quantity must be one of {sorted(self.QUANTITIES)}; got "
                                f"{name!r}")

    def reshape(self, values: NDArray) -> NDArray:
        """Per-pose values (N, ...) on the grid, shape ``grid_shape + (...)``."""
        if self.grid_shape is None:
            raise InvalidCableError("reshape needs a map computed on a Grid")
        return np.asarray(values).reshape(*self.grid_shape, *np.shape(values)[1:])

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: pose, status, lowest frequency, deflection."""
        names = self.robot.pattern.coordinates
        frame = pd.DataFrame(self.poses, columns=list(names))
        frame.insert(0, "status", self.status)
        frame["lowest_frequency"] = self.lowest_frequency
        for i, name in enumerate(names):
            frame[f"d{name}"] = self.deflection[:, i]
        frame["translation"] = self.translation
        return frame


@dataclass(frozen=True)
class _MapTask:
    robot: CableRobot
    poses: NDArray
    load: NDArray
    model: str
    kwargs: dict[str, Any]


def _map_chunk(task: _MapTask) -> dict[str, NDArray]:
    """Frequencies, deflections and status of one chunk of poses (one stiffness each)."""
    result = stiffness_analysis(task.robot, task.poses, None, task.model,  # type: ignore[arg-type]
                                **task.kwargs)
    modes = modes_from(result.stiffness, mass_matrix(task.robot, task.poses), result.status)
    load = np.broadcast_to(task.load, task.poses.shape)
    return {"frequencies": modes.frequencies,
            "deflection": deflection_from(result.stiffness, load), "status": result.status}


def stiffness_map(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    load: ArrayLike,
    model: StiffnessModel = "coupled",
    *,
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    **kwargs: Any,
) -> StiffnessMap:
    """Lowest natural frequency and deflection under ``load`` over a workspace grid.

    Parameters
    ----------
    robot : CableRobot
        Needs cable properties (see :func:`catenary.platform_stiffness`).
    poses : Grid or array_like, shape (N, n)
        A grid from :func:`tension_opt.workspace.workspace_grid`, or poses (m, rad).
    load : array_like, shape (n,)
        Wrench added on the platform (N, N m), e.g. ``[100, 0, 0]``.
    model : {"coupled", "straight"}
    executor, chunk_size, progress
        As :func:`tension_opt.workspace.wrench_feasible_workspace`.
    **kwargs
        Passed to :func:`catenary.robot_stiffness.stiffness_analysis` (``wrench``,
        ``objective``, ``backend``, ...); the tensions are the model's own.

    Returns
    -------
    StiffnessMap
        Per pose the values :func:`catenary.natural_frequencies` and
        :func:`catenary.deflection` give; NaN where the model has no equilibrium.
    """
    if model not in MODELS:
        raise InvalidCableError(f'model must be "coupled" or "straight"; got model={model!r}')
    grid = poses if isinstance(poses, Grid) else None
    P = robot.as_poses(poses.poses if isinstance(poses, Grid) else poses)
    added = np.asarray(load, dtype=float)
    if added.shape != (robot.dof,) or not np.isfinite(added).all():
        raise InvalidCableError(f"load must be finite with shape ({robot.dof},) (N, N m); "
                                f"got {np.shape(load)}")
    tasks = [_MapTask(robot, P[s], added, model, dict(kwargs))
             for s in chunk_slices(len(P), chunk_size)]
    parts = run_chunks(_map_chunk, tasks, executor, progress=progress,
                       description="stiffness map")
    if parts:
        out = merge_chunks(parts, ("frequencies", "deflection", "status"))
    else:
        out = {"frequencies": np.zeros((0, robot.dof)), "deflection": np.zeros((0, robot.dof)),
               "status": np.zeros(0, dtype=str)}
    return StiffnessMap(P, out["frequencies"], out["deflection"], out["status"], added, model,
                        robot, grid.shape if grid is not None else None,
                        grid.axes if grid is not None else None)


def plot_stiffness_map(result: StiffnessMap, quantity: str = "lowest_frequency",
                       z: float | None = None, *, ax: Axes | None = None,
                       cmap: str | None = None) -> Axes:
    """Heat map of a quantity of a grid :class:`StiffnessMap` over a slice.

    Parameters
    ----------
    result : StiffnessMap
        Computed on a :class:`~tension_opt.workspace.Grid` with several points along two
        position coordinates; the other coordinates fixed, except the vertical one,
        whose layer nearest ``z`` is drawn (default: the middle one).
    quantity : {"lowest_frequency", "deflection"}
        Hz, or the length of the translation under the load (mm).
    z : float, optional
        Height of the slice (m).
    ax : matplotlib Axes, optional
    cmap : str, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    values = result.quantity(quantity)
    if result.grid_shape is None or result.axes is None:
        raise InvalidCableError("plot_stiffness_map needs a map computed on a Grid")
    pattern = result.robot.pattern
    shape, axes = result.grid_shape, result.axes
    varying = [i for i in pattern.positions if shape[i] > 1]
    if len(varying) < 2:
        raise InvalidCableError("plot_stiffness_map needs a grid with several points along "
                                "two position coordinates")
    h, v = varying[:2]
    index: list[int | slice] = [slice(None)] * len(shape)
    for i, axis in enumerate(axes):
        if i in (h, v):
            continue
        if len(axis) == 1:
            index[i] = 0
            continue
        if i != pattern.vertical_coordinate:
            raise InvalidCableError(f"plot_stiffness_map needs {pattern.coordinates[i]} fixed "
                                    "on the grid")
        index[i] = len(axis) // 2 if z is None else int(np.argmin(np.abs(axis - z)))
    data = result.reshape(values)[tuple(index)]
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4.5))
    mesh = ax.pcolormesh(axes[h], axes[v], np.ma.masked_invalid(data.T), shading="nearest",
                         cmap=cmap or "viridis")
    ax.figure.colorbar(mesh, ax=ax).set_label(result.QUANTITIES[quantity])
    names = pattern.coordinates
    title = f"{result.QUANTITIES[quantity]}, {result.model} model"
    if quantity == "deflection":
        title = title.replace("the load", "(" + ", ".join(f"{v:g}" for v in result.load) + ")")
    ax.set(xlabel=f"{names[h]} (m)", ylabel=f"{names[v]} (m)", aspect="equal", title=title)
    return ax
