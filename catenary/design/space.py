"""Design variables: which numbers of a robot an optimiser may move, and within what box.

A :class:`DesignSpace` maps a vector ``x`` (k,) of design variables to a
:class:`tension_opt.CableRobot` (:meth:`DesignSpace.robot_at`) and carries a criterion's
derivatives by the robot's own numbers (a :class:`RobotGradient`) back to ``x``
(:meth:`DesignSpace.chain`). A variable sets one or more entries of the robot at once,
each ``factor * x_j``, so that four towers share one height, or two towers stay mirror
images (factors ``+1`` and ``-1``):

- :func:`anchor_coordinate`: coordinates of drawing points (base frame, m);
- :func:`attachment_coordinate`: coordinates of attachment points (platform frame, m);
- :func:`cable_diameter`: the cables' diameter (m); the cable keeps its material (the
  density and the modulus of the base robot's cable, or of a catalogue material given
  to the space): weight per length and ``EA`` scale with ``d^2``;
- :func:`winch_t_max`: the upper tension bound of one or more winches (N);
- :func:`pulley_radius`: the wheel radius of one or more guide pulleys (m).

A robot with guide pulleys is a space of its own kind (:attr:`DesignSpace.numeric`):
the criteria's analytic derivatives span each cable from a fixed drawing point, so the
optimiser differentiates every criterion of such a space by central differences, and
only criteria whose values model pulleys evaluate on it (the straight-cable
:class:`~catenary.design.PeakTension`, :class:`~catenary.design.TensionEnergy` and
:class:`~catenary.design.CableStrength`; the sag-aware ones raise their error).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.robot.model import CableProperties

from ..errors import InvalidDesignError
from ..materials import get_material

__all__ = ["KINDS", "DesignSpace", "DesignVariable", "RobotGradient", "anchor_coordinate",
           "attachment_coordinate", "cable_diameter", "pulley_radius", "winch_t_max"]

FloatArray = NDArray[np.float64]

#: The kinds of design variable.
KINDS = ("anchors", "attachments", "diameter", "t_max", "pulley_radius")
_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}


@dataclass(frozen=True)
class DesignVariable:
    """One design variable: the robot entries it sets and its box.

    Attributes
    ----------
    name : str
    kind : {"anchors", "attachments", "diameter", "t_max", "pulley_radius"}
    entries : tuple of (cable, axis, factor)
        The entries set to ``factor * x``: ``(cable, axis)`` of a point array for
        ``"anchors"`` / ``"attachments"``, ``(cable, 0)`` for ``"t_max"`` and
        ``"pulley_radius"``, none for ``"diameter"``.
    lower, upper : float
        The box of ``x`` (m or N), finite, ``lower < upper``.
    """

    name: str
    kind: str
    entries: tuple[tuple[int, int, float], ...]
    lower: float
    upper: float

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InvalidDesignError(f"kind must be one of {KINDS}, got {self.kind!r}")
        lo, up = float(self.lower), float(self.upper)
        if not (np.isfinite(lo) and np.isfinite(up) and lo < up):
            raise InvalidDesignError(
                f"variable {self.name!r}: bounds must be finite with lower < upper, got "
                f"({self.lower!r}, {self.upper!r})")
        if self.kind == "diameter" and not lo > 0:
            raise InvalidDesignError(f"variable {self.name!r}: a diameter's lower bound must "
                                     f"be > 0 m, got {lo!r}")
        if self.kind in ("t_max", "pulley_radius") and not lo > 0:
            unit = "N" if self.kind == "t_max" else "m"
            raise InvalidDesignError(f"variable {self.name!r}: a {self.kind}'s lower bound "
                                     f"must be > 0 {unit}, got {lo!r}")
        if self.kind != "diameter" and not self.entries:
            raise InvalidDesignError(f"variable {self.name!r} sets no cable: give cables")
        if self.kind == "diameter" and self.entries:
            raise InvalidDesignError(f"variable {self.name!r}: a diameter sets every cable, "
                                     "give no entries (cable_diameter(lower, upper))")
        for cable, axis, factor in self.entries:
            if not (isinstance(cable, int | np.integer) and isinstance(axis, int | np.integer)
                    and 0 <= axis <= 2):
                raise InvalidDesignError(f"variable {self.name!r}: entries are (cable, axis, "
                                         f"factor) with integer cable and axis 0..2, got "
                                         f"{(cable, axis, factor)!r}")
            if factor == 0 or not np.isfinite(factor):
                raise InvalidDesignError(f"variable {self.name!r}: factors must be finite "
                                         "and nonzero")
            if self.kind in ("t_max", "pulley_radius") and (axis != 0 or factor <= 0):
                raise InvalidDesignError(f"variable {self.name!r}: a {self.kind} entry is "
                                         "(cable, 0, factor > 0) (winch_t_max, "
                                         "pulley_radius)")


def _entries(cables: int | Sequence[int], axis: int | str | None,
             factors: Sequence[float] | None, name: str) -> tuple[tuple[int, int, float], ...]:
    cable_list = [cables] if isinstance(cables, int | np.integer) else list(cables)
    if not all(isinstance(c, int | np.integer) for c in cable_list):
        raise InvalidDesignError(f"variable {name!r}: cables must be integer indices, got "
                                 f"{cables!r}")
    if axis is None:
        ax = 0
    elif axis in _AXES:
        ax = _AXES[axis]
    else:
        raise InvalidDesignError(f"variable {name!r}: axis must be 'x', 'y', 'z' or 0..2, "
                                 f"got {axis!r}")
    fac = [1.0] * len(cable_list) if factors is None else [float(f) for f in factors]
    if len(fac) != len(cable_list):
        raise InvalidDesignError(f"variable {name!r}: {len(fac)} factors for "
                                 f"{len(cable_list)} cables; give one per cable")
    return tuple((int(c), ax, f) for c, f in zip(cable_list, fac, strict=True))


def anchor_coordinate(name: str, cables: int | Sequence[int], axis: int | str,
                      lower: float, upper: float,
                      factors: Sequence[float] | None = None) -> DesignVariable:
    """A coordinate (m, base frame) of the drawing points of ``cables``, each
    ``factor * x`` (default factors 1: the cables share the value).

    Examples
    --------
    >>> height = anchor_coordinate("tower height", [0, 1, 2, 3], "z", 4.0, 20.0)
    >>> height.entries[0]
    (0, 2, 1.0)
    """
    return DesignVariable(name, "anchors", _entries(cables, axis, factors, name), lower, upper)


def attachment_coordinate(name: str, cables: int | Sequence[int], axis: int | str,
                          lower: float, upper: float,
                          factors: Sequence[float] | None = None) -> DesignVariable:
    """A coordinate (m, platform frame) of the attachment points of ``cables``."""
    return DesignVariable(name, "attachments", _entries(cables, axis, factors, name),
                          lower, upper)


def cable_diameter(lower: float, upper: float, name: str = "cable diameter") -> DesignVariable:
    """The diameter (m) of every cable, within ``[lower, upper]``."""
    return DesignVariable(name, "diameter", (), lower, upper)


def winch_t_max(name: str, cables: int | Sequence[int], lower: float,
                upper: float) -> DesignVariable:
    """The upper tension bound (N) of the winches of ``cables`` (shared)."""
    return DesignVariable(name, "t_max", _entries(cables, None, None, name), lower, upper)


def pulley_radius(name: str, cables: int | Sequence[int], lower: float,
                  upper: float) -> DesignVariable:
    """The wheel radius (m) of the guide pulleys of ``cables`` (shared; each of these
    cables must leave over a pulley in the space's robot)."""
    return DesignVariable(name, "pulley_radius", _entries(cables, None, None, name), lower,
                          upper)


@dataclass(frozen=True, eq=False)
class RobotGradient:
    """Derivatives of a scalar by a robot's design numbers.

    Attributes
    ----------
    anchors, attachments : ndarray, shape (m, 3)
        By the drawing points (base frame) and the attachment points (platform frame)
        (unit of the scalar per m).
    diameter : float
        By the cable diameter (per m).
    t_max : ndarray, shape (m,)
        By each winch's upper tension bound (per N).
    """

    anchors: FloatArray
    attachments: FloatArray
    diameter: float
    t_max: FloatArray

    @classmethod
    def zeros(cls, m: int) -> RobotGradient:
        """All zero, for ``m`` cables."""
        return cls(np.zeros((m, 3)), np.zeros((m, 3)), 0.0, np.zeros(m))

    def __add__(self, other: RobotGradient) -> RobotGradient:
        return RobotGradient(self.anchors + other.anchors,
                             self.attachments + other.attachments,
                             self.diameter + other.diameter, self.t_max + other.t_max)

    def scaled(self, factor: float) -> RobotGradient:
        """This gradient times ``factor``."""
        return RobotGradient(self.anchors * factor, self.attachments * factor,
                             self.diameter * factor, self.t_max * factor)


@dataclass(frozen=True, eq=False)
class DesignSpace:
    """A base robot and the variables an optimiser may move (module notes).

    Parameters
    ----------
    robot : CableRobot
        The base design; entries no variable sets keep its values.
    variables : sequence of DesignVariable
        At least one; unique names; no robot entry set by two variables.
    material : str, optional
        A catalogue material (:data:`catenary.MATERIALS`) for the cables, with the
        rope modulus; default: the base robot's cable (its density and modulus).

    Raises
    ------
    InvalidDesignError
        Naming the variable and what to change.
    """

    robot: CableRobot
    variables: tuple[DesignVariable, ...]
    material: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.robot, CableRobot):
            raise InvalidDesignError(f"robot must be a tension_opt.CableRobot, got "
                                     f"{type(self.robot).__name__}")
        variables = tuple(self.variables)
        object.__setattr__(self, "variables", variables)
        if not variables or not all(isinstance(v, DesignVariable) for v in variables):
            raise InvalidDesignError("variables must be a non-empty sequence of "
                                     "DesignVariable (anchor_coordinate, cable_diameter, ...)")
        names = [v.name for v in variables]
        if len(set(names)) != len(names):
            raise InvalidDesignError(f"variable names must be unique, got {names}")
        m = self.robot.m
        seen: dict[tuple[str, int, int], str] = {}
        for v in variables:
            for cable, axis, _ in v.entries or ((0, 0, 1.0),):
                if not 0 <= cable < m:
                    raise InvalidDesignError(f"variable {v.name!r}: cable {cable} is not in "
                                             f"0..{m - 1}")
                key = (v.kind, cable, axis)
                if key in seen:
                    raise InvalidDesignError(f"variables {seen[key]!r} and {v.name!r} both "
                                             f"set {v.kind} of cable {cable}")
                seen[key] = v.name
        pulleys = self.robot.pulleys
        for v in variables:
            if v.kind == "pulley_radius" and (pulleys is None or any(
                    pulleys[cable] is None for cable, _, _ in v.entries)):
                raise InvalidDesignError(
                    f"variable {v.name!r} sets the pulley radius of a cable without a guide "
                    "pulley: give the robot pulleys (robot.with_(pulleys=[...]))")
        if ("diameter" in self.kinds or self.material is not None) and self.robot.cable is None:
            raise InvalidDesignError(
                "a cable diameter variable or material= needs a robot with cable properties "
                "(robot.with_(cable=CableProperties(...)))")
        if self.material is not None:
            get_material(self.material)  # fail early on an unknown name

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kind of each variable, shape (k,)."""
        return tuple(v.kind for v in self.variables)

    @property
    def numeric(self) -> bool:
        """Whether the optimiser differentiates every criterion by central differences:
        the robot has guide pulleys (module notes)."""
        return bool(self.robot.has_pulleys)

    @property
    def k(self) -> int:
        """The number of variables."""
        return len(self.variables)

    @property
    def lower(self) -> FloatArray:
        """Lower bounds, shape (k,)."""
        return np.array([v.lower for v in self.variables])

    @property
    def upper(self) -> FloatArray:
        """Upper bounds, shape (k,)."""
        return np.array([v.upper for v in self.variables])

    @property
    def names(self) -> list[str]:
        """Variable names."""
        return [v.name for v in self.variables]

    @property
    def x0(self) -> FloatArray:
        """The base robot's values (the first entry of each variable, over its factor),
        clipped into the box, shape (k,)."""
        r = self.robot
        out = []
        for v in self.variables:
            if v.kind == "diameter":
                out.append(r.cable.diameter if r.cable is not None else v.lower)
                continue
            cable, axis, factor = v.entries[0]
            source = {"anchors": r.anchors, "attachments": r.attachments}.get(v.kind)
            if v.kind == "pulley_radius":
                wheel = None if r.pulleys is None else r.pulleys[cable]
                assert wheel is not None  # checked when the space was made
                value = wheel.radius
            elif source is not None:
                value = source[cable, axis]
            else:
                value = np.broadcast_to(r.t_max, (r.m,))[cable]
            out.append(value / factor)
        return np.clip(np.array(out, dtype=float), self.lower, self.upper)

    def with_material(self, material: str | None) -> DesignSpace:
        """The same space with the cables of catalogue ``material``."""
        return DesignSpace(self.robot, self.variables, material)

    def cable_at(self, diameter: float) -> CableProperties:
        """The cable of diameter ``diameter`` (m) in this space's material."""
        base = self.robot.cable
        if base is None:
            raise InvalidDesignError("the base robot has no cable properties")
        if self.material is not None:
            w, EA = get_material(self.material).line_properties(diameter, g=self.robot.g or 9.81)
            return CableProperties(float(diameter), float(w) / (self.robot.g or 9.81), float(EA))
        scale = (diameter / base.diameter) ** 2
        return CableProperties(float(diameter), base.linear_mass * scale, base.EA * scale)

    def robot_at(self, x: ArrayLike) -> CableRobot:
        """The robot of design ``x`` (k,).

        Raises
        ------
        InvalidDesignError
            If ``x`` has the wrong shape or is not finite.
        """
        x = self.checked(x)
        r = self.robot
        anchors, attachments = r.anchors.copy(), r.attachments.copy()
        t_max = np.broadcast_to(np.asarray(r.t_max, dtype=float), (r.m,)).copy()
        cable = r.cable
        pulleys = None if r.pulleys is None else list(r.pulleys)
        if self.material is not None and cable is not None:
            cable = self.cable_at(cable.diameter)
        for v, value in zip(self.variables, x, strict=True):
            if v.kind == "diameter":
                cable = self.cable_at(value)
            for cable_i, axis, factor in v.entries:
                if v.kind == "anchors":
                    anchors[cable_i, axis] = factor * value
                elif v.kind == "attachments":
                    attachments[cable_i, axis] = factor * value
                elif v.kind == "pulley_radius":
                    wheel = None if pulleys is None else pulleys[cable_i]
                    assert pulleys is not None and wheel is not None  # checked in the space
                    pulleys[cable_i] = replace(wheel, radius=factor * value)
                else:
                    t_max[cable_i] = factor * value
        if pulleys is None:
            return r.with_(anchors=anchors, attachments=attachments, t_max=t_max, cable=cable)
        return r.with_(anchors=anchors, attachments=attachments, t_max=t_max, cable=cable,
                       pulleys=pulleys)

    def checked(self, x: ArrayLike) -> FloatArray:
        """``x`` as a float array of shape (k,), finite."""
        arr = np.asarray(x, dtype=float)
        if arr.shape != (self.k,) or not np.isfinite(arr).all():
            raise InvalidDesignError(f"x must be {self.k} finite numbers ({self.names}), got "
                                     f"shape {arr.shape}")
        return arr

    def chain(self, gradient: RobotGradient) -> FloatArray:
        """A :class:`RobotGradient` carried to the variables, shape (k,).

        Raises
        ------
        InvalidDesignError
            For a space over a robot with guide pulleys (:attr:`numeric`), whose
            criteria are differentiated numerically.
        """
        if self.numeric:
            raise InvalidDesignError(
                "a space over a robot with guide pulleys has no analytic gradient: the "
                "criteria span each cable from a fixed drawing point (the optimiser "
                "differentiates them by central differences)")
        out = np.zeros(self.k)
        for j, v in enumerate(self.variables):
            if v.kind == "diameter":
                out[j] = gradient.diameter
                continue
            source = {"anchors": gradient.anchors, "attachments": gradient.attachments}
            for cable, axis, factor in v.entries:
                out[j] += factor * (source[v.kind][cable, axis] if v.kind in source
                                    else gradient.t_max[cable])
        return out
