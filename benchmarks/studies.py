"""Parameter studies of the reference robot: one robot parameter swept, a tidy table out.

The reference study (summarised in ``thesis.md``) swept the cable diameter, the cable
density, the end-effector mass, the pond area (at a fixed aspect ratio), the pond
aspect ratio (at a fixed area) and the cable material of the algae-harvesting robot
:func:`tension_opt.presets.algae_harvester`, at the nominal pose (0, 0, 0) and at
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
:mod:`tension_opt.executors` (in this process by default, or a process pool, or a
Dask cluster); the table is the same whichever runs it. A pose that is infeasible or
whose catenary fails stays in the table with its status and NaN numbers; a sweep never
stops at one bad point.

Command line::

    python -m benchmarks.studies diameter --executor processes:2 --out diameter.csv
    python -m benchmarks.studies material --materials steel polyethylene kevlar
    python -m benchmarks.studies mass --values 100 200 300 --pose 0 0 0 --pose 8 -5 2

Units are SI throughout (m, kg, N, Pa); lengths and differences in the table are in
metres, relative errors in percent.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

import catenary
from catenary.materials import CableMaterial, get_material, material_names
from tension_opt import CableRobot, distribute, presets
from tension_opt.errors import InvalidInputError
from tension_opt.executors import Executor, chunk_slices, run_chunks

__all__ = [
    "COLUMNS",
    "DEFAULT_POSES",
    "MODELS",
    "NOMINAL_ASPECT_RATIO",
    "NOMINAL_POND_AREA",
    "ROBOT_OVERRIDES",
    "STUDY_PARAMETERS",
    "StudyParameter",
    "main",
    "material_study",
    "study_robot",
    "summarize",
    "sweep",
]

ROBOT_OVERRIDES: tuple[str, ...] = (
    "pond_length",
    "pond_width",
    "tower_height",
    "offset_x",
    "offset_y",
    "mass",
    "cable_diameter",
    "cable_density",
    "t_min",
    "t_max",
    "g",
    "EA",
)
"""Keyword overrides of :func:`tension_opt.presets.algae_harvester` (SI units)."""

NOMINAL_POND_LENGTH = 80.9
"""Pond extent along x of the reference robot (m)."""
NOMINAL_POND_WIDTH = 50.0
"""Pond extent along y of the reference robot (m)."""
NOMINAL_POND_AREA = NOMINAL_POND_LENGTH * NOMINAL_POND_WIDTH
"""Pond area of the reference robot, 4045 m^2."""
NOMINAL_ASPECT_RATIO = NOMINAL_POND_LENGTH / NOMINAL_POND_WIDTH
"""Pond aspect ratio PL/PW of the reference robot, 1.618."""

DEFAULT_POSES: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0), (8.0, -5.0, 2.0))
"""Poses of the study's sweeps (m): the nominal pose and an arbitrary one."""

SagModel = Literal["thesis", "coupled"]

MODELS: tuple[SagModel, ...] = ("thesis", "coupled")
"""Sag models of :func:`catenary.inverse_kinematics` a sweep can evaluate."""


@dataclass(frozen=True)
class StudyParameter:
    """A robot parameter that :func:`sweep` knows by name.

    Attributes
    ----------
    name : str
        Name given to :func:`sweep` and written in the ``parameter`` column.
    description : str
        What the parameter is, and what stays fixed while it moves.
    unit : str
        SI unit of the values ("" for materials and ratios).
    defaults : tuple
        Values swept when none are given (the study's ranges).
    override : str or None
        The :func:`~tension_opt.presets.algae_harvester` keyword the value sets, or None
        for derived parameters (pond area, aspect ratio, material).
    """

    name: str
    description: str
    unit: str
    defaults: tuple[Any, ...]
    override: str | None = None


def _grid(start: float, stop: float, step: float, digits: int = 6) -> tuple[float, ...]:
    count = round((stop - start) / step) + 1
    return tuple(round(start + k * step, digits) for k in range(count))


_AREA_FACTORS = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0)
_ASPECT_RATIOS = (0.25, 0.5, 0.75, 1.0, 1.5, round(NOMINAL_ASPECT_RATIO, 3), 2.0, 3.0, 4.0)

