"""Preset robots: the reference algae-harvesting robot and published CDPR geometries."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

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
    centre of the pond surface, z up. The end-effector is a point mass.

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
    unknown = set(overrides) - set(_ALGAE_DEFAULTS)
    if unknown:
        raise InvalidInputError(
            f"unknown override(s) {sorted(unknown)}; allowed: {sorted(_ALGAE_DEFAULTS)}"
        )
    p = {**_ALGAE_DEFAULTS, **overrides}
    for key in ("pond_length", "pond_width", "tower_height", "mass", "cable_diameter",
                "cable_density"):
        value = p[key]
        if not np.isfinite(value) or value <= 0:
            raise InvalidInputError(f"{key} must be a positive finite number, got {value!r}")
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


@cache
def _load(name: str) -> dict[str, Any]:
    text = resources.files("tension_opt").joinpath("data", f"{name}.json").read_text()
    return json.loads(text)


def _published(name: str, kind: str, home: list[float], cable: CableProperties | None,
               g: float = 9.81) -> CableRobot:
    data = _load(name)
    return CableRobot(
        anchors=np.array(data["anchors"]),
        attachments=np.array(data["attachments"]),
        mass=data["mass"],
        kind=kind,  # type: ignore[arg-type]
        com=np.array(data["com"]),
        g=g,
        t_min=data["f_min"],
        t_max=data["f_max"],
        cable=cable,
        home=np.array(home),
        name=data["name"],
    )


def cogiro() -> CableRobot:
    """CoGiRo: 8 cables, 6 DOF, cable-suspended, about 15 x 11 x 6 m (100..5000 N).

    Home pose (0, 0, 2 m, no rotation), as in CASPR's model.
    """
    # 4 mm steel cable, 0.064 kg/m; EA from the 8.2e-6 m^2 section at ~100 GPa.
    return _published("cogiro", "spatial6", [0, 0, 2.0, 0, 0, 0],
                      CableProperties(0.004, 0.064, 8.2051e-6 * 100e9))


def ipanema3() -> CableRobot:
    """IPAnema 3: 8 cables, 6 DOF, crossed layout, about 17 x 11 x 3.8 m (100..3000 N)."""
    return _published("ipanema3", "spatial6", [0, 0, 1.3, 0, 0, 0],
                      CableProperties.from_density(0.006, 980.0))


def kntu_planar() -> CableRobot:
    """KNTU planar robot: 4 cables, 3 DOF (x, y, rotation) in a horizontal plane (no gravity).

    Its lower tension bound 0.001 N is a numerical placeholder of the source data.
    """
    return _published("kntu_planar", "planar3", [0, 0, 0], None, g=0.0)


def point_xz_4cable() -> CableRobot:
    """Planar point mass in the xz plane with 4 cables, gravity in the plane (5..50 N)."""
    return _published("point_xz_4cable", "planar_point2", [0, 0], None)


PUBLISHED = {
    "cogiro": cogiro,
    "ipanema3": ipanema3,
    "kntu_planar": kntu_planar,
    "point_xz_4cable": point_xz_4cable,
}
