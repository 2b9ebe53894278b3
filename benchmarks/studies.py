"""Parameter studies of the reference robot: one robot parameter swept, a tidy table out.

The reference study (summarised in ``thesis.md``) swept the cable diameter, the cable
density, the end-effector mass, the pond area (at a fixed aspect ratio), the pond
aspect ratio (at a fixed area) and the cable material of the algae-harvesting robot
:func:`tension_opt.robot.presets.algae_harvester`, at the nominal pose (0, 0, 0) and at
(8, -5, 2), and looked at how the sag changes the cable lengths. :func:`sweep` redoes
any of these (or sweeps any other override of the preset) and returns one row per
(sweep point, pose, cable) with

- the straight-line length ``Le`` and the straight-statics tensions of the minimum-sum
  LP and of the pseudo-inverse (:func:`tension_opt.distribute`);
- the sagging length in the study's decoupled convention
  (:func:`catenary.inverse_kinematics` with ``model="thesis"``) and in the coupled
  model (``model="coupled"``), their differences ``D = L - Le`` and relative errors,
  tensions, equilibrium residuals, iteration counts and statuses.

Every sweep point is a different robot; the poses of a point are solved together
(vectorised). The points are split into chunks and run through an executor of
:mod:`tension_opt.workspace.executors` (in this process by default, or a process pool, or a
Dask cluster); the table is the same whichever runs it. A pose that is infeasible or
whose catenary fails stays in the table with its status and NaN numbers; a sweep never
stops at one bad point.

Command line (:mod:`benchmarks.cli`)::

    python -m benchmarks study diameter --executor processes:2 --out diameter.csv
    python -m benchmarks study material --materials steel polyethylene kevlar
    python -m benchmarks study mass --values 100 200 300 --pose 0 0 0 --pose 8 -5 2

The study's parameters and the robots of the sweep points are in
:mod:`benchmarks.study_points`.

Units are SI throughout (m, kg, N, Pa); lengths and differences in the table are in
metres, relative errors in percent.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

import catenary
from benchmarks.study_points import (
    NOMINAL_ASPECT_RATIO,
    NOMINAL_POND_AREA,
    ROBOT_OVERRIDES,
    STUDY_PARAMETERS,
    StudyParameter,
    SweepPoint,
    cable_density,
    canonical_parameter,
    check_material_use,
    check_overrides,
    study_robot,
    sweep_points,
)
from catenary.materials import CableMaterial
from tension_opt import CableRobot, distribute, presets
from tension_opt.distribution.chunks import chunk_slices
from tension_opt.errors import InvalidInputError
from tension_opt.workspace.executors import Executor, run_chunks

__all__ = [
    "COLUMNS",
    "DEFAULT_POSES",
    "MODELS",
    "NOMINAL_ASPECT_RATIO",
    "NOMINAL_POND_AREA",
    "ROBOT_OVERRIDES",
    "STUDY_PARAMETERS",
    "StudyParameter",
    "material_study",
    "study_robot",
    "summarize",
    "sweep",
]

DEFAULT_POSES: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0), (8.0, -5.0, 2.0))
"""Poses of the study's sweeps (m): the nominal pose and an arbitrary one."""

SagModel = Literal["thesis", "coupled"]

MODELS: tuple[SagModel, ...] = ("thesis", "coupled")
"""Sag models of :func:`catenary.inverse_kinematics` a sweep can evaluate."""

