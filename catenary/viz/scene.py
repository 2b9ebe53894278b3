"""What a view of the robot draws, as arrays: no plotting library is imported here.

:func:`robot_scenes` solves the cables of a batch of poses once (the sag model's own
tensions, or the tensions given) and returns one :class:`RobotScene` per pose: the
drawing points, the attachment points, the platform as a closed solid, each cable as
points sampled along its elastic catenary (or its straight chord), its tensions, its
unstretched length, its sag below the chord and how it is drawn (taut, slack, outside
its bounds, or with no tensions at all). The matplotlib, plotly and animation views
(:mod:`catenary.viz`) draw these arrays and compute nothing of their own.

A catenary curve runs from the attachment point (end A) to the drawing point (end B)
in the cable's vertical plane (:mod:`catenary.geometry`), sampled by
:func:`catenary.profile` from the catenary's own forces and unstretched length. Over a
guide pulley (:mod:`catenary.pulleys`) the free span runs to where the cable leaves its
wheel, tangent to it, and the curve goes on along the wrapped arc to the drawing point;
the scene also holds each wheel's outline.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot
from tension_opt.status import Status

from ..elastic import axial_compliance, evaluate, profile
from ..errors import InvalidCableError
from ..geometry import (
    E_Z,
    CablePlanes,
    check_robot,
    extreme_tensions,
    straight_planes,
)
from ..geometry import taut_catenaries as solve_taut
from ..inverse import InverseKinematicsResult, inverse_kinematics
from ..pulleys import settle_wraps
from .wheels import Wheels, wheels_at

__all__ = [
    "MODELS",
    "STATES",
    "RobotScene",
    "check_model",
    "platform_solid",
    "robot_scene",
    "robot_scenes",
    "sag_below_chord",
]

FloatArray = NDArray[np.float64]
ViewModel = Literal["coupled", "thesis", "straight"]

#: The cable models a view draws.
MODELS: tuple[str, ...] = ("coupled", "thesis", "straight")
#: How a cable is drawn: ``"taut"`` within its bounds, ``"out_of_bounds"`` (its lowest
#: or highest tension outside ``[t_min, t_max]``), ``"slack"`` (no tension),
#: ``"infeasible"`` (no tensions for the pose, or no taut catenary carries the tension).
STATES: tuple[str, ...] = ("taut", "out_of_bounds", "slack", "infeasible")
#: Tension (N) at or below which a cable counts as slack, relative to the pose's largest.
SLACK_SHARE = 1e-9
#: Bound violation allowed before a cable counts as outside its bounds, relative.
BOUND_SHARE = 1e-6


@dataclass(frozen=True, eq=False)
class RobotScene:
    """One pose of a robot as a view draws it (all in the base frame, SI units).

    Attributes
    ----------
    robot : CableRobot
    pose : ndarray, shape (n,)
        The platform pose (m, rad).
    model : str
        ``"coupled"``, ``"thesis"`` or ``"straight"``: how the cables were solved.
    anchors : ndarray, shape (m, 3)
        Drawing points (m).
    attachments : ndarray, shape (m, 3)
        Attachment points on the platform (m).
    curves : ndarray, shape (m, k, 3)
        Points along each cable from its attachment point to its drawing point (m);
        a catenary sampled at ``samples`` points of equal unstretched arc length, or the
        straight chord (slack and infeasible cables, the straight model). Over guide
        pulleys the free span ends where the cable leaves its wheel, and
        :data:`catenary.viz.wheels.ARC_SAMPLES` more points follow the wrapped arc to
        the drawing point (repeats of the drawing point for a cable without a pulley).
    tensions : ndarray, shape (m,)
        Tension at the drawing point (N); NaN where the pose has none.
    tensions_platform : ndarray, shape (m,)
        Tension at the attachment point (N).
    lowest, highest : ndarray, shape (m,)
        Lowest and highest tension along each cable (N).
    lengths : ndarray, shape (m,)
        Unstretched cable lengths (m), the wrapped arc included; the straight length
        for the straight model.
    straight_lengths : ndarray, shape (m,)
        Chord from attachment to drawing point (m); over a pulley the straight cable's
        length, its wrapped arc included (``robot.inverse_kinematics``).
    sag : ndarray, shape (m,)
        Largest vertical drop of the cable below its chord (m), from the catenary's own
        forces (:func:`sag_below_chord`); 0 for straight cables. Over a pulley, of the
        free span below its own chord.
    closure : ndarray, shape (m,)
        Distance (m) between the sampled curve's end and the drawing point before the
        curve is closed onto it (the catenary solver's residual; 0 when straight).
    state : ndarray of str, shape (m,)
        One of :data:`STATES` per cable.
    status : str
        The pose's status from the solve (``"converged"``, ``"optimal"``,
        ``"infeasible"``, ...).
    exits : ndarray, shape (m, 3)
        Where each free span ends (m): the drawing point, or where the cable leaves
        its guide pulley.
    wheels : ndarray, shape (m, k, 3), or None
        The outline of each guide pulley's wheel, swivelled to the pose, at
        :data:`catenary.viz.wheels.WHEEL_SAMPLES` points (NaN for a cable without
        one); None for a robot without pulleys.
    """

    robot: CableRobot
    pose: FloatArray
    model: str
    anchors: FloatArray
    attachments: FloatArray
    curves: FloatArray
    tensions: FloatArray
    tensions_platform: FloatArray
    lowest: FloatArray
    highest: FloatArray
    lengths: FloatArray
    straight_lengths: FloatArray
    sag: FloatArray
    closure: FloatArray
    state: NDArray[np.str_]
    status: str
    exits: FloatArray
    wheels: FloatArray | None = None

    @property
    def m(self) -> int:
        """Number of cables."""
        return int(self.anchors.shape[0])

    @property
    def feasible(self) -> bool:
        """Whether the pose has tensions and every cable is taut within its bounds."""
        return bool(np.all(self.state == "taut"))

    def platform(self, size: float | None = None) -> tuple[FloatArray, NDArray[np.intp]]:
        """The platform as a closed solid: ``vertices`` (k, 3) (m) and triangles (t, 3)
        (indices into the vertices); see :func:`platform_solid`."""
        return platform_solid(self.robot, self.pose, size)


def check_model(model: object) -> str:
    """``model`` if it is one of :data:`MODELS`, else :class:`InvalidCableError`."""
    if model not in MODELS:
        raise InvalidCableError(
            f'model must be "coupled", "thesis" or "straight"; got model={model!r}'
        )
    return str(model)


def _check_tensions(tensions: ArrayLike, N: int, m: int) -> FloatArray:
    """Given tensions as (N, m) floats >= 0 (NaN allowed: that pose has none)."""
    try:
        T = np.asarray(tensions, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidCableError(
            f"tensions must be numbers (N), shape ({N}, {m}) or ({m},); "
            f"got {type(tensions).__name__}"
        ) from exc
    if T.shape == (m,):
        T = np.broadcast_to(T, (N, m))
    if T.shape != (N, m):
        raise InvalidCableError(
            f"tensions must have shape ({N}, {m}) (or ({m},) for every "
            f"pose), one per cable (N); got {T.shape}"
        )
    if np.isinf(T).any() or (T < 0).any():
        raise InvalidCableError(
            "tensions must be finite and >= 0 (N): cables only pull; "
            "use NaN for a pose without tensions"
        )
    return np.array(T, dtype=float)


def robot_scenes(
    robot: CableRobot,
    poses: ArrayLike,
    tensions: ArrayLike | None = None,
    model: ViewModel = "coupled",
    *,
    samples: int = 101,
    wrench: ArrayLike | None = None,
    objective: Any = "min_sum",
    backend: Any = "auto",
    **options: Any,
) -> list[RobotScene]:
    """Scenes of a batch of poses, the cables solved in one call.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad).
    tensions : array_like, shape (N, m) or (m,), optional
        Tension of each cable at its drawing point (N), >= 0; a row of NaN is a pose
        without tensions. Default: the model's own, :func:`catenary.inverse_kinematics`
        for ``"coupled"`` and ``"thesis"``, :func:`tension_opt.distribute` for
        ``"straight"``. Given tensions draw each cable as the taut catenary through its
        two ends that carries the tension at the drawing point.
    model : {"coupled", "thesis", "straight"}
        The sag model. A robot without cable properties, or with weightless cables,
        has straight cables in every model.
    samples : int
        Points along each catenary, >= 2.
    wrench, objective, backend, **options
        Passed to the solve of the default tensions (external wrench (N, N m) besides
        gravity; objective and backend as in :func:`tension_opt.distribute`).

    Returns
    -------
    list of RobotScene
        One per pose.

    Raises
    ------
    InvalidCableError
        For an unknown model, ``samples`` below 2, or tensions of the wrong shape or
        sign.
    tension_opt.errors.InvalidInputError
        For poses of the wrong shape or with NaN.
    """
    check_robot(robot, pulleys=True)
    model = check_model(model)  # type: ignore[assignment]
    if isinstance(samples, bool) or not isinstance(samples, int | np.integer) or samples < 2:
        raise InvalidCableError(
            f"samples must be an integer >= 2 (points along a cable); got samples={samples!r}"
        )
    p = robot.as_poses(poses)
    planes = straight_planes(robot, p)
    # The straight lengths: chords, or over pulleys the wrapped arcs with them.
    straight = (robot.cable_geometry(p, check=False).total_lengths if robot.has_pulleys
                else planes.chord)
    sagging = (
        model != "straight"
        and robot.cable is not None
        and (robot.cable.weight_per_length(robot.g) > 0 or np.isfinite(robot.cable.EA))
    )
    solve = dict(wrench=wrench, objective=objective, backend=backend, **options)
    planes, wheels, cables, status = _batch_cables(robot, p, planes, tensions, model,
                                                   sagging, solve)
    # The unstretched arcs on the wheels, once for the batch.
    arcs = (np.zeros(planes.x.shape) if wheels is None
            else wheels.arcs(np.nan_to_num(cables.tensions), cables.EA))
    return [_scene(robot, p, planes, cables, status, model, samples, k, wheels,
                   (straight[k], arcs[k])) for k in range(len(p))]


def _batch_cables(robot: CableRobot, p: FloatArray, planes: CablePlanes,
                  tensions: ArrayLike | None, model: str, sagging: bool,
                  solve: dict[str, Any]
                  ) -> tuple[CablePlanes, Wheels | None, _Cables, NDArray[np.str_]]:
    """The free spans' planes, the guide pulleys (:func:`wheels_at`), the cables and each
    pose's status of a batch: catenaries carrying the given ``tensions``, the sag model's
    own, or straight cables with the distribution's tensions (``planes``: the straight
    free spans)."""
    if tensions is not None:
        T = _check_tensions(tensions, len(p), robot.m)
        status = np.where(np.isnan(T).any(axis=1), Status.INFEASIBLE, Status.OPTIMAL)
        if robot.has_pulleys and sagging:  # the wheels turned to the catenaries' ends
            w, EA = _cable_constants(robot)
            given = np.asarray(np.isfinite(T).all(axis=1), dtype=bool)
            ends = settle_wraps(robot, p, np.nan_to_num(T), given, w, EA).planes.upper_ends
            # A slack cable, or one too weak for a catenary: its straight exit point.
            planes = planes.with_upper_ends(np.where(np.isfinite(ends), ends,
                                                     planes.upper_ends))
        return planes, wheels_at(robot, planes), _catenaries_of(robot, planes, T,
                                                                 sagging), status
    if sagging:
        res = _solved(robot, p, model, solve)
        if res.exit_points is not None:  # the wheels as the solve left them
            planes = planes.with_upper_ends(np.where(np.isfinite(res.exit_points),
                                                     res.exit_points, planes.upper_ends))
        wheels = wheels_at(robot, planes)
        return planes, wheels, _solved_catenaries(robot, res, wheels), np.asarray(
            res.status, dtype=str)
    options = {k: v for k, v in solve.items() if k not in ("objective", "backend", "wrench")}
    straight = tension_opt.distribute(robot, p, solve["objective"], solve["backend"],
                                      wrench=solve["wrench"], **options)
    T = np.where(straight.success[:, None], straight.tensions, np.nan)
    return planes, wheels_at(robot, planes), _catenaries_of(robot, planes, T, False), \
        np.asarray(straight.status, dtype=str)


def robot_scene(
    robot: CableRobot,
    pose: ArrayLike,
    tensions: ArrayLike | None = None,
    model: ViewModel = "coupled",
    **kwargs: Any,
) -> RobotScene:
    """The scene of one pose (``pose`` shape (n,) or (1, n)); see :func:`robot_scenes`.

    Raises
    ------
    InvalidCableError
        If ``pose`` holds more than one pose, and as :func:`robot_scenes`.
    """
    check_robot(robot, pulleys=True)
    p = robot.as_poses(pose)
    if len(p) != 1:
        raise InvalidCableError(
            f"pose must be one pose, shape ({robot.dof},); got {len(p)} "
            "poses: draw them one at a time, or use animate()"
        )
    return robot_scenes(robot, p, tensions, model, **kwargs)[0]


# ------------------------------------------------------------------------- catenaries
@dataclass(frozen=True)
class _Cables:
    """The cables of a batch, each array (N, m): forces (N), lengths (m), whether each
    cable is a catenary (else its chord is drawn) and whether one was found."""

    H: FloatArray
    V_A: FloatArray
    L0: FloatArray
    tensions: FloatArray
    curved: NDArray[np.bool_]
    found: NDArray[np.bool_]
    w: float
    EA: float


def _cable_constants(robot: CableRobot) -> tuple[float, float]:
    """Weight per length (N/m) and axial stiffness (N); weightless rigid without cables."""
    if robot.cable is None:
        return 0.0, np.inf
    return robot.cable.weight_per_length(robot.g), float(robot.cable.EA)


def _catenaries_of(robot: CableRobot, planes: CablePlanes, T: FloatArray, sagging: bool) -> _Cables:
    """Catenaries carrying the tensions ``T`` (N, m) at their drawing points, or
    straight cables (``sagging`` False)."""
    w, EA = _cable_constants(robot)
    if not sagging:
        # A straight cable pulls along its chord with one tension: (H, V_A) its parts.
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.where(planes.chord > 0, planes.x / planes.chord, 0.0)
            sin = np.where(planes.chord > 0, planes.z / planes.chord, 1.0)
        none = np.zeros(T.shape, dtype=bool)
        return _Cables(T * cos, T * sin, planes.chord.copy(), T, none, np.isfinite(T), 0.0, np.inf)
    pulled = np.isfinite(T) & (T > 0)
    cat = solve_taut(planes.x, planes.z, np.where(pulled, T, 1.0), w, EA, end="B")
    found = pulled & cat.converged & np.isfinite(cat.L0)
    return _Cables(cat.H, cat.V_A, cat.L0, T, found, found | (np.isfinite(T) & ~pulled), w, EA)


def _solved(robot: CableRobot, poses: FloatArray, model: str, solve: dict[str, Any]
            ) -> InverseKinematicsResult:
    """The sag model's own solution of a batch."""
    options = {k: v for k, v in solve.items() if k not in ("objective", "backend", "wrench")}
    sag_model: Literal["thesis", "coupled"] = "thesis" if model == "thesis" else "coupled"
    return inverse_kinematics(
        robot, poses, sag_model, solve["objective"], solve["backend"], solve["wrench"], **options
    )


