"""Interference of sagging cables: certified closest distances between catenaries.

Cable ``i`` hangs in its vertical plane as the elastic catenary

    r_i(s) = A_i + x(s) e_h + z(s) e_z + (s / L0) c,        0 <= s <= L0

``s`` its unstretched arc length from the attachment point ``A_i``, ``x(s), z(s)`` the
spans of the piece of cable from ``A_i`` to ``s`` (:func:`catenary.elastic.evaluate`),
and ``c`` the solver's tiny closure residual at the drawing point spread along the
cable (as :mod:`catenary.viz` draws it). Its tangent is
``r' = (1 + T/EA) (H e_h + V e_z) / T + c / L0`` with ``V = V_A + w s`` and
``T = |(H, V)|``, so

- ``|r'| <= lam = 1 + T_max / EA + |c| / L0`` (1 for an inextensible cable);
- ``|r''| <= K = w / EA + (1 + T_max / EA) w H / T_min^2``.

:func:`curve_distance` finds the smallest distance between two such curves in three
steps, vectorised over every pair and pose:

1. **bracket**: both curves sampled at ``samples`` points; every piece between two
   samples is replaced by its chord, and the chords of every two pieces are compared
   exactly (:func:`tension_opt.workspace.segment_distance`);
2. **certify**: a piece of parameter length ``h`` stays within ``K h^2 / 8`` of its chord,
   so ``min(chord distance - e_a - e_b)`` over all pieces is a lower bound on the true
   minimum; so is the Lipschitz bound ``d_grid - (lam_a h_a + lam_b h_b) / 2`` of the
   sample points (``d_grid`` their smallest distance). The larger of the two is
   returned as ``lower_bound``;
3. **refine**: from the closest chords, a bounded Gauss-Newton minimisation over the two
   arc parameters: each step replaces both curves by their tangent segments over a trust
   interval (inside ``[0, L0]``) and takes their exact closest points; a step is kept
   only where it shortens the true distance, else the interval halves.

The returned distance is that of two actual points of the curves, so
``lower_bound <= true minimum <= distance``; their difference is ``gap``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.checks import whole_positive
from tension_opt.errors import InvalidInputError
from tension_opt.workspace import Grid, prepare, wrench_feasible_workspace
from tension_opt.workspace.interference import (
    SHARED_TRIM,
    CableClearance,
    cable_pairs,
    check_clearance,
    check_trim,
    pair_ranges,
    segment_distance,
    shared_ends,
)
from tension_opt.workspace.interference import cable_clearance as straight_clearance
from tension_opt.workspace.interference_free import InterferenceResult, interference_result

from .curves import CatenaryCurves
from .geometry import E_Z, CablePlanes, cable_data, cable_planes, check_robot
from .interference_compiled import pack_curves, solve_pairs, use_compiled
from .interference_kernels import STEPS
from .inverse import inverse_kinematics
from .pulleys import settle_wraps
from .workspace import sag_workspace

__all__ = [
    "SAMPLES",
    "CatenaryCurves",
    "CurveDistance",
    "cable_clearance",
    "curve_distance",
    "curves_in",
    "interference_free_workspace",
    "robot_curves",
    "robot_pair_distances",
]

FloatArray = NDArray[np.float64]

#: Default number of samples along each cable for the bracket and the certificate.
SAMPLES = 33
# How many curve pairs are bracketed at once (bounds the memory of the piece-by-piece
# comparison); the refinement's steps are interference_kernels.STEPS, on both paths.
_CELLS_PER_BLOCK = 400_000


@dataclass(frozen=True)
class CurveDistance:
    """Closest points of two batches of catenaries (:func:`curve_distance`).

    Attributes
    ----------
    distance : ndarray, shape S
        Distance of the closest points found (m): an upper bound on the true minimum.
    lower_bound : ndarray, shape S
        Certified lower bound on the true minimum (m), >= 0.
    s, t : ndarray, shape S
        Arc parameters of the closest points on the first and second curve (m).
    point_a, point_b : ndarray, shape S + (3,)
        The closest points (m).
    """

    distance: FloatArray
    lower_bound: FloatArray
    s: FloatArray
    t: FloatArray
    point_a: FloatArray
    point_b: FloatArray

    @property
    def gap(self) -> FloatArray:
        """``distance - lower_bound`` (m): how far the answer may be from the minimum."""
        return self.distance - self.lower_bound


def _bracket(
    a: CatenaryCurves, b: CatenaryCurves, ra: FloatArray, rb: FloatArray, n: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Start parameters ``s0, t0`` and the certified lower bound for flat batches (S,).

    ``ra, rb`` (S, 2) are the compared parameter intervals (m). Each piece lies in the
    ball around its chord's midpoint of radius half the chord plus its tube ``K h^2 / 8``;
    two pieces whose balls are farther apart than the closest two samples cannot hold
    the minimum, and their balls' distance is their lower bound. The chords of the
    other pieces are compared exactly."""
    u = np.linspace(0.0, 1.0, n)
    sa = ra[:, :1] + (ra[:, 1:] - ra[:, :1]) * u
    sb = rb[:, :1] + (rb[:, 1:] - rb[:, :1]) * u
    pa, pb = a.points(sa), b.points(sb)
    ha, hb = (ra[:, 1] - ra[:, 0]) / (n - 1), (rb[:, 1] - rb[:, 0]) / (n - 1)
    lam_a, K_a = a.bounds()
    lam_b, K_b = b.bounds()
    S = len(ha)
    with np.errstate(invalid="ignore"):
        e_a, e_b = K_a * ha**2 / 8, K_b * hb**2 / 8
        nodes = np.linalg.norm(pa[:, :, None, :] - pb[:, None, :, :], axis=-1).reshape(S, -1)
        upper = nodes.min(axis=1)
        lips = upper - (lam_a * ha + lam_b * hb) / 2
        ma, mb = 0.5 * (pa[:, 1:] + pa[:, :-1]), 0.5 * (pb[:, 1:] + pb[:, :-1])
        rad_a = 0.5 * np.linalg.norm(pa[:, 1:] - pa[:, :-1], axis=-1) + e_a[:, None]
        rad_b = 0.5 * np.linalg.norm(pb[:, 1:] - pb[:, :-1], axis=-1) + e_b[:, None]
        balls = (
            np.linalg.norm(ma[:, :, None] - mb[:, None], axis=-1)
            - rad_a[:, :, None]
            - rad_b[:, None, :]
        )
        near = ~(balls > upper[:, None, None])  # NaN curves stay in: they give NaN
    i, j, k = np.nonzero(near)
    cells = segment_distance(pa[i, j], pa[i, j + 1], pb[i, k], pb[i, k + 1])
    exact = np.full(balls.shape, np.inf)
    exact[i, j, k] = np.nan_to_num(cells.distance, nan=np.inf)
    with np.errstate(invalid="ignore"):
        bound = np.where(near, exact - e_a[:, None, None] - e_b[:, None, None], balls)
        tube = bound.reshape(S, -1).min(axis=1)
        lower = np.maximum(np.fmax(tube, lips), 0.0)
    best = np.argmin(exact.reshape(S, -1), axis=1)
    frac_s = np.zeros(balls.shape)
    frac_t = np.zeros(balls.shape)
    frac_s[i, j, k], frac_t[i, j, k] = cells.s, cells.t
    jb, kb = np.divmod(best, n - 1)
    idx = np.arange(S)
    s0 = sa[idx, jb] + frac_s.reshape(S, -1)[idx, best] * ha
    t0 = sb[idx, kb] + frac_t.reshape(S, -1)[idx, best] * hb
    lower = np.where(np.isnan(nodes).any(axis=1), np.nan, lower)
    return s0, t0, lower