COLUMNS: dict[str, str] = {
    "parameter": "name of the swept parameter",
    "value": "its value at this sweep point (a material name for 'material')",
    "point": "index of the sweep point",
    "pose": "index of the pose",
    "x": "pose x (m)",
    "y": "pose y (m)",
    "z": "pose z (m)",
    "cable": "cable index 0..3 (P1 (-,-), P2 (-,+), P3 (+,+), P4 (+,-))",
    "material": "catalogue material of the cable ('' when density/EA are given directly)",
    "diameter": "cable diameter (m)",
    "density": "cable density on the full nominal section (kg/m^3)",
    "w": "cable weight per length (N/m)",
    "EA": "axial stiffness (N); inf for the inextensible cable of the study",
    "breaking_load": "nominal rope breaking load of the material (N); NaN if unknown",
    "mass": "end-effector mass (kg)",
    "t_min": "lower tension bound (N)",
    "pond_length": "pond extent along x, PL (m)",
    "pond_width": "pond extent along y, PW (m)",
    "Le": "straight-line cable length (m)",
    "T_lp": "minimum-sum (LP) tension, straight-line statics (N)",
    "status_lp": "status of the LP",
    "T_pinv": "pseudo-inverse (minimum-norm, unbounded) tension, straight statics (N)",
    "status_pinv": "status of the pseudo-inverse",
    "L_<model>": "unstretched sagging cable length (m)",
    "D_<model>": "sag difference L - Le (m); an elastic cable's unstretched L can be < Le",
    "rel_error_<model>": "100 D / L (%)",
    "T_<model>": "tension at the drawing point (N); the imposed LP tension for 'thesis'",
    "T_platform_<model>": "tension at the end-effector (N)",
    "residual_<model>": "force left on the end-effector by the catenary end forces and the "
                        "load (N); not zero in the decoupled 'thesis' convention",
    "iterations_<model>": "sequential-convex-programming iterations of the pose (0 for "
                          "'thesis'; -1 where the call raised)",
    "catenary_iterations_<model>": "Newton iterations of this cable's catenary solves (-1 "
                                   "where the call raised)",
    "status_<model>": "'converged', 'infeasible', 'catenary_failed', 'max_iter' or 'error'",
    "L_difference": "L_coupled - L_thesis (m), when both models run",
    "note": "error message of a library call that raised at this point ('' otherwise)",
}
"""Columns of the tables of :func:`sweep`, ``<model>`` being "thesis" or "coupled"."""


@dataclass(frozen=True)
class _Chunk:
    """Work sent to an executor: consecutive sweep points and what to compute."""

    points: tuple[SweepPoint, ...]
    poses: NDArray[np.float64]
    models: tuple[SagModel, ...]
    objective: str
    backend: str


# ----------------------------------------------------------------------------
# the work of one chunk (module level: picklable for process pools and Dask)


def _run_chunk(chunk: _Chunk) -> pd.DataFrame:
    """Table of the sweep points of one chunk (rows: point, pose, cable)."""
    return pd.concat(
        [_point_frame(p, chunk.poses, chunk.models, chunk.objective, chunk.backend)
         for p in chunk.points],
        ignore_index=True,
    )


def _error_text(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}"


class _Columns:
    """Columns of one sweep point's rows: one row per (pose, cable), N poses, m cables."""

    def __init__(self, N: int, m: int) -> None:
        self.N, self.m, self.rows = N, m, N * m
        self.cols: dict[str, Any] = {}
        self.notes: list[str] = []

    def cable(self, a: ArrayLike) -> NDArray[np.float64]:
        """Per-cable values (N, m) as a column."""
        return np.asarray(a, dtype=np.float64).reshape(self.rows)

    def pose(self, a: ArrayLike) -> NDArray[Any]:
        """Per-pose values (N,) repeated over the cables."""
        return np.repeat(np.asarray(a), self.m)

    def full(self, value: Any, dtype: Any = None) -> NDArray[Any]:
        """One value on every row."""
        return np.full(self.rows, value, dtype=dtype)


def _point_frame(
    point: SweepPoint,
    poses: NDArray[np.float64],
    models: tuple[SagModel, ...],
    objective: str,
    backend: str,
) -> pd.DataFrame:
    """Rows of one sweep point: all poses solved at once, one row per (pose, cable)."""
    robot = presets.algae_harvester(**point.overrides)
    out = _Columns(poses.shape[0], robot.m)
    _describe(out, point, robot, poses)
    _straight(out, robot, poses, backend)
    lengths = {model: _sagging(out, robot, poses, model, objective, backend)
               for model in models}
    if "thesis" in lengths and "coupled" in lengths:
        out.cols["L_difference"] = lengths["coupled"] - lengths["thesis"]
    out.cols["note"] = out.full("; ".join(out.notes), dtype=object)
    return pd.DataFrame(out.cols)