def _solved_catenaries(robot: CableRobot, res: InverseKinematicsResult,
                       wheels: Wheels | None) -> _Cables:
    """The catenaries of a sag model's solution; over pulleys, of the free spans (the
    wrapped arcs' unstretched lengths taken off)."""
    w, EA = _cable_constants(robot)
    ok = res.success[:, None] & np.isfinite(res.lengths)
    free = res.lengths
    if wheels is not None:
        free = res.lengths - wheels.arcs(res.tensions, EA)
    return _Cables(
        res.horizontal_tensions,
        res.platform_forces[..., 2],
        free,
        np.where(ok, res.tensions, np.nan),
        ok,
        ok,
        w,
        EA,
    )


def sag_below_chord(
    x: ArrayLike,
    z: ArrayLike,
    H: ArrayLike,
    V_A: ArrayLike,
    L0: ArrayLike,
    w: float,
    EA: float = np.inf,
) -> FloatArray:
    """Largest vertical drop of an elastic catenary below its chord (m).

    The drop ``(z/x) x(s) - z(s)`` is largest where the cable's slope ``V(s)/H`` equals
    the chord's ``z/x``: at ``s* = (H z/x - V_A)/w`` (clipped to ``[0, L0]``), whose
    position the span equations give for the piece of cable from A to ``s*``.

    Parameters
    ----------
    x, z : array_like, shape S
        Horizontal span (m), > 0 for a drop, and height of end B over end A (m).
    H, V_A, L0 : array_like, shape S
        Horizontal tension (N), vertical force at end A (N, upward along the cable) and
        unstretched length (m) of the catenary.
    w, EA : float
        Weight per length (N/m) and axial stiffness (N).

    Returns
    -------
    ndarray, shape S
        The drop (m), 0 for vertical, straight or weightless cables.
    """
    x, z, H, V_A, L0 = (np.asarray(a, dtype=float) for a in (x, z, H, V_A, L0))
    if w <= 0:
        return np.zeros(np.broadcast_shapes(x.shape, z.shape, H.shape, V_A.shape, L0.shape))
    with np.errstate(all="ignore"):
        slope = np.where(x > 0, z / x, 0.0)
        s = np.clip((H * slope - V_A) / w, 0.0, L0)
        s_pos = np.where(s > 0, s, 1.0)
        xs, zs, *_ = evaluate(
            H,
            V_A + w * s_pos,
            s_pos,
            w,
            axial_compliance(np.asarray(EA, dtype=float)),
            jacobian=False,
        )
        drop = np.where((s > 0) & (x > 0) & (H > 0), slope * xs - zs, 0.0)
    return np.where(np.isfinite(drop), np.maximum(drop, 0.0), 0.0)


