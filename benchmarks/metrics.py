"""Metrics of the benchmark: smoothness of tension series, timing aggregates, accuracy, sag.

Functions are pure functions of arrays (vectorised with numpy) and know nothing about
solvers or files; only :func:`thesis_sag` looks at a robot, to place its cables, and
:func:`objective_excess` at a problem form, to measure on its scaled problem.
Tension series have shape (N, m): N consecutive poses of a trajectory, m cables, in
newtons. NaN entries (poses without a solution) are skipped: a difference involving a
NaN does not count.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.certify.scaling import scaled_batch
from tension_opt.problem.form import StandardForm

#: Shift of the shifted geometric mean, in the unit of the values (qpbenchmark's choice).
DEFAULT_SHIFT = 10.0
#: Shift of the shifted geometric means of the certificate's measures (dimensionless):
#: about the rounding of double precision, so that exact answers all count alike.
RESIDUAL_SHIFT = 1e-15


def _series(tensions: ArrayLike) -> NDArray:
    T = np.asarray(tensions, dtype=float)
    if T.ndim == 1:
        T = T[:, None]
    if T.ndim != 2:
        raise ValueError(f"tension series must have shape (N, m), got {T.shape}")
    return T


def differences(tensions: ArrayLike, order: int = 1) -> NDArray:
    """Finite differences along the poses.

    Parameters
    ----------
    tensions : array_like, shape (N, m) or (N,)
        Tension series (N).
    order : int
        1 for steps ``T[k+1] - T[k]``, 2 for second differences.

    Returns
    -------
    ndarray, shape (max(N - order, 0), m)
        Differences (N); NaN where a term is NaN.
    """
    T = _series(tensions)
    if T.shape[0] <= order:
        return np.zeros((0, T.shape[1]))
    return np.diff(T, n=order, axis=0)


def total_variation(tensions: ArrayLike) -> float:
    """Total variation ``sum_k sum_i |T[k+1, i] - T[k, i]|`` (N) of a tension series.

    Parameters
    ----------
    tensions : array_like, shape (N, m) or (N,)

    Returns
    -------
    float
        Sum over poses and cables of the absolute steps (N); 0 for fewer than two poses.
    """
    return float(np.nansum(np.abs(differences(tensions))))


def max_step(tensions: ArrayLike) -> float:
    """Largest absolute step ``max_{k,i} |T[k+1, i] - T[k, i]|`` (N); 0 if there is none."""
    d = np.abs(differences(tensions))
    return float(np.nanmax(d, initial=0.0)) if np.isfinite(d).any() else 0.0


def max_second_difference(tensions: ArrayLike) -> float:
    """Largest absolute second difference ``|T[k+2] - 2 T[k+1] + T[k]|`` (N); 0 if none."""
    d = np.abs(differences(tensions, order=2))
    return float(np.nanmax(d, initial=0.0)) if np.isfinite(d).any() else 0.0


def jump_count(tensions: ArrayLike, threshold: float) -> int:
    """Number of steps ``k`` at which some cable's tension changes by more than ``threshold``.

    Parameters
    ----------
    tensions : array_like, shape (N, m) or (N,)
    threshold : float
        Jump threshold (N), > 0.

    Returns
    -------
    int
        Count of steps (between 0 and N - 1) with ``max_i |T[k+1, i] - T[k, i]| > threshold``.
    """
    if not threshold > 0:
        raise ValueError(f"threshold must be positive, got {threshold!r}")
    d = np.abs(differences(tensions))
    with np.errstate(invalid="ignore"):
        return int((np.where(np.isnan(d), 0.0, d) > threshold).any(axis=1).sum())


def smoothness(tensions: ArrayLike, threshold: float) -> dict[str, float]:
    """All smoothness metrics of a series as a dict (see the functions of this module).

    Keys: ``total_variation``, ``max_step``, ``max_second_diff`` (N) and ``jumps`` (count
    of steps above ``threshold`` N).
    """
    return {
        "total_variation": total_variation(tensions),
        "max_step": max_step(tensions),
        "max_second_diff": max_second_difference(tensions),
        "jumps": float(jump_count(tensions, threshold)),
    }


def shifted_geometric_mean(values: ArrayLike, shift: float = DEFAULT_SHIFT) -> float:
    """Shifted geometric mean ``exp(mean(log(v + shift))) - shift``.

    Parameters
    ----------
    values : array_like, shape (K,)
        Non-negative values (for instance times in microseconds).
    shift : float
        Shift ``>= 0`` in the unit of ``values``; damps the weight of tiny values.

    Returns
    -------
    float
        NaN for an empty input.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size == 0:
        return float("nan")
    if (v < 0).any() or np.isnan(v).any():
        raise ValueError("shifted geometric mean needs non-negative, non-NaN values")
    return float(np.exp(np.mean(np.log(v + shift))) - shift)