STUDY_PARAMETERS: dict[str, StudyParameter] = {
    p.name: p
    for p in (
        StudyParameter("diameter", "cable diameter", "m", _grid(0.010, 0.030, 0.002),
                       "cable_diameter"),
        StudyParameter("density", "cable material density (full nominal section)", "kg/m^3",
                       _grid(1000.0, 10000.0, 1000.0), "cable_density"),
        StudyParameter("mass", "end-effector mass; t_min = m g follows it unless t_min is "
                       "given", "kg", _grid(100.0, 400.0, 25.0), "mass"),
        StudyParameter("pond_area", "pond area PL*PW at a fixed aspect ratio PL/PW (80.9/50 "
                       "unless pond_length/pond_width are given)", "m^2",
                       tuple(round(f * NOMINAL_POND_AREA, 3) for f in _AREA_FACTORS)),
        StudyParameter("aspect_ratio", "pond aspect ratio PL/PW at a fixed area (80.9*50 m^2 "
                       "unless pond_length/pond_width are given)", "", _ASPECT_RATIOS),
        StudyParameter("material", "cable material of the catalogue catenary.MATERIALS "
                       "(density; EA too with elastic=True)", "", tuple(material_names())),
    )
}
"""The study's sweeps by name, with their default values.

Any other keyword of :data:`ROBOT_OVERRIDES` can be swept too (``sweep("tower_height",
[5, 7.6, 10])``); it has no default values. ``"cable_diameter"`` and ``"cable_density"``
are the same as ``"diameter"`` and ``"density"``.
"""

_ALIASES = {"cable_diameter": "diameter", "cable_density": "density"}

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


# ----------------------------------------------------------------------------
# sweep points


@dataclass(frozen=True)
class _Point:
    """One sweep point: the preset overrides that make its robot."""

    index: int
    parameter: str
    value: Any
    overrides: dict[str, Any]
    material: str  # catalogue name, "" when none
    breaking_load: float
    pond: tuple[float, float]


@dataclass(frozen=True)
class _Chunk:
    """Work sent to an executor: consecutive sweep points and what to compute."""

    points: tuple[_Point, ...]
    poses: NDArray[np.float64]
    models: tuple[SagModel, ...]
    objective: str
    backend: str


def _canonical(parameter: str) -> str:
    if not isinstance(parameter, str):
        raise InvalidInputError(f"parameter must be a name; got {parameter!r}")
    name = _ALIASES.get(parameter, parameter)
    if name not in STUDY_PARAMETERS and name not in ROBOT_OVERRIDES:
        known = sorted(set(STUDY_PARAMETERS) | set(ROBOT_OVERRIDES) - set(_ALIASES))
        raise InvalidInputError(f"unknown study parameter {parameter!r}; known: {known}")
    return name


def _check_overrides(overrides: dict[str, Any]) -> None:
    unknown = sorted(set(overrides) - set(ROBOT_OVERRIDES))
    if unknown:
        raise InvalidInputError(
            f"unknown robot override(s) {unknown}; allowed: {list(ROBOT_OVERRIDES)}"
        )


