"""tension_opt: cable-tension distribution for cable-driven parallel robots.

Tension distribution posed as interchangeable convex problems (minimum sum, minimum
norm, pseudo-inverse, min-max, centred, smoothed), solved by exact closed forms,
cvxpy, qpsolvers or scipy/HiGHS, over batches of poses.
"""

import sys
from pathlib import Path

from tension_opt import compiled_cache, dynamics, workspace
from tension_opt.backends import available_backends, get_backend
from tension_opt.distribution.distributor import Distributor, RealtimeResult
from tension_opt.distribution.entry import distribute
from tension_opt.distribution.solution import TensionSolution
from tension_opt.errors import (
    BackendNotAvailableError,
    InvalidInputError,
    RobotFileError,
    SolverError,
    TensionOptError,
    UnsupportedProblemError,
)
from tension_opt.problem.form import Objective, TensionProblem
from tension_opt.robot import CableProperties, CableRobot, Pulley, caspr, presets
from tension_opt.robot.caspr import load_caspr
from tension_opt.status import Status
from tension_opt.workspace import (
    WorkspaceResult,
    workspace_grid,
    wrench_closure_workspace,
    wrench_feasible_workspace,
)
from tension_opt.workspace.margin import capacity_margin

__version__ = "0.1.0"

# The robot's presets and CASPR import live in tension_opt.robot; these public names
# also import as modules of their own (`import tension_opt.presets`).
sys.modules.setdefault("tension_opt.presets", presets)
sys.modules.setdefault("tension_opt.caspr", caspr)

__all__ = [
    "BackendNotAvailableError",
    "CableProperties",
    "CableRobot",
    "Distributor",
    "InvalidInputError",
    "Objective",
    "Pulley",
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
    "wrench_closure_workspace",
    "wrench_feasible_workspace",
]

# Before any kernel runs (numba reads its disk cache at a kernel's first call): the
# caches a source change made stale go.
compiled_cache.guard("tension_opt", {"tension_opt": Path(__file__).parent})
