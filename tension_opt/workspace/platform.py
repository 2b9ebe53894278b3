"""Cables against the platform: the platform as a convex polyhedron.

The platform is the convex hull of vertices given in the platform frame (the argument
``platform_hull``, else the robot's :attr:`~tension_opt.CableRobot.platform_hull` from
its robot file, else the attachment points). Every cable leaves the hull at its own
attachment point, so each cable is compared *away from it*: the piece of cable within
``exclude`` metres of its attachment point is left out, and the rest of the straight
cable is compared exactly with every triangle of the hull's faces
(:func:`segment_triangle_distance`). A cable that runs into the platform from its
attachment point crosses the hull there and gets 0; one that leaves outwards at an
angle ``phi`` to the nearest face gets about ``exclude sin(phi)`` or more.

A hull of coplanar vertices is a flat plate (its polygon's triangles); one of collinear
vertices or a single point has no faces: nothing to meet, clearance ``inf``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull

from tension_opt.checks import as_finite, is_number
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.workspace.interference import segment_distance

__all__ = [
    "PlatformClearance",
    "hull_triangles",
    "platform_clearance",
    "segment_triangle_distance",
]

FloatArray = NDArray[np.float64]

#: Default share of the platform's size (largest vertex distance from the vertices'
#: centroid) left out around each cable's attachment point.
EXCLUDE_SHARE = 0.1


def hull_triangles(vertices: ArrayLike) -> FloatArray:
    """Triangles of the faces of the convex hull of ``vertices``, shape (F, 3, 3) (m).

    Parameters
    ----------
    vertices : array_like, shape (k, 3)
        Points in the platform frame (m).

    Returns
    -------
    ndarray, shape (F, 3, 3)
        Each triangle's three corners; a flat hull gives its polygon fanned into
        triangles, a hull of collinear points or one point none (F = 0).
    """
    V = np.asarray(vertices, dtype=float)
    centred = V - V.mean(axis=0)
    scale = max(float(np.abs(centred).max(initial=0.0)), 1e-300)
    _, sv, vt = np.linalg.svd(centred / scale, full_matrices=False)
    rank = int((sv > 1e-9 * max(sv.max(initial=0.0), 1e-300)).sum()) if len(sv) else 0
    if rank >= 3 and len(V) >= 4:
        return V[ConvexHull(V).simplices]
    if rank == 2 and len(V) >= 3:  # a plate: its polygon, fanned from one corner
        ring = ConvexHull(centred @ vt[:2].T).vertices  # counter-clockwise in the plane
        fan = np.stack([np.full(len(ring) - 2, ring[0]), ring[1:-1], ring[2:]], axis=1)
        return V[fan]
    return np.zeros((0, 3, 3))


def _inside(x: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
    """Whether points ``x`` in the triangles' planes lie in them (barycentric >= 0)."""
    v0, v1, v2 = b - a, c - a, x - a
    d00, d01, d11 = (np.einsum("...i,...i->...", p, q) for p, q in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("...i,...i->...", v2, v0), np.einsum("...i,...i->...", v2, v1)
    den = d00 * d11 - d01 * d01
    with np.errstate(invalid="ignore", divide="ignore"):
        v = (d11 * d20 - d01 * d21) / den
        w = (d00 * d21 - d01 * d20) / den
    tol = -1e-12
    return np.asarray((den > 0) & (v >= tol) & (w >= tol) & (v + w <= 1 - tol))


def segment_triangle_distance(
    p0: ArrayLike, p1: ArrayLike, a: ArrayLike, b: ArrayLike, c: ArrayLike
) -> FloatArray:
    """Exact smallest distance between segments ``p0 p1`` and triangles ``a b c``.

    The minimum lies on an edge of the triangle against the segment, at an end of the
    segment over the triangle's inside, or is 0 where the segment crosses the triangle.

    Parameters
    ----------
    p0, p1 : array_like, shape S + (3,)
        Segment ends (m).
    a, b, c : array_like, shape S + (3,)
        Triangle corners (m); broadcast against the segments.

    Returns
    -------
    ndarray, shape S
        Distances (m).
    """
    p0, p1, a, b, c = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (p0, p1, a, b, c)))
    best = np.minimum.reduce(
        [segment_distance(p0, p1, u, v).distance for u, v in ((a, b), (b, c), (c, a))]
    )
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = n / norm[..., None]
        h0 = np.einsum("...i,...i->...", p0 - a, unit)
        h1 = np.einsum("...i,...i->...", p1 - a, unit)
        for x, h in ((p0, h0), (p1, h1)):  # an end above the triangle's inside
            foot = x - h[..., None] * unit
            best = np.where(_inside(foot, a, b, c), np.minimum(best, np.abs(h)), best)
        cross = (h0 * h1 <= 0) & (h0 != h1)
        sigma = np.where(cross, h0 / np.where(cross, h0 - h1, 1.0), 0.0)
        hit = p0 + sigma[..., None] * (p1 - p0)
    return np.where(cross & _inside(hit, a, b, c), 0.0, best)