def _curves(
    planes: CablePlanes,
    k: int,
    cables: _Cables,
    attach: FloatArray,
    anchors: FloatArray,
    samples: int,
) -> tuple[FloatArray, FloatArray]:
    """Points along the free spans of pose ``k`` (m, samples, 3), from the attachment
    points to ``anchors`` (their upper ends), and each curve's closure (m)."""
    t = np.linspace(0.0, 1.0, samples)
    chord = anchors - attach
    points = attach[:, None, :] + t[None, :, None] * chord[:, None, :]
    closure = np.zeros(len(attach))
    curved = cables.curved[k]
    if curved.any():
        H, V_A, L0 = cables.H[k, curved], cables.V_A[k, curved], cables.L0[k, curved]
        _, xs, zs = profile(H, V_A + cables.w * L0, L0, cables.w, cables.EA, n=samples)
        e_h = planes.e_h[k, curved]
        sampled = attach[curved, None, :] + xs[..., None] * e_h[:, None, :] + zs[..., None] * E_Z
        # The solver's residual at B, spread along the cable so that the curve ends on
        # the drawing point (it is reported in `closure`).
        miss = anchors[curved] - sampled[:, -1, :]
        closure[curved] = np.linalg.norm(miss, axis=1)
        points[curved] = sampled + t[None, :, None] * miss[:, None, :]
        points[curved, 0] = attach[curved]
        points[curved, -1] = anchors[curved]
    return points, closure