def relative_shifted_geometric_means(
    frame: pd.DataFrame,
    value: str,
    solver: str = "backend",
    instance: Sequence[str] = ("scenario", "problem", "setting"),
    shift: float = DEFAULT_SHIFT,
    penalty: float | None = None,
) -> pd.Series:
    """Shifted geometric mean of ``value`` per solver, divided by the best solver's, as qpbenchmark.

    Each solver is averaged over the instances (rows grouped by ``instance``) it has a
    row for; leave out the rows of instances a solver cannot express. A row whose
    ``value`` is NaN is a failure and counts as ``penalty``, by default the largest
    value of the column.

    Parameters
    ----------
    frame : DataFrame
        One row per (instance, solver).
    value : str
        Column to aggregate (e.g. time per pose in microseconds).
    solver : str
        Column naming the solver.
    instance : sequence of str
        Columns identifying an instance.
    shift : float
        Shift of the geometric mean, in the unit of ``value``.
    penalty : float, optional
        Value given to failures.

    Returns
    -------
    Series
        Index: solvers; values: ratio to the best (the best is 1.0), sorted ascending.
    """
    if frame.empty:
        return pd.Series(dtype=float)
    values = frame[value].astype(float)
    fill = penalty if penalty is not None else float(np.nanmax(values, initial=0.0))
    data = frame.assign(_v=values.fillna(fill))
    means = pd.Series({
        name: shifted_geometric_mean(group.groupby(list(instance))["_v"].first(), shift)
        for name, group in data.groupby(solver, sort=False)
    }, dtype=float)
    best = means.min()
    return (means / best if best > 0 else means * np.nan).sort_values()


def objective_excess(form: StandardForm, tensions: ArrayLike, exact: ArrayLike) -> NDArray:
    """Objective excess of ``tensions`` over the optimum ``exact`` (both (N, m), N).

    Measured as a certificate's duality gap is (:mod:`tension_opt.certify.certificate`): on the
    scaled problem (objective over its size), relative to ``max(1, |f*|)`` there; so an
    answer certified at a target has an excess of about the target at most.

    Returns
    -------
    ndarray, shape (N,)
        Excess (dimensionless; negative where the answer is below the optimum, i.e. not
        quite feasible); NaN where either is missing.
    """
    batch = scaled_batch(form)
    f = batch.objective(batch.lift(np.asarray(tensions, dtype=float)))
    f_star = batch.objective(batch.lift(np.asarray(exact, dtype=float)))
    return (f - f_star) / np.maximum(1.0, np.abs(f_star))


def percentiles(samples: ArrayLike, q: Sequence[float] = (50.0, 95.0)) -> NDArray:
    """Percentiles of non-NaN samples, shape (len(q),); NaN where there is no sample."""
    s = np.asarray(samples, dtype=float).ravel()
    s = s[np.isfinite(s)]
    if s.size == 0:
        return np.full(len(q), np.nan)
    return np.percentile(s, q)


def relative_gap(values: ArrayLike, reference: ArrayLike) -> NDArray:
    """Relative gap ``|v - r| / max(|r|, 1)`` elementwise (dimensionless); NaN propagates."""
    v = np.asarray(values, dtype=float)
    r = np.asarray(reference, dtype=float)
    return np.abs(v - r) / np.maximum(np.abs(r), 1.0)


