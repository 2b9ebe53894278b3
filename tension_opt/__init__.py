"""tension_opt: cable-tension distribution for cable-driven parallel robots.

Tension distribution posed as interchangeable convex problems (minimum sum, minimum
norm, pseudo-inverse, min-max, centred, smoothed), solved by exact closed forms,
cvxpy, qpsolvers or scipy/HiGHS, over batches of poses.
"""

from pathlib import Path

from tension_opt import caspr, compiled_cache, dynamics, presets, workspace
from tension_opt.backends import available_backends, get_backend
from tension_opt.caspr import load_caspr
from tension_opt.distribute import distribute
from tension_opt.errors import (
    BackendNotAvailableError,
    InvalidInputError,
    RobotFileError,
    SolverError,
    TensionOptError,
    UnsupportedProblemError,
)
from tension_opt.margin import capacity_margin
from tension_opt.problems import Objective, TensionProblem
from tension_opt.realtime import Distributor, RealtimeResult
from tension_opt.robot import CableProperties, CableRobot
from tension_opt.solution import Status, TensionSolution
from tension_opt.workspace import WorkspaceResult, workspace_grid, wrench_feasible_workspace

__version__ = "0.1.0"

__all__ = [
    "BackendNotAvailableError",
    "CableProperties",
    "CableRobot",
    "Distributor",
    "InvalidInputError",
    "Objective",
    "RealtimeResult",
    "RobotFileError",
    "SolverError",
    "Status",
    "TensionOptError",
    "TensionProblem",
    "TensionSolution",
    "UnsupportedProblemError",
    "WorkspaceResult",
    "available_backends",
    "capacity_margin",
    "caspr",
    "distribute",
    "dynamics",
    "get_backend",
    "load_caspr",
    "presets",
    "workspace",
    "workspace_grid",
    "wrench_feasible_workspace",
]

# Before any kernel runs (numba reads its disk cache at a kernel's first call): the
# caches a source change made stale go.
compiled_cache.guard("tension_opt", {"tension_opt": Path(__file__).parent})
