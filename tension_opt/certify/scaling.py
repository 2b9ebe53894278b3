"""A batch of problems as the generic solvers see it: scaled, lifted, dense, per pose.

:func:`scaled_batch` writes a :class:`~tension_opt.problem.form.StandardForm` in the units
of :func:`scaling_reference` (tensions
over a reference tension, equilibrium rows over their norms, objective over its size)
and lifts a min-max term to an epigraph variable ``t >= (v_i / vmax) x_i``::

    minimise   1/2 x' diag(P) x + c' x
    subject to Aeq x = beq,  G x <= h,  lb <= x <= ub

Every generic backend hands these matrices to its solver, and the certificate of any
solution (:mod:`tension_opt.certify.certificate`) is measured on the same matrices, so a
solver's tolerance and the certificate mean the same thing.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from tension_opt.problem.form import StandardForm
from tension_opt.tolerances import ROW_FLOOR, UB_SHARE

__all__ = [
    "ScaledBatch",
    "Scaling",
    "compiled_scaling",
    "narrowed",
    "reference_tension",
    "scaled_batch",
    "scaled_objective",
    "scaling_reference",
]


@dataclass(frozen=True)
class Scaling:
    """Nondimensionalisation of a batch, pose by pose (:func:`scaling_reference`,
    :func:`compiled_scaling`).

    Attributes
    ----------
    tension : ndarray, shape (N,)
        Reference tension ``s`` (N): ``T = s x``.
    rows : ndarray, shape (N, n)
        Factors ``1 / ||A_i||`` of the equilibrium rows (a row shorter than
        :data:`ROW_FLOOR` of the longest is divided by that much only; 1 for a zero
        matrix).
    top : ndarray, shape (N,)
        Largest Hessian entry (QP) or cost (LP, min-max weights included) of the form.
    quadratic : ndarray of bool, shape (N,)
        Whether the pose's objective has a quadratic term.
    vmax : float
        Largest min-max weight (1 without a min-max term).
    """

    tension: NDArray
    rows: NDArray
    top: NDArray
    quadratic: NDArray
    vmax: float

    def objective_unit(self) -> NDArray:
        """Size of the objective per pose, ``top s^2`` (QP) or ``top s`` (LP), in the
        form's units: a scaled objective is the form's divided by it, shape (N,)."""
        with np.errstate(over="ignore"):
            return self.top * np.where(self.quadratic, self.tension**2, self.tension)


def narrowed(form: StandardForm) -> tuple[StandardForm, NDArray | None]:
    """``form`` with every finite upper bound above ``1 / UB_SHARE`` typical tensions
    (:meth:`~tension_opt.problem.form.StandardForm.typical_tension`) lowered to that
    cap, and the mask (N, m) of the bounds lowered (None, and ``form`` itself, where
    none is).

    A far bound floors the reference tension (:func:`scaling_reference`) and with it
    the unit of the solvers' tolerances and of the certificate: at ``t_max = 1e12`` N on
    the study robot an answer 1 % off the optimum met the target. With the cap, the
    reference is the typical tension at any bound. A solution of the narrowed problem
    whose lowered bounds are not active is optimal for ``form`` with the same
    multipliers; the backends solve the others again with the bounds as given
    (:meth:`tension_opt.backends.base.Backend.solve`)."""
    cap = form.typical_tension()[:, None] / UB_SHARE
    with np.errstate(invalid="ignore"):
        over = np.isfinite(form.ub) & (form.ub > cap)
    if not over.any():
        return form, None
    return replace(form, ub=np.where(over, cap, form.ub)), over


def scaling_reference(form: StandardForm) -> Scaling:
    """How each pose of ``form`` is nondimensionalised for the solvers (see the module
    docstring of :mod:`tension_opt.problem.form`): the numpy reference of
    :func:`compiled_scaling`."""
    with np.errstate(over="ignore", invalid="ignore"):
        s = np.array(form.typical_tension(), dtype=float)
    bad = ~np.isfinite(s)
    if bad.any():  # a wrench near 1e300 N: a finite stand-in keeps the scaled data finite
        lb = np.where(np.isfinite(form.lb[bad]), np.abs(form.lb[bad]), 0.0)
        s[bad] = np.maximum(np.maximum(np.abs(form.b[bad]).max(axis=1, initial=0.0),
                                       lb.max(axis=1, initial=0.0)), 1e-12)
    # A pose that needs little tension (no load, a small lower bound) keeps its box
    # at most 1e3 reference tensions wide: interior-point solvers stall on wider ones.
    ub = np.where(np.isfinite(form.ub), np.abs(form.ub), 0.0).max(axis=1, initial=0.0)
    s = np.maximum(s, UB_SHARE * ub)
    with np.errstate(over="ignore", invalid="ignore"):
        norms = np.linalg.norm(form.A, axis=2)
        # A row far shorter than the others (a moment the cables can hardly make, or
        # one that is zero but for rounding) is scaled up by 1e3 at most: blown up to
        # unit length, its rounding would become an equation.
        floor = ROW_FLOOR * norms.max(axis=1, initial=0.0)[:, None]
        size = np.maximum(norms, floor)
        rows = np.where((size > 0) & np.isfinite(size),
                        1.0 / np.where(size > 0, size, 1.0), 1.0)
    quadratic = form.q.max(axis=1, initial=0.0)
    linear = np.abs(form.c).max(axis=1, initial=0.0)
    vmax = 1.0
    if form.minmax is not None:
        vmax = float(np.abs(form.minmax).max(initial=0.0)) or 1.0
        linear = np.maximum(linear, vmax)
    square = quadratic > 0
    top = np.where(square, quadratic, np.where(linear > 0, linear, 1.0))
    return Scaling(tension=s, rows=rows, top=top, quadratic=square, vmax=vmax)


@dataclass
class ScaledBatch:
    """``min 1/2 x'diag(P)x + c'x  s.t.  Aeq x = beq, G x <= h, lb <= x <= ub`` per pose.

    Attributes
    ----------
    P, c, lb, ub : ndarray, shape (N, k)
        ``k = m`` (+1 for a min-max epigraph variable, last).
    Aeq : ndarray, shape (N, n, k)
        Equilibrium rows over their norms.
    beq : ndarray, shape (N, n)
    G : ndarray, shape (N, g, k)
        Extra rows over their norms, then the ``m`` epigraph rows of a min-max term.
    h : ndarray, shape (N, g)
    scale : ndarray, shape (N,)
        Reference tension per pose (N): ``T = scale x``.
    m : int
        Number of cables.
    scaling : Scaling
        The form's :class:`Scaling`.
    epigraph : ndarray, shape (m,), optional
        Min-max weights over their largest (the epigraph rows), None without min-max.
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
    scaling: Scaling | None = None
    epigraph: NDArray | None = None

    #: Number of poses, and variables per pose (cables, and the epigraph variable of a
    #: min-max term).
    N: int = field(init=False, repr=False)
    k: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.N, self.k = (int(size) for size in self.P.shape)

    def subset(self, index: NDArray | slice) -> ScaledBatch:
        """The poses ``index`` (indices, mask or slice); each pose's scaling is its own."""
        return ScaledBatch(self.P[index], self.c[index], self.Aeq[index], self.beq[index],
                           self.G[index], self.h[index], self.lb[index], self.ub[index],
                           self.scale[index], self.m, None, self.epigraph)

    def tensions(self, x: NDArray) -> NDArray:
        """Tensions (N, m) (N) of scaled solutions ``x`` (N, k)."""
        return x[:, : self.m] * self.scale[:, None]

    def lift(self, tensions: NDArray) -> NDArray:
        """Scaled variables ``x`` (N, k) of tensions (N, m) (N); the epigraph variable
        is the smallest that holds, ``max_i (v_i / vmax) x_i``."""
        with np.errstate(over="ignore", invalid="ignore"):
            x = np.asarray(tensions, dtype=float) / self.scale[:, None]
        if self.epigraph is None:
            return x
        return np.concatenate([x, (x * self.epigraph).max(axis=1, keepdims=True)], axis=1)

    def objective(self, x: NDArray) -> NDArray:
        """Scaled objective ``1/2 x'Px + c'x`` of ``x`` (N, k), shape (N,)."""
        with np.errstate(over="ignore", invalid="ignore"):
            return np.einsum("nk,nk->n", 0.5 * self.P * x + self.c, x)


