"""Wrench-feasible workspace over grids or random samples, with the capacity margin.

A pose is *wrench-feasible* when tensions within ``[t_min, t_max]`` hold the platform's
weight plus every external wrench of a given set (each on its own). Beside the yes/no
answer every pose gets its **capacity margin** (N)::

    margin = max s  such that  A T = b,  t_min + s <= T <= t_max - s      (one wrench)

positive inside the workspace, zero on its boundary, negative outside (see
:mod:`tension_opt.workspace.margin` for its infinite values and how it is computed). With
several wrenches the margin is the smallest over them. A pose is reported feasible
when ``margin >= -FEAS_TOL * scale``, ``scale`` being the pose's typical tension.

The package holds one job per module:

- :mod:`~tension_opt.workspace.grid`: :class:`Grid`, :func:`workspace_grid`,
  :func:`sample_poses`, :func:`cell_widths` (the poses to check);
- :mod:`~tension_opt.workspace.result`: :class:`WorkspaceResult`;
- :mod:`~tension_opt.workspace.compute`: :func:`wrench_feasible_workspace`, chunks of
  poses over an executor (in-process, a process pool or Dask; the chunks, and so the
  result, do not depend on the executor);
- :mod:`~tension_opt.workspace.interference`: :func:`cable_clearance`,
  :func:`segment_distance` (straight cables' closest distances);
- :mod:`~tension_opt.workspace.platform`: :func:`platform_clearance` (cables against
  the platform polyhedron);
- :mod:`~tension_opt.workspace.interference_free`: :func:`interference_free_workspace`;
- :mod:`~tension_opt.workspace.wrench_set`: :class:`WrenchPolytope` (polytopes of
  external wrenches, by vertices or ``H w <= h``);
- :mod:`~tension_opt.workspace.hyperplane`: :func:`wrench_space_margin`,
  :func:`available_wrench_facets` (the wrench-space margin by hyperplane shifting);
- :mod:`~tension_opt.workspace.criteria`: :func:`wrench_closure_workspace`,
  :func:`static_feasible_workspace`, :data:`CRITERIA` (every criterion by name);
- :mod:`~tension_opt.workspace.orientation`: :func:`orientation_workspace`,
  :func:`total_orientation_workspace`, :func:`inclusion_orientation_workspace`;
- :func:`combine_workspaces` (``a & b``): poses that meet several criteria;
- :mod:`~tension_opt.workspace.plots`: :func:`plot_slice`, :func:`plot_workspace_3d`.

The margin itself is :func:`tension_opt.workspace.margin.capacity_margin`, also importable from
here.
"""

from tension_opt.problem.affine import CONSISTENCY_TOL, RANK_TOL
from tension_opt.workspace.compute import (
    CHUNK_SIZE,
    FEAS_TOL,
    on_drawing_point,
    prepare,
    wrench_feasible_workspace,
)
from tension_opt.workspace.criteria import (
    CLOSURE_TOL,
    CRITERIA,
    closure_ratio,
    static_feasible_workspace,
    wrench_closure_workspace,
)
from tension_opt.workspace.grid import (
    MAX_GRID_POINTS,
    Grid,
    cell_widths,
    sample_poses,
    workspace_grid,
)
from tension_opt.workspace.hyperplane import available_wrench_facets, wrench_space_margin
from tension_opt.workspace.interference import (
    CableClearance,
    SegmentDistance,
    cable_clearance,
    segment_distance,
)
from tension_opt.workspace.interference_free import (
    InterferenceResult,
    interference_free_workspace,
)
from tension_opt.workspace.margin import LP_CAP, capacity_margin, margin_lp, margin_solve
from tension_opt.workspace.orientation import (
    inclusion_orientation_workspace,
    orientation_workspace,
    total_orientation_workspace,
)
from tension_opt.workspace.platform import PlatformClearance, platform_clearance
from tension_opt.workspace.plots import plot_slice, plot_workspace_3d
from tension_opt.workspace.result import WorkspaceResult, combine_workspaces
from tension_opt.workspace.wrench_set import WrenchPolytope

__all__ = [
    "CHUNK_SIZE",
    "CLOSURE_TOL",
    "CONSISTENCY_TOL",
    "CRITERIA",
    "FEAS_TOL",
    "LP_CAP",
    "MAX_GRID_POINTS",
    "RANK_TOL",
    "CableClearance",
    "Grid",
    "InterferenceResult",
    "PlatformClearance",
    "SegmentDistance",
    "WorkspaceResult",
    "WrenchPolytope",
    "available_wrench_facets",
    "cable_clearance",
    "capacity_margin",
    "cell_widths",
    "closure_ratio",
    "combine_workspaces",
    "inclusion_orientation_workspace",
    "interference_free_workspace",
    "margin_lp",
    "margin_solve",
    "on_drawing_point",
    "orientation_workspace",
    "platform_clearance",
    "plot_slice",
    "plot_workspace_3d",
    "prepare",
    "sample_poses",
    "segment_distance",
    "static_feasible_workspace",
    "total_orientation_workspace",
    "workspace_grid",
    "wrench_closure_workspace",
    "wrench_feasible_workspace",
    "wrench_space_margin",
]
