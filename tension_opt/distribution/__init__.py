"""Distribution: :func:`~tension_opt.distribution.entry.distribute` (a batch, in chunks,
or a smoothed sequence), the certified compiled pass of large batches
(:mod:`~tension_opt.distribution.certified`), the real-time
:class:`~tension_opt.distribution.distributor.Distributor`, and
:class:`~tension_opt.distribution.solution.TensionSolution`, the one place where an
answer is assembled and judged."""

from tension_opt.distribution.distributor import Distributor, RealtimeResult
from tension_opt.distribution.entry import distribute
from tension_opt.distribution.solution import TensionSolution

__all__ = ["Distributor", "RealtimeResult", "TensionSolution", "distribute"]
