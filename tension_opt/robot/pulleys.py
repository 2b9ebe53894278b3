"""Swivel guide pulleys: where a cable leaves its pulley, and how much of it is wrapped.

Geometry (Pott's swivel pulley). The cable arrives from its winch along the pulley's
swivel axis and first touches the wheel at the drawing point ``A`` (``robot.anchors``).
``axis`` is the unit vector from ``A`` towards the side the cable comes from (the
winch). The wheel (radius ``r``) turns about that axis so that its plane contains the
attachment point ``B``; its centre lies at ``C = A + r h``, ``h`` the unit vector from
the axis towards ``B``, perpendicular to it. The cable wraps from ``A`` around the
wheel through the *wrap angle* ``beta`` and leaves it at the tangent point ``T``
towards ``B``. In the wheel's plane, with ``x = (B - A) . axis`` and
``y = |(B - A) x axis| - r`` the coordinates of ``B`` about ``C``::

    l    = sqrt(x^2 + y^2 - r^2)                       free span |B - T|
    beta = (pi + atan2(r, l) - atan2(y, x)) mod 2 pi    wrap angle (rad)
    T    = A - r sin(beta) axis + r (1 - cos(beta)) h

and the cable's length is ``r beta + l``. Its derivative with respect to ``B`` is the
unit vector from ``T`` to ``B`` (the wrapped arc's change cancels the tangent point's
move), so the structure matrix keeps its form with the free span's direction.

A pose is *degenerate* for a pulley when ``B`` lies on the swivel axis (no swivel
angle) or on or inside the wheel (no tangent).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_finite, check_positive, is_number
from tension_opt.errors import InvalidInputError

__all__ = ["Pulley", "PulleyExits", "check_pulleys", "pulley_arrays", "pulley_exits",
           "swivel_basis", "swivel_turn"]


@dataclass(frozen=True)
class Pulley:
    """A swivel guide pulley at a cable's drawing point.

    Parameters
    ----------
    radius : float
        Wheel radius (m), > 0 (the radius of the cable's centre line on the wheel).
    axis : array_like, shape (3,)
        Swivel axis in the base frame: the direction from the drawing point towards the
        side the cable comes from (its winch). Normalised on construction.
    """

    radius: float
    axis: ArrayLike = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))

    def __post_init__(self) -> None:
        if not is_number(self.radius):
            raise InvalidInputError(f"Pulley radius must be a number (m), got {self.radius!r}")
        check_positive("Pulley radius", float(self.radius))
        axis = as_finite("Pulley axis", self.axis, (3,))
        norm = float(np.linalg.norm(axis))
        if not norm > 0:
            raise InvalidInputError("Pulley axis must be a non-zero 3-vector (towards the "
                                    "winch), got [0, 0, 0]")
        if abs(norm - 1.0) > 4e-16:  # a unit axis stays bit for bit (robot files)
            axis = axis / norm
        axis.setflags(write=False)
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "axis", axis)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Pulley) and self.radius == other.radius
                and bool(np.array_equal(self.axis, other.axis)))

    def __hash__(self) -> int:
        return hash((self.radius, tuple(np.asarray(self.axis).tolist())))


def check_pulleys(pulleys: object, m: int) -> tuple[Pulley | None, ...] | None:
    """A robot's ``pulleys`` argument as a tuple of ``m`` entries (a :class:`Pulley` or
    None each), or None when no cable has one.

    Raises
    ------
    InvalidInputError
        Naming the entry that is neither a Pulley nor None, or a wrong count.
    """
    if pulleys is None:
        return None
    if isinstance(pulleys, Pulley) or not isinstance(pulleys, Sequence):
        raise InvalidInputError(f"pulleys must be a list of {m} entries (a Pulley or None per "
                                f"cable), got {type(pulleys).__name__}")
    if len(pulleys) != m:
        raise InvalidInputError(f"pulleys must have one entry per cable ({m}), got "
                                f"{len(pulleys)}")
    for i, p in enumerate(pulleys):
        if p is not None and not isinstance(p, Pulley):
            raise InvalidInputError(f"pulleys[{i}] must be a Pulley or None, got "
                                    f"{type(p).__name__}")
    out = tuple(pulleys)
    return out if any(p is not None for p in out) else None


def pulley_arrays(pulleys: Sequence[Pulley | None]) -> tuple[NDArray, NDArray, NDArray]:
    """The cables of a robot's ``pulleys`` that have one, as arrays: their indices (k,),
    radii (k,) (m) and unit swivel axes (k, 3)."""
    idx = np.array([i for i, q in enumerate(pulleys) if q is not None], dtype=np.intp)
    chosen = [q for q in pulleys if q is not None]
    radii = np.array([q.radius for q in chosen], dtype=float)
    axes = np.array([np.asarray(q.axis, dtype=float) for q in chosen]).reshape(-1, 3)
    return idx, radii, axes


def swivel_basis(axis: NDArray) -> tuple[NDArray, NDArray]:
    """Two unit vectors ``e1, e2`` (k, 3) completing each axis (k, 3) to a right-handed
    frame; the swivel angle is measured from ``e1`` towards ``e2``. ``e1`` is the world
    axis least aligned with ``axis``, made perpendicular to it."""
    pick = np.eye(3)[np.argmin(np.abs(axis), axis=-1)]
    e1 = pick - np.sum(pick * axis, axis=-1, keepdims=True) * axis
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(axis, e1)


@dataclass(frozen=True)
class PulleyExits:
    """Where the cables with a pulley leave it, for a batch of poses.

    Attributes
    ----------
    exit_points : ndarray, shape (N, k, 3)
        Tangent points ``T`` (m), base frame.
    wrap : ndarray, shape (N, k)
        Wrap angles ``beta`` (rad), in [0, 2 pi).
    spans : ndarray, shape (N, k)
        Free spans ``|B - T|`` (m).
    swivel : ndarray, shape (N, k) or None
        Swivel angles (rad), from :func:`swivel_basis`'s ``e1`` towards ``e2``; None
        when not asked for.
    degenerate : ndarray, shape (N, k)
        ``B`` on the swivel axis or on or inside the wheel: no exit point (NaN there).
    """

    exit_points: NDArray
    wrap: NDArray
    spans: NDArray
    swivel: NDArray | None
    degenerate: NDArray


def pulley_exits(anchors: ArrayLike, axes: ArrayLike, radii: ArrayLike,
                 points: ArrayLike, *, swivel: bool = True) -> PulleyExits:
    """Exit points and wrap angles of ``k`` swivel pulleys, vectorised over poses.

    Parameters
    ----------
    anchors : array_like, shape (k, 3)
        Drawing points ``A`` (m).
    axes : array_like, shape (k, 3)
        Unit swivel axes (towards the winch).
    radii : array_like, shape (k,)
        Wheel radii (m), > 0.
    points : array_like, shape (N, k, 3)
        Attachment points ``B`` in the base frame (m).
    swivel : bool
        Also the swivel angles (two more products and an arctangent per cable).

    Returns
    -------
    PulleyExits
    """
    A, a = np.asarray(anchors, dtype=float), np.asarray(axes, dtype=float)
    r = np.asarray(radii, dtype=float)
    perp = np.asarray(points, dtype=float) - A
    x = np.einsum("nki,ki->nk", perp, a)
    perp -= x[..., None] * a  # d - (d . a) a: from the axis towards B
    v = np.sqrt(np.einsum("nki,nki->nk", perp, perp))
    scale = np.maximum(1.0, np.abs(A).max(initial=0.0))
    y = v - r
    span2 = x * x + y * y - r * r
    degenerate = (v <= 1e-12 * scale) | (span2 <= (1e-12 * scale) ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        span = np.sqrt(span2)
        wrap = np.mod(np.pi + np.arctan2(r, span) - np.arctan2(y, x), 2 * np.pi)
        # T = A - r sin(beta) axis + r (1 - cos(beta)) h, with h = perp / v
        exits = A - (r * np.sin(wrap))[..., None] * a
        exits += (r * (1.0 - np.cos(wrap)) / v)[..., None] * perp
        angle = None
        if swivel:
            e1, e2 = swivel_basis(a)
            angle = np.arctan2(np.einsum("nki,ki->nk", perp, e2),
                               np.einsum("nki,ki->nk", perp, e1))
    if degenerate.any():
        for arr in (exits, wrap, span, angle):
            if arr is not None:
                arr[degenerate] = np.nan
    return PulleyExits(exits, wrap, span, angle, degenerate)


def swivel_turn(anchors: ArrayLike, axes: ArrayLike, radii: ArrayLike, points: ArrayLike,
                wrap: ArrayLike) -> tuple[NDArray, NDArray]:
    """How the exit point follows the attachment point sideways: the wheel planes' unit
    normals ``n = axis x h`` (N, k, 3) and the rate ``r (1 - cos beta) / v`` (N, k) at
    which the exit point moves along ``n`` per metre that ``B`` moves along it (``v`` the
    distance of ``B`` from the swivel axis, m).

    Moving ``B`` within the wheel's plane slides the exit point along the cable (no
    change of direction); moving it along ``n`` turns the wheel by ``dB . n / v`` and
    carries the exit point, at ``r (1 - cos beta)`` from the axis, with it. So the free
    span's unit vector ``u`` (towards the exit point, length ``l``) turns as
    ``du = -[(I - u u') / l - rate n n' / l] dB``.
    """
    A, a = np.asarray(anchors, dtype=float), np.asarray(axes, dtype=float)
    perp = np.asarray(points, dtype=float) - A
    perp -= np.einsum("nki,ki->nk", perp, a)[..., None] * a
    v = np.sqrt(np.einsum("nki,nki->nk", perp, perp))
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = np.cross(a, perp / v[..., None])
        rate = np.asarray(radii, dtype=float) * (1.0 - np.cos(wrap)) / v
    return normal, rate