def performance_profile(ratios: ArrayLike, taus: ArrayLike) -> NDArray:
    """Dolan-More performance profile: fraction of instances with ratio ``<= tau``.

    Parameters
    ----------
    ratios : array_like, shape (K,)
        Performance ratios of one solver (its time over the best time of each instance);
        ``inf`` or NaN for failures.
    taus : array_like, shape (P,)
        Ratio thresholds (>= 1).

    Returns
    -------
    ndarray, shape (P,)
        Fraction in [0, 1] for each threshold.
    """
    r = np.asarray(ratios, dtype=float).ravel()
    t = np.asarray(taus, dtype=float).ravel()
    if r.size == 0:
        return np.zeros_like(t)
    r = np.where(np.isnan(r), np.inf, r)
    return (r[None, :] <= t[:, None]).mean(axis=1)


# ------------------------------------------------------------------ sag (catenary)
def thesis_sag(robot: CableRobot, poses: ArrayLike, tensions: ArrayLike) -> dict[str, float]:
    """Catenary columns of the study's sag convention for a point-mass robot.

    Each cable is an inextensible (or elastic, with ``robot.cable.EA``) catenary in its
    vertical plane from the platform point (end A) to its drawing point (end B), with
    the distributed tension imposed as the tension magnitude at the drawing point. The
    catenary end forces at the platform do not balance the weight in this convention;
    their imbalance is the residual against the coupled model (which balances it).

    Parameters
    ----------
    robot : CableRobot
        A point mass moving in space (a non-rotating pattern with positions along x, y
        and z, e.g. ``"point3"``) with ``cable`` properties; NaN columns otherwise.
    poses : array_like, shape (N, 3)
        Platform positions (m).
    tensions : array_like, shape (N, m)
        Tensions (N); rows with NaN are skipped.

    Returns
    -------
    dict
        ``catenary_length_mean`` (m), ``sag_max_mm`` and ``sag_mean_mm`` (catenary length
        minus straight length, mm), ``catenary_iterations_mean`` and
        ``catenary_iterations_max`` (per cable), ``catenary_converged`` (fraction) and
        ``thesis_residual_max`` (N, largest ``|sum of catenary end forces - weight|``).
        All NaN if the catenary package is missing or no row is solved.
    """
    keys = ("catenary_length_mean", "sag_max_mm", "sag_mean_mm", "catenary_iterations_mean",
            "catenary_iterations_max", "catenary_converged", "thesis_residual_max")
    out = dict.fromkeys(keys, float("nan"))
    T = np.asarray(tensions, dtype=float)
    ok = np.isfinite(T).all(axis=1)
    # The convention places each cable in its vertical plane from one platform point: a
    # point mass moving in space.
    pattern = robot.pattern
    if (pattern.rotates or pattern.position_axes != (0, 1, 2) or robot.cable is None
            or not ok.any()):
        return out
    try:
        from catenary.solve import solve_length
    except ImportError:
        return out
    geometry = robot.cable_geometry(np.asarray(poses, dtype=float)[ok])
    T = T[ok]
    rel = geometry.vectors  # platform -> drawing point, (N, m, 3)
    x = np.hypot(rel[..., 0], rel[..., 1])
    z = rel[..., 2]
    w = robot.cable.weight_per_length(robot.g)
    # The numpy reference (lengths to 1e-11 of the kernels'): a metric column is no
    # reason to compile the catenary kernels in the main job.
    res = solve_length(x, z, np.maximum(T, 0.0), w, EA=robot.cable.EA, end="B",
                       compiled=False)
    L = np.asarray(res.L0, dtype=float)
    sag_mm = 1e3 * (L - geometry.lengths)
    e_h = rel[..., :2] / np.maximum(x, 1e-300)[..., None]
    force = np.concatenate([np.asarray(res.H)[..., None] * e_h,
                            np.asarray(res.V_A)[..., None]], axis=-1).sum(axis=1)
    force[:, 2] -= robot.weight
    out.update(
        catenary_length_mean=float(np.nanmean(L)),
        sag_max_mm=float(np.nanmax(sag_mm)),
        sag_mean_mm=float(np.nanmean(sag_mm)),
        catenary_iterations_mean=float(np.mean(res.iterations)),
        catenary_iterations_max=float(np.max(res.iterations)),
        catenary_converged=float(np.mean(res.converged)),
        thesis_residual_max=float(np.nanmax(np.linalg.norm(force, axis=1))),
    )
    return out
