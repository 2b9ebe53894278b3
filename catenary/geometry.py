"""Cable geometry in the catenaries' vertical planes, and the cable forces on the platform.

Every cable of a robot hangs as an elastic catenary in the vertical plane through its
platform attachment point and its drawing point (anchor). In the terms of
:mod:`catenary.elastic`, end A of cable ``i`` is the attachment point ``b_i`` and end B
the drawing point ``P_i``: the horizontal span is ``x_i = |(P_i - b_i)_xy|`` and the
height ``z_i = P_iz - b_iz`` (either sign). The force the cable applies to the platform
is ``f_i = H_i e_i + V_A,i e_z`` (N, base frame), ``e_i`` the horizontal unit vector
from ``b_i`` towards ``P_i``; the tension at the drawing point is ``T_B = |(H, V_B)|``,
at the platform ``T_A = |(H, V_A)|``.

What the inverse and forward kinematics, the coupled solver and the coupled margin
share lives here: the planes of a batch of poses (:func:`cable_planes`, built on
:meth:`tension_opt.CableRobot.cable_geometry`), the platform forces and their wrench,
taut catenaries through both ends and how their platform force turns with the tension,
the extreme tensions along a cable, the cable data, and the outcomes of the sag model
that :class:`tension_opt.status.Status` does not name.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot
from tension_opt.kernels.launch import compiled_for

from .elastic import flexibility, length_derivative
from .errors import InvalidCableError
from .solve import solve_length

__all__ = [
    "E_Z",
    "CablePlanes",
    "Catenaries",
    "cable_data",
    "cable_planes",
    "cable_wrench",
    "check_robot",
    "equilibrium_residual",
    "extreme_tensions",
    "force_slope",
    "planes_along",
    "platform_forces",
    "refuse_pulleys",
    "sagging_cable_data",
    "straight_planes",
    "taut_catenaries",
]

FloatArray = NDArray[np.float64]

#: Upward unit vector of the base frame.
E_Z = np.array([0.0, 0.0, 1.0])

# ----------------------------------------------------------------------------- planes
@dataclass(frozen=True)
class CablePlanes:
    """Cables of a batch of poses in their vertical planes.

    Attributes
    ----------
    position : ndarray, shape (N, 3)
        Platform reference point in the base frame (m).
    rotation : ndarray, shape (N, 3, 3)
        Platform orientation.
    arms : ndarray, shape (N, m, 3)
        Attachment points relative to the reference point, ``R a_i`` (m).
    x : ndarray, shape (N, m)
        Horizontal span from the attachment point to the drawing point (m), >= 0.
    z : ndarray, shape (N, m)
        Height of the drawing point over the attachment point (m).
    e_h : ndarray, shape (N, m, 3)
        Horizontal unit vector towards the drawing point (0 for a vertical cable).
    chord : ndarray, shape (N, m)
        Straight length ``sqrt(x^2 + z^2)`` (m).
    """

    position: FloatArray
    rotation: FloatArray
    arms: FloatArray
    x: FloatArray
    z: FloatArray
    e_h: FloatArray
    chord: FloatArray

    def subset(self, index: NDArray[np.intp] | slice) -> CablePlanes:
        """The planes of some poses (``index`` into the batch)."""
        return CablePlanes(*(getattr(self, f.name)[index] for f in fields(self)))

    @property
    def upper_ends(self) -> FloatArray:
        """Each cable's upper end (N, m, 3) in the base frame (m): its drawing point, or
        where it leaves its guide pulley."""
        return (self.position[:, None, :] + self.arms + self.x[..., None] * self.e_h
                + self.z[..., None] * E_Z)

    def with_upper_ends(self, ends: FloatArray) -> CablePlanes:
        """These cables' planes with their upper ends moved to ``ends`` (N, m, 3) (m)."""
        return planes_along(self.position, self.rotation, self.arms,
                            ends - (self.position[:, None, :] + self.arms))


def cable_planes(robot: CableRobot, poses: NDArray) -> CablePlanes:
    """Planes of the cables of a batch of poses.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Platform poses (m, rad). A pose that puts a cable on its drawing point is not
        rejected: that cable has ``x = z = 0`` and ``e_h = 0``.

    Returns
    -------
    CablePlanes
    """
    refuse_pulleys(robot)
    geometry = robot.cable_geometry(poses, check=False)
    return planes_along(geometry.position, np.asarray(geometry.rotation), geometry.arms,
                        geometry.vectors)


def straight_planes(robot: CableRobot, poses: NDArray) -> CablePlanes:
    """:func:`cable_planes` of the straight cables, guide pulleys allowed: over a pulley
    a cable's plane runs from its attachment point to where it leaves the wheel."""
    geometry = robot.cable_geometry(poses, check=False)
    return planes_along(geometry.position, np.asarray(geometry.rotation), geometry.arms,
                        geometry.vectors)


