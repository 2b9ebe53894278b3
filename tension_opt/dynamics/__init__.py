"""Dynamics of the platform: inertial wrench, timed trajectories, simulation, timing.

- :mod:`~tension_opt.dynamics.wrench`: :func:`required_wrench` (Newton-Euler: gravity
  and inertia, moments about the reference point), :func:`inertia_terms`,
  :func:`inertia_wrench`; the velocity coordinates used throughout;
- :mod:`~tension_opt.dynamics.rotation`: angular velocity and acceleration of
  rotation-vector poses;
- :mod:`~tension_opt.dynamics.timed`: :class:`TimedTrajectory` and
  :func:`distribute_trajectory` (dynamic tensions with every objective and smoothing
  option of :func:`tension_opt.distribute` and joint smoothing);
- :mod:`~tension_opt.dynamics.simulate`: :func:`simulate`, open-loop forward dynamics;
- :mod:`~tension_opt.dynamics.path`, :mod:`~tension_opt.dynamics.intervals`,
  :mod:`~tension_opt.dynamics.timing`, :mod:`~tension_opt.dynamics.timing_convex`,
  :mod:`~tension_opt.dynamics.reachability`, :mod:`~tension_opt.dynamics.stage_lp`,
  :mod:`~tension_opt.dynamics.lp`: :func:`time_optimal`, the time-optimal timing of a
  path under tension, velocity and acceleration limits, feasible between its grid
  points too (a convex program over the tensions of every check, or TOPP-RA
  reachability with the tensions as LP variables);
- :mod:`~tension_opt.dynamics.facets`: :func:`wrench_facets`, the wrench-feasible set
  as linear inequalities on the wrench (hyperplane shifting);
- :mod:`~tension_opt.dynamics.workspace`: :func:`dynamic_workspace`, the
  wrench-feasible workspace under a box of accelerations.
"""

from tension_opt.dynamics.facets import wrench_facets
from tension_opt.dynamics.path import PathSpline, PathStages, path_stages
from tension_opt.dynamics.rotation import twist_rates
from tension_opt.dynamics.simulate import SimulationResult, simulate
from tension_opt.dynamics.timed import TimedTrajectory, distribute_trajectory
from tension_opt.dynamics.timing import TimingResult, time_optimal
from tension_opt.dynamics.workspace import acceleration_vertices, dynamic_workspace
from tension_opt.dynamics.wrench import (
    inertia_terms,
    inertia_wrench,
    required_wrench,
)

__all__ = [
    "PathSpline",
    "PathStages",
    "SimulationResult",
    "TimedTrajectory",
    "TimingResult",
    "acceleration_vertices",
    "distribute_trajectory",
    "dynamic_workspace",
    "inertia_terms",
    "inertia_wrench",
    "path_stages",
    "required_wrench",
    "simulate",
    "time_optimal",
    "twist_rates",
    "wrench_facets",
]