def _describe(out: _Columns, point: SweepPoint, robot: CableRobot,
              poses: NDArray[np.float64]) -> None:
    """The point's parameter, the poses, the cable and the robot's data."""
    assert robot.cable is not None
    value_type = object if isinstance(point.value, str) else np.float64
    out.cols.update({
        "parameter": out.full(point.parameter, dtype=object),
        "value": out.full(point.value, dtype=value_type),
        "point": out.full(point.index, dtype=np.int64),
        "pose": out.pose(np.arange(out.N, dtype=np.int64)),
        "x": out.pose(poses[:, 0]),
        "y": out.pose(poses[:, 1]),
        "z": out.pose(poses[:, 2]),
        "cable": np.tile(np.arange(out.m, dtype=np.int64), out.N),
        "material": out.full(point.material, dtype=object),
        "diameter": out.full(robot.cable.diameter),
        "density": out.full(cable_density(point, robot)),
        "w": out.full(robot.cable.weight_per_length(robot.g)),
        "EA": out.full(float(robot.cable.EA)),
        "breaking_load": out.full(point.breaking_load),
        "mass": out.full(float(robot.mass)),
        "t_min": np.tile(np.asarray(robot.t_min, dtype=np.float64), out.N),
        "pond_length": out.full(point.pond[0]),
        "pond_width": out.full(point.pond[1]),
    })


def _straight(out: _Columns, robot: CableRobot, poses: NDArray[np.float64],
              backend: str) -> None:
    """Straight lengths, and the LP and pseudo-inverse tensions of straight statics."""
    nan = np.full((out.N, out.m), np.nan)
    try:
        Le, _ = robot.inverse_kinematics(poses)
    except Exception as exc:  # a sweep never stops at one point
        Le = nan
        out.notes.append(f"straight lengths: {_error_text(exc)}")
    out.cols["Le"] = out.cable(Le)
    for key, obj, back in (("lp", "min_sum", backend), ("pinv", "pinv", "auto")):
        try:
            sol = distribute(robot, poses, obj, back)
            T, status = sol.tensions, np.array([str(s) for s in sol.status], dtype=object)
        except Exception as exc:
            T, status = nan, np.full(out.N, "error", dtype=object)
            out.notes.append(f"{key}: {_error_text(exc)}")
        out.cols[f"T_{key}"] = out.cable(T)
        out.cols[f"status_{key}"] = out.pose(status)


def _sagging(out: _Columns, robot: CableRobot, poses: NDArray[np.float64], model: SagModel,
             objective: str, backend: str) -> NDArray[np.float64]:
    """Columns of one sag model; returns its lengths (N * m,) (m)."""
    N, m = out.N, out.m
    try:
        ik = catenary.inverse_kinematics(robot, poses, model=model, objective=objective,
                                         backend=backend)
        L, T, T_A = ik.lengths, ik.tensions, ik.tensions_platform
        residual, its, cat_its = ik.equilibrium_residual, ik.iterations, \
            ik.catenary_iterations
        status = np.asarray(ik.status, dtype=object)
        # Failed poses carry NaN lengths already; keep their residual NaN too.
        residual = np.where(np.isnan(L).any(axis=1), np.nan, residual)
    except Exception as exc:
        L = T = T_A = np.full((N, m), np.nan)
        residual = np.full(N, np.nan)
        its, cat_its = np.full(N, -1), np.full((N, m), -1)
        status = np.full(N, "error", dtype=object)
        out.notes.append(f"{model}: {_error_text(exc)}")
    L = out.cable(L)
    D = L - out.cols["Le"]
    out.cols[f"L_{model}"] = L
    out.cols[f"D_{model}"] = D
    with np.errstate(invalid="ignore", divide="ignore"):
        out.cols[f"rel_error_{model}"] = 100.0 * D / L
    out.cols[f"T_{model}"] = out.cable(T)
    out.cols[f"T_platform_{model}"] = out.cable(T_A)
    out.cols[f"residual_{model}"] = out.pose(np.asarray(residual, dtype=np.float64))
    out.cols[f"iterations_{model}"] = out.pose(np.asarray(its, dtype=np.int64))
    out.cols[f"catenary_iterations_{model}"] = np.asarray(cat_its, dtype=np.int64).reshape(
        out.rows)
    out.cols[f"status_{model}"] = out.pose(status)
    return L


# ----------------------------------------------------------------------------
# public API