def planes_along(position: FloatArray, rotation: FloatArray, arms: FloatArray,
                 vectors: FloatArray) -> CablePlanes:
    """The :class:`CablePlanes` of cables along ``vectors`` (N, m, 3), each from its
    attachment point to its upper end (the drawing point, or where the cable leaves its
    guide pulley: :mod:`catenary.pulleys`) (m)."""
    d = vectors
    x = np.hypot(d[..., 0], d[..., 1])
    e_h = np.zeros_like(d)
    with np.errstate(invalid="ignore", divide="ignore"):
        e_h[..., :2] = np.where(x[..., None] > 0, d[..., :2] / x[..., None], 0.0)
    # The chord from the plane's own spans, so that it is consistent with x and z to
    # the last bit (the catenary solvers see x and z).
    chord = np.sqrt(x * x + d[..., 2] ** 2)
    return CablePlanes(position, rotation, arms, x, d[..., 2], e_h, chord)


def check_robot(robot: object, pulleys: bool = False) -> None:
    """Raise :class:`InvalidCableError` unless ``robot`` is a
    :class:`tension_opt.CableRobot`, without guide pulleys unless ``pulleys``
    (:func:`refuse_pulleys`)."""
    if not isinstance(robot, CableRobot):
        raise InvalidCableError(
            f"robot must be a tension_opt.CableRobot (e.g. tension_opt.robot.presets."
            f"algae_harvester()); got {type(robot).__name__}")
    if not pulleys:
        refuse_pulleys(robot)


def refuse_pulleys(robot: CableRobot) -> None:
    """Raise :class:`InvalidCableError` for a robot with guide pulleys where the caller
    spans each sagging cable from a fixed drawing point: a sagging cable leaves its
    pulley tangentially, at another point than the straight cable
    (:mod:`catenary.pulleys`; :func:`catenary.inverse_kinematics` models it)."""
    if robot.has_pulleys:
        raise InvalidCableError(
            "this sag computation spans each cable from a fixed drawing point and does not "
            "model guide pulleys; catenary.inverse_kinematics does, "
            "and the straight kinematics (robot.inverse_kinematics) take any pulley")


def cable_data(robot: CableRobot, pulleys: bool = False) -> tuple[float, float]:
    """Weight per length ``w`` (N/m) and axial stiffness ``EA`` (N) of the robot's cables.

    Raises
    ------
    InvalidCableError
        If the robot has no cable properties, or has guide pulleys (:func:`refuse_pulleys`)
        and ``pulleys`` is False (the caller does not model them).
    """
    if not pulleys:
        refuse_pulleys(robot)
    if robot.cable is None:
        raise InvalidCableError(
            f"robot {robot.name!r} has no cable properties: build it with "
            "cable=CableProperties(diameter, linear_mass, EA) to use the catenary model"
        )
    return robot.cable.weight_per_length(robot.g), float(robot.cable.EA)


def sagging_cable_data(robot: CableRobot, instead: str) -> tuple[float, float]:
    """:func:`cable_data` of cables that sag: a weight per length > 0, else
    :class:`InvalidCableError` saying what to use ``instead`` (no guide pulleys)."""
    w, EA = cable_data(robot)
    if not w > 0:
        raise InvalidCableError(f"weightless cables do not sag: {instead}")
    return w, EA


# ----------------------------------------------------------------------------- forces
def platform_forces(planes: CablePlanes, H: FloatArray, V_A: FloatArray) -> FloatArray:
    """Force of each cable on the platform, ``H e_h + V_A e_z`` (N), shape (N, m, 3).

    Parameters
    ----------
    planes : CablePlanes
    H, V_A : ndarray, shape (N, m)
        Horizontal tension and vertical force at the platform end of each catenary (N).
    """
    return H[..., None] * planes.e_h + V_A[..., None] * E_Z


def cable_wrench(robot: CableRobot, forces: FloatArray, arms: FloatArray) -> FloatArray:
    """Total wrench of the cable forces on the platform (N, N m), shape (N, n).

    Parameters
    ----------
    robot : CableRobot
    forces : ndarray, shape (N, m, 3)
        Force of each cable on the platform (N), base frame.
    arms : ndarray, shape (N, m, 3)
        Attachment points relative to the reference point, ``R a_i`` (m).
    """
    # Summed over the cables in order (a contiguous copy: numpy would otherwise sum a
    # strided selection pairwise, which rounds differently).
    return np.ascontiguousarray(robot.cable_wrenches(forces, arms)).sum(axis=1)


def equilibrium_residual(robot: CableRobot, forces: FloatArray, arms: FloatArray,
                         required: FloatArray) -> FloatArray:
    """Norm of the wrench left on the platform (N, N m), shape (N,).

    Parameters
    ----------
    robot : CableRobot
    forces, arms : ndarray, shape (N, m, 3)
        As in :func:`cable_wrench`.
    required : ndarray, shape (N, n)
        The wrench the cables must apply, ``robot.required_wrench(poses, wrench)``.
    """
    return np.linalg.norm(cable_wrench(robot, forces, arms) - required, axis=1)


