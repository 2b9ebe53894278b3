"""Elastic catenary of a single cable, and the sag-aware kinematics of a cable robot.

A single hanging cable (these need nothing but numpy and scipy):

- ``catenary.elastic``: the pure, vectorised span equations (Irvine's elastic
  catenary) with their analytic flexibility and stiffness;
- ``catenary.solve``: the forward (length -> forces) and inverse (tension -> length)
  solvers;
- ``catenary.materials``: a small cable catalogue.

A :class:`tension_opt.CableRobot` whose cables sag (built on ``tension_opt``):

- ``catenary.geometry``: the cables in their vertical planes, the platform forces and
  their wrench, the extreme tensions along a cable;
- ``catenary.inverse``: sag-aware inverse kinematics (:func:`inverse_kinematics`, the
  thesis convention and the coupled model), over guide pulleys with
  ``catenary.pulleys``;
- ``catenary.sensitivity``: derivatives of the thesis convention's lengths by the pose,
  the tensions, the cable weight and ``EA`` (:func:`length_jacobian`);
- ``catenary.coupled_sensitivity``: derivatives of the coupled model's tensions and
  lengths (:func:`coupled_jacobian`);
- ``catenary.coupled``: the coupled model's sequential convex programming;
- ``catenary.forward``: sag-aware forward kinematics (:func:`forward_kinematics`);
- ``catenary.margin``: the coupled capacity margin (:func:`coupled_margin`);
- ``catenary.workspace``: the coupled-sag workspace (:func:`sag_workspace`).
- ``catenary.interference``: certified closest distances between sagging cables
  (:func:`cable_clearance`, :func:`curve_distance`) and the interference-free
  workspace with sag (:func:`interference_free_workspace`).
- ``catenary.robot_stiffness``: the platform's stiffness with straight or sagging
  elastic cables (:func:`platform_stiffness`), compiled for batches
  (``catenary.stiffness_kernels``, ``catenary.stiffness_compiled``) and for one pose
  at a time in loops (:class:`PoseStiffness`, ``catenary.stiffness_loop``);
- ``catenary.response``: natural frequencies, mode shapes and static deflection
  (:func:`natural_frequencies`, :func:`vibration_modes`, :func:`deflection`);
- ``catenary.stiffness_maps``: the lowest frequency and the deflection over a grid
  (:func:`stiffness_map`, :func:`plot_stiffness_map`).
- ``catenary.timing``: sag-aware time-optimal timing of a path
  (:func:`time_optimal_sag`).
- ``catenary.viz``: views of the robot with its sagging cables (:func:`plot_robot`,
  matplotlib or plotly), animations along a path (:func:`animate`), workspace and
  compliance overlays (:func:`plot_workspace`, :func:`plot_compliance`); matplotlib and
  plotly are imported when a view is drawn.
"""

from pathlib import Path

from tension_opt import compiled_cache

from . import warmup as warmup  # registers its kernel families with tension_opt's warm-up
from .coupled_sensitivity import CoupledSensitivity, coupled_jacobian
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
from .forward import ForwardKinematicsResult, forward_kinematics
from .interference import (
    CatenaryCurves,
    CurveDistance,
    cable_clearance,
    curve_distance,
    interference_free_workspace,
)
from .inverse import InverseKinematicsResult, inverse_kinematics
from .margin import coupled_margin
from .materials import (
    MATERIALS,
    CableMaterial,
    breaking_load,
    cable_properties,
    get_material,
    material_names,
)
from .response import (
    VibrationModes,
    deflection,
    mass_matrix,
    natural_frequencies,
    vibration_modes,
)
from .robot_stiffness import StiffnessResult, platform_stiffness, stiffness_analysis
from .sensitivity import LengthSensitivity, length_jacobian
from .solve import ForcesResult, LengthResult, solve_forces, solve_length
from .stiffness_loop import PoseStiffness
from .stiffness_maps import StiffnessMap, plot_stiffness_map, stiffness_map
from .timing import SagTimingResult, time_optimal_sag
from .viz import (
    RobotScene,
    ViewOptions,
    animate,
    animation_figure,
    compliance_ellipsoid,
    plot_compliance,
    plot_robot,
    plot_workspace,
    robot_scene,
    robot_scenes,
)
from .workspace import SagWorkspaceResult, sag_workspace

__all__ = [
    "MATERIALS",
    "CableMaterial",
    "CatenaryCurves",
    "CatenaryError",
    "CoupledSensitivity",
    "CurveDistance",
    "ForcesResult",
    "ForwardKinematicsResult",
    "InvalidCableError",
    "InverseKinematicsResult",
    "LengthResult",
    "LengthSensitivity",
    "PoseStiffness",
    "RobotScene",
    "SagTimingResult",
    "SagWorkspaceResult",
    "StiffnessMap",
    "StiffnessResult",
    "VibrationModes",
    "ViewOptions",
    "animate",
    "animation_figure",
    "breaking_load",
    "cable_clearance",
    "cable_properties",
    "compliance_ellipsoid",
    "coupled_jacobian",
    "coupled_margin",
    "curve_distance",
    "deflection",
    "flexibility",
    "forward_kinematics",
    "get_material",
    "interference_free_workspace",
    "inverse_kinematics",
    "length_derivative",
    "length_jacobian",
    "mass_matrix",
    "material_names",
    "natural_frequencies",
    "platform_stiffness",
    "plot_compliance",
    "plot_robot",
    "plot_stiffness_map",
    "plot_workspace",
    "profile",
    "robot_scene",
    "robot_scenes",
    "sag_workspace",
    "solve_forces",
    "solve_length",
    "span_jacobian",
    "spans",
    "stiffness",
    "stiffness_analysis",
    "stiffness_map",
    "stretched_length",
    "tension",
    "time_optimal_sag",
    "vibration_modes",
]

# Before any kernel runs (numba reads its disk cache at a kernel's first call): the
# caches a source change made stale go, the kernels' imports of tension_opt included.
compiled_cache.guard(
    "catenary",
    {"catenary": Path(__file__).parent, "tension_opt": Path(compiled_cache.__file__).parent},
)