@dataclass(frozen=True, eq=False)
class PlatformClearance:
    """Distances of the cables to the platform (:func:`platform_clearance`).

    Attributes
    ----------
    clearance : ndarray, shape (N,)
        Smallest distance of a cable to the platform (m); ``inf`` for a platform with
        no faces.
    cable : ndarray of int, shape (N,)
        The cable at that distance.
    distances : ndarray, shape (N, m)
        Each cable's distance to the platform (m), its first ``exclude`` metres left out.
    triangles : ndarray, shape (F, 3, 3)
        The hull's faces in the platform frame (m).
    exclude : float
        Length left out at each attachment point (m).
    """

    clearance: FloatArray
    cable: NDArray[np.intp]
    distances: FloatArray
    triangles: FloatArray
    exclude: float


def _check_hull(robot: CableRobot, platform_hull: ArrayLike | None) -> FloatArray:
    if platform_hull is None:
        given = robot.platform_hull
        return np.asarray(robot.attachments if given is None else given, dtype=float)
    V = as_finite("platform_hull", platform_hull)
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 1:
        raise InvalidInputError(
            f"platform_hull must have shape (k, 3) (vertices in the "
            f"platform frame, m), got {V.shape}"
        )
    return V


def platform_clearance(
    robot: CableRobot,
    poses: ArrayLike,
    platform_hull: ArrayLike | None = None,
    *,
    exclude: float | None = None,
) -> PlatformClearance:
    """Smallest distance of every straight cable to the platform's faces and edges.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad).
    platform_hull : array_like, shape (k, 3), optional
        Vertices of the platform polyhedron in the platform frame (m); default the
        robot's ``platform_hull``, else the attachment points. The attachment points
        should lie on its surface.
    exclude : float, optional
        Length of cable left out at its attachment point (m), >= 0. Default: 0.1 times
        the platform's size (largest distance of a vertex from their centroid).

    Returns
    -------
    PlatformClearance
        ``clearance`` (N,), ``cable`` (N,) and ``distances`` (N, m), in m.

    Raises
    ------
    InvalidInputError
        On bad poses, ``platform_hull`` or ``exclude``.
    """
    V = _check_hull(robot, platform_hull)
    size = float(np.linalg.norm(V - V.mean(axis=0), axis=1).max())
    if exclude is None:
        rho = EXCLUDE_SHARE * size
    elif is_number(exclude) and np.isfinite(exclude) and exclude >= 0:
        rho = float(exclude)
    else:
        raise InvalidInputError(
            f"exclude must be a finite number >= 0 (m of cable left "
            f"out at its attachment point), got {exclude!r}"
        )
    tri = hull_triangles(V)
    geometry = robot.cable_geometry(poses, check=False)
    N, m = geometry.lengths.shape
    if len(tri) == 0:
        dist = np.full((N, m), np.inf)
    else:
        corners = geometry.position[:, None, None, :] + np.einsum(
            "nij,fkj->nfki", geometry.rotation, tri
        )  # (N, F, 3, 3)
        A, D, L = geometry.attachment_points, geometry.vectors, geometry.lengths
        with np.errstate(invalid="ignore", divide="ignore"):
            start = A + np.where(L > 0, np.minimum(rho / L, 1.0), 0.0)[..., None] * D
        c = corners[:, None]  # (N, 1, F, 3, 3) against cables (N, m, 1, 3)
        dist = segment_triangle_distance(
            start[:, :, None], (A + D)[:, :, None], c[..., 0, :], c[..., 1, :], c[..., 2, :]
        ).min(axis=2)
        dist = np.where(L > rho, dist, np.inf)  # a cable shorter than `exclude`: nothing left
    cable = np.argmin(dist, axis=1) if m else np.zeros(N, dtype=np.intp)
    return PlatformClearance(dist[np.arange(N), cable], cable.astype(np.intp), dist, tri, rho)
