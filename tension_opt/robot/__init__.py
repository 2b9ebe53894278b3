"""The robot: its model (:mod:`~tension_opt.robot.model`; the cables of a batch of poses
in :mod:`~tension_opt.robot.geometry`, guide pulleys in
:mod:`~tension_opt.robot.pulleys`), description files
(:mod:`~tension_opt.robot.files`, :mod:`~tension_opt.robot.formats`), the CASPR import
(:mod:`~tension_opt.robot.caspr`) and the presets with their data
(:mod:`~tension_opt.robot.presets`, ``data/``).

``python -m tension_opt check FILE`` prints a summary of a robot description file
(:mod:`tension_opt.cli`).
"""

from tension_opt.checks import as_float_array
from tension_opt.robot.geometry import CableGeometry, StraightForwardKinematicsResult
from tension_opt.robot.model import CableProperties, CableRobot, box_inertia
from tension_opt.robot.pulleys import Pulley

__all__ = [
    "CableGeometry",
    "CableProperties",
    "CableRobot",
    "Pulley",
    "StraightForwardKinematicsResult",
    "as_float_array",
    "box_inertia",
]
