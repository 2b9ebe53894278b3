"""Dense, scaled per-pose matrices shared by the generic (per-pose) backends.

Tensions are solved in units of a typical tension ``s`` per pose (``T = s x``) and the
objective divided by ``s`` (LP) or ``s^2`` (QP), so solver tolerances are relative.
A min-max term is lifted to an epigraph variable ``tau >= v_i x_i``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt.problems import StandardForm


@dataclass
class DenseBatch:
    """``min 1/2 x'diag(P)x + c'x  s.t.  Aeq x = beq, G x <= h, lb <= x <= ub`` per pose.

    Attributes
    ----------
    P, c, lb, ub : ndarray, shape (N, k)
        ``k = m`` (+1 for a min-max epigraph variable, last).
    Aeq : ndarray, shape (N, n, k)
    beq : ndarray, shape (N, n)
    G : ndarray, shape (N, g, k)
    h : ndarray, shape (N, g)
    scale : ndarray, shape (N,)
    """

    P: NDArray
    c: NDArray
    Aeq: NDArray
    beq: NDArray
    G: NDArray
    h: NDArray
    lb: NDArray
    ub: NDArray
    scale: NDArray
    m: int

    @property
    def N(self) -> int:
        return int(self.P.shape[0])

    @property
    def k(self) -> int:
        return int(self.P.shape[1])

    def tensions(self, x: NDArray) -> NDArray:
        """Tensions (N, m) of scaled solutions ``x`` (N, k)."""
        return x[:, : self.m] * self.scale[:, None]



def dense_batch(form: StandardForm) -> DenseBatch:
    """Scaled, lifted dense matrices of a batch."""
    N, n, m = form.N, form.n, form.m
    s = form.scale()
    sigma = s**2 if form.q.any() else s
    P = form.q * (s**2 / sigma)[:, None]
    c = form.c * (s / sigma)[:, None]
    Aeq = form.A
    beq = form.b / s[:, None]
    lb = form.lb / s[:, None]
    ub = form.ub / s[:, None]
    G = np.zeros((N, 0, m)) if form.G is None else form.G
    h = np.zeros((N, 0)) if form.h is None else form.h / s[:, None]
    if form.minmax is not None:
        v = form.minmax
        k = m + 1
        P = np.concatenate([P, np.zeros((N, 1))], axis=1)
        c = np.concatenate([c, (s / sigma)[:, None]], axis=1)
        Aeq = np.concatenate([Aeq, np.zeros((N, n, 1))], axis=2)
        lb = np.concatenate([lb, np.full((N, 1), -np.inf)], axis=1)
        ub = np.concatenate([ub, np.full((N, 1), np.inf)], axis=1)
        # v_i x_i - tau <= 0
        rows = np.zeros((N, m, k))
        rows[:, np.arange(m), np.arange(m)] = v
        rows[:, :, m] = -1.0
        G = np.concatenate([np.concatenate([G, np.zeros((N, G.shape[1], 1))], axis=2), rows],
                           axis=1)
        h = np.concatenate([h, np.zeros((N, m))], axis=1)
    return DenseBatch(P, c, Aeq, beq, G, h, lb, ub, s, m)
