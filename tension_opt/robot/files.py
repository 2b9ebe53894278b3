"""Robot description files: the schema, reading with validation, and writing.

A robot file is YAML (``.yaml``/``.yml``) or JSON (``.json``) holding one mapping whose
fields are those of :class:`RobotDescription` (SI units; ``docs/robot_files.md`` has a
full example). :meth:`tension_opt.CableRobot.from_file` and
:meth:`~tension_opt.CableRobot.to_file` read and write it; floats are written with
Python's shortest round-trip ``repr``, so a robot written and read back is the same
robot bit for bit.

A bad file raises :class:`~tension_opt.errors.RobotFileError` naming each bad field by
its path (``cable.EA``, ``anchors[2][1]``), its line in the file, and the fix.

Cable materials
---------------
:mod:`tension_opt` sits below :mod:`catenary` and never imports it, so it does not hold
the cable catalogue (:mod:`catenary.materials`). A file gives a cable's numbers
(diameter, ``linear_mass`` or ``density``, ``EA``); ``material`` is an optional label,
checked against :data:`MATERIAL_NAMES` (the catalogue's names) so that a typo is caught.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from os import PathLike
from typing import Annotated, Any, Literal, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from tension_opt.checks import far_coordinate, inertia_tensor
from tension_opt.errors import InvalidInputError, RobotFileError
from tension_opt.kinds import KINDS
from tension_opt.robot.formats import (
    SUFFIXES,
    checked_path,
    file_error,
    json_text,
    line_map,
    parse_text,
    yaml_text,
)
from tension_opt.robot.pulleys import Pulley

__all__ = [
    "FORMAT_VERSION",
    "MATERIAL_NAMES",
    "SUFFIXES",
    "CableSpec",
    "RobotDescription",
    "Units",
    "load_description",
    "read_robot_file",
    "reported_against",
    "robot_arguments",
    "robot_document",
    "write_document",
    "write_robot_file",
]

#: Version of the file format written by :func:`write_robot_file`.
FORMAT_VERSION = 1
#: Cable material labels a file may give: the names and aliases of the catalogue in
#: :mod:`catenary.materials` (a test keeps the two lists equal).
MATERIAL_NAMES = ("steel", "dyneema", "uhmwpe", "aramid", "kevlar", "polyester",
                  "polyethylene")
_INF_WORDS = {"inf", "+inf", ".inf", "+.inf", "infinity", "+infinity"}


# ------------------------------------------------------------------ value types
def _inf_word(value: Any) -> Any:
    """``"inf"`` (any case, with or without sign or dot) as ``float("inf")``."""
    if isinstance(value, str):
        if value.strip().lower() in _INF_WORDS:
            return math.inf
        raise ValueError(f'expected a number or "inf", got the text {value!r}')
    return value


_Number = Annotated[float, Field(strict=True, allow_inf_nan=False)]
_NumberOrInf = Annotated[float, Field(strict=True, allow_inf_nan=True),
                         BeforeValidator(_inf_word)]
_Vector3 = Annotated[list[_Number], Field(min_length=3, max_length=3)]


def _as_list(value: Any) -> Any:
    """One number for all cables as a list of one."""
    return value if isinstance(value, list) else [value]


# One number for all cables or one per cable (the count is checked against the anchors).
_PerCable = Annotated[list[_Number], Field(min_length=1), BeforeValidator(_as_list)]
_PerCableOrInf = Annotated[list[_NumberOrInf], Field(min_length=1), BeforeValidator(_as_list)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Units(_Strict):
    """The units the file is written in: SI only, stated so that nobody guesses."""

    length: Literal["m"] = Field(description="m: every length and position in metres "
                                 "(convert other units before writing the file).")
    mass: Literal["kg"] = Field(description="kg: masses in kilograms, inertia in kg m^2.")
    force: Literal["N"] = Field(description="N: tension bounds and EA in newtons.")
    angle: Literal["rad"] = Field("rad", description="rad: pose angles in radians "
                                  "(optional).")


class CableSpec(_Strict):
    """Mechanical properties shared by all cables (:class:`tension_opt.CableProperties`)."""

    diameter: _Number = Field(gt=0, description="Cable diameter (m), > 0.")
    linear_mass: _Number | None = Field(
        None, ge=0, description="Mass per unit length (kg/m), >= 0; or give density.")
    density: _Number | None = Field(
        None, gt=0, description="Density of a solid circular section (kg/m^3), > 0; "
        "linear_mass = density * pi/4 * diameter^2. Give it or linear_mass, not both.")
    EA: _NumberOrInf = Field(
        math.inf, gt=0, description='Axial stiffness (N), > 0, or "inf" for an '
        "inextensible cable (the default).")
    material: str | None = Field(
        None, description="Optional label, one of " + ", ".join(MATERIAL_NAMES) + "; "
        "the numbers above are what counts.")

    @field_validator("material")
    @classmethod
    def _known_material(cls, value: str | None) -> str | None:
        if value is not None and value.strip().lower() not in MATERIAL_NAMES:
            raise ValueError(f"unknown cable material {value!r}: use one of "
                             f"{', '.join(MATERIAL_NAMES)}, or leave the label out")
        return value

    @model_validator(mode="after")
    def _one_mass_source(self) -> CableSpec:
        if (self.linear_mass is None) == (self.density is None):
            given = "both" if self.linear_mass is not None else "neither"
            named = f" (material {self.material!r} is a label only)" if self.material else ""
            raise ValueError(
                f"give exactly one of linear_mass (kg/m) or density (kg/m^3); the file "
                f"gives {given}{named}")
        return self


class PulleySpec(_Strict):
    """A swivel guide pulley at a cable's drawing point (:class:`tension_opt.Pulley`)."""

    radius: _Number = Field(gt=0, description="Wheel radius (m), > 0.")
    axis: _Vector3 = Field(description="Swivel axis [x, y, z] in the base frame: from the "
                           "drawing point towards the side the cable comes from (its winch); "
                           "normalised on reading.")


