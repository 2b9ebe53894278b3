"""Cable interference of straight cables: closest distances between cables, and to the platform.

A straight cable is the segment from its attachment point ``A`` (platform) to its drawing
point ``B`` (anchor). :func:`segment_distance` gives the exact closest points of two
segments, vectorised over any batch shape: the minimum of the convex quadratic
``|P0 + s d1 - Q0 - t d2|^2`` over the square ``[0, 1]^2`` lies inside it (where the
segments are not parallel) or on one of its four edges (a point against a segment), so
the smallest of these five candidates is the answer, also for parallel, collinear and
zero-length segments.

:func:`cable_clearance` applies it to every pair of cables of a batch of poses.

Cables that share an end
    Two cables attached to one platform point (every point-mass robot), or drawn from
    one point, meet there by design. Such a pair is *compared away from the shared end*:
    each cable loses the piece of length ``shared_trim`` times its own length at that
    end, and the distance is that of the remaining pieces. Straight cables meeting at
    an angle ``theta`` so get about ``2 trim L sin(theta / 2)``, which falls to zero
    only when they run along each other. The pair is flagged in
    :attr:`CableClearance.shared`.

:func:`tension_opt.workspace.platform.platform_clearance` measures each cable against
the platform, a convex polyhedron.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import is_number
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot

__all__ = [
    "PARALLEL",
    "SHARED_TRIM",
    "CableClearance",
    "SegmentDistance",
    "cable_clearance",
    "cable_pairs",
    "check_trim",
    "segment_distance",
    "shared_ends",
]

FloatArray = NDArray[np.float64]

#: Default share of each cable's length left out at an end it shares with another.
SHARED_TRIM = 0.05
#: Relative size of ``a e - b^2`` below which two segments count as parallel.
PARALLEL = 1e-14


@dataclass(frozen=True)
class SegmentDistance:
    """Closest points of two batches of segments (:func:`segment_distance`).

    Attributes
    ----------
    distance : ndarray, shape S
        Smallest distance between the segments (m).
    s, t : ndarray, shape S
        Where the closest points lie, as fractions in ``[0, 1]`` from ``p0`` to ``p1``
        and from ``q0`` to ``q1``.
    point_a, point_b : ndarray, shape S + (3,)
        The closest points on the first and on the second segment (m).
    """

    distance: FloatArray
    s: FloatArray
    t: FloatArray
    point_a: FloatArray
    point_b: FloatArray


def segment_distance(p0: ArrayLike, p1: ArrayLike, q0: ArrayLike, q1: ArrayLike) -> SegmentDistance:
    """Exact closest points of segments ``p0 p1`` and ``q0 q1``, vectorised.

    Parameters
    ----------
    p0, p1, q0, q1 : array_like, shape S + (3,)
        End points (m), broadcast against each other; a segment may have zero length.

    Returns
    -------
    SegmentDistance
        Distances (m), fractions ``s, t`` and the closest points. Where the minimum is
        not unique (parallel overlapping segments) one of the closest pairs is given.
    """
    p0, p1, q0, q1 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (p0, p1, q0, q1)))
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    b = np.einsum("...i,...i->...", d1, d2)
    c = np.einsum("...i,...i->...", d1, r)
    f = np.einsum("...i,...i->...", d2, r)
    with np.errstate(invalid="ignore", divide="ignore"):
        denom = a * e - b * b
        inside = denom > PARALLEL * a * e
        s_in = np.where(inside, (b * f - c * e) / np.where(inside, denom, 1.0), 0.0)
        t_in = np.where(inside, (a * f - b * c) / np.where(inside, denom, 1.0), 0.0)
        inside &= (s_in >= 0) & (s_in <= 1) & (t_in >= 0) & (t_in <= 1)

        def frac(num: FloatArray, den: FloatArray) -> FloatArray:
            return np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0), 0, 1)

        zero, one = np.zeros_like(a), np.ones_like(a)
        s = np.stack([s_in, zero, one, frac(-c, a), frac(b - c, a)], axis=-1)
        t = np.stack([t_in, frac(f, e), frac(f + b, e), zero, one], axis=-1)
    pa = p0[..., None, :] + s[..., None] * d1[..., None, :]
    pb = q0[..., None, :] + t[..., None] * d2[..., None, :]
    dist = np.linalg.norm(pa - pb, axis=-1)
    dist[..., 0] = np.where(inside, dist[..., 0], np.inf)
    k = np.argmin(dist, axis=-1)[..., None]
    pick = np.take_along_axis
    return SegmentDistance(
        pick(dist, k, -1)[..., 0],
        pick(s, k, -1)[..., 0],
        pick(t, k, -1)[..., 0],
        pick(pa, k[..., None], -2)[..., 0, :],
        pick(pb, k[..., None], -2)[..., 0, :],
    )


def cable_pairs(m: int) -> NDArray[np.intp]:
    """Every pair ``(i, j)``, ``i < j``, of ``m`` cables, shape (m (m - 1) / 2, 2)."""
    i, j = np.triu_indices(m, k=1)
    return np.stack([i, j], axis=1).astype(np.intp)


def shared_ends(robot: CableRobot, pairs: NDArray[np.intp]) -> tuple[NDArray, NDArray]:
    """Which pairs of cables share their platform point, and which their drawing point.

    Parameters
    ----------
    robot : CableRobot
    pairs : ndarray of int, shape (P, 2)

    Returns
    -------
    at_platform, at_anchor : ndarray of bool, shape (P,)
        Attachment points (platform frame) or drawing points within ``1e-12`` times the
        robot's size of each other.
    """
    size = 1e-12 * max(1.0, float(np.abs(robot.anchors).max()))
    i, j = pairs[:, 0], pairs[:, 1]
    at_platform = np.linalg.norm(robot.attachments[i] - robot.attachments[j], axis=1) <= size
    at_anchor = np.linalg.norm(robot.anchors[i] - robot.anchors[j], axis=1) <= size
    return at_platform, at_anchor


def check_trim(shared_trim: object) -> float:
    """``shared_trim`` as a float in ``[0, 0.5)``, or the package's error naming it."""
    value = float(shared_trim) if is_number(shared_trim) else np.nan  # type: ignore[arg-type]
    if not 0 <= value < 0.5:
        raise InvalidInputError(
            f"shared_trim must be a number in [0, 0.5) (share of each cable's length left "
            f"out at a shared end), got {shared_trim!r}"
        )
    return value