def extreme_tensions(
    H: FloatArray, V_A: FloatArray, V_B: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Lowest and highest tension along each cable (N), each of the shape of ``H``.

    The tension ``sqrt(H^2 + V^2)`` is smallest where ``V = 0``: at the lowest point of
    the cable when it lies between the ends, otherwise at an end.
    """
    T_A, T_B = np.hypot(H, V_A), np.hypot(H, V_B)
    dip = (V_A < 0) & (V_B > 0)
    return np.where(dip, H, np.minimum(T_A, T_B)), np.maximum(T_A, T_B)


# ------------------------------------------------------------------------- catenaries
class Catenaries(NamedTuple):
    """Taut catenaries of a batch of cables, each array of the cables' shape."""

    #: Horizontal tension (N).
    H: FloatArray
    #: Vertical force at the platform end A, positive upward along the cable (N).
    V_A: FloatArray
    #: Vertical force at the drawing point B (N).
    V_B: FloatArray
    #: Unstretched length (m).
    L0: FloatArray
    #: Iterations of the single-cable solver.
    iterations: NDArray[np.int64]
    #: Where a taut catenary carries the tension.
    converged: NDArray[np.bool_]


def taut_catenaries(x: FloatArray, z: FloatArray, T: FloatArray, w: float, EA: float,
                    end: Literal["A", "B"]) -> Catenaries:
    """Taut catenaries through both ends with tension ``T`` (N) at ``end``.

    Parameters
    ----------
    x, z : ndarray
        Horizontal span (m) and height of the drawing point over the attachment (m).
    T : ndarray
        Tension magnitude (N) at the platform end ``"A"`` or the drawing point ``"B"``.
    w, EA : float
        Weight per length (N/m) and axial stiffness (N).
    end : {"A", "B"}

    Returns
    -------
    Catenaries
        Unpacks as ``H, V_A, V_B, L0, iterations, converged``
        (:func:`catenary.solve_length`).
    """
    # The size rule of plain calls: few cables take the numpy reference, compiling nothing.
    res = solve_length(x, z, T, w, EA, end=end, compiled=compiled_for(np.size(x)))
    return Catenaries(res.H, res.V_A, res.V_B, res.L0, res.iterations, res.converged)


def force_slope(planes: CablePlanes, H: FloatArray, V_A: FloatArray, V_B: FloatArray,
                L0: FloatArray, w: float, EA: float) -> FloatArray:
    """Derivative of each cable's platform force with its platform-end tension, (k, m, 3).

    At fixed end points the catenary is a one-parameter family in ``L0``: the spans
    stay put if ``(dH, dV_B) = -F^-1 (dx/dL0, dz/dL0) dL0`` (``F`` the flexibility).
    With ``q = F^-1 (dx/dL0, dz/dL0)`` and ``D = -dT_A/dL0 = (H q_x + V_A (q_z + w))
    / T_A``, ``dH/dT_A = q_x / D`` and ``dV_A/dT_A = (q_z + w) / D``. A vertical cable
    (``H = 0``) has ``f = V_A e_z`` and slope ``sign(V_A) e_z``.

    Parameters
    ----------
    planes : CablePlanes
        Planes of the k poses.
    H, V_A, V_B, L0 : ndarray, shape (k, m)
        The current catenaries (N, m).
    w, EA : float
        Weight per length (N/m) and axial stiffness (N).
    """
    with np.errstate(all="ignore"):
        F = flexibility(H, V_B, L0, w, EA)
        lx, lz = length_derivative(H, V_B, L0, w, EA)
        a, bb, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 1]
        det = a * d - bb * bb
        qx = (d * lx - bb * lz) / det
        qz = (a * lz - bb * lx) / det
        T_A = np.hypot(H, V_A)
        D = (H * qx + V_A * (qz + w)) / T_A
        dH = qx / D
        dV = (qz + w) / D
    vertical = planes.x == 0
    dH = np.where(vertical, 0.0, dH)
    dV = np.where(vertical, np.sign(V_A), dV)
    # Cables whose sag is below the rounding of their length (see solve_length): the end
    # tangent leaves the chord by delta = w x / (2 T), so f = T (cos, sin)(theta - delta) and
    # f' = (cos, sin)(phi) + delta (-sin, cos)(phi) with phi = theta - delta.
    with np.errstate(all="ignore"):
        light = (w * planes.chord < 1e-7 * T_A) & ~vertical
        phi = np.arctan2(V_A, H)
        delta = w * planes.x / (2.0 * T_A)
    dH = np.where(light, np.cos(phi) - delta * np.sin(phi), dH)
    dV = np.where(light, np.sin(phi) + delta * np.cos(phi), dV)
    return dH[..., None] * planes.e_h + dV[..., None] * E_Z