def _as_number(parameter: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{parameter} values must be numbers; got {value!r}") from None
    if not math.isfinite(number) and not (parameter == "t_max" and number == math.inf):
        raise InvalidInputError(f"{parameter} values must be finite; got {value!r}")
    return number


def _point_overrides(
    parameter: str,
    value: Any,
    overrides: dict[str, Any],
    material: str | CableMaterial | None,
    elastic: bool,
) -> tuple[dict[str, Any], Any, CableMaterial | None, tuple[float, float]]:
    """Preset overrides of one sweep point, the value as stored, the material and pond."""
    point = dict(overrides)
    pond_length = float(overrides.get("pond_length", NOMINAL_POND_LENGTH))
    pond_width = float(overrides.get("pond_width", NOMINAL_POND_WIDTH))
    mat: CableMaterial | None = None
    if parameter == "material":
        mat = get_material(value)
        stored: Any = value if isinstance(value, str) else mat.name
    else:
        stored = _as_number(parameter, value)
        if material is not None:
            mat = get_material(material)
    if parameter in ("pond_area", "aspect_ratio"):
        if stored <= 0:
            raise InvalidInputError(f"{parameter} must be > 0; got {value!r}")
        if parameter == "pond_area":
            area, ratio = stored, pond_length / pond_width
        else:
            area, ratio = pond_length * pond_width, stored
        pond_length, pond_width = math.sqrt(area * ratio), math.sqrt(area / ratio)
        point["pond_length"], point["pond_width"] = pond_length, pond_width
    elif parameter != "material":
        key = STUDY_PARAMETERS[parameter].override if parameter in STUDY_PARAMETERS else parameter
        assert key is not None
        point[key] = stored
        if key == "pond_length":
            pond_length = stored
        elif key == "pond_width":
            pond_width = stored
    if mat is not None:
        point["cable_density"] = mat.density
    if elastic:
        assert mat is not None
        cable = presets.algae_harvester(**point).cable
        assert cable is not None
        point["EA"] = float(mat.rope_modulus * math.pi / 4.0 * cable.diameter**2)
    return point, stored, mat, (pond_length, pond_width)


def _points(
    parameter: str,
    values: Iterable[Any],
    overrides: dict[str, Any],
    material: str | CableMaterial | None,
    elastic: bool,
) -> list[_Point]:
    """Validated sweep points; every robot is built once here so bad input raises now."""
    points = []
    for index, value in enumerate(values):
        point, stored, mat, pond = _point_overrides(parameter, value, overrides, material,
                                                    elastic)
        try:
            robot = presets.algae_harvester(**point)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{parameter}={value!r}: {exc}") from None
        assert robot.cable is not None
        load = float(mat.breaking_load(robot.cable.diameter)) if mat is not None else math.nan
        points.append(_Point(index, parameter, stored, point, mat.name if mat else "", load,
                             pond))
    if not points:
        raise InvalidInputError(f"no values to sweep for {parameter!r}")
    return points


def study_robot(
    parameter: str,
    value: Any,
    *,
    material: str | CableMaterial | None = None,
    elastic: bool = False,
    **robot_overrides: Any,
) -> CableRobot:
    """The reference robot at one sweep point, as :func:`sweep` builds it.

    Parameters
    ----------
    parameter : str
        A name of :data:`STUDY_PARAMETERS` or of :data:`ROBOT_OVERRIDES`.
    value : float or str
        The parameter's value (SI units; a material name for ``"material"``).
    material, elastic, **robot_overrides
        As in :func:`sweep`.

    Returns
    -------
    CableRobot

    Examples
    --------
    A pond of twice the area at the same aspect ratio:

    >>> r = study_robot("pond_area", 2 * NOMINAL_POND_AREA)
    >>> length, width = 2 * (r.anchors[:, :2].max(axis=0) - 6.1)
    >>> print(f"{length * width / NOMINAL_POND_AREA:.6f} {length / width:.4f}")
    2.000000 1.6180
    """
    name = _canonical(parameter)
    _check_overrides(robot_overrides)
    _check_material_use(name, robot_overrides, material, elastic)
    point = _points(name, [value], robot_overrides, material, elastic)[0]
    return presets.algae_harvester(**point.overrides)


def _check_material_use(
    parameter: str,
    overrides: dict[str, Any],
    material: str | CableMaterial | None,
    elastic: bool,
) -> None:
    has_material = material is not None or parameter == "material"
    if material is not None and parameter == "material":
        raise InvalidInputError("a material sweep takes its materials as values; drop material=")
    if has_material and ("cable_density" in overrides or parameter == "density"):
        raise InvalidInputError(
            "the material sets the cable density: drop cable_density or the material"
        )
    if elastic and not has_material:
        raise InvalidInputError(
            "elastic=True takes EA from a catalogue material: give material=... (or EA=...)"
        )
    if elastic and ("EA" in overrides or parameter == "EA"):
        raise InvalidInputError("elastic=True sets EA from the material: drop EA or elastic")
    name = STUDY_PARAMETERS[parameter].override if parameter in STUDY_PARAMETERS else parameter
    if name is not None and name in overrides:
        raise InvalidInputError(f"{name} is swept; do not also pass it as an override")


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


def _density(point: _Point, robot: CableRobot) -> float:
    """Cable density (kg/m^3): as given, else from the linear mass of the robot's cable."""
    if "cable_density" in point.overrides:
        return float(point.overrides["cable_density"])
    assert robot.cable is not None
    density = robot.cable.linear_mass / (math.pi / 4.0 * robot.cable.diameter**2)
    return float(f"{density:.12g}")  # 7860.0, not 7860.000000000001


def _point_frame(
    point: _Point,
    poses: NDArray[np.float64],
    models: tuple[SagModel, ...],
    objective: str,
    backend: str,
) -> pd.DataFrame:
    """Rows of one sweep point: all poses solved at once, one row per (pose, cable)."""
    robot = presets.algae_harvester(**point.overrides)
    assert robot.cable is not None
    N, m = poses.shape[0], robot.m
    rows = N * m
    notes: list[str] = []

    def cable(a: ArrayLike) -> NDArray[np.float64]:
        return np.asarray(a, dtype=np.float64).reshape(rows)

    def pose(a: ArrayLike) -> NDArray[Any]:
        return np.repeat(np.asarray(a), m)

    nan = np.full((N, m), np.nan)
    cols: dict[str, Any] = {
        "parameter": np.full(rows, point.parameter, dtype=object),
        "value": np.full(rows, point.value, dtype=object if isinstance(point.value, str)
                         else np.float64),
        "point": np.full(rows, point.index, dtype=np.int64),
        "pose": pose(np.arange(N, dtype=np.int64)),
        "x": pose(poses[:, 0]),
        "y": pose(poses[:, 1]),
        "z": pose(poses[:, 2]),
        "cable": np.tile(np.arange(m, dtype=np.int64), N),
        "material": np.full(rows, point.material, dtype=object),
        "diameter": np.full(rows, robot.cable.diameter),
        "density": np.full(rows, _density(point, robot)),
        "w": np.full(rows, robot.cable.weight_per_length(robot.g)),
        "EA": np.full(rows, float(robot.cable.EA)),
        "breaking_load": np.full(rows, point.breaking_load),
        "mass": np.full(rows, float(robot.mass)),
        "t_min": np.tile(np.asarray(robot.t_min, dtype=np.float64), N),
        "pond_length": np.full(rows, point.pond[0]),
        "pond_width": np.full(rows, point.pond[1]),
    }

    try:
        Le, _ = robot.inverse_kinematics(poses)
    except Exception as exc:  # a sweep never stops at one point
        Le = nan
        notes.append(f"straight lengths: {_error_text(exc)}")
    cols["Le"] = cable(Le)

    for key, obj, back in (("lp", "min_sum", backend), ("pinv", "pinv", "auto")):
        try:
            sol = distribute(robot, poses, obj, back)
            T, status = sol.tensions, np.array([str(s) for s in sol.status], dtype=object)
        except Exception as exc:
            T, status = nan, np.full(N, "error", dtype=object)
            notes.append(f"{key}: {_error_text(exc)}")
        cols[f"T_{key}"] = cable(T)
        cols[f"status_{key}"] = pose(status)

    lengths: dict[str, NDArray[np.float64]] = {}
    for model in models:
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
            L, T, T_A = nan, nan, nan
            residual = np.full(N, np.nan)
            its, cat_its = np.full(N, -1), np.full((N, m), -1)
            status = np.full(N, "error", dtype=object)
            notes.append(f"{model}: {_error_text(exc)}")
        L = cable(L)
        D = L - cols["Le"]
        lengths[model] = L
        cols[f"L_{model}"] = L
        cols[f"D_{model}"] = D
        with np.errstate(invalid="ignore", divide="ignore"):
            cols[f"rel_error_{model}"] = 100.0 * D / L
        cols[f"T_{model}"] = cable(T)
        cols[f"T_platform_{model}"] = cable(T_A)
        cols[f"residual_{model}"] = pose(np.asarray(residual, dtype=np.float64))
        cols[f"iterations_{model}"] = pose(np.asarray(its, dtype=np.int64))
        cols[f"catenary_iterations_{model}"] = np.asarray(cat_its, dtype=np.int64).reshape(rows)
        cols[f"status_{model}"] = pose(status)
    if "thesis" in lengths and "coupled" in lengths:
        cols["L_difference"] = lengths["coupled"] - lengths["thesis"]
    cols["note"] = np.full(rows, "; ".join(notes), dtype=object)
    return pd.DataFrame(cols)


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
        Values to sweep, shape (K,); default ``STUDY_PARAMETERS[parameter].defaults``
        (the study's ranges). Required for parameters without defaults.
    poses : array_like, shape (N, 3) or (3,), optional
        End-effector positions (m); default :data:`DEFAULT_POSES`, (0, 0, 0) and
        (8, -5, 2).
    material : str or CableMaterial, optional
        Cable material for every point (its density replaces ``cable_density``).
        Not with ``parameter="material"``.
    elastic : bool
        Give the cable the axial stiffness ``EA = E_rope * pi/4 * d^2`` of its catalogue
        material. Default False: the inextensible cable of the reference study (which
        used only the density).
    models : sequence of {"thesis", "coupled"}
        Sag models to evaluate (:func:`catenary.inverse_kinematics`).
    objective : str
        Tension objective of the sag models (:func:`tension_opt.distribute`); the
        straight-statics columns are always the minimum-sum LP and the pseudo-inverse.
    backend : str
        Backend of the LP and of the sag models (``"auto"``: the exact closed form).
    executor : str, Executor or dask.distributed.Client, optional
        Where the chunks of sweep points run: None or ``"inprocess"``,
        ``"processes[:N]"``, ``"dask:tcp://host:8786"``, an
        :class:`~tension_opt.executors.Executor`, or a Dask client. The result does not
        depend on it.
    chunk_size : int
        Sweep points per chunk (>= 1).
    progress : bool
        Show a progress bar over the chunks.
    **robot_overrides
        Fixed overrides of :func:`tension_opt.presets.algae_harvester` (SI units),
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
    name = _canonical(parameter)
    _check_overrides(robot_overrides)
    _check_material_use(name, robot_overrides, material, elastic)
    model_names = tuple(models)
    if not model_names or any(mo not in MODELS for mo in model_names) \
            or len(set(model_names)) != len(model_names):
        raise InvalidInputError(f"models must be distinct names among {MODELS}; got {models!r}")
    chosen = cast(tuple[SagModel, ...], model_names)  # checked just above
    if values is None:
        if name not in STUDY_PARAMETERS:
            raise InvalidInputError(f"{parameter!r} has no default values: pass values=[...]")
        values = STUDY_PARAMETERS[name].defaults
    elif isinstance(values, str | CableMaterial) or np.isscalar(values):
        values = [values]  # one value
    elif isinstance(values, np.ndarray):
        values = values.ravel().tolist()
    points = _points(name, list(values), robot_overrides, material, elastic)
    p = _as_poses(poses)
    chunks = [
        _Chunk(tuple(points[s]), p, chosen, objective, backend)
        for s in chunk_slices(len(points), chunk_size)
    ]
    frames = run_chunks(_run_chunk, chunks, executor=executor, progress=progress,
                        description=f"{name} sweep")
    return pd.concat(frames, ignore_index=True)


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


# ----------------------------------------------------------------------------
# command line


def _parser() -> argparse.ArgumentParser:
    names = [*STUDY_PARAMETERS,
             *(n for n in ROBOT_OVERRIDES if n not in _ALIASES and n not in STUDY_PARAMETERS)]
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.studies",
        description="Sweep one parameter of the reference algae-harvesting robot and "
                    "tabulate straight and sagging cable lengths and tensions.")
    parser.add_argument("parameter", choices=names, metavar="PARAMETER",
                        help=f"one of {names}")
    parser.add_argument("--values", nargs="+", metavar="V",
                        help="values to sweep, SI units (material names for 'material'); "
                             "default: the study's range")
    parser.add_argument("--materials", nargs="+", metavar="NAME",
                        help="same as --values for the material study")
    parser.add_argument("--pose", nargs=3, type=float, action="append", metavar=("X", "Y", "Z"),
                        help="a pose in m (repeat for several); default (0,0,0) and (8,-5,2)")
    parser.add_argument("--material", help="cable material for every point (not with "
                                           "'material')")
    parser.add_argument("--elastic", action="store_true",
                        help="EA from the material's rope modulus (default: inextensible)")
    parser.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    parser.add_argument("--set", nargs="+", default=[], metavar="KEY=VALUE",
                        help=f"fixed robot overrides among {list(ROBOT_OVERRIDES)}")
    parser.add_argument("--executor", metavar="SPEC",
                        help="inprocess (default), processes[:N] or dask[:ADDRESS]")
    parser.add_argument("--chunk-size", type=int, default=1, help="sweep points per chunk")
    parser.add_argument("--out", type=Path, help="write the full table as CSV here")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m benchmarks.studies PARAMETER [options]``.

    Prints a summary per (sweep point, pose) and writes the full table with ``--out``.
    """
    parser = _parser()
    args = parser.parse_args(argv)
    raw = args.materials if args.materials is not None else args.values
    if args.materials is not None and args.parameter != "material":
        parser.error(f"--materials goes with the 'material' sweep, not {args.parameter!r}")
    values: list[Any] | None
    try:
        values = raw if raw is None or args.parameter == "material" else [float(v) for v in raw]
    except ValueError:
        parser.error(f"--values takes numbers; got {raw}")
    overrides: dict[str, Any] = {}
    for item in args.set:
        key, sep, text = item.partition("=")
        try:
            overrides[key] = float(text)
        except ValueError:
            sep = ""
        if not sep:
            parser.error(f"--set takes KEY=NUMBER; got {item!r}")
    try:
        table = sweep(args.parameter, values, args.pose, material=args.material,
                      elastic=args.elastic, models=args.models, executor=args.executor,
                      chunk_size=args.chunk_size, progress=not args.no_progress, **overrides)
    except ValueError as exc:
        parser.error(str(exc))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out, index=False)
        print(f"{len(table)} rows written to {args.out}", file=sys.stderr)
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.float_format", "{:.4g}".format):
        print(summarize(table).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
