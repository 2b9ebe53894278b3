"""Backends: one module per way of solving, listed in one registry.

``closed_form`` (exact, vectorised), ``cvxpy[:SOLVER]``, ``qpsolvers:SOLVER`` and
``scipy:highs``. :func:`available_backends` lists those installed;
:func:`choose_backend` is the one place a backend is chosen for a problem.
"""

from tension_opt.backends.base import Backend, RawResult
from tension_opt.backends.registry import (
    able_backends,
    available_backends,
    choose_backend,
    get_backend,
)

__all__ = [
    "Backend",
    "RawResult",
    "able_backends",
    "available_backends",
    "choose_backend",
    "get_backend",
]
