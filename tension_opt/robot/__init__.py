"""The robot: its model (:mod:`~tension_opt.robot.model`), description files
(:mod:`~tension_opt.robot.files`, :mod:`~tension_opt.robot.formats`), the CASPR import
(:mod:`~tension_opt.robot.caspr`) and the presets with their data
(:mod:`~tension_opt.robot.presets`, ``data/``).

``python -m tension_opt check FILE`` prints a summary of a robot description file
(:mod:`tension_opt.cli`).
"""

from tension_opt.checks import as_float_array
from tension_opt.robot.model import (
    CableGeometry,
    CableProperties,
    CableRobot,
    StraightForwardKinematicsResult,
    box_inertia,
)

__all__ = [
    "CableGeometry",
    "CableProperties",
    "CableRobot",
    "StraightForwardKinematicsResult",
    "as_float_array",
    "box_inertia",
]
