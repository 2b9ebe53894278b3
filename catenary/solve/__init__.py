"""Forward and inverse solvers of the elastic catenary, vectorised over cables.

* :func:`solve_forces` -- unstretched length -> end forces (2 unknowns H, V_B);
  :mod:`catenary.solve.forces`.
* :func:`solve_length` -- an end tension -> unstretched length (unknowns
  H, V_B, L0; the tension condition is built into the parametrisation, so
  Newton works on the two span equations only); :mod:`catenary.solve.length`,
  its Newton in :mod:`catenary.solve.length_newton` and its bracketing
  fallback in :mod:`catenary.solve.length_bracket`.

Both run compiled (numba) kernels (:mod:`catenary.solve.kernels`, reached through
:mod:`catenary.solve.compiled`) for the cables those settle: the same guesses, Newton
steps and certificate, cable by cable (over threads for large batches), at a few
microseconds per call. The numpy implementation described below is the reference: it
solves the cables the kernels leave (vertical, weightless, zero-tension, degenerate,
not converged, ``end="H"``) and decides on invalid arguments; ``compiled=False`` runs
it alone. Statuses are the same either way, values the same to rounding.

Both work on nondimensional data: lengths in units of the chord and forces
in units of the problem's force scale, both rounded to powers of two (exact,
so the rounding is that of SI units), which keeps every product of forces in
range from 1e-300 to 1e300 N. Both run one Newton iteration on all
unconverged cables at once (analytic Jacobian from
:func:`catenary.elastic.evaluate`), starting from a closed-form guess that is
already accurate for taut cables, and hand the few cables Newton cannot
finish to a bracketed one-dimensional search over the hyperbolic end angles,
then polish them by Newton. Every loop has a hard iteration cap. Before a
cable is reported converged its answer is checked (the certificate): finite
forces whose catenary spans the chord to ``RES_TOL = 1e-8`` of its length
and, for :func:`solve_length`, meets the prescribed tension to ``T_TOL =
1e-9``. Per-cable outcomes are reported in ``status``; only invalid
arguments raise. Result types, statuses, scaling, the certificate and
argument checks live in :mod:`catenary.solve.common`.

Status values
-------------
Numpy unicode arrays of these strings (values of
``tension_opt.status.Status``):

``"converged"``      solution found and certified (for :func:`solve_length`:
                     the taut branch).
``"slack"``          weightless cable longer than its chord: zero tension.
``"infeasible"``     no catenary satisfies the data (inextensible cable shorter
                     than the chord, end tension too small to span the chord...).
``"indeterminate"``  the geometry does not fix the tension (taut inextensible
                     weightless or vertical cable); forces are NaN.
``"not_converged"``  no certified answer, forces NaN: an iteration cap was hit,
                     or no double-precision answer spans the chord to 1e-8
                     (a cable 1e9 times longer than its chord, a stretch under
                     its own weight of 1e10...), or the forces or the scaled
                     weight or compliance are beyond the double range.
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
