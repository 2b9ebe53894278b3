"""Elastic catenary of a single cable: span equations and solvers.

``catenary.elastic`` holds the pure, vectorised span equations (Irvine's
elastic catenary) with their analytic flexibility and stiffness;
``catenary.solve`` the forward (length -> forces) and inverse
(tension -> length) solvers; ``catenary.materials`` a small cable catalogue.
These need nothing but numpy and scipy; ``catenary.kinematics`` (sag-aware inverse and
forward kinematics of a :class:`tension_opt.CableRobot`) builds on ``tension_opt``.
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
from .kinematics import (
    ForwardKinematicsResult,
    InverseKinematicsResult,
    forward_kinematics,
    inverse_kinematics,
)
from .materials import (
    MATERIALS,
    CableMaterial,
    breaking_load,
    cable_properties,
    get_material,
    material_names,
)
from .solve import ForcesResult, LengthResult, solve_forces, solve_length
from .workspace import SagWorkspaceResult, coupled_margin, sag_workspace

__all__ = [
    "MATERIALS",
    "CableMaterial",
    "CatenaryError",
    "ForcesResult",
    "ForwardKinematicsResult",
    "InvalidCableError",
    "InverseKinematicsResult",
    "LengthResult",
    "SagWorkspaceResult",
    "breaking_load",
    "cable_properties",
    "coupled_margin",
    "flexibility",
    "forward_kinematics",
    "get_material",
    "inverse_kinematics",
    "length_derivative",
    "material_names",
    "profile",
    "sag_workspace",
    "solve_forces",
    "solve_length",
    "span_jacobian",
    "spans",
    "stiffness",
    "stretched_length",
    "tension",
]
