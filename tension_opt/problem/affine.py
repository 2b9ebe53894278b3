"""Tensions in equilibrium as an affine set ``T = T0 + Z z``, for a batch of poses.

Every tension distribution ``A T = b`` (``A`` of shape (N, n, m)) is a particular
solution ``T0`` plus a combination of null-space vectors ``Z``: :func:`pinv_and_null`
(full row rank) and :func:`solution_set` (any rank, with the consistency of ``b``) give
the minimum-norm ``T0`` and an orthonormal null-space basis, for the closed-form
backend (:mod:`tension_opt.backends.closed_form`) and the capacity margin
(:mod:`tension_opt.workspace.margin`). The minimisation over the set (bounds as
half-spaces, the minimum of a maximum of lines) is :mod:`tension_opt.backends.lowdim`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt.problem.form import safe_norm

__all__ = [
    "CONSISTENCY_TOL",
    "RANK_TOL",
    "SolutionSet",
    "pinv_and_null",
    "solution_set",
]

#: Singular values below this fraction of the largest count as zero (rank of ``A``).
RANK_TOL = 1e-10
#: ``b`` is outside the range of a singular ``A`` when its residual exceeds this
#: fraction of ``||b||``.
CONSISTENCY_TOL = 1e-9


def _particular(U: NDArray, inv_s: NDArray, Vt: NDArray, b: NDArray) -> tuple[NDArray, NDArray]:
    """``T0 = V diag(inv_s) U^T b`` (N, m) from an SVD, and ``U^T b`` (N, n)."""
    Utb = np.einsum("nik,ni->nk", U, b)
    r = inv_s.shape[1]
    # Two operands: several times faster than one three-operand einsum, same rounding.
    return np.einsum("nki,nk->ni", Vt[:, :r, :] * inv_s[..., None], Utb[:, :r]), Utb


def _det3(a: NDArray, b: NDArray, c: NDArray) -> NDArray:
    """Determinant of the 3 x 3 matrices with columns a, b, c (each (N, 3))."""
    return (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
            - a[:, 1] * (b[:, 0] * c[:, 2] - b[:, 2] * c[:, 0])
            + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))


def pinv_and_null(A: NDArray, b: NDArray, svd: tuple[NDArray, NDArray, NDArray] | None = None
                  ) -> tuple[NDArray, NDArray]:
    """Minimum-norm solution of ``A T = b`` and an orthonormal null-space basis.

    For the common 3 x 4 case the null vector comes from the generalised cross
    product, so no matrix factorisation is needed.

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
        Full row rank, ``m > n``.
    b : ndarray, shape (N, n)
    svd : (U, s, Vt), optional
        ``numpy.linalg.svd(A, full_matrices=True)`` when the caller already has it
        (shapes other than 3 x 4 use it).

    Returns
    -------
    T_pinv : ndarray, shape (N, m)
    Z : ndarray, shape (N, m, m - n)
    """
    _N, n, m = A.shape
    if (n, m) == (3, 4):
        u = [A[:, :, i] for i in range(4)]
        null = np.stack([_det3(u[1], u[2], u[3]), -_det3(u[0], u[2], u[3]),
                         _det3(u[0], u[1], u[3]), -_det3(u[0], u[1], u[2])], axis=1)
        null /= np.linalg.norm(null, axis=1, keepdims=True)
        # A particular solution through the 3 x 3 normal matrix, then projected off the null
        # vector: the projection removes the rounding of the normal-equation solve.
        M = np.einsum("nik,njk->nij", A, A)
        y = np.linalg.solve(M, b[..., None])[..., 0]
        T = np.einsum("nik,ni->nk", A, y)
        T -= np.einsum("nk,nk->n", T, null)[:, None] * null
        return T, null[..., None]
    U, s, Vt = svd if svd is not None else np.linalg.svd(A, full_matrices=True)
    T, _ = _particular(U, 1.0 / s, Vt, b)
    return T, np.swapaxes(Vt[:, n:, :], 1, 2)


@dataclass(frozen=True)
class SolutionSet:
    """The solutions ``T = particular + Z z`` of ``A T = b`` for a batch of poses.

    Attributes
    ----------
    particular : ndarray, shape (N, m)
        Minimum-norm (least-squares) solution ``T0`` (N).
    vt : ndarray, shape (N, m, m)
        Right singular vectors of ``A``; the last ``m - rank`` rows span the null space.
    rank : ndarray of int, shape (N,)
        Numerical rank of ``A`` (singular values above ``RANK_TOL`` of the largest).
    consistent : ndarray of bool, shape (N,)
        ``b`` lies in the range of ``A`` (else no tensions are in equilibrium).
    """

    particular: NDArray
    vt: NDArray
    rank: NDArray
    consistent: NDArray

    @property
    def dimension(self) -> NDArray:
        """Null-space dimension ``m - rank`` per pose, shape (N,)."""
        return self.vt.shape[1] - self.rank

    def basis(self, index: NDArray, d: int) -> NDArray:
        """Orthonormal null-space basis ``Z`` of the poses ``index`` whose null space has
        dimension ``d``, shape (len(index), m, d)."""
        m = self.vt.shape[1]
        return np.swapaxes(self.vt[index, m - d:, :], 1, 2)


def solution_set(A: NDArray, b: NDArray) -> SolutionSet:
    """Solutions of ``A T = b`` for structure matrices of any rank (one batched SVD).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)

    Returns
    -------
    SolutionSet
    """
    U, S, Vt = np.linalg.svd(A, full_matrices=True)
    rank = (S > RANK_TOL * np.maximum(S[:, :1], 1e-300)).sum(axis=1)
    keep = np.arange(S.shape[1])[None, :] < rank[:, None]
    with np.errstate(divide="ignore"):
        inv_s = np.where(keep, 1.0 / S, 0.0)
    T0, Utb = _particular(U, inv_s, Vt, b)
    outside = np.where(np.arange(Utb.shape[1])[None, :] < rank[:, None], 0.0, Utb)
    consistent = safe_norm(outside, axis=1) <= CONSISTENCY_TOL * safe_norm(b, axis=1)
    return SolutionSet(T0, Vt, rank, consistent)


