"""Platform stiffness of one pose and of batches, compiled (numba): the kernel twins
of :func:`catenary.robot_stiffness.stiffness_analysis`.

The numpy reference is :mod:`catenary.robot_stiffness` (its module docstring derives
the formulas): each cable's 3x3 stiffness at its platform end, straight
(``(EA / L) u u^T + (T / L) I``) or a sagging elastic catenary (``E K2 E^T + (H / x)
(I_xy - e_h e_h^T)``, ``K2`` the inverse of the span flexibility of
:func:`catenary.solve.kernels.spans_one`), summed into the 6x6 spatial stiffness with
the moment arms and the load term, whose rows and columns the robot kind keeps. A
pose is computed here in one pass over its cables, in scalars, with the cable forces,
the tensions, the unstretched lengths and the equilibrium residual on the way.

Where the kernel cannot answer as the reference would (a cable on its drawing point or
a vertical one, a catenary the compiled length solve leaves to the numpy path, a
degenerate limit of the span formulas) the pose gets :data:`FALLBACK` and the caller
computes it by the numpy reference; a row of given tensions with NaN gets
:data:`NOT_RUN` (NaN results; straight cables keep those of the cables that have
a tension), as in the reference.

The robot's constants travel as one float array (:func:`catenary.stiffness_compiled.pack`);
the models are
:data:`STRAIGHT` (given tensions), :data:`COUPLED_B` / :data:`COUPLED_A` (catenaries
carrying given tensions at the drawing point / at the platform) and
:data:`COUPLED_STATE` (catenaries given by their forces and lengths, as the coupled
inverse kinematics returns them).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from tension_opt.kernels.geometry import arm_and_vector, platform_position, rotation

from .solve.kernels import CONVERGED as CATENARY_OK
from .solve.kernels import solve_length_one, spans_one

__all__ = [
    "BLOCK",
    "COUPLED_A",
    "COUPLED_B",
    "COUPLED_STATE",
    "FALLBACK",
    "HEADER",
    "INVALID",
    "NEAR_VERTICAL",
    "NOT_RUN",
    "OK",
    "STRAIGHT",
    "stiffness_batch",
    "stiffness_parallel",
    "stiffness_pose",
]

#: Codes of a pose: computed, to be computed by the numpy reference, a row of given
#: tensions with NaN (not run), data the reference rejects (a pose or wrench not finite,
#: a given tension below 0 or infinite: the caller raises its error).
OK, FALLBACK, NOT_RUN, INVALID = 0, 1, 2, 3
#: Cable models of the kernels.
STRAIGHT, COUPLED_B, COUPLED_A, COUPLED_STATE = 0, 1, 2, 3
#: Floats before the selection, anchors and attachments in the packed constants: kind, m, n,
#: weight (N), zero length (m), w (N/m), 1/EA (1/N), EA (N), rotates, com (3).
HEADER = 12
#: :data:`catenary.robot_stiffness.NEAR_VERTICAL` (the vertical limit of ``H / x``).
NEAR_VERTICAL = 1e-8
#: Poses per block of the parallel kernel (each block has its own scratch).
BLOCK = 256
#: Settings of the taut catenaries of given tensions (those of
#: :func:`catenary.solve_length`, which the reference calls).
_CAT_RTOL, _CAT_ITER = 1e-9, 30


@njit(cache=True, error_model="numpy", inline="always")
def add_cable(
    K6: NDArray,
    rotates: bool,
    a00: float,
    a01: float,
    a02: float,
    a11: float,
    a12: float,
    a22: float,
    r0: float,
    r1: float,
    r2: float,
    f0: float,
    f1: float,
    f2: float,
) -> None:
    """Add one cable to the spatial stiffness ``K6`` (6, 6): ``J^T K_i J`` with ``J =
    [I, -[r]x]`` and, where the platform ``rotates``, the load term ``-[f]x [r]x``;
    ``K_i`` symmetric, given by its upper triangle ``a``, ``r`` the arm (m), ``f`` the
    cable force (N)."""
    K6[0, 0] += a00
    K6[0, 1] += a01
    K6[0, 2] += a02
    K6[1, 0] += a01
    K6[1, 1] += a11
    K6[1, 2] += a12
    K6[2, 0] += a02
    K6[2, 1] += a12
    K6[2, 2] += a22
    if not rotates:
        return
    # B = K_i [r]x, row by row.
    b00, b01, b02 = a01 * r2 - a02 * r1, a02 * r0 - a00 * r2, a00 * r1 - a01 * r0
    b10, b11, b12 = a11 * r2 - a12 * r1, a12 * r0 - a01 * r2, a01 * r1 - a11 * r0
    b20, b21, b22 = a12 * r2 - a22 * r1, a22 * r0 - a02 * r2, a02 * r1 - a12 * r0
    # -B above, -B^T below ([r]x K_i = -(K_i [r]x)^T).
    K6[0, 3] -= b00
    K6[0, 4] -= b01
    K6[0, 5] -= b02
    K6[1, 3] -= b10
    K6[1, 4] -= b11
    K6[1, 5] -= b12
    K6[2, 3] -= b20
    K6[2, 4] -= b21
    K6[2, 5] -= b22
    K6[3, 0] -= b00
    K6[4, 0] -= b01
    K6[5, 0] -= b02
    K6[3, 1] -= b10
    K6[4, 1] -= b11
    K6[5, 1] -= b12
    K6[3, 2] -= b20
    K6[4, 2] -= b21
    K6[5, 2] -= b22
    # -[r]x B - [f]x [r]x, with [f]x [r]x = r f^T - (f . r) I.
    fr = f0 * r0 + f1 * r1 + f2 * r2
    K6[3, 3] -= (r1 * b20 - r2 * b10) + (r0 * f0 - fr)
    K6[3, 4] -= (r1 * b21 - r2 * b11) + r0 * f1
    K6[3, 5] -= (r1 * b22 - r2 * b12) + r0 * f2
    K6[4, 3] -= (r2 * b00 - r0 * b20) + r1 * f0
    K6[4, 4] -= (r2 * b01 - r0 * b21) + (r1 * f1 - fr)
    K6[4, 5] -= (r2 * b02 - r0 * b22) + r1 * f2
    K6[5, 3] -= (r0 * b10 - r1 * b00) + r2 * f0
    K6[5, 4] -= (r0 * b11 - r1 * b01) + r2 * f1
    K6[5, 5] -= (r0 * b12 - r1 * b02) + (r2 * f2 - fr)


@njit(cache=True, error_model="numpy", inline="always")
def catenary_terms(
    H: float, V_B: float, L0: float, w: float, inv_EA: float
) -> tuple[float, float, float, float, bool]:
    """In-plane stiffness ``K2 = d(H, V_B)/d(x, z)`` of one catenary, ``(k_xx, k_xz,
    k_zz)``, its sideways stiffness ``H / x`` (:func:`catenary.robot_stiffness.
    across_stiffness`) and whether the span formulas are regular there (else the
    numpy reference answers)."""
    x, _, f_xx, f_xz, f_zz, _, _, regular = spans_one(H, V_B, L0, w, inv_EA)
    det = f_xx * f_zz - f_xz * f_xz
    V_A = V_B - w * L0
    ends = min(abs(V_A), abs(V_B))
    limit = (H <= NEAR_VERTICAL * ends and V_A * V_B >= 0.0) or H == 0.0
    turn = 1.0 / f_xx if limit else H / x
    return f_zz / det, -f_xz / det, f_xx / det, turn, regular


@njit(cache=True, error_model="numpy", inline="always")
def _row(i: int, W0: float, W1: float, W2: float, W3: float, W4: float, W5: float) -> float:
    """Component ``i`` of the spatial wrench ``(W0, ..., W5)``."""
    if i < 3:
        return W0 if i == 0 else (W1 if i == 1 else W2)
    return W3 if i == 3 else (W4 if i == 4 else W5)


@njit(cache=True, error_model="numpy")
def stiffness_pose(
    data: NDArray,
    model: int,
    pose: NDArray,
    wrench: NDArray,
    given: NDArray,
    H_in: NDArray,
    F_in: NDArray,
    L_in: NDArray,
    K: NDArray,
    Kc: NDArray,
    forces: NDArray,
    tensions: NDArray,
    lengths: NDArray,
    scratch: NDArray,
) -> tuple[int, float]:
    """Platform stiffness of one pose (hot numerical kernel: allocates nothing).

    Parameters
    ----------
    data : ndarray
        The robot's constants (:func:`catenary.stiffness_compiled.pack`).
    model : int
        :data:`STRAIGHT`, :data:`COUPLED_B`, :data:`COUPLED_A` or
        :data:`COUPLED_STATE`.
    pose, wrench : ndarray, shape (n,)
        Pose (m, rad) and external wrench besides gravity (N, N m).
    given : ndarray, shape (m,)
        Tensions (N) of the straight and the given-tension catenary models.
    H_in, F_in, L_in : ndarray, shapes (m,), (m, 3) and (m,)
        For :data:`COUPLED_STATE`: each catenary's horizontal tension (N), force on the
        platform (N; its vertical component ``V_A`` is read) and unstretched length (m),
        as :class:`catenary.InverseKinematicsResult` holds them (``V_B = V_A + w L0``).
    K : ndarray, shape (n, n)
        Written: ``K = -dW/dq`` (N/m, N m/rad).
    Kc, forces : ndarray, shapes (m, 3, 3) and (m, 3)
        Written: each cable's stiffness (N/m) and force on the platform (N).
    tensions, lengths : ndarray, shape (m,)
        Written: tension at the drawing point (N) and unstretched length (m).
    scratch : ndarray, shape (41,)
        Scratch: the spatial stiffness (6, 6) and a catenary (5,).

    Returns
    -------
    (code, residual)
        :data:`OK`, :data:`FALLBACK`, :data:`NOT_RUN` or :data:`INVALID`, and the norm of
        the wrench left on the platform (N, N m; NaN unless OK).
    """
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    K6, cat = scratch[:36].reshape((6, 6)), scratch[36:41]
    weight, zero_length, w, inv_EA, EA = data[3], data[4], data[5], data[6], data[7]
    rotates = data[8] != 0.0
    sel = data[HEADER : HEADER + n]
    anchors = data[HEADER + n : HEADER + n + 3 * m].reshape((m, 3))
    attachments = data[HEADER + n + 3 * m : HEADER + n + 6 * m].reshape((m, 3))
    for a in range(n):
        if not (math.isfinite(pose[a]) and math.isfinite(wrench[a])):
            return INVALID, np.nan
    if model != COUPLED_STATE:
        for i in range(m):
            if given[i] < 0.0 or given[i] == np.inf:
                return INVALID, np.nan
    missing = False
    if model != COUPLED_STATE:
        for i in range(m):
            missing = missing or not given[i] == given[i]
        if missing and model != STRAIGHT:
            return NOT_RUN, np.nan  # no catenaries (straight cables each have theirs)
    R = rotation(kind, pose)
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = R
    position = platform_position(kind, pose)
    K6[:, :] = 0.0
    W0 = W1 = W2 = W3 = W4 = W5 = 0.0
    for i in range(m):
        r0, r1, r2, v0, v1, v2 = arm_and_vector(R, position, anchors, attachments, i)
        if model == STRAIGHT:
            L = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
            if not (L > zero_length and L < np.inf):
                return FALLBACK, np.nan
            u0, u1, u2 = v0 / L, v1 / L, v2 / L
            T = given[i]
            s, t = EA / L, T / L
            # (T / L) I off the diagonal as the reference adds it: 0 (NaN without T).
            o = t * 0.0
            a00, a01, a02 = s * (u0 * u0) + t, s * (u0 * u1) + o, s * (u0 * u2) + o
            a11, a12, a22 = s * (u1 * u1) + t, s * (u1 * u2) + o, s * (u2 * u2) + t
            f0, f1, f2 = T * u0, T * u1, T * u2
            tensions[i], lengths[i] = T, L * EA / (EA + T)
        else:
            x = math.hypot(v0, v1)
            if not (x > 0.0 and x < np.inf):
                return FALLBACK, np.nan  # a vertical cable: the reference's limit
            if model == COUPLED_STATE:
                H, V_A, L0 = H_in[i], F_in[i, 2], L_in[i]
                V_B = V_A + w * L0
                if not (H == H and V_B == V_B):
                    return NOT_RUN, np.nan
            else:
                if (
                    solve_length_one(
                        model == COUPLED_B, x, v2, given[i], w, inv_EA, _CAT_RTOL, _CAT_ITER, cat
                    )
                    != CATENARY_OK
                ):
                    return FALLBACK, np.nan
                H, V_B, V_A, L0 = cat[0], cat[1], cat[2], cat[3]
            k_xx, k_xz, k_zz, turn, regular = catenary_terms(H, V_B, L0, w, inv_EA)
            if not regular:
                return FALLBACK, np.nan
            c, s_ = v0 / x, v1 / x
            a00 = k_xx * (c * c) + turn * (1.0 - c * c)
            a01 = k_xx * (c * s_) + turn * (0.0 - c * s_)
            a11 = k_xx * (s_ * s_) + turn * (1.0 - s_ * s_)
            a02, a12, a22 = k_xz * c, k_xz * s_, k_zz
            f0, f1, f2 = H * c, H * s_, V_A
            tensions[i], lengths[i] = math.hypot(H, V_B), L0
        Kc[i, 0, 0], Kc[i, 0, 1], Kc[i, 0, 2] = a00, a01, a02
        Kc[i, 1, 0], Kc[i, 1, 1], Kc[i, 1, 2] = a01, a11, a12
        Kc[i, 2, 0], Kc[i, 2, 1], Kc[i, 2, 2] = a02, a12, a22
        forces[i, 0], forces[i, 1], forces[i, 2] = f0, f1, f2
        add_cable(K6, rotates, a00, a01, a02, a11, a12, a22, r0, r1, r2, f0, f1, f2)
        W0 += f0
        W1 += f1
        W2 += f2
        W3 += r1 * f2 - r2 * f1
        W4 += r2 * f0 - r0 * f2
        W5 += r0 * f1 - r1 * f0
    # Gravity (0, 0, -weight) at the centre of mass R com.
    cm0 = R00 * data[9] + R01 * data[10] + R02 * data[11]
    cm1 = R10 * data[9] + R11 * data[10] + R12 * data[11]
    cm2 = R20 * data[9] + R21 * data[10] + R22 * data[11]
    if rotates:  # -[F_g]x [c]x = -(c F_g^T - (F_g . c) I), F_g = (0, 0, -weight)
        K6[3, 5] += cm0 * weight
        K6[4, 5] += cm1 * weight
        K6[5, 5] += cm2 * weight
        K6[3, 3] -= cm2 * weight
        K6[4, 4] -= cm2 * weight
        K6[5, 5] -= cm2 * weight
    # The wrench left: the cables' and gravity's, plus the external one (kept rows).
    W2, W3, W4 = W2 - weight, W3 - cm1 * weight, W4 + cm0 * weight
    res = 0.0
    for a in range(n):
        ia = int(sel[a])
        left = _row(ia, W0, W1, W2, W3, W4, W5) + wrench[a]
        res += left * left
        for b in range(n):
            K[a, b] = K6[ia, int(sel[b])]
    return (NOT_RUN if missing else OK), math.sqrt(res)


@njit(cache=True, nogil=True, error_model="numpy")
def stiffness_batch(
    data: NDArray,
    model: int,
    poses: NDArray,
    wrenches: NDArray,
    given: NDArray,
    H_in: NDArray,
    F_in: NDArray,
    L_in: NDArray,
    K: NDArray,
    Kc: NDArray,
    forces: NDArray,
    tensions: NDArray,
    lengths: NDArray,
    residual: NDArray,
    codes: NDArray,
) -> None:
    """:func:`stiffness_pose` over poses (N, n) in the calling thread.

    ``wrenches`` (N, n) or (1, n) for one wrench on every pose; ``given`` (N, m) or
    (1, m); ``H_in`` (N, m) or (1, m), ``F_in`` (N, m, 3) or (1, m, 3), ``L_in`` (N, m)
    or (1, m); ``K`` (N, n, n), ``residual`` and ``codes`` (N,) written. ``Kc`` (N, m,
    3, 3), ``forces`` (N, m, 3), ``tensions`` and ``lengths`` (N, m) are written per
    pose, or are (1, ...) scratch for a call that wants the stiffness alone. A pose
    not OK has NaN in its rows."""
    scratch = np.empty(41)
    for k in range(poses.shape[0]):
        _pose_into(
            data,
            model,
            poses,
            wrenches,
            given,
            H_in,
            F_in,
            L_in,
            K,
            Kc,
            forces,
            tensions,
            lengths,
            residual,
            codes,
            scratch,
            k,
        )


@njit(cache=True, error_model="numpy", parallel=True)
def stiffness_parallel(
    data: NDArray,
    model: int,
    poses: NDArray,
    wrenches: NDArray,
    given: NDArray,
    H_in: NDArray,
    F_in: NDArray,
    L_in: NDArray,
    K: NDArray,
    Kc: NDArray,
    forces: NDArray,
    tensions: NDArray,
    lengths: NDArray,
    residual: NDArray,
    codes: NDArray,
) -> None:
    """:func:`stiffness_batch` on numba's threads, blocks of :data:`BLOCK` poses (the
    same arithmetic per pose; scratch of its own per block where ``Kc`` is)."""
    N = poses.shape[0]
    m = int(data[1])
    full = Kc.shape[0] == N
    for block in prange((N + BLOCK - 1) // BLOCK):
        scratch = np.empty(41)
        if full:
            sKc, sf, sT, sL = Kc, forces, tensions, lengths
        else:
            sKc, sf = np.empty((1, m, 3, 3)), np.empty((1, m, 3))
            sT, sL = np.empty((1, m)), np.empty((1, m))
        for k in range(block * BLOCK, min(N, (block + 1) * BLOCK)):
            _pose_into(
                data,
                model,
                poses,
                wrenches,
                given,
                H_in,
                F_in,
                L_in,
                K,
                sKc,
                sf,
                sT,
                sL,
                residual,
                codes,
                scratch,
                k,
            )


@njit(cache=True, error_model="numpy", inline="always")
def _pose_into(
    data: NDArray,
    model: int,
    poses: NDArray,
    wrenches: NDArray,
    given: NDArray,
    H_in: NDArray,
    F_in: NDArray,
    L_in: NDArray,
    K: NDArray,
    Kc: NDArray,
    forces: NDArray,
    tensions: NDArray,
    lengths: NDArray,
    residual: NDArray,
    codes: NDArray,
    scratch: NDArray,
    k: int,
) -> None:
    """Pose ``k`` of a batch into its rows (NaN unless OK)."""
    j = k if Kc.shape[0] == poses.shape[0] else 0
    wr = wrenches[k] if wrenches.shape[0] > 1 else wrenches[0]
    g = given[k] if given.shape[0] > 1 else given[0]
    s = k if H_in.shape[0] > 1 else 0
    code, res = stiffness_pose(
        data,
        model,
        poses[k],
        wr,
        g,
        H_in[s],
        F_in[s],
        L_in[s],
        K[k],
        Kc[j],
        forces[j],
        tensions[j],
        lengths[j],
        scratch,
    )
    codes[k], residual[k] = code, res
    if code != OK:
        K[k] = np.nan
    if code != OK and not (code == NOT_RUN and model == STRAIGHT):
        Kc[j] = np.nan
        forces[j] = np.nan
        tensions[j] = np.nan
        lengths[j] = np.nan
