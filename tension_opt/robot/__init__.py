"""The cable robot model (:mod:`tension_opt.robot.model`) and its command line.

``python -m tension_opt.robot check FILE`` prints a summary of a robot description file
(:mod:`tension_opt.robot_cli`).
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
