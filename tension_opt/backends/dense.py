"""Dense, scaled per-pose matrices shared by the generic (per-pose) backends.

Tensions are solved in units of a typical tension ``s`` per pose (``T = s x``) and the
objective divided by its own size (:func:`objective_scale`), so that the largest
Hessian entry (QP) or cost (LP) is 1 and solver tolerances are relative: a smoothing
weight of 1e10 or a weight of 1e-8 poses the solver the same well-scaled problem.
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


def working_scale(form: StandardForm) -> NDArray:
    """Typical tension per pose (N), :meth:`StandardForm.scale`, shape (N,), with a
    finite stand-in (the largest wrench entry or lower bound) where it overflows (a
    wrench near 1e300 N, say), so that scaled problems stay finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        s = np.array(form.scale(), dtype=float)
    bad = ~np.isfinite(s)
    if bad.any():
        lb = np.where(np.isfinite(form.lb[bad]), np.abs(form.lb[bad]), 0.0)
        s[bad] = np.maximum(np.maximum(np.abs(form.b[bad]).max(axis=1, initial=0.0),
                                       lb.max(axis=1, initial=0.0)), 1e-12)
    return s


def scaled_objective(form: StandardForm, s: NDArray
                     ) -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
    """The objective in units ``T = s x``, divided by its own size.

    Each pose's objective is divided by ``s^2 max_i q_i`` where it has a quadratic
    term (its largest Hessian entry becomes 1), else by ``s`` times its largest cost or
    min-max weight (its largest cost becomes 1). Dividing an objective by a positive
    number leaves its minimiser unchanged; no ``s^2`` is formed, so nothing overflows.
    A min-max term ``max_i v_i x_i`` is written ``vmax * max_i (v_i / vmax) x_i`` so
    that its epigraph rows have unit weights whatever the scale of ``v``.

    Parameters
    ----------
    form : StandardForm
    s : ndarray, shape (N,)
        Typical tension per pose (N), :func:`working_scale`.

    Returns
    -------
    P, c : ndarray, shape (N, m)
        Scaled diagonal Hessian and cost.
    tau : ndarray, shape (N,)
        Scaled cost of the epigraph variable ``tau >= (v_i / vmax) x_i``.
    v : ndarray, shape (m,), or None
        Min-max weights over their largest, ``v / vmax``.
    """
    quadratic = form.q.max(axis=1, initial=0.0)
    linear = np.abs(form.c).max(axis=1, initial=0.0)
    vmax = 1.0
    v = None
    if form.minmax is not None:
        vmax = float(np.abs(form.minmax).max(initial=0.0)) or 1.0
        v = form.minmax / vmax
        linear = np.maximum(linear, vmax)
    square = quadratic > 0
    top = np.where(square, quadratic, np.where(linear > 0, linear, 1.0))
    per_s = np.where(square, s, 1.0)  # a QP's linear term also shrinks by s
    tau = vmax / top / per_s
    return form.q / top[:, None], form.c / top[:, None] / per_s[:, None], tau, v


def dense_batch(form: StandardForm) -> DenseBatch:
    """Scaled, lifted dense matrices of a batch."""
    N, n, m = form.N, form.n, form.m
    s = working_scale(form)
    P, c, tau, v_hat = scaled_objective(form, s)
    Aeq = form.A
    beq = form.b / s[:, None]
    lb = form.lb / s[:, None]
    ub = form.ub / s[:, None]
    G = np.zeros((N, 0, m)) if form.G is None else form.G
    h = np.zeros((N, 0)) if form.h is None else form.h / s[:, None]
    if v_hat is not None:
        v = v_hat
        k = m + 1
        P = np.concatenate([P, np.zeros((N, 1))], axis=1)
        c = np.concatenate([c, tau[:, None]], axis=1)
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
