"""Backends: one module per way of solving, and a small registry.

``closed_form`` (exact, vectorised), ``cvxpy[:SOLVER]``, ``qpsolvers:SOLVER`` and
``scipy:highs``. :func:`available_backends` lists those installed.
"""

from tension_opt.backends.base import Backend, RawResult, available_backends, get_backend

__all__ = ["Backend", "RawResult", "available_backends", "get_backend"]
