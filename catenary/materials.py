"""A small catalogue of cable materials and their line properties.

Values are nominal, for studies and examples; check a manufacturer's data
sheet for design. The elastic modulus of a *rope* is well below that of its
fibre or wire material (lay, construction, bedding-in), so the catalogue gives
an effective rope modulus next to the material one, and the line properties
use the effective one by default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InvalidCableError

__all__ = ["MATERIALS", "STANDARD_GRAVITY", "CableMaterial", "cable_properties", "get_material"]

STANDARD_GRAVITY = 9.81
"""Gravity used by the reference study (m/s^2)."""


@dataclass(frozen=True)
class CableMaterial:
    """Nominal properties of a cable material.

    Attributes
    ----------
    name : str
        Catalogue key.
    density : float
        Mass density of the solid material (kg/m^3). The cable is treated as a
        full circular section of its nominal diameter, as in the reference
        study.
    modulus : float
        Young's modulus of the material (Pa).
    rope_modulus : float
        Effective modulus of a rope made of it, on the nominal section (Pa).
    note : str
        Source or caveat.
    """

    name: str
    density: float
    modulus: float
    rope_modulus: float
    note: str = ""

    def line_properties(
        self, diameter: ArrayLike, g: float = STANDARD_GRAVITY, rope: bool = True
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Weight per unit length ``w`` (N/m) and axial stiffness ``EA`` (N).

        Parameters
        ----------
        diameter : array_like
            Nominal cable diameter (m), ``> 0``.
        g : float
            Gravity (m/s^2).
        rope : bool
            Use the effective rope modulus (default) instead of the material's.
        """
        d = np.asarray(diameter, dtype=np.float64)
        if np.any(~np.isfinite(d)) or np.any(d <= 0):
            raise InvalidCableError(f"diameter must be finite and > 0 (m); got {diameter!r}")
        area = math.pi / 4.0 * d * d
        E = self.rope_modulus if rope else self.modulus
        return self.density * area * g, E * area


MATERIALS: dict[str, CableMaterial] = {
    m.name: m
    for m in (
        CableMaterial(
            "steel",
            7860.0,
            200e9,
            100e9,
            "steel wire rope; effective rope modulus roughly 80-120 GPa",
        ),
        CableMaterial(
            "dyneema",
            975.0,
            100e9,
            60e9,
            "UHMWPE fibre (970-1150 kg/m^3); braided rope modulus well below the fibre's",
        ),
        CableMaterial(
            "aramid",
            1440.0,
            100e9,
            50e9,
            "aramid/Kevlar fibre, E about 70-120 GPa (Kevlar as in the reference study)",
        ),
        CableMaterial("polyester", 1380.0, 10e9, 5e9, "polyester (PET) fibre rope"),
        CableMaterial(
            "polyethylene",
            1150.0,
            1e9,
            1e9,
            "polyethylene as in the reference study (density only there); modulus nominal",
        ),
    )
}
MATERIALS["uhmwpe"] = MATERIALS["dyneema"]
MATERIALS["kevlar"] = MATERIALS["aramid"]


def get_material(name: str) -> CableMaterial:
    """Catalogue entry by name (case-insensitive); raises with the known names."""
    try:
        return MATERIALS[name.lower()]
    except KeyError:
        raise InvalidCableError(
            f"unknown cable material {name!r}; known: {', '.join(sorted(MATERIALS))}"
        ) from None


def cable_properties(
    material: str | CableMaterial,
    diameter: ArrayLike,
    g: float = STANDARD_GRAVITY,
    rope: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weight per unit length ``w`` (N/m) and axial stiffness ``EA`` (N).

    Parameters
    ----------
    material : str or CableMaterial
        Catalogue name ("steel", "dyneema", "aramid", "polyester",
        "polyethylene", ...) or a material.
    diameter : array_like
        Nominal cable diameter (m).
    g : float
        Gravity (m/s^2).
    rope : bool
        Use the effective rope modulus (default) or the material modulus.

    Examples
    --------
    The reference study's 20 mm steel cable weighs 24.22 N/m:

    >>> w, EA = cable_properties("steel", 0.020)
    >>> round(float(w), 2)
    24.22
    """
    m = get_material(material) if isinstance(material, str) else material
    return m.line_properties(diameter, g=g, rope=rope)