def pair_ranges(at_platform: NDArray, at_anchor: NDArray, trim: float) -> FloatArray:
    """Compared part of each cable of each pair, as fractions of its length from the
    platform end: shape (P, 2, 2), ``[..., 0]`` start and ``[..., 1]`` end."""
    lo = np.where(at_platform, trim, 0.0)
    hi = np.where(at_anchor, 1.0 - trim, 1.0)
    rng = np.stack([lo, hi], axis=-1)  # (P, 2)
    return np.repeat(rng[:, None, :], 2, axis=1)


@dataclass(frozen=True, eq=False)
class CableClearance:
    """Closest distances between the cables of a batch of poses (:func:`cable_clearance`).

    Unpacks as ``clearance, pair = cable_clearance(robot, poses)``.

    Attributes
    ----------
    clearance : ndarray, shape (N,)
        Smallest distance between two cables at each pose (m); NaN where the cables
        could not be found (a sag model that failed at that pose).
    pair : ndarray of int, shape (N, 2)
        The two cables (indices ``i < j``) at that distance.
    distances : ndarray, shape (N, P)
        Distance of every pair (m), pairs as in :attr:`pairs`.
    lower_bound : ndarray, shape (N, P)
        Certified lower bound on each pair's true smallest distance (m): equal to
        ``distances`` for straight cables; for sagging cables see
        :func:`catenary.cable_clearance`.
    points : ndarray, shape (N, P, 2, 3)
        Closest points on the first and on the second cable of each pair (m).
    arc : ndarray, shape (N, P, 2)
        Where these points lie along each cable, measured from its attachment point
        (m along the straight cable; unstretched length for a catenary).
    pairs : ndarray of int, shape (P, 2)
        The pairs ``(i, j)``, ``i < j`` (:func:`cable_pairs`).
    shared : ndarray of bool, shape (P,)
        Pairs that share an end, compared away from it (``shared_trim``).
    model : str
        ``"straight"``, ``"coupled"`` or ``"thesis"``.
    extras : dict
        Model-specific extras (the sag model's inverse kinematics status).
    """

    clearance: FloatArray
    pair: NDArray[np.intp]
    distances: FloatArray
    lower_bound: FloatArray
    points: FloatArray
    arc: FloatArray
    pairs: NDArray[np.intp]
    shared: NDArray[np.bool_]
    model: str
    extras: dict[str, Any]

    def __iter__(self) -> Any:
        return iter((self.clearance, self.pair))

    @classmethod
    def from_pairs(
        cls,
        distances: FloatArray,
        lower: FloatArray,
        points: FloatArray,
        arc: FloatArray,
        pairs: NDArray[np.intp],
        shared: NDArray[np.bool_],
        model: str,
        extras: dict[str, Any] | None = None,
    ) -> CableClearance:
        """The result from per-pair values: the smallest pair of each pose picked out."""
        N = distances.shape[0]
        if pairs.shape[0] == 0:  # one cable: nothing to meet
            return cls(
                np.full(N, np.inf),
                np.full((N, 2), -1, dtype=np.intp),
                distances,
                lower,
                points,
                arc,
                pairs,
                shared,
                model,
                extras or {},
            )
        filled = np.where(np.isnan(distances), np.inf, distances)
        k = np.argmin(filled, axis=1)
        clearance = distances[np.arange(N), k]
        clearance = np.where(np.isnan(distances).any(axis=1), np.nan, clearance)
        return cls(
            clearance, pairs[k], distances, lower, points, arc, pairs, shared, model, extras or {}
        )


