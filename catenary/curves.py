"""Sagging cables as curves in space: points, tangents and the bounds of the certified
distances of :mod:`catenary.interference` (see its module notes for the formulas)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .elastic import axial_compliance, evaluate
from .geometry import E_Z

__all__ = ["CatenaryCurves"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CatenaryCurves:
    """Elastic catenaries in space, batch shape ``S`` (see the module notes).

    Attributes
    ----------
    origin : ndarray, shape S + (3,)
        Attachment point ``A`` (m), base frame.
    e_h : ndarray, shape S + (3,)
        Horizontal unit vector of the cable's plane, towards the drawing point.
    H, V_A, L0 : ndarray, shape S
        Horizontal tension (N), vertical force at ``A`` (N, upward along the cable) and
        unstretched length (m).
    w : float
        Weight per length (N/m).
    EA : float
        Axial stiffness (N), ``inf`` for an inextensible cable.
    closure : ndarray, shape S + (3,)
        Drawing point minus the curve's end ``r(L0)`` without closure (m), spread along
        the cable in proportion to ``s``.
    """

    origin: FloatArray
    e_h: FloatArray
    H: FloatArray
    V_A: FloatArray
    L0: FloatArray
    w: float
    EA: float
    closure: FloatArray

    def _spans(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        H, V = self.H[..., None], self.V_A[..., None] + self.w * s
        with np.errstate(all="ignore"):
            x, z, *_ = evaluate(
                H,
                V,
                np.where(s > 0, s, 1.0),
                self.w,
                axial_compliance(np.asarray(self.EA, dtype=float)),
                jacobian=False,
            )
        return np.where(s > 0, x, 0.0), np.where(s > 0, z, 0.0)

    def points(self, s: ArrayLike, closed: bool = True) -> FloatArray:
        """Points at arc parameters ``s`` (m), shape S + (k,) -> S + (k, 3) (m)."""
        s = np.asarray(s, dtype=float)
        x, z = self._spans(s)
        p = self.origin[..., None, :] + x[..., None] * self.e_h[..., None, :] + z[..., None] * E_Z
        if closed:
            with np.errstate(all="ignore"):
                share = np.where(self.L0[..., None] > 0, s / self.L0[..., None], 0.0)
            p = p + share[..., None] * self.closure[..., None, :]
        return np.asarray(p)

    def tangents(self, s: ArrayLike) -> FloatArray:
        """Derivatives ``dr/ds`` at arc parameters ``s``, shape S + (k,) -> S + (k, 3)."""
        s = np.asarray(s, dtype=float)
        H, V = self.H[..., None], self.V_A[..., None] + self.w * s
        T = np.hypot(H, V)
        with np.errstate(all="ignore"):
            stretch = 1.0 + T / self.EA
            ch = np.where(T > 0, stretch * H / T, 0.0)
            cv = np.where(T > 0, stretch * V / T, 1.0)
            lin = np.where(self.L0[..., None] > 0, 1.0 / self.L0[..., None], 0.0)
        return np.asarray(
            ch[..., None] * self.e_h[..., None, :]
            + cv[..., None] * E_Z
            + lin[..., None] * self.closure[..., None, :]
        )

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        """Lipschitz constant ``lam`` (largest ``|r'|``) and curvature bound ``K``
        (largest ``|r''|``, 1/m), shape S each."""
        V_B = self.V_A + self.w * self.L0
        T_max = np.maximum(np.hypot(self.H, self.V_A), np.hypot(self.H, V_B))
        crosses = (self.V_A < 0) & (V_B > 0)
        V_min = np.where(crosses, 0.0, np.minimum(np.abs(self.V_A), np.abs(V_B)))
        with np.errstate(all="ignore"):
            stretch = 1.0 + T_max / self.EA
            lam = stretch + np.where(
                self.L0 > 0, np.linalg.norm(self.closure, axis=-1) / self.L0, 0.0
            )
            T2 = self.H**2 + V_min**2
            bend = np.where(self.H > 0, self.w * self.H / T2, np.where(V_min > 0, 0.0, np.inf))
            K = self.w / self.EA + stretch * np.where(self.w > 0, bend, 0.0)
        return lam, K

    def take(self, index: Any) -> CatenaryCurves:
        """The curves at ``index`` of the batch."""
        return CatenaryCurves(
            self.origin[index],
            self.e_h[index],
            self.H[index],
            self.V_A[index],
            self.L0[index],
            self.w,
            self.EA,
            self.closure[index],
        )