def _refine(
    a: CatenaryCurves,
    b: CatenaryCurves,
    ra: FloatArray,
    rb: FloatArray,
    s: FloatArray,
    t: FloatArray,
    ha: FloatArray,
    hb: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Bounded Gauss-Newton on the two arc parameters, for flat batches (S,); each pair
    stops when its step or its trust interval falls below ``1e-12`` of its lengths, or
    a rejected step below ``1e-7`` of them."""
    pa, pb = a.points(s[:, None])[:, 0], b.points(t[:, None])[:, 0]
    d = np.linalg.norm(pa - pb, axis=-1)
    tol = 1e-12 * (1.0 + ra[:, 1] + rb[:, 1])
    live = np.flatnonzero(np.isfinite(d))
    for _ in range(STEPS):
        if not len(live):
            break
        ca, cb, sl, tl = a.take(live), b.take(live), s[live], t[live]
        ta, tb = ca.tangents(sl[:, None])[:, 0], cb.tangents(tl[:, None])[:, 0]
        a_lo, a_hi = np.maximum(ra[live, 0], sl - ha[live]), np.minimum(ra[live, 1], sl + ha[live])
        b_lo, b_hi = np.maximum(rb[live, 0], tl - hb[live]), np.minimum(rb[live, 1], tl + hb[live])
        pl, ql = pa[live], pb[live]
        step = segment_distance(
            pl + (a_lo - sl)[:, None] * ta,
            pl + (a_hi - sl)[:, None] * ta,
            ql + (b_lo - tl)[:, None] * tb,
            ql + (b_hi - tl)[:, None] * tb,
        )
        s1 = a_lo + step.s * (a_hi - a_lo)
        t1 = b_lo + step.t * (b_hi - b_lo)
        qa, qb = ca.points(s1[:, None])[:, 0], cb.points(t1[:, None])[:, 0]
        d1 = np.linalg.norm(qa - qb, axis=-1)
        better = d1 < d[live]
        keep = live[better]
        s[keep], t[keep], d[keep] = s1[better], t1[better], d1[better]
        pa[keep], pb[keep] = qa[better], qb[better]
        ha[live[~better]] *= 0.5
        hb[live[~better]] *= 0.5
        moved = np.abs(s1 - sl) + np.abs(t1 - tl)
        # A step the distance cannot tell from staying (it changes quadratically, so
        # steps below about 1e-7 of the lengths are rounding) ends the search too.
        done = (moved <= tol[live]) | (ha[live] + hb[live] <= tol[live])
        done |= ~better & (moved <= 1e5 * tol[live])
        live = live[~done]
    return d, s, t, pa, pb


def curve_distance(
    a: CatenaryCurves,
    b: CatenaryCurves,
    range_a: ArrayLike | None = None,
    range_b: ArrayLike | None = None,
    samples: int = SAMPLES,
    compiled: bool | None = None,
) -> CurveDistance:
    """Certified smallest distance between two batches of catenaries (module notes).

    Parameters
    ----------
    a, b : CatenaryCurves
        Batch shape ``S`` each (the same).
    range_a, range_b : array_like, shape S + (2,), optional
        Compared interval of arc parameters ``[lo, hi]`` (m) of each curve; default
        ``[0, L0]``.
    samples : int
        Samples along each curve for the bracket and the certificate, >= 2; the lower
        bound tightens as ``1 / samples^2``.
    compiled : bool, optional
        The compiled kernel (:mod:`catenary.interference_kernels`, the same steps pair
        by pair); by default for :data:`tension_opt.kernels.launch.COMPILED_MIN` pairs
        or more. False: the numpy reference.

    Returns
    -------
    CurveDistance
        NaN where a curve has non-finite data.
    """
    n = whole_positive("samples", samples)
    if n < 2:
        raise InvalidInputError(f"samples must be a whole number >= 2, got {samples!r}")
    shape = a.H.shape
    if b.H.shape != shape:
        raise InvalidInputError(
            f"the two batches of curves differ in shape: {shape} and {b.H.shape}"
        )
    full_a = np.stack([np.zeros(shape), a.L0], axis=-1)
    full_b = np.stack([np.zeros(shape), b.L0], axis=-1)
    ra = (full_a if range_a is None else np.broadcast_to(range_a, (*shape, 2))).reshape(-1, 2)
    rb = (full_b if range_b is None else np.broadcast_to(range_b, (*shape, 2))).reshape(-1, 2)
    fa, fb = _flat(a), _flat(b)
    S = fa.H.size
    if use_compiled(S, compiled):
        packed = np.concatenate([pack_curves(fa), pack_curves(fb)])
        pairs = np.stack([np.arange(S), S + np.arange(S)], axis=1)
        out = _pairs(packed, pairs, np.concatenate([ra, rb], axis=1), n,
                     lambda idx: (fa.take(idx), fb.take(idx)))
    else:
        out = _numpy_pairs(fa, fb, ra, rb, n)
    d, lower, s, t, pa, pb = out
    return CurveDistance(
        d.reshape(shape),
        lower.reshape(shape),
        s.reshape(shape),
        t.reshape(shape),
        pa.reshape(*shape, 3),
        pb.reshape(*shape, 3),
    )


def _flat(c: CatenaryCurves) -> CatenaryCurves:
    """Curves of any batch shape as a flat batch."""
    f = c.take(np.s_[...])
    return CatenaryCurves(f.origin.reshape(-1, 3), f.e_h.reshape(-1, 3), f.H.ravel(),
                          f.V_A.ravel(), f.L0.ravel(), c.w, c.EA, f.closure.reshape(-1, 3))


def _numpy_pairs(fa: CatenaryCurves, fb: CatenaryCurves, ra: FloatArray, rb: FloatArray,
                 n: int) -> list[FloatArray]:
    """The numpy reference on flat batches: distance, lower bound, s, t (S,) and the
    two points (S, 3)."""
    S = fa.H.size
    out = [np.full(S, np.nan) for _ in range(4)] + [np.full((S, 3), np.nan) for _ in range(2)]
    block = max(1, _CELLS_PER_BLOCK // (n - 1) ** 2)
    for lo in range(0, S, block):  # blocks of curve pairs, not poses: bounded memory
        sl = slice(lo, min(S, lo + block))
        ca, cb = fa.take(sl), fb.take(sl)
        s0, t0, lower = _bracket(ca, cb, ra[sl], rb[sl], n)
        ha = (ra[sl, 1] - ra[sl, 0]) / (n - 1)
        hb = (rb[sl, 1] - rb[sl, 0]) / (n - 1)
        d, s, t, pa, pb = _refine(ca, cb, ra[sl], rb[sl], s0, t0, ha, hb)
        for arr, val in zip(out, (d, np.minimum(lower, d), s, t, pa, pb), strict=True):
            arr[sl] = val
    return out


def _pairs(packed: FloatArray, pairs: NDArray, ranges: FloatArray, n: int,
           curves_of: Any) -> list[FloatArray]:
    """The compiled kernel on ``pairs`` (S, 2) of rows of ``packed`` with their
    intervals (S, 4), in :func:`_numpy_pairs`' layout; ``curves_of(index)`` gives the
    two flat batches of curves of some pairs, for the numpy path of the pairs the
    kernel leaves."""
    res, left = solve_pairs(packed, pairs, ranges, n)
    out = [res[:, 0], res[:, 1], res[:, 2], res[:, 3], res[:, 4:7], res[:, 7:10]]
    if left.any():
        idx = np.flatnonzero(left)
        ca, cb = curves_of(idx)
        for arr, val in zip(out, _numpy_pairs(ca, cb, ranges[idx, :2], ranges[idx, 2:], n),
                            strict=True):
            arr[idx] = val
    return out


def robot_curves(
    robot: CableRobot, poses: NDArray, H: ArrayLike, V_A: ArrayLike, L0: ArrayLike
) -> CatenaryCurves:
    """The catenaries of a robot's cables, batch shape (N, m).

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (weight per length, ``EA``).
    poses : ndarray, shape (N, n)
        Validated poses (m, rad).
    H, V_A, L0 : array_like, shape (N, m)
        Horizontal tension (N), vertical force at the platform (N, upward along the
        cable) and unstretched length (m) of each cable, e.g. from
        :func:`catenary.inverse_kinematics` (``horizontal_tensions``,
        ``platform_forces[..., 2]``, ``lengths``).

    Returns
    -------
    CatenaryCurves
        Ending on the drawing points (the solver's residual there spread along the
        cables, :attr:`CatenaryCurves.closure`).
    """
    w, EA = cable_data(robot)
    planes = cable_planes(robot, poses)
    return curves_in(planes, H, V_A, L0, w, EA, robot.anchors[None])


def curves_in(planes: CablePlanes, H: ArrayLike, V_A: ArrayLike, L0: ArrayLike, w: float,
              EA: float, tops: NDArray | None = None) -> CatenaryCurves:
    """The catenaries of cables spanning ``planes`` (N, m) from their attachment points to
    their upper ends (drawing points, or where they leave their guide pulleys), with
    horizontal tensions ``H``, vertical forces at the platform ``V_A`` (N) and
    unstretched free lengths ``L0`` (m), (N, m) each; ending on those upper ends
    (``tops``, (N, m, 3) or broadcast; default the planes' own)."""
    origin = planes.position[:, None, :] + planes.arms
    H, V_A, L0 = (np.asarray(v, dtype=float) for v in (H, V_A, L0))
    open_curves = CatenaryCurves(origin, planes.e_h, H, V_A, L0, w, EA, np.zeros_like(origin))
    end = open_curves.points(L0[..., None], closed=False)[..., 0, :]
    if tops is None:
        tops = origin + planes.x[..., None] * planes.e_h + planes.z[..., None] * E_Z
    return CatenaryCurves(origin, planes.e_h, H, V_A, L0, w, EA, tops - end)


def _curves_over_wheels(robot: CableRobot, P: NDArray, res: Any, H: NDArray, V_A: NDArray,
                        nan: NDArray) -> CatenaryCurves:
    """The free spans of a robot with guide pulleys, from the attachment points to where
    the cables leave their wheels: the wheel states settled again under the answer's
    exit tensions are the answer's own (:func:`catenary.pulleys.settle_wraps`)."""
    w, EA = cable_data(robot, pulleys=True)
    T = np.where(np.isfinite(res.tensions), res.tensions, 0.0)
    sag = settle_wraps(robot, P, T, res.success, w, EA)
    free = (res.lengths - sag.arcs(res.tensions, EA)) * nan
    return curves_in(sag.planes, H, V_A, free, w, EA)


def _check_model(model: object) -> Literal["straight", "coupled", "thesis"]:
    if model not in ("straight", "coupled", "thesis"):
        raise InvalidInputError(f"model must be 'coupled', 'thesis' or 'straight', got {model!r}")
    return model  # type: ignore[return-value]


def cable_clearance(
    robot: CableRobot,
    poses: ArrayLike,
    model: str = "coupled",
    *,
    shared_trim: float = SHARED_TRIM,
    samples: int = SAMPLES,
    compiled: bool | None = None,
    **options: Any,
) -> CableClearance:
    """Smallest distance between every two sagging cables of a batch of poses, certified.

    The same signature and result as :func:`tension_opt.workspace.cable_clearance`,
    with the cables as catenaries (module notes).

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable``.
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad).
    model : {"coupled", "thesis", "straight"}
        The sag model of :func:`catenary.inverse_kinematics` whose catenaries are
        compared; ``"straight"`` is the straight-cable answer.
    shared_trim : float
        Share of each cable's length, in ``[0, 0.5)``, left out at an end it shares with
        the other cable of a pair (unstretched length from that end).
    samples : int
        Samples along each cable for the bracket and the certificate.
    compiled : bool, optional
        The compiled kernels of the inverse kinematics (as
        :func:`catenary.inverse_kinematics` decides by default) and of the distances
        (as :func:`curve_distance`, pairs counted over all poses; each cable is then
        sampled once per pose); False: the numpy references.
    **options
        Passed to :func:`catenary.inverse_kinematics` (``objective``, ``backend``,
        ``wrench`` ...).

    Returns
    -------
    CableClearance
        ``clearance`` (N,) in m and ``pair`` (N, 2); per pair ``distances`` (N, P),
        certified ``lower_bound`` (N, P), ``points`` (N, P, 2, 3) and ``arc`` (N, P, 2)
        (unstretched length from the attachment point, m). ``extras["status"]`` is the
        inverse kinematics' status; poses where it failed get NaN.

    Raises
    ------
    InvalidInputError
        On bad poses, model, shared_trim or samples.
    InvalidCableError
        If the robot has no cable properties.
    """
    model = _check_model(model)
    if model == "straight":
        return straight_clearance(robot, poses, shared_trim=shared_trim)
    check_robot(robot, pulleys=True)
    trim = check_trim(shared_trim)
    whole_positive("samples", samples)
    P = robot.as_poses(poses)
    res = inverse_kinematics(robot, P, model, compiled=compiled, **options)
    nan = np.where(res.success[:, None] & np.isfinite(res.lengths), 1.0, np.nan)
    H, V_A = res.horizontal_tensions * nan, res.platform_forces[..., 2] * nan
    curves = (_curves_over_wheels(robot, P, res, H, V_A, nan) if robot.has_pulleys
              else robot_curves(robot, P, H, V_A, res.lengths * nan))
    pairs = cable_pairs(robot.m)
    at_platform, at_anchor = shared_ends(robot, pairs)
    frac = pair_ranges(at_platform, at_anchor, trim)  # (P, 2, 2)
    found = robot_pair_distances(curves, pairs, frac, samples, compiled)
    points = np.stack([found.point_a, found.point_b], axis=-2)
    arc = np.stack([found.s, found.t], axis=-1)
    extras = {"status": res.status, "gap": found.gap}
    shared = at_platform | at_anchor
    return CableClearance.from_pairs(
        found.distance, found.lower_bound, points, arc, pairs, shared, model, extras
    )


def robot_pair_distances(curves: CatenaryCurves, pairs: NDArray, frac: NDArray, samples: int,
                 compiled: bool | None) -> CurveDistance:
    """:func:`curve_distance` of every pair of a robot's curves at each pose.

    Parameters
    ----------
    curves : CatenaryCurves
        Batch shape (N, m): the cables of N poses (:func:`robot_curves`).
    pairs : ndarray of int, shape (P, 2)
        Cables compared (:func:`tension_opt.workspace.cable_pairs`).
    frac : ndarray, shape (P, 2, 2)
        Share of each cable's unstretched length compared, ``[lo, hi]`` per cable of a
        pair (:func:`tension_opt.workspace.interference.pair_ranges`).
    samples : int
    compiled : bool, optional
        As in :func:`curve_distance` (pairs counted over all poses); on the compiled
        path each curve is sampled once, however many pairs it is in.

    Returns
    -------
    CurveDistance
        Batch shape (N, P).
    """
    i, j = pairs[:, 0], pairs[:, 1]
    L0 = np.asarray(curves.L0)
    ra, rb = frac[None, :, 0, :] * L0[:, i, None], frac[None, :, 1, :] * L0[:, j, None]
    n = whole_positive("samples", samples)
    N, m = L0.shape
    if n < 2 or not use_compiled(N * len(pairs), compiled):
        a, b = curves.take(np.s_[:, i]), curves.take(np.s_[:, j])
        return curve_distance(a, b, ra, rb, samples, compiled=False)
    rows = np.arange(N)[:, None] * m
    idx = np.stack([rows + i, rows + j], axis=-1).reshape(-1, 2)
    ranges = np.concatenate([ra, rb], axis=-1).reshape(-1, 4)

    def curves_of(k: NDArray) -> tuple[CatenaryCurves, CatenaryCurves]:
        flat = _flat(curves)
        return flat.take(idx[k, 0]), flat.take(idx[k, 1])

    d, lower, s, t, pa, pb = _pairs(pack_curves(curves), idx, ranges, n, curves_of)
    shape = (N, len(pairs))
    return CurveDistance(d.reshape(shape), lower.reshape(shape), s.reshape(shape),
                         t.reshape(shape), pa.reshape(*shape, 3), pb.reshape(*shape, 3))


def interference_free_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    clearance: float = 0.0,
    *,
    model: str = "coupled",
    with_wrenches: bool = False,
    wrenches: ArrayLike | None = None,
    shared_trim: float = SHARED_TRIM,
    samples: int = SAMPLES,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    **options: Any,
) -> InterferenceResult:
    """Which poses keep every two sagging cables more than ``clearance`` apart.

    As :func:`tension_opt.workspace.interference_free_workspace`, with the cables as the
    catenaries of ``model`` (:func:`cable_clearance`). ``with_wrenches`` adds the
    coupled-sag wrench feasibility (:func:`catenary.sag_workspace`) for ``"coupled"``
    and the straight one otherwise; ``feasible`` is the AND of both.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n), or Grid
    clearance : float
        Required smallest distance between two cables (m), >= 0.
    model : {"coupled", "thesis", "straight"}
    with_wrenches : bool
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches of the wrench check (N, N m).
    shared_trim, samples
        As :func:`cable_clearance`.
    bounds : (array_like, array_like), optional
        The sampled box, as in :func:`tension_opt.workspace.wrench_feasible_workspace`.
    **options
        Passed to the inverse kinematics and the wrench check (``backend`` ...).

    Returns
    -------
    InterferenceResult
    """
    required = check_clearance(clearance)
    model = _check_model(model)
    P, _, layout = prepare(robot, poses, wrenches, bounds)
    clear = cable_clearance(robot, P, model, shared_trim=shared_trim, samples=samples, **options)
    wrench = None
    if with_wrenches:
        check = sag_workspace if model == "coupled" else wrench_feasible_workspace
        wrench = check(robot, P, wrenches, **options)
    return interference_result(robot, P, layout, clear, required, wrench)
