"""A small catalogue of cable materials and their line properties.

Values are nominal, for studies and examples; check a manufacturer's data
sheet for design. The elastic modulus of a *rope* is well below that of its
fibre or wire material (lay, construction, bedding-in), so the catalogue gives
an effective rope modulus next to the material one, and the line properties
use the effective one by default. Likewise for strength: ``strength`` is the
tensile strength of the fibre or wire, ``rope_strength`` the breaking strength
of a rope made of it *on its nominal (full circular) section*, so that
``rope_strength * pi/4 * d**2`` is a nominal breaking load (N) of a ``d`` rope
(:func:`breaking_load`). NaN where the catalogue knows no value.

Densities are those of the solid material on the full nominal section, as in
the reference study (steel 7860, polyethylene 1150, Kevlar 1440 kg/m^3); a
real stranded or braided rope weighs less per metre (voids, fill factor about
0.5-0.7), so these line weights are upper bounds.

Sources
-------
steel
    Wire grades 1770-1960 MPa (EN 12385-4 / ISO 2408 tensile grades 1570,
    1770, 1960, 2160 N/mm^2); ``strength`` takes grade 1960. Rope: the minimum
    breaking force of EN 12385-4 / ISO 2408, ``F_min = K d^2 R_r``, with
    ``K = 0.356`` for 6x19 and 6x36 class ropes with steel core (IWRC), gives
    ``K R_r / (pi/4) = 888 MPa`` on the nominal section at grade 1960 (about
    0.8 of the wire grade on the metallic area). Modulus: steel 200 GPa; wire
    rope on its nominal section roughly 80-120 GPa.
dyneema (uhmwpe)
    DSM Dyneema fact sheet (CIS YA100, 2010): SK75/SK78 fibre 3.3-3.9 GPa,
    modulus 109-132 GPa, density 970-980 kg/m^3. Rope: about 1 GPa on the
    nominal section for 12-strand braids of SK75/SK78 (Samson AmSteel-Blue,
    3/16 in = 4.8 mm, is rated 5400 lbf = 24 kN, i.e. 1.35 GPa; thicker ropes
    reach less per unit section).
aramid (kevlar)
    DuPont Kevlar technical guide: Kevlar 29 fibre 2.9 GPa (Kevlar 49 3.0 GPa,
    up to 3.6 GPa for high-strength grades), modulus 70-112 GPa, density
    1440 kg/m^3 (the reference study's Kevlar). Rope strength depends strongly on
    construction and jacket: not catalogued (NaN).
polyester
    PET high-tenacity industrial yarn about 1.1 GPa, 1380 kg/m^3. Rope: ISO 1141
    3- and 8-strand polyester ropes break at about 195 MPa on the nominal section
    (e.g. 12 mm 22.6 kN, 18 mm 49.8 kN, 24 mm 88 kN; Engineering ToolBox,
    "Polyester rope - strength").
polyethylene
    The reference study's "polyethylene", 1150 kg/m^3 (density only there; the
    grade is not stated, so no strength is catalogued). Modulus nominal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import is_number

from .errors import InvalidCableError
from .solve.common import float_argument

__all__ = [
    "MATERIALS",
    "STANDARD_GRAVITY",
    "CableMaterial",
    "breaking_load",
    "cable_properties",
    "get_material",
    "material_names",
]

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
    strength : float
        Tensile strength of the fibre or wire (Pa); NaN if unknown.
    rope_strength : float
        Nominal breaking strength of a rope made of it, on the rope's nominal
        (full circular) section (Pa); NaN if unknown.
    """

    name: str
    density: float
    modulus: float
    rope_modulus: float
    note: str = ""
    strength: float = math.nan
    rope_strength: float = math.nan

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
        area = _area(diameter)
        if not (is_number(g) and 0.0 <= float(g) < math.inf):
            raise InvalidCableError(f"g must be a finite number >= 0 (m/s^2); got g={g!r}")
        E = self.rope_modulus if rope else self.modulus
        return self.density * area * g, E * area

    def breaking_load(self, diameter: ArrayLike, rope: bool = True) -> NDArray[np.float64]:
        """Nominal breaking load (N) of a cable of this material.

        Parameters
        ----------
        diameter : array_like
            Nominal cable diameter (m), ``> 0``; any shape.
        rope : bool
            Rope breaking strength on the nominal section (default), or the
            fibre/wire strength times the full nominal section (an upper bound
            that no rope reaches).

        Returns
        -------
        ndarray
            ``strength * pi/4 * d**2`` (N), the shape of ``diameter``; NaN where
            the catalogue has no strength for this material.
        """
        area = _area(diameter)
        return (self.rope_strength if rope else self.strength) * area


