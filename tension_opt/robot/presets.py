"""Preset robots: the reference algae-harvesting robot and published CDPR geometries.

Each preset is a robot description file in ``tension_opt/robot/data/`` (YAML, the format of
:mod:`tension_opt.robot.files`), read by :meth:`CableRobot.from_file`; the files also
say where their numbers come from.
"""

from __future__ import annotations

from importlib import resources
from typing import Any

import numpy as np

from tension_opt.checks import check_positive, is_number
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableProperties, CableRobot

_ALGAE_DEFAULTS: dict[str, float] = {
    "pond_length": 80.9,  # along x (the study's code; its table swaps PL and PW)
    "pond_width": 50.0,  # along y
    "tower_height": 7.6,
    "offset_x": 6.1,
    "offset_y": 6.1,
    "mass": 258.6,
    "cable_diameter": 0.020,
    "cable_density": 7860.0,
    "t_min": None,  # type: ignore[dict-item]  # default: the platform weight m*g
    "t_max": np.inf,
    "g": 9.81,
    "EA": np.inf,
}


def algae_harvester(**overrides: Any) -> CableRobot:
    """The 4-cable, 3-DOF algae-harvesting robot of the reference study.

    Four towers of height ``tower_height`` stand ``offset_x``/``offset_y`` outside the
    corners of a ``pond_length`` (x) by ``pond_width`` (y) pond; base frame at the
    centre of the pond surface, z up. The end-effector is a point mass. Without
    overrides the robot is read from ``data/algae_harvester.yaml``; with overrides it
    is built from the study's parameters (the same numbers at the defaults).

    Parameters
    ----------
    **overrides
        Any of ``pond_length`` (80.9 m), ``pond_width`` (50 m), ``tower_height``
        (7.6 m), ``offset_x`` (6.1 m), ``offset_y`` (6.1 m), ``mass`` (258.6 kg),
        ``cable_diameter`` (0.020 m), ``cable_density`` (7860 kg/m^3), ``t_min``
        (default ``mass * g`` = 2536.866 N), ``t_max`` (inf N), ``g`` (9.81 m/s^2),
        ``EA`` (inf N).

    Returns
    -------
    CableRobot
        Cables ordered as in the study: P1 = (-,-), P2 = (-,+), P3 = (+,+), P4 = (+,-).
    """
    if not overrides:
        return _from_data("algae_harvester")
    return algae_harvester_from_parameters(**overrides)


def algae_harvester_from_parameters(**overrides: Any) -> CableRobot:
    """The algae-harvesting robot built from the study's parameters (see
    :func:`algae_harvester`, which reads the defaults from its file)."""
    unknown = set(overrides) - set(_ALGAE_DEFAULTS)
    if unknown:
        raise InvalidInputError(
            f"unknown override(s) {sorted(unknown)}; allowed: {sorted(_ALGAE_DEFAULTS)}"
        )
    p = {**_ALGAE_DEFAULTS, **overrides}
    for key in ("pond_length", "pond_width", "tower_height", "mass", "cable_diameter",
                "cable_density"):
        check_positive(key, p[key])
    for key in ("offset_x", "offset_y"):
        if not (is_number(p[key]) and np.isfinite(p[key])):
            raise InvalidInputError(f"{key} must be a finite number, got {p[key]!r}")
    hx = p["pond_length"] / 2 + p["offset_x"]
    hy = p["pond_width"] / 2 + p["offset_y"]
    h = p["tower_height"]
    anchors = np.array([[-hx, -hy, h], [-hx, hy, h], [hx, hy, h], [hx, -hy, h]])
    t_min = p["mass"] * p["g"] if p["t_min"] is None else p["t_min"]
    return CableRobot(
        anchors=anchors,
        attachments=np.zeros((4, 3)),
        mass=p["mass"],
        kind="point3",
        g=p["g"],
        t_min=t_min,
        t_max=p["t_max"],
        cable=CableProperties.from_density(p["cable_diameter"], p["cable_density"], p["EA"]),
        home=np.zeros(3),
        name="algae harvester",
    )


def _from_data(name: str) -> CableRobot:
    """The preset robot of ``data/<name>.yaml``."""
    with resources.as_file(resources.files("tension_opt.robot") / "data" / f"{name}.yaml") as path:
        return CableRobot.from_file(path)


def cogiro() -> CableRobot:
    """CoGiRo: 8 cables, 6 DOF, cable-suspended, about 15 x 11 x 6 m (100..5000 N).

    Home pose (0, 0, 2 m, no rotation), as in CASPR's model; 4 mm steel cable,
    0.064 kg/m, EA from the 8.2e-6 m^2 section at ~100 GPa.
    """
    return _from_data("cogiro")


def ipanema3() -> CableRobot:
    """IPAnema 3: 8 cables, 6 DOF, crossed layout, about 17 x 11 x 3.8 m (100..3000 N)."""
    return _from_data("ipanema3")


def kntu_planar() -> CableRobot:
    """KNTU planar robot: 4 cables, 3 DOF (x, y, rotation) in a horizontal plane (no gravity).

    Its lower tension bound 0.001 N is a numerical placeholder of the source data.
    """
    return _from_data("kntu_planar")


def point_xz_4cable() -> CableRobot:
    """Planar point mass in the xz plane with 4 cables, gravity in the plane (5..50 N)."""
    return _from_data("point_xz_4cable")


#: The published robots (every preset but the reference study's), by file name.
PUBLISHED = {
    "cogiro": cogiro,
    "ipanema3": ipanema3,
    "kntu_planar": kntu_planar,
    "point_xz_4cable": point_xz_4cable,
}
