"""Comparison with MoorPy's single-line catenary on the same forward problems."""

from __future__ import annotations

import contextlib
import io
import sys

import numpy as np
import pytest

import catenary as cat
from benchmarks.cable_cases import sweep

moorpy_catenary = pytest.importorskip("moorpy.Catenary").catenary


# MoorPy needs a finite EA; this is inextensible for every case here.
EA_RIGID = 1e25


def moorpy_forces(x: float, z: float, L0: float, w: float, EA: float):
    """(H, V_A, V_B, profile_type) from MoorPy, in this package's conventions.

    MoorPy returns the forces the line exerts on its ends, positive up:
    (fAH, fAV, fBH, fBV) = (H, V_A, -H, -V_B). A seabed far below (CB < 0)
    keeps it from seabed contact. Its ``breakpoint()`` calls are disabled.
    """
    EA = EA_RIGID if np.isinf(EA) else EA
    hook = sys.breakpointhook
    sys.breakpointhook = lambda *a, **k: None
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            fAH, fAV, _fBH, fBV, info = moorpy_catenary(x, z, L0, EA, w, CB=-1e3 * (L0 + abs(z)))
    finally:
        sys.breakpointhook = hook
    return fAH, fAV, -fBV, info.get("ProfileType")


def test_moorpy_sign_conventions_on_reference_case() -> None:
    # MoorPy test-suite case, reference values in 50-digit arithmetic.
    H, V_A, V_B, _ = moorpy_forces(400, 200, 500, 200, 7.51e12)
    r = cat.solve_forces(400, 200, 500, 200, 7.51e12)
    assert H == pytest.approx(r.H, rel=1e-6)
    assert V_A == pytest.approx(r.V_A, rel=1e-6)
    assert V_B == pytest.approx(r.V_B, rel=1e-6)
    assert r.V_A < 0


def run_comparison(max_cases: int | None = None, seed: int = 0) -> dict[str, object]:
    """Solve the sweep's non-vertical forward problems with both solvers."""
    s = sweep()
    keep = (s["x"] > 0) & (s["z"] != 0)
    idx = np.flatnonzero(keep)
    if max_cases is not None and idx.size > max_cases:
        idx = np.random.default_rng(seed).choice(idx, max_cases, replace=False)
    ours = cat.solve_forces(*(s[k][idx] for k in ("x", "z", "L0", "w", "EA")))
    out = {"n": idx.size, "ours_ok": int(ours.converged.sum()), "errors": 0, "fallback": 0}
    rel = np.full(idx.size, np.nan)
    res = np.full(idx.size, np.nan)
    bound = np.full(idx.size, np.nan)
    for j, i in enumerate(idx):
        args = (s["x"][i], s["z"][i], s["L0"][i], s["w"][i], s["EA"][i])
        try:
            H, V_A, V_B, ptype = moorpy_forces(*args)
        except Exception:  # MoorPy raises its own errors on failure
            out["errors"] += 1
            continue
        if ptype is not None and ptype < 0:
            # MoorPy's last-resort approximations (straight massless spring,
            # bilinear): not a catenary solution.
            out["fallback"] += 1
            continue
        # Does MoorPy's answer satisfy the span equations?
        xm, zm = cat.spans(H, V_B, args[2], args[3], args[4])
        res[j] = max(abs(xm - args[0]), abs(zm - args[1])) / (args[2] + np.hypot(*args[:2]))
        scale = np.hypot(ours.H[j], ours.V_B[j]) + s["w"][i] * s["L0"][i]
        # Force error that MoorPy's residual alone implies (stiffness x residual).
        K = cat.stiffness(ours.H[j], ours.V_B[j], *args[2:])
        bound[j] = np.abs(K).max() * max(abs(xm - args[0]), abs(zm - args[1])) / scale
        rel[j] = max(abs(H - ours.H[j]), abs(V_A - ours.V_A[j]), abs(V_B - ours.V_B[j])) / scale
    out["rel"] = rel
    out["residual"] = res
    out["bound"] = bound
    # MoorPy "converged" to something that is not a solution, silently.
    out["wrong"] = int(np.sum(res > 1e-6))
    return out


def test_agreement_with_moorpy_where_it_converges() -> None:
    res = run_comparison(max_cases=600)
    rel, resid = res["rel"], res["residual"]
    returned = np.isfinite(rel)
    # MoorPy's answer is a solution when it satisfies the span equations to
    # its own tolerance (1e-6 m absolute, so 1e-6 relative to be fair).
    good = returned & (resid <= 1e-6)
    assert res["ours_ok"] == res["n"]  # we solve every case
    assert good.sum() >= 0.5 * res["n"]
    # Where MoorPy's answer is a solution, it is ours: the forces agree to the
    # accuracy its residual allows (ill-conditioned near-taut cables aside).
    assert np.median(rel[good]) < 1e-8
    explained = rel[good] <= 10 * res["bound"][good] + 1e-8
    assert np.mean(explained) > 0.98, np.sort(rel[good][~explained])
    print(
        f"\nMoorPy on {res['n']} cases: exceptions {res['errors']}, last-resort "
        f"fallbacks {res['fallback']}, wrong answers returned silently {res['wrong']}, "
        f"solutions {good.sum()}"
    )