def _states(
    robot: CableRobot, cables: _Cables, k: int, lowest: FloatArray, highest: FloatArray
) -> NDArray[np.str_]:
    """How each cable of pose ``k`` is drawn (:data:`STATES`)."""
    T = cables.tensions[k]
    m = len(T)
    if not np.isfinite(T).all():
        return np.full(m, "infeasible")
    scale = max(float(np.nanmax(np.abs(T))), 1e-300)
    t_min, t_max = np.asarray(robot.t_min, float), np.asarray(robot.t_max, float)
    tol = BOUND_SHARE * np.maximum(scale, np.where(np.isfinite(t_max), t_max, 0.0))
    state = np.full(m, "taut", dtype="<U13")
    state[(lowest < t_min - tol) | (highest > t_max + tol)] = "out_of_bounds"
    state[T <= SLACK_SHARE * scale] = "slack"
    state[~cables.found[k]] = "infeasible"
    return state


def _scene(
    robot: CableRobot,
    poses: FloatArray,
    planes: CablePlanes,
    cables: _Cables,
    status: NDArray[np.str_],
    model: str,
    samples: int,
    k: int,
    wheels: Wheels | None,
    lengths_of: tuple[FloatArray, FloatArray],
) -> RobotScene:
    """The scene of pose ``k`` of a solved batch (over guide pulleys, ``wheels``;
    ``lengths_of``: the pose's straight lengths and unstretched wrapped arcs (m,))."""
    straight, arcs = lengths_of
    attach = planes.position[k] + planes.arms[k]
    anchors = np.asarray(robot.anchors, dtype=float)
    exits = planes.upper_ends[k]
    curves, closure = _curves(planes, k, cables, attach, exits, samples)
    if wheels is not None:  # the wrapped arcs follow the free spans
        curves = np.concatenate([curves, wheels.arc_points(k)[:, 1:]], axis=1)
    curved = cables.curved[k]
    with np.errstate(invalid="ignore"):
        V_B = cables.V_A[k] + cables.w * cables.L0[k]
        T_A = np.where(curved, np.hypot(cables.H[k], cables.V_A[k]), cables.tensions[k])
        low, high = extreme_tensions(cables.H[k], cables.V_A[k], V_B)
    lowest = np.where(curved, low, cables.tensions[k])
    highest = np.where(curved, high, cables.tensions[k])
    sag = np.where(
        curved,
        sag_below_chord(
            planes.x[k], planes.z[k], cables.H[k], cables.V_A[k], cables.L0[k], cables.w, cables.EA
        ),
        0.0,
    )
    lengths = np.where(cables.found[k] & curved, cables.L0[k], planes.chord[k]) + arcs
    return RobotScene(
        robot,
        poses[k].copy(),
        model,
        anchors.copy(),
        attach,
        curves,
        cables.tensions[k].copy(),
        T_A,
        lowest,
        highest,
        lengths,
        straight.copy(),
        sag,
        closure,
        _states(robot, cables, k, lowest, highest),
        str(status[k]),
        exits,
        None if wheels is None else wheels.outlines(k),
    )


