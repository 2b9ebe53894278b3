"""Sweep points of the parameter studies: the study's parameters and the robot of a point.

:data:`STUDY_PARAMETERS` names the reference study's sweeps (cable diameter and
density, end-effector mass, pond area and aspect ratio, cable material) with their
default ranges; any other override of :func:`tension_opt.robot.presets.algae_harvester`
(:data:`ROBOT_OVERRIDES`) can be swept too. :func:`sweep_points` turns a parameter and
its values into validated :class:`SweepPoint` objects, each holding the preset
overrides that build its robot (:func:`study_robot`). Units are SI (m, kg, N, Pa).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from catenary.materials import CableMaterial, get_material, material_names
from tension_opt import CableRobot, presets
from tension_opt.errors import InvalidInputError

__all__ = [
    "NOMINAL_ASPECT_RATIO",
    "NOMINAL_POND_AREA",
    "NOMINAL_POND_LENGTH",
    "NOMINAL_POND_WIDTH",
    "ROBOT_OVERRIDES",
    "STUDY_PARAMETERS",
    "StudyParameter",
    "SweepPoint",
    "cable_density",
    "canonical_parameter",
    "check_material_use",
    "check_overrides",
    "parameter_names",
    "study_robot",
    "sweep_points",
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
"""Keyword overrides of :func:`tension_opt.robot.presets.algae_harvester` (SI units)."""

NOMINAL_POND_LENGTH = 80.9
"""Pond extent along x of the reference robot (m)."""
NOMINAL_POND_WIDTH = 50.0
"""Pond extent along y of the reference robot (m)."""
NOMINAL_POND_AREA = NOMINAL_POND_LENGTH * NOMINAL_POND_WIDTH
"""Pond area of the reference robot, 4045 m^2."""
NOMINAL_ASPECT_RATIO = NOMINAL_POND_LENGTH / NOMINAL_POND_WIDTH
"""Pond aspect ratio PL/PW of the reference robot, 1.618."""

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
        The :func:`~tension_opt.robot.presets.algae_harvester` keyword the value sets, or None
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



def parameter_names() -> list[str]:
    """Names :func:`sweep` accepts: the study's sweeps, then the other overrides."""
    return [*STUDY_PARAMETERS,
            *(n for n in ROBOT_OVERRIDES if n not in _ALIASES and n not in STUDY_PARAMETERS)]


@dataclass(frozen=True)
class SweepPoint:
    """One sweep point: the preset overrides that make its robot.

    Attributes
    ----------
    index : int
        Position of the point in the sweep.
    parameter : str
        Canonical name of the swept parameter.
    value : float or str
        The value as stored in the table (a material name for ``"material"``).
    overrides : dict
        Keywords of :func:`tension_opt.robot.presets.algae_harvester` (SI units).
    material : str
        Catalogue name of the cable material, ``""`` when none.
    breaking_load : float
        Nominal rope breaking load (N); NaN without a material.
    pond : tuple of float
        Pond length (x) and width (y) (m).
    """

    index: int
    parameter: str
    value: Any
    overrides: dict[str, Any]
    material: str  # catalogue name, "" when none
    breaking_load: float
    pond: tuple[float, float]


def canonical_parameter(parameter: str) -> str:
    """The parameter's name in :data:`STUDY_PARAMETERS` or :data:`ROBOT_OVERRIDES`.

    ``"cable_diameter"`` and ``"cable_density"`` become ``"diameter"`` and ``"density"``.

    Raises
    ------
    InvalidInputError
        For an unknown name, listing the known ones.
    """
    if not isinstance(parameter, str):
        raise InvalidInputError(f"parameter must be a name; got {parameter!r}")
    name = _ALIASES.get(parameter, parameter)
    if name not in STUDY_PARAMETERS and name not in ROBOT_OVERRIDES:
        known = sorted(set(STUDY_PARAMETERS) | set(ROBOT_OVERRIDES) - set(_ALIASES))
        raise InvalidInputError(f"unknown study parameter {parameter!r}; known: {known}")
    return name


def check_overrides(overrides: dict[str, Any]) -> None:
    """Raise :class:`InvalidInputError` for keys not in :data:`ROBOT_OVERRIDES`."""
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


def sweep_points(
    parameter: str,
    values: Iterable[Any],
    overrides: dict[str, Any],
    material: str | CableMaterial | None,
    elastic: bool,
) -> list[SweepPoint]:
    """Validated sweep points; every robot is built once here so bad input raises now.

    Parameters
    ----------
    parameter : str
        Canonical name (:func:`canonical_parameter`).
    values : iterable
        The values (SI units; material names or materials for ``"material"``).
    overrides : dict
        Fixed preset overrides (checked with :func:`check_overrides`).
    material : str or CableMaterial, optional
        Cable material of every point.
    elastic : bool
        EA from the material's rope modulus.

    Returns
    -------
    list of SweepPoint
    """
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
        points.append(SweepPoint(index, parameter, stored, point, mat.name if mat else "",
                                 load, pond))
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
    name = canonical_parameter(parameter)
    check_overrides(robot_overrides)
    check_material_use(name, robot_overrides, material, elastic)
    point = sweep_points(name, [value], robot_overrides, material, elastic)[0]
    return presets.algae_harvester(**point.overrides)


def check_material_use(
    parameter: str,
    overrides: dict[str, Any],
    material: str | CableMaterial | None,
    elastic: bool,
) -> None:
    """Raise :class:`InvalidInputError` for conflicting material, density and EA options.

    A material (given, or swept) sets the density, ``elastic`` needs a material and sets
    EA, and the swept parameter may not also be a fixed override.
    """
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


def cable_density(point: SweepPoint, robot: CableRobot) -> float:
    """Cable density (kg/m^3): as given, else from the linear mass of the robot's cable."""
    if "cable_density" in point.overrides:
        return float(point.overrides["cable_density"])
    assert robot.cable is not None
    density = robot.cable.linear_mass / (math.pi / 4.0 * robot.cable.diameter**2)
    return float(f"{density:.12g}")  # 7860.0, not 7860.000000000001