def _area(diameter: ArrayLike) -> NDArray[np.float64]:
    """Nominal section ``pi/4 d^2`` (m^2) of validated diameters (m)."""
    d = float_argument("diameter", diameter)
    if np.any(~np.isfinite(d)) or np.any(d <= 0):
        raise InvalidCableError(f"diameter must be finite and > 0 (m); got {diameter!r}")
    return math.pi / 4.0 * d * d


_STEEL_ROPE_K = 0.356
"""Minimum breaking force factor of 6x19 / 6x36 class ropes with steel core (EN 12385-4)."""

MATERIALS: dict[str, CableMaterial] = {
    m.name: m
    for m in (
        CableMaterial(
            "steel",
            7860.0,
            200e9,
            100e9,
            "steel wire rope; effective rope modulus roughly 80-120 GPa; wire grade 1960 MPa, "
            "rope 6x36 IWRC (EN 12385-4, K = 0.356)",
            strength=1960e6,
            rope_strength=_STEEL_ROPE_K * 1960e6 / (math.pi / 4.0),
        ),
        CableMaterial(
            "dyneema",
            975.0,
            100e9,
            60e9,
            "UHMWPE fibre (970-1150 kg/m^3; DSM SK75/SK78 3.3-3.9 GPa); braided rope modulus "
            "well below the fibre's; 12-strand rope about 1 GPa on the nominal section",
            strength=3.5e9,
            rope_strength=1.0e9,
        ),
        CableMaterial(
            "aramid",
            1440.0,
            100e9,
            50e9,
            "aramid/Kevlar fibre, E about 70-120 GPa, Kevlar 29/49 2.9-3.6 GPa (Kevlar as in "
            "the reference study); rope strength not catalogued",
            strength=2.9e9,
        ),
        CableMaterial(
            "polyester",
            1380.0,
            10e9,
            5e9,
            "polyester (PET) fibre rope; high-tenacity yarn about 1.1 GPa, ISO 1141 3-/8-strand "
            "rope about 195 MPa on the nominal section",
            strength=1.1e9,
            rope_strength=195e6,
        ),
        CableMaterial(
            "polyethylene",
            1150.0,
            1e9,
            1e9,
            "polyethylene as in the reference study (density only there); modulus nominal; "
            "grade unknown, no strength catalogued",
        ),
    )
}
MATERIALS["uhmwpe"] = MATERIALS["dyneema"]
MATERIALS["kevlar"] = MATERIALS["aramid"]


def material_names(aliases: bool = False) -> list[str]:
    """Catalogue names in catalogue order; with ``aliases`` also "uhmwpe", "kevlar"."""
    if aliases:
        return list(MATERIALS)
    return [name for name, m in MATERIALS.items() if m.name == name]


def get_material(name: str | CableMaterial) -> CableMaterial:
    """Catalogue entry by name (case-insensitive); raises with the known names.

    A :class:`CableMaterial` is returned as is.
    """
    if isinstance(name, CableMaterial):
        return name
    if not isinstance(name, str):
        raise InvalidCableError(
            f"a cable material is a name or a CableMaterial; got {type(name).__name__}"
        )
    try:
        return MATERIALS[name.strip().lower()]
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
    return get_material(material).line_properties(diameter, g=g, rope=rope)


def breaking_load(
    material: str | CableMaterial, diameter: ArrayLike, rope: bool = True
) -> NDArray[np.float64]:
    """Nominal breaking load (N) of a cable of a catalogue material.

    Parameters
    ----------
    material : str or CableMaterial
        Catalogue name or a material.
    diameter : array_like
        Nominal cable diameter (m), ``> 0``; any shape.
    rope : bool
        Rope breaking strength on the nominal section (default) or the
        fibre/wire strength (an upper bound).

    Returns
    -------
    ndarray
        Breaking load (N), the shape of ``diameter``; NaN where the catalogue
        has no strength for the material.

    Examples
    --------
    A 20 mm steel wire rope (6x36 IWRC, grade 1960) breaks at about 279 kN:

    >>> round(float(breaking_load("steel", 0.020)) / 1e3)
    279
    """
    return get_material(material).breaking_load(diameter, rope=rope)
