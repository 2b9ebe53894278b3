"""Robot design by optimisation: design variables, criteria with analytic gradients, and
a multi-start optimiser over them (guide: ``docs/guides/design.md``).

- :mod:`catenary.design.space`: :class:`DesignSpace` and its variables (drawing and
  attachment points, cable diameter, winch ``t_max``);
- :mod:`catenary.design.criteria`: peak tension, tension energy, workspace volume (and
  how every criterion is smoothed and differentiated); :mod:`catenary.design.lengths`:
  sag correction, cable mass; :mod:`catenary.design.cable_criteria`: the cable's
  strength, the lowest natural frequency; :mod:`catenary.design.base`: their common
  ground;
- :mod:`catenary.design.optimize`: :func:`optimize_design`.
"""

from .base import Criterion, CriterionValue, soft_max
from .cable_criteria import CableStrength, LowestFrequency
from .criteria import PeakTension, TensionEnergy, WorkspaceCoverage
from .lengths import CableMass, SagCorrection
from .optimize import DesignConstraint, DesignResult, optimize_design
from .space import (
    DesignSpace,
    DesignVariable,
    RobotGradient,
    anchor_coordinate,
    attachment_coordinate,
    cable_diameter,
    pulley_radius,
    winch_t_max,
)

__all__ = [
    "CableMass",
    "CableStrength",
    "Criterion",
    "CriterionValue",
    "DesignConstraint",
    "DesignResult",
    "DesignSpace",
    "DesignVariable",
    "LowestFrequency",
    "PeakTension",
    "RobotGradient",
    "SagCorrection",
    "TensionEnergy",
    "WorkspaceCoverage",
    "anchor_coordinate",
    "attachment_coordinate",
    "cable_diameter",
    "optimize_design",
    "pulley_radius",
    "soft_max",
    "winch_t_max",
]
