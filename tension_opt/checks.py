"""Checks of user input where it enters the package.

Each check returns the value as a float array or raises
:class:`~tension_opt.errors.InvalidInputError` naming the argument and the fix.
"""

from __future__ import annotations

import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.errors import InvalidInputError


def check_positive(name: str, value: float) -> None:
    """Raise the package's error unless ``value`` is a positive finite number."""
    if not is_number(value) or not np.isfinite(value) or value <= 0:
        raise InvalidInputError(f"{name} must be a positive finite number, got {value!r}")


def whole_positive(name: str, value: object) -> int:
    """``value`` as a whole number >= 1 (an integer, not a bool), or the package's error
    naming ``name``."""
    try:
        if isinstance(value, bool | np.bool_):
            raise TypeError(name)
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidInputError(f"{name} must be a whole number >= 1, got {value!r}") from None
    if number < 1:
        raise InvalidInputError(f"{name} must be a whole number >= 1, got {number}")
    return number


def is_number(value: object) -> bool:
    """Whether ``value`` is a real scalar (not a bool)."""
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool)


def as_float_array(name: str, value: ArrayLike) -> NDArray:
    """``value`` as a float array, or the package's error naming the argument.

    Raises
    ------
    InvalidInputError
        If numpy cannot make a real float array of it (text, ragged nesting, None,
        complex numbers).
    """
    if type(value) is np.ndarray and value.dtype.kind in "fiub":  # the usual call
        return value.astype(float, copy=False)
    if value is None or isinstance(value, str | bytes):
        raise InvalidInputError(f"{name} must be numbers, got {value!r}")
    try:
        raw = np.asarray(value)
        if raw.dtype.kind in "USV":  # text is not numbers, even where numpy reads it so
            raise TypeError
        if raw.dtype.kind != "c":
            return raw.astype(float, copy=False)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"{name} must be a rectangular array of numbers, got {value!r}"[:300]) from None
    raise InvalidInputError(f"{name} must be real numbers, got complex ones: pass its real "
                            f"part ({name}.real) if that is meant")


def as_finite(name: str, value: ArrayLike, shape: tuple[int, ...] | None = None) -> NDArray:
    """``value`` as a finite float array (of ``shape`` if given), or the package's error
    naming the argument and the first bad entry."""
    arr = as_float_array(name, value)
    if shape is not None and arr.shape != shape:
        raise InvalidInputError(f"{name} must have shape {shape}, got {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InvalidInputError(f"{name} has a non-finite value {arr[idx]!r} at index {idx}")
    return arr


def per_cable(name: str, value: ArrayLike, m: int) -> NDArray:
    """A scalar or per-cable ``value`` as an array of shape (m,)."""
    arr = as_float_array(name, value)
    try:
        return np.broadcast_to(arr, (m,)).copy()
    except ValueError:
        raise InvalidInputError(
            f"{name} must be a number or have shape ({m},) (one per cable), got "
            f"shape {arr.shape}") from None



def label(name: str, value: object) -> str:
    """``value`` as a label (a robot's name): non-empty text that UTF-8 can write, so that
    a robot file holds it; else the package's error naming ``name``."""
    if not isinstance(value, str) or not value:
        raise InvalidInputError(f"{name} must be non-empty text (a label for tables, plots "
                                f"and robot files), got {value!r}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as error:
        raise InvalidInputError(f"{name} must be non-empty text that UTF-8 can write, got "
                                f"{value!r}: {error.reason}") from None
    return str(value)


def inertia_tensor(value: ArrayLike) -> NDArray:
    """A (3, 3) inertia tensor (kg m^2), checked symmetric and positive semi-definite."""
    inertia = as_finite("inertia", value, (3, 3))
    if not np.allclose(inertia, inertia.T, rtol=1e-9, atol=1e-12 * np.abs(inertia).max()):
        raise InvalidInputError(
            f"inertia must be symmetric, got {inertia.tolist()}; give the tensor about the "
            "centre of mass in the platform frame")
    # halves first: the sum of two entries near the float range's end overflows
    inertia = np.where(inertia == inertia.T, inertia, 0.5 * inertia + 0.5 * inertia.T)
    smallest = float(np.linalg.eigvalsh(inertia)[0])
    if smallest < -1e-12 * max(1.0, np.abs(inertia).max()):
        raise InvalidInputError(
            f"inertia must be positive semi-definite (smallest eigenvalue {smallest:g} "
            "kg m^2); check the signs of the products of inertia")
    return inertia


#: Largest magnitude (m) of a coordinate of a robot's points (anchors, attachments,
#: centre of mass): 1000 km, far beyond any cable robot, so that a length in the wrong
#: unit or from a far origin is refused rather than computed with.
MAX_COORDINATE = 1e6
#: Two points closer than this share of the larger of their two magnitudes (or of 1 m,
#: whichever is larger) are one point.
COINCIDENT_SHARE = 1e-9


def far_coordinate(points: NDArray) -> tuple[tuple[int, ...], str] | None:
    """The index of the first coordinate of the finite array ``points`` beyond
    :data:`MAX_COORDINATE`, and what is wrong with it and the fix; None if there is none."""
    far = np.abs(points) > MAX_COORDINATE
    if not far.any():
        return None
    index = tuple(int(i) for i in np.argwhere(far)[0])
    return index, (f"{float(points[index]):g} m is beyond {MAX_COORDINATE:g} m from the "
                   "base origin: give lengths in metres (not millimetres) from an origin at "
                   "the robot")


def check_reach(**arrays: NDArray) -> None:
    """Raise the package's error naming the first coordinate of the arrays (given by
    name) beyond :data:`MAX_COORDINATE`."""
    for name, points in arrays.items():
        found = far_coordinate(points)
        if found is not None:
            index, text = found
            raise InvalidInputError(name + "".join(f"[{i}]" for i in index) + f" = {text}")


def coincident_pair(points: NDArray) -> tuple[int, int] | None:
    """A pair ``(i, j)``, ``i < j``, of rows of ``points`` (finite, shape (m, 3), within
    :data:`MAX_COORDINATE`) closer than :data:`COINCIDENT_SHARE` of the larger of their
    own largest coordinates or of 1 m; None if no two rows coincide.

    Memory and time grow as m (log m): each point is compared with its nearest neighbour
    (a k-d tree) only. That finds every coinciding robot: if ``i`` and ``j`` coincide and
    ``j`` is the larger, ``j``'s nearest neighbour is no farther than ``i`` and its
    tolerance no smaller. Of the pairs so found the one named is the first.
    """
    m = len(points)
    if m < 2:
        return None
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(points).query(points, k=2)
    rows = np.arange(m)
    # a point's first neighbour is itself, or another point at the same place
    other = np.where(nearest[:, 0] == rows, nearest[:, 1], nearest[:, 0])
    size = np.maximum(1.0, np.abs(points).max(axis=1))
    gap = np.linalg.norm(points - points[other], axis=1)
    close = np.flatnonzero(gap < COINCIDENT_SHARE * np.maximum(size, size[other]))
    if not len(close):
        return None
    pairs = np.sort(np.stack([close, other[close]], axis=1), axis=1)
    i, j = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))[0]]
    return int(i), int(j)