def reference_tension(form: StandardForm) -> NDArray:
    """Reference tension per pose (N), shape (N,): the typical tension floored by
    :data:`~tension_opt.tolerances.UB_SHARE` of the box, finite even where
    :meth:`StandardForm.typical_tension` overflows (``scaling_reference(form).tension``);
    the batch's when it is already built, else the scaling kernel's alone (building the
    whole scaled batch only for this would be wasted)."""
    with _CACHE_LOCK:
        batch = _CACHE.get(form)
    return batch.scale if batch is not None else compiled_scaling(form).tension


def scaled_objective(form: StandardForm, s: NDArray | None = None,
                     scaling: Scaling | None = None
                     ) -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
    """The objective in units ``T = s x``, divided by its own size.

    Each pose's objective is divided by ``s^2 max_i q_i`` where it has a quadratic
    term (its largest Hessian entry becomes 1), else by ``s`` times its largest cost or
    min-max weight (its largest cost becomes 1). No ``s^2`` is formed, so nothing
    overflows. A min-max term ``max_i v_i x_i`` is written ``vmax * max_i (v_i / vmax)
    x_i`` so that its epigraph rows have unit weights whatever the scale of ``v``.

    Parameters
    ----------
    form : StandardForm
    s : ndarray, shape (N,), optional
        Reference tension per pose (N); default ``scaling_reference(form).tension``.
    scaling : Scaling, optional
        ``scaling_reference(form)``, if already at hand.

    Returns
    -------
    P, c : ndarray, shape (N, m)
        Scaled diagonal Hessian and cost.
    tau : ndarray, shape (N,)
        Scaled cost of the epigraph variable.
    v : ndarray, shape (m,), or None
        Min-max weights over their largest, ``v / vmax``.
    """
    scaling = scaling_reference(form) if scaling is None else scaling
    s = scaling.tension if s is None else s
    top = scaling.top
    per_s = np.where(scaling.quadratic, s, 1.0)  # a QP's linear term also shrinks by s
    tau = scaling.vmax / top / per_s
    v = None if form.minmax is None else form.minmax / scaling.vmax
    return form.q / top[:, None], form.c / top[:, None] / per_s[:, None], tau, v


