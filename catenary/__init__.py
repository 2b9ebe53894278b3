"""Elastic catenary of a single cable: span equations and solvers.

``catenary.elastic`` holds the pure, vectorised span equations (Irvine's
elastic catenary) with their analytic flexibility and stiffness;
``catenary.solve`` the forward (length -> forces) and inverse
(tension -> length) solvers; ``catenary.materials`` a small cable catalogue.
These need nothing but numpy and scipy.
"""

from .elastic import (
    flexibility,
    length_derivative,
    profile,
    span_jacobian,
    spans,
    stiffness,
    stretched_length,
    tension,
)
from .errors import CatenaryError, InvalidCableError
from .materials import MATERIALS, CableMaterial, cable_properties, get_material
from .solve import ForcesResult, LengthResult, solve_forces, solve_length

__all__ = [
    "MATERIALS",
    "CableMaterial",
    "CatenaryError",
    "ForcesResult",
    "InvalidCableError",
    "LengthResult",
    "cable_properties",
    "flexibility",
    "get_material",
    "length_derivative",
    "profile",
    "solve_forces",
    "solve_length",
    "span_jacobian",
    "spans",
    "stiffness",
    "stretched_length",
    "tension",
]