class RobotDescription(_Strict):
    """One robot, as written in a robot file. Every quantity is in SI units."""

    version: Literal[1] = Field(1, description="File format version: 1.")
    name: str = Field(min_length=1, description="Label used in tables and plots.")
    source: str | None = Field(None, description="Where the numbers come from (optional).")
    notes: str | None = Field(None, description="Free remarks (optional).")
    kind: str = Field(description="Motion pattern, one of " + ", ".join(KINDS) + ".")
    units: Units = Field(description="Units of the file: {length: m, mass: kg, force: N}.")
    anchors: list[_Vector3] = Field(
        min_length=1, description="Drawing points (cable exit points) in the base frame, "
        "one [x, y, z] per cable (m); base frame z up, gravity along -z.")
    attachments: list[_Vector3] = Field(
        min_length=1, description="Attachment points in the platform frame, one [x, y, z] "
        "per cable in the order of anchors (m); all zero for a point mass.")
    mass: _Number = Field(gt=0, description="Platform mass (kg), > 0.")
    com: _Vector3 = Field([0.0, 0.0, 0.0], description="Centre of mass in the platform "
                          "frame, [x, y, z] (m); default the origin.")
    inertia: Annotated[list[_Vector3], Field(min_length=3, max_length=3)] | None = Field(
        None, description="Inertia tensor about the centre of mass in the platform frame, "
        "3 rows of 3 (kg m^2), symmetric positive semi-definite; default: a solid box "
        "spanning the attachments.")
    g: _Number = Field(9.81, ge=0, description="Gravitational acceleration along -z "
                       "(m/s^2), >= 0; 0 for a horizontal planar robot.")
    t_min: _PerCable = Field(
        [0.0], description="Lower tension bound (N), >= 0: one number or one per cable.")
    t_max: _PerCableOrInf = Field(
        [math.inf], description='Upper tension bound (N), >= t_min: one number or one per '
        'cable; "inf" for none.')
    cable: CableSpec | None = Field(None, description="Cable properties (optional; needed "
                                    "by the sag models).")
    home: list[_Number] | None = Field(None, description="A central pose, one entry per "
                                       "pose coordinate of the kind (m, rad) (optional).")
    platform_hull: list[_Vector3] | None = Field(
        None, min_length=1, description="Vertices of the platform as a convex polyhedron, "
        "[x, y, z] each in the platform frame (m), for the cable-platform interference "
        "(optional; default the convex hull of the attachments).")
    pulleys: list[PulleySpec | None] | None = Field(
        None, description="A swivel guide pulley per cable, in the order of anchors, or "
        "null for a cable drawn from a fixed point (optional; default none).")

    @field_validator("kind")
    @classmethod
    def _known_kind(cls, value: str) -> str:
        if value not in KINDS:
            raise ValueError(f"unknown kind {value!r}: use one of {', '.join(KINDS)}")
        return value

    @field_validator("inertia")
    @classmethod
    def _symmetric_inertia(cls, value: list[list[float]] | None) -> list[list[float]] | None:
        if value is not None:
            try:
                inertia_tensor(value)
            except InvalidInputError as error:
                raise ValueError(str(error)) from None
        return value

    @field_validator("t_min", "t_max")
    @classmethod
    def _bounds_pull(cls, value: list[float]) -> list[float]:
        for v in value:
            if math.isnan(v) or v < 0:
                raise ValueError(f"tension bounds must be numbers >= 0 (N), got {v!r}: "
                                 "cables can only pull")
        return value