# ------------------------------------------------------------------------- platform
def platform_solid(
    robot: CableRobot, pose: ArrayLike, size: float | None = None
) -> tuple[FloatArray, NDArray[np.intp]]:
    """The platform as a closed solid: the convex hull of its attachment points.

    Attachment points that span less than ``size`` along a platform axis (a point mass,
    a flat platform) are extruded to ``size`` along it, so a point mass is a cube.

    Parameters
    ----------
    robot : CableRobot
    pose : array_like, shape (n,)
        The platform pose (m, rad).
    size : float, optional
        Smallest extent of the solid along each platform axis (m); default 2 % of the
        frame's largest extent (the drawing points' bounding box).

    Returns
    -------
    vertices : ndarray, shape (k, 3)
        Corners of the solid in the base frame (m).
    triangles : ndarray of int, shape (t, 3)
        The hull's faces, indices into ``vertices``.
    """
    from scipy.spatial import ConvexHull  # only when a platform is drawn

    p = robot.as_poses(pose)[:1]
    position, rotation = robot.frames(p)
    if size is None:
        size = 0.02 * float(np.ptp(robot.anchors, axis=0).max())
    local = np.asarray(robot.attachments, dtype=float)
    centre = 0.5 * (local.min(axis=0) + local.max(axis=0))
    for axis in range(3):
        if np.ptp(local[:, axis]) < size:
            lo, hi = local.copy(), local.copy()
            lo[:, axis] = centre[axis] - 0.5 * size
            hi[:, axis] = centre[axis] + 0.5 * size
            local = np.concatenate([lo, hi])
    vertices = position[0] + np.unique(local, axis=0) @ rotation[0].T
    hull = ConvexHull(vertices, qhull_options="QJ")
    return vertices, np.asarray(hull.simplices, dtype=np.intp)