def _as_poses(poses: ArrayLike | None) -> NDArray[np.float64]:
    given = DEFAULT_POSES if poses is None else poses
    arr = np.asarray(given, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 1:
        raise InvalidInputError(
            f"poses must have shape (N, 3) (x, y, z in m); got {np.shape(given)}"
        )
    if not np.isfinite(arr).all():
        raise InvalidInputError("poses must be finite")
    return arr


def _models(models: Sequence[str]) -> tuple[SagModel, ...]:
    names = tuple(models)
    if not names or any(mo not in MODELS for mo in names) or len(set(names)) != len(names):
        raise InvalidInputError(f"models must be distinct names among {MODELS}; got {models!r}")
    return cast(tuple[SagModel, ...], names)  # checked just above


def _values(name: str, parameter: str, values: Iterable[Any] | None) -> list[Any]:
    """The values of a sweep as a list: the defaults, one value, or any iterable."""
    if values is None:
        if name not in STUDY_PARAMETERS:
            raise InvalidInputError(f"{parameter!r} has no default values: pass values=[...]")
        return list(STUDY_PARAMETERS[name].defaults)
    if isinstance(values, str | CableMaterial) or np.isscalar(values):
        return [values]  # one value
    if isinstance(values, np.ndarray):
        return values.ravel().tolist()
    return list(values)


def _checked_points(name: str, parameter: str, values: Iterable[Any] | None,
                    models: Sequence[str], overrides: dict[str, Any],
                    material: str | CableMaterial | None,
                    elastic: bool) -> tuple[list[SweepPoint], tuple[SagModel, ...]]:
    """The sweep points and sag models of :func:`sweep`, all options checked."""
    check_overrides(overrides)
    check_material_use(name, overrides, material, elastic)
    chosen = _models(models)
    points = sweep_points(name, _values(name, parameter, values), overrides, material, elastic)
    return points, chosen


def sweep(
    parameter: str,
    values: Iterable[Any] | None = None,
    poses: ArrayLike | None = None,
    *,
    material: str | CableMaterial | None = None,
    elastic: bool = False,
    models: Sequence[str] = MODELS,
    objective: str = "min_sum",
    backend: str = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = 1,
    progress: bool = False,
    **robot_overrides: Any,
) -> pd.DataFrame:
    """Sweep one parameter of the reference robot; a tidy table of lengths and tensions.

    Parameters
    ----------
    parameter : str
        ``"diameter"`` (m), ``"density"`` (kg/m^3), ``"mass"`` (kg), ``"pond_area"``
        (m^2, aspect ratio fixed), ``"aspect_ratio"`` (PL/PW, area fixed),
        ``"material"`` (catalogue names), or any other keyword of
        :data:`ROBOT_OVERRIDES` (``"tower_height"``, ``"t_max"``, ...).
    values : iterable, optional
        Values to sweep, shape (K,); default the study's range
        ``STUDY_PARAMETERS[parameter].defaults`` (required for other parameters).
    poses : array_like, shape (N, 3) or (3,), optional
        End-effector positions (m); default :data:`DEFAULT_POSES`.
    material : str or CableMaterial, optional
        Cable material for every point (its density replaces ``cable_density``).
        Not with ``parameter="material"``.
    elastic : bool
        Give the cable the axial stiffness ``EA = E_rope * pi/4 * d^2`` of its material;
        default False: the inextensible cable of the reference study.
    models : sequence of {"thesis", "coupled"}
        Sag models to evaluate (:func:`catenary.inverse_kinematics`).
    objective : str
        Tension objective of the sag models (:func:`tension_opt.distribute`); the
        straight-statics columns are always the minimum-sum LP and the pseudo-inverse.
    backend : str
        Backend of the LP and of the sag models (``"auto"``: the exact closed form).
    executor : str, Executor or dask.distributed.Client, optional
        Where the chunks of sweep points run: None or ``"inprocess"``, ``"processes[:N]"``,
        ``"dask:tcp://host:8786"``, an executor or a Dask client; the result is the same.
    chunk_size, progress : int, bool
        Sweep points per chunk (>= 1); show a progress bar over the chunks.
    **robot_overrides
        Fixed overrides of :func:`tension_opt.robot.presets.algae_harvester` (SI units),
        e.g. ``mass=300`` or ``t_max=20000``; not the swept parameter.

    Returns
    -------
    pandas.DataFrame
        ``K * N * m`` rows (m = 4 cables), ordered by sweep point, pose and cable; the
        columns are described in :data:`COLUMNS`. Infeasible or failed poses keep their
        rows, with their status and NaN numbers.

    Raises
    ------
    tension_opt.errors.InvalidInputError
        For an unknown parameter or override, a value the robot rejects (a negative
        diameter ...), bad poses or models, or conflicting material options.
    catenary.InvalidCableError
        For an unknown material.

    Examples
    --------
    >>> table = sweep("mass", [200.0, 300.0], poses=[0, 0, 0], models=("thesis",))
    >>> table.groupby("value")["T_lp"].first().round(1).tolist()
    [3646.3, 5469.4]
    """
    name = canonical_parameter(parameter)
    points, chosen = _checked_points(name, parameter, values, models, robot_overrides,
                                     material, elastic)
    work = (_as_poses(poses), chosen, objective, backend)
    chunks = [_Chunk(tuple(points[s]), *work) for s in chunk_slices(len(points), chunk_size)]
    return pd.concat(run_chunks(_run_chunk, chunks, executor=executor, progress=progress,
                                description=f"{name} sweep"), ignore_index=True)


def material_study(
    materials: Iterable[str | CableMaterial] | None = None,
    poses: ArrayLike | None = None,
    diameter: float = 0.020,
    **options: Any,
) -> pd.DataFrame:
    """The reference robot with cables of catalogue materials.

    Parameters
    ----------
    materials : iterable of str or CableMaterial, optional
        Catalogue names ("steel", "dyneema"/"uhmwpe", "aramid"/"kevlar", "polyester",
        "polyethylene") or materials; default the whole catalogue.
    poses : array_like, shape (N, 3), optional
        End-effector positions (m); default :data:`DEFAULT_POSES`.
    diameter : float
        Cable diameter (m), 20 mm as in the study.
    **options
        As in :func:`sweep` (``elastic``, ``models``, ``executor``, ``progress``, robot
        overrides, ...). ``elastic=False`` (default) reproduces the study, which changed
        the density only.

    Returns
    -------
    pandas.DataFrame
        The table of :func:`sweep` with ``parameter == "material"``; ``value`` holds the
        names as given, ``material`` the catalogue names, ``breaking_load`` the nominal
        rope breaking load (N).

    Examples
    --------
    The study's nominal-pose sag difference: 207.4 mm for steel, 6.6 mm for Kevlar.

    >>> t = material_study(["steel", "kevlar"], poses=[0, 0, 0], models=("thesis",))
    >>> (1e3 * t.groupby("value", sort=False)["D_thesis"].first()).round(1).tolist()
    [207.4, 6.6]
    """
    if "cable_diameter" in options:
        raise InvalidInputError("give the diameter as diameter=..., not cable_diameter")
    return sweep("material", materials, poses, cable_diameter=diameter, **options)


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """One row per (sweep point, pose): the largest differences and the statuses.

    Parameters
    ----------
    table : pandas.DataFrame
        A table of :func:`sweep`.

    Returns
    -------
    pandas.DataFrame
        Columns ``parameter, value, pose, x, y, z``, the sum of the LP and of the
        pseudo-inverse tensions (N), and per model the largest ``D`` (mm), the largest
        relative error (%) and the status.
    """
    keys = ["point", "pose"]
    grouped = table.groupby(keys, sort=True)
    out = grouped[["parameter", "value", "x", "y", "z"]].first()
    out["sum_T_lp"] = grouped["T_lp"].sum(min_count=1)
    out["sum_T_pinv"] = grouped["T_pinv"].sum(min_count=1)
    for model in MODELS:
        if f"D_{model}" not in table:
            continue
        out[f"max_D_{model}_mm"] = 1e3 * grouped[f"D_{model}"].max()
        out[f"max_rel_error_{model}"] = grouped[f"rel_error_{model}"].max()
        out[f"status_{model}"] = grouped[f"status_{model}"].first()
    return out.reset_index()


if __name__ == "__main__":  # the old spelling of ``python -m benchmarks study ...``
    import runpy

    sys.argv.insert(1, "study")
    runpy.run_module("benchmarks", run_name="__main__", alter_sys=True)