def _unit_rows(M: NDArray, rhs: NDArray) -> tuple[NDArray, NDArray]:
    """Rows of ``M x <= rhs`` (N, g, k) over their norms (zero rows kept)."""
    norms = np.linalg.norm(M, axis=2)
    factor = np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 1.0)
    return M * factor[..., None], rhs * factor


# A solve asks for the scaled matrices of one form up to three times (the solver, the
# backend's certificate, the solution's); building them costs more than a small DAQP
# solve, so each form keeps its own. Forms are frozen and compared by identity, and the
# cached arrays are read-only, so a cached batch always matches its form.
_CACHE: weakref.WeakKeyDictionary[StandardForm, ScaledBatch] = weakref.WeakKeyDictionary()
_CACHE_LOCK = threading.Lock()


def scaled_batch(form: StandardForm) -> ScaledBatch:
    """Scaled, lifted dense matrices of a batch (see the module docstring); read-only,
    built once per form."""
    with _CACHE_LOCK:
        batch = _CACHE.get(form)
    if batch is None:
        batch = _build(form)
        for name in ("P", "c", "Aeq", "beq", "G", "h", "lb", "ub", "scale"):
            getattr(batch, name).flags.writeable = False
        with _CACHE_LOCK:
            _CACHE[form] = batch
    return batch


def compiled_scaling(form: StandardForm) -> Scaling:
    """:func:`scaling_reference` by the compiled kernel
    (:mod:`tension_opt.kernels.scaling`; the method is its reference), for batches of
    :data:`~tension_opt.kernels.launch.COMPILED_MIN` poses or more (smaller ones by the
    reference, which compiles nothing)."""
    from tension_opt.kernels.launch import compiled_for

    if not compiled_for(form.N):
        return scaling_reference(form)
    from tension_opt.kernels.arrays import frozen
    from tension_opt.kernels.first_use import announce
    from tension_opt.kernels.scaling import batch_scaling

    announce("scaling", batch_scaling)

    vmax = 0.0
    if form.minmax is not None:
        vmax = float(np.abs(form.minmax).max(initial=0.0)) or 1.0
    A, b, lb, ub, q, c = (frozen(a) for a in (form.A, form.b, form.lb, form.ub, form.q, form.c))
    tension, rows, top, quadratic = batch_scaling(A, b, lb, ub, q, c, vmax, UB_SHARE, ROW_FLOOR)
    return Scaling(tension=tension, rows=rows, top=top, quadratic=quadratic,
                   vmax=vmax or 1.0)


def _build(form: StandardForm) -> ScaledBatch:
    """The matrices of :func:`scaled_batch`, built afresh."""
    N, n, m = form.N, form.n, form.m
    scaling = compiled_scaling(form)
    s = scaling.tension
    P, c, tau, v_hat = scaled_objective(form, s, scaling)
    with np.errstate(over="ignore", invalid="ignore"):
        Aeq = form.A * scaling.rows[..., None]
        beq = form.b * scaling.rows / s[:, None]
        lb = form.lb / s[:, None]
        ub = form.ub / s[:, None]
        if form.G is None or form.h is None:
            G, h = np.zeros((N, 0, m)), np.zeros((N, 0))
        else:
            G, h = _unit_rows(form.G, form.h / s[:, None])
    if v_hat is not None:
        k = m + 1
        P = np.concatenate([P, np.zeros((N, 1))], axis=1)
        c = np.concatenate([c, tau[:, None]], axis=1)
        Aeq = np.concatenate([Aeq, np.zeros((N, n, 1))], axis=2)
        lb = np.concatenate([lb, np.full((N, 1), -np.inf)], axis=1)
        ub = np.concatenate([ub, np.full((N, 1), np.inf)], axis=1)
        # (v_i / vmax) x_i - t <= 0
        rows = np.zeros((N, m, k))
        rows[:, np.arange(m), np.arange(m)] = v_hat
        rows[:, :, m] = -1.0
        G = np.concatenate([np.concatenate([G, np.zeros((N, G.shape[1], 1))], axis=2), rows],
                           axis=1)
        h = np.concatenate([h, np.zeros((N, m))], axis=1)
    return ScaledBatch(P, c, Aeq, beq, G, h, lb, ub, s, m, scaling, v_hat)