# ------------------------------------------------------------------ errors
def _field_path(loc: tuple[str | int, ...]) -> str:
    """``("cable", "EA")`` -> ``cable.EA``; ``("anchors", 2, 1)`` -> ``anchors[2][1]``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text or "(file)"


def _line_of(loc: tuple[str | int, ...], lines: dict[tuple[str | int, ...], int]) -> int:
    """Line of the deepest written prefix of ``loc``; 0 if unknown."""
    for end in range(len(loc), -1, -1):
        if loc[:end] in lines:
            return lines[loc[:end]]
    return 0


def _error_line(error: Mapping[str, Any], lines: dict[tuple[str | int, ...], int]) -> int:
    """Line of a field error; a field missing from the top level has none."""
    loc = tuple(error["loc"])
    if error["type"] == "missing" and len(loc) == 1:
        return 0
    return _line_of(loc, lines)


def _model_at(loc: tuple[str | int, ...]) -> type[BaseModel] | None:
    """The schema model whose fields sit at ``loc`` (the root, ``cable``, ``units``)."""
    nested: dict[tuple[str | int, ...], type[BaseModel]] = {
        ("cable",): CableSpec, ("units",): Units, (): RobotDescription}
    return nested.get(tuple(loc))


def _field_doc(loc: tuple[str | int, ...]) -> str:
    names = [part for part in loc if isinstance(part, str)]
    if not names:
        return ""
    model = _model_at(tuple(names[:-1]))
    field = None if model is None else model.model_fields.get(names[-1])
    return "" if field is None or not field.description else field.description


def _explain(error: Mapping[str, Any]) -> str:
    """What is wrong with one field and how to fix it, from a pydantic error."""
    loc = tuple(error["loc"])
    kind = error["type"]
    doc = _field_doc(loc)
    if kind == "missing":
        return f"missing; add it: {doc}" if doc else "missing; add it"
    if kind == "extra_forbidden":
        model = _model_at(loc[:-1])
        known = ", ".join(model.model_fields) if model else ""
        return f"unknown field; remove it or correct its spelling (fields here: {known})"
    if kind == "value_error":
        return str(error["ctx"]["error"])
    got = repr(error.get("input"))
    got = got if len(got) <= 80 else got[:77] + "..."
    message = f"{error['msg'][0].lower()}{error['msg'][1:]} (got {got})"
    return f"{message}; expected: {doc}" if doc else message


@contextmanager
def reported_against(path: str | PathLike[str]) -> Iterator[None]:
    """Turn a package input error raised inside into a :class:`RobotFileError` of ``path``."""
    try:
        yield
    except RobotFileError:
        raise
    except InvalidInputError as error:
        raise file_error(path, [("(robot)", 0, str(error))]) from None


# ------------------------------------------------------------------ reading
def _consistency(d: RobotDescription) -> list[tuple[tuple[str | int, ...], str]]:
    """Problems between fields that each passed the schema: counts, order, home size."""
    m = len(d.anchors)
    found: list[tuple[tuple[str | int, ...], str]] = []
    if len(d.attachments) != m:
        found.append((("attachments",), f"has {len(d.attachments)} points but anchors has "
                      f"{m}: give one attachment point per cable, in the order of anchors"))
    for name in ("t_min", "t_max"):
        value = getattr(d, name)
        if len(value) not in (1, m):
            found.append(((name,), f"has {len(value)} entries for {m} cables: give one "
                          "number for all cables or one per cable"))
    if not found:
        low = np.broadcast_to(np.array(d.t_min, dtype=float), (m,))
        high = np.broadcast_to(np.array(d.t_max, dtype=float), (m,))
        for i in np.flatnonzero(low > high)[:1]:
            found.append((("t_min",), f"cable {i}: t_min = {float(low[i])!r} exceeds t_max "
                          f"= {float(high[i])!r}; lower t_min or raise t_max"))
    if d.pulleys is not None and len(d.pulleys) != m:
        found.append((("pulleys",), f"has {len(d.pulleys)} entries for {m} cables: give one "
                      "per cable (null for a cable without a pulley)"))
    pattern = KINDS[d.kind]
    if d.home is not None and len(d.home) != pattern.pose_size:
        found.append((("home",), f"has {len(d.home)} entries but a {d.kind} pose has "
                      f"{pattern.pose_size}: ({', '.join(pattern.coordinates)})"))
    far = [(name, far_coordinate(np.array(getattr(d, name), dtype=float)))
           for name in ("anchors", "attachments", "com")]
    found += [((name, *where[0]), where[1]) for name, where in far if where is not None]
    return found


def load_description(path: str | PathLike[str]) -> RobotDescription:
    """Read and validate a robot file (YAML or JSON by its suffix).

    Raises
    ------
    RobotFileError
        Naming each bad field's path, its line and the fix.
    """
    file = checked_path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise RobotFileError(f"robot file {file} cannot be read: {error}", str(file)) from None
    data = parse_text(file, text)
    if not isinstance(data, dict):
        raise file_error(file, [("(file)", 1, "the file must hold one mapping of fields "
                                 "(name: ..., kind: ..., anchors: ...)")])
    try:
        description = RobotDescription.model_validate(data)
    except ValidationError as error:
        lines = line_map(text)
        raise file_error(file, [
            (_field_path(tuple(e["loc"])), _error_line(e, lines), _explain(e))
            for e in error.errors()]) from None
    found = _consistency(description)
    if found:
        lines = line_map(text)
        raise file_error(file, [(_field_path(loc), _line_of(loc, lines), text)
                                for loc, text in found])
    return description


class _CableType(Protocol):
    def __call__(self, diameter: float, linear_mass: float, EA: float) -> Any: ...

    def from_density(self, diameter: float, density: float, EA: float) -> Any: ...


R = TypeVar("R")


def _bound_array(values: list[float], m: int) -> NDArray:
    return np.broadcast_to(np.array(values, dtype=float), (m,)).copy()


def robot_arguments(description: RobotDescription, cable_type: _CableType
                    ) -> dict[str, Any]:
    """Keyword arguments of :class:`tension_opt.CableRobot` for a validated description;
    the cable is made by ``cable_type`` (:class:`tension_opt.CableProperties`)."""
    d = description
    m = len(d.anchors)
    cable = None
    if d.cable is not None:  # the schema holds exactly one of density and linear_mass
        c = d.cable
        if c.density is not None:
            cable = cable_type.from_density(c.diameter, c.density, c.EA)
        elif c.linear_mass is not None:
            cable = cable_type(c.diameter, c.linear_mass, c.EA)
    return {
        "anchors": np.array(d.anchors, dtype=float),
        "attachments": np.array(d.attachments, dtype=float),
        "mass": d.mass, "kind": d.kind, "com": np.array(d.com, dtype=float), "g": d.g,
        "t_min": _bound_array(d.t_min, m), "t_max": _bound_array(d.t_max, m),
        "cable": cable, "home": None if d.home is None else np.array(d.home, dtype=float),
        "name": d.name,
        "inertia": None if d.inertia is None else np.array(d.inertia, dtype=float),
        "platform_hull": (None if d.platform_hull is None
                          else np.array(d.platform_hull, dtype=float)),
        "pulleys": None if d.pulleys is None else [
            None if q is None else Pulley(q.radius, np.array(q.axis, dtype=float))
            for q in d.pulleys],
    }


def read_robot_file(path: str | PathLike[str], robot_type: Callable[..., R],
                    cable_type: _CableType) -> R:
    """The robot of a file, made by ``robot_type`` (:class:`tension_opt.CableRobot`).

    Raises
    ------
    RobotFileError
        For a file that does not describe a valid robot.
    """
    description = load_description(path)
    with reported_against(path):
        return robot_type(**robot_arguments(description, cable_type))


# ------------------------------------------------------------------ writing
class _DescribedRobot(Protocol):
    """What a robot file records of a robot (read-only fields of a CableRobot)."""

    @property
    def name(self) -> str: ...

    @property
    def kind(self) -> str: ...

    @property
    def anchors(self) -> NDArray: ...

    @property
    def attachments(self) -> NDArray: ...

    @property
    def mass(self) -> float: ...

    @property
    def com(self) -> NDArray: ...

    @property
    def inertia(self) -> NDArray | None: ...

    @property
    def g(self) -> float: ...

    @property
    def t_min(self) -> NDArray | float: ...

    @property
    def t_max(self) -> NDArray | float: ...

    @property
    def cable(self) -> Any: ...

    @property
    def home(self) -> NDArray | None: ...

    @property
    def platform_hull(self) -> NDArray | None: ...

    @property
    def pulleys(self) -> Sequence[Pulley | None] | None: ...


def _per_cable(values: NDArray | float) -> float | list[float]:
    """One number when every cable has the same (bit for bit, so -0.0 stays), else a list."""
    listed = np.atleast_1d(np.asarray(values, dtype=float)).tolist()
    return listed[0] if len({repr(v) for v in listed}) == 1 else listed


def robot_document(robot: _DescribedRobot) -> dict[str, Any]:
    """The fields of a robot file describing ``robot`` (plain Python values)."""
    if robot.kind not in KINDS:
        raise RobotFileError(
            f"kind {robot.kind!r} is not in tension_opt.kinds.KINDS, so a file cannot name "
            "it: register the kind or write the robot in code")
    document: dict[str, Any] = {
        "version": FORMAT_VERSION, "name": str(robot.name), "kind": robot.kind,
        "units": {"length": "m", "mass": "kg", "force": "N", "angle": "rad"},
        "anchors": np.asarray(robot.anchors, dtype=float).tolist(),
        "attachments": np.asarray(robot.attachments, dtype=float).tolist(),
        "mass": float(robot.mass), "com": np.asarray(robot.com, dtype=float).tolist(),
    }
    if robot.inertia is not None:
        document["inertia"] = np.asarray(robot.inertia, dtype=float).tolist()
    document["g"] = float(robot.g)
    document["t_min"] = _per_cable(robot.t_min)
    document["t_max"] = _per_cable(robot.t_max)
    if robot.cable is not None:
        document["cable"] = {"diameter": float(robot.cable.diameter),
                             "linear_mass": float(robot.cable.linear_mass),
                             "EA": float(robot.cable.EA)}
    if robot.home is not None:
        document["home"] = np.asarray(robot.home, dtype=float).tolist()
    if robot.platform_hull is not None:
        document["platform_hull"] = np.asarray(robot.platform_hull, dtype=float).tolist()
    if robot.pulleys is not None:
        document["pulleys"] = [None if q is None else {"radius": float(q.radius),
                                                       "axis": np.asarray(q.axis).tolist()}
                               for q in robot.pulleys]
    return document


def write_document(path: str | PathLike[str], document: dict[str, Any],
                   header: str = "") -> None:
    """Write robot-file fields as YAML or JSON (by the suffix of ``path``).

    ``header`` lines are written as YAML comments (ignored for JSON).
    """
    file = checked_path(path)
    text = (json_text(document) if SUFFIXES[file.suffix.lower()] == "json"
            else yaml_text(document, header))
    file.write_text(text, encoding="utf-8")


def write_robot_file(path: str | PathLike[str], robot: _DescribedRobot) -> None:
    """Write ``robot`` to a YAML or JSON file; reading it back gives the same robot."""
    write_document(path, robot_document(robot))
