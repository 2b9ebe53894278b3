"""Forward and inverse solvers of the elastic catenary, vectorised over cables.

* :func:`solve_forces` -- unstretched length -> end forces (2 unknowns H, V_B);
  :mod:`catenary.solve.forces`.
* :func:`solve_length` -- an end tension -> unstretched length (unknowns
  H, V_B, L0; the tension condition is built into the parametrisation, so
  Newton works on the two span equations only); :mod:`catenary.solve.length`
  with its bracketing fallback in :mod:`catenary.solve.length_bracket`.

Both run one Newton iteration on all unconverged cables at once (analytic
Jacobian from :func:`catenary.elastic.evaluate`), starting from a closed-form
guess that is already accurate for taut cables, and hand the few cables
Newton cannot finish to a bracketing method that cannot fail to converge.
Per-cable outcomes are reported in ``status``; only invalid arguments raise.
Result types, statuses and argument checks live in
:mod:`catenary.solve.common`.

Status values
-------------
Numpy unicode arrays of these strings (values of
``tension_opt.solution.Status``):

``"converged"``      solution found (for :func:`solve_length`: the taut branch).
``"slack"``          weightless cable longer than its chord: zero tension.
``"infeasible"``     no catenary satisfies the data (inextensible cable shorter
                     than the chord, end tension too small to span the chord...).
``"indeterminate"``  the geometry does not fix the tension (taut inextensible
                     weightless or vertical cable); forces are NaN.
``"not_converged"``  the iteration limit was hit (not expected; please report).
"""

from __future__ import annotations

# The status strings and array alias, importable from here as before the split
# (explicit re-exports).
from .common import CONVERGED as CONVERGED
from .common import INDETERMINATE as INDETERMINATE
from .common import INFEASIBLE as INFEASIBLE
from .common import NOT_CONVERGED as NOT_CONVERGED
from .common import SLACK as SLACK
from .common import FloatArray as FloatArray
from .common import ForcesResult, LengthResult
from .forces import solve_forces
from .length import End as End
from .length import solve_length

__all__ = ["ForcesResult", "LengthResult", "solve_forces", "solve_length"]
