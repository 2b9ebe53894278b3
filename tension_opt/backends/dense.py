"""Dense, scaled per-pose matrices shared by the generic (per-pose) backends.

The matrices are those of :mod:`tension_opt.scaled` (tensions over a reference tension,
equilibrium rows over their norms, objective over its size, a min-max term lifted to
an epigraph variable): the solvers and the certificate of their answers
(:mod:`tension_opt.certificate`) see the same problem. The names here are kept for the
backends and the micro-benchmarks.
"""

from __future__ import annotations

from tension_opt.problems import StandardForm
from tension_opt.scaled import ScaledBatch, scaled_batch, scaled_objective, working_scale

__all__ = ["DenseBatch", "dense_batch", "scaled_objective", "working_scale"]

#: The scaled, lifted batch of a form (:class:`tension_opt.scaled.ScaledBatch`).
DenseBatch = ScaledBatch


def dense_batch(form: StandardForm) -> ScaledBatch:
    """Scaled, lifted dense matrices of a batch (:func:`tension_opt.scaled.scaled_batch`)."""
    return scaled_batch(form)