def cable_clearance(
    robot: CableRobot,
    poses: ArrayLike,
    model: str = "straight",
    *,
    shared_trim: float = SHARED_TRIM,
) -> CableClearance:
    """Smallest distance between every two straight cables of a batch of poses.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad).
    model : {"straight"}
        Straight cables (segments from attachment to drawing point). The sagging
        models ``"coupled"`` and ``"thesis"`` are :func:`catenary.cable_clearance`, with
        the same signature.
    shared_trim : float
        Share of each cable's length, in ``[0, 0.5)``, left out at an end it shares
        with the other cable of a pair (see the module notes).

    Returns
    -------
    CableClearance
        ``clearance`` (N,) in m and ``pair`` (N, 2); per pair ``distances`` (N, P),
        ``points`` (N, P, 2, 3) and ``arc`` (N, P, 2). A cable on its drawing point (zero
        length) is a point and is compared as one.

    Raises
    ------
    InvalidInputError
        On bad poses, ``model`` or ``shared_trim``.
    """
    if model != "straight":
        raise InvalidInputError(
            f"model must be 'straight' here, got {model!r}; sagging cables ('coupled', "
            "'thesis') are catenary.cable_clearance(robot, poses, model=...)"
        )
    trim = check_trim(shared_trim)
    geometry = robot.cable_geometry(poses, check=False)
    A = geometry.attachment_points  # (N, m, 3)
    D = geometry.vectors
    pairs = cable_pairs(robot.m)
    at_platform, at_anchor = shared_ends(robot, pairs)
    rng = pair_ranges(at_platform, at_anchor, trim)  # (P, 2, 2)
    ends = []
    for side in (0, 1):
        idx = pairs[:, side]
        lo, hi = rng[:, side, 0, None], rng[:, side, 1, None]
        ends.append((A[:, idx] + lo * D[:, idx], A[:, idx] + hi * D[:, idx], lo, hi))
    (a0, a1, alo, ahi), (b0, b1, blo, bhi) = ends
    res = segment_distance(a0, a1, b0, b1)
    L = geometry.lengths
    arc = np.stack(
        [
            (alo[:, 0] + res.s * (ahi - alo)[:, 0]) * L[:, pairs[:, 0]],
            (blo[:, 0] + res.t * (bhi - blo)[:, 0]) * L[:, pairs[:, 1]],
        ],
        axis=-1,
    )
    points = np.stack([res.point_a, res.point_b], axis=-2)
    return CableClearance.from_pairs(
        res.distance, res.distance.copy(), points, arc, pairs, at_platform | at_anchor, "straight"
    )


def check_clearance(clearance: object) -> float:
    """``clearance`` (m) as a finite float >= 0, or the package's error naming it."""
    value = float(clearance) if is_number(clearance) else np.nan  # type: ignore[arg-type]
    if not np.isfinite(value) or value < 0:
        raise InvalidInputError(
            f"clearance must be a finite number >= 0 (smallest allowed distance between "
            f"cables, m; e.g. the cable diameter), got {clearance!r}"
        )
    return value
