"""Benchmark of the catenary solvers (run as a script; prints a table).

    python benchmarks/bench_catenary.py [n_cables]

* ``solve_length`` vectorised over 10^6 cables of the reference robot's
  workspace (end-B tensions 2537..15000 N, 20 mm steel cable, inextensible).
* ``solve_forces`` on the same cables, against MoorPy's ``catenary()`` called
  per cable, and success rates of both on the test sweep.
"""

from __future__ import annotations

import contextlib
import io
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# Run as a script from a checkout: import this checkout's packages.
sys.path.insert(0, str(ROOT))
import catenary as cat  # noqa: E402

TOWER = np.array([46.55, 31.1, 7.6])
W_STEEL = 7860 * np.pi / 4 * 0.02**2 * 9.81


def workspace(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random poses of the reference robot -> (x, z, T_B) of its 4 cables, flattened."""
    rng = np.random.default_rng(seed)
    m = -(-n // 4)
    p = np.column_stack(
        [rng.uniform(-40.45, 40.45, m), rng.uniform(-25, 25, m), rng.uniform(0, 5, m)]
    )
    sx = np.array([-1, -1, 1, 1])
    sy = np.array([-1, 1, 1, -1])
    dx = sx * TOWER[0] - p[:, :1]
    dy = sy * TOWER[1] - p[:, 1:2]
    x = np.hypot(dx, dy).ravel()[:n]
    z = np.repeat(TOWER[2] - p[:, 2], 4)[:n]
    T = rng.uniform(2537.0, 15000.0, x.size)
    return x, z, T


def best_time(f, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def moorpy_call(x: float, z: float, L0: float, w: float, EA: float):
    from moorpy.Catenary import catenary

    EA = 1e25 if np.isinf(EA) else EA
    hook = sys.breakpointhook
    sys.breakpointhook = lambda *a, **k: None
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            return catenary(x, z, L0, EA, w, CB=-1e3 * (L0 + abs(z)))
    finally:
        sys.breakpointhook = hook


def moorpy_ok(out, args) -> bool:
    """MoorPy result is a catenary solution (not a fallback, residual <= 1e-6)."""
    fAH, _fAV, _fBH, fBV, info = out
    if info.get("ProfileType", 1) in (-1, -2):
        return False
    xm, zm = cat.spans(fAH, -fBV, *args[2:])
    return max(abs(xm - args[0]), abs(zm - args[1])) <= 1e-6 * (args[2] + np.hypot(*args[:2]))


def main(n: int = 1_000_000) -> None:
    rows: list[tuple[str, str]] = []
    x, z, T = workspace(n)
    r = cat.solve_length(x, z, T, W_STEEL, end="B")
    t = best_time(lambda: cat.solve_length(x, z, T, W_STEEL, end="B"))
    it = r.iterations
    rows += [
        ("solve_length, thesis workspace, cables", f"{x.size:,}"),
        ("  ns per cable (vectorised)", f"{1e9 * t / x.size:.0f}"),
        (
            "  Newton iterations median / p99 / max",
            f"{np.median(it):.0f} / {np.percentile(it, 99):.0f} / {it.max()}",
        ),
        ("  converged", f"{r.converged.mean():.4%}"),
        (
            "  L0 - chord (mm) min / max",
            f"{1e3 * np.nanmin(r.L0 - np.hypot(x, z)):.2f} / "
            f"{1e3 * np.nanmax(r.L0 - np.hypot(x, z)):.1f}",
        ),
    ]
    L0 = r.L0
    f = cat.solve_forces(x, z, L0, W_STEEL)
    t = best_time(lambda: cat.solve_forces(x, z, L0, W_STEEL))
    ns_ours = 1e9 * t / x.size
    it = f.iterations
    rows += [
        ("solve_forces, same cables", f"{x.size:,}"),
        ("  ns per cable (vectorised)", f"{ns_ours:.0f}"),
        (
            "  Newton iterations median / p99 / max",
            f"{np.median(it):.0f} / {np.percentile(it, 99):.0f} / {it.max()}",
        ),
        ("  max |T_B - T| / T", f"{np.nanmax(np.abs(f.T_B / T - 1)):.1e}"),
    ]
    try:
        import moorpy  # noqa: F401
    except ImportError:
        rows.append(("MoorPy", "not installed (pip install moorpy)"))
    else:
        k = min(3000, len(x))  # MoorPy is called one cable at a time
        args = [(x[i], z[i], L0[i], W_STEEL, np.inf) for i in range(k)]
        t0 = time.perf_counter()
        for a in args:
            moorpy_call(*a)
        ns_mp = 1e9 * (time.perf_counter() - t0) / k
        rows += [
            (f"MoorPy catenary(), {k} calls", f"{ns_mp:,.0f} ns per cable"),
            ("  ratio MoorPy / ours", f"{ns_mp / ns_ours:,.0f}x"),
        ]
        from benchmarks.cable_cases import sweep

        s = sweep()
        ours = cat.solve_forces(s["x"], s["z"], s["L0"], s["w"], s["EA"])
        ok_mp = 0
        for i in range(s["x"].size):
            params = tuple(float(s[key][i]) for key in ("x", "z", "L0", "w", "EA"))
            try:
                ok_mp += moorpy_ok(moorpy_call(*params), params)
            except Exception:  # MoorPy raises on failure
                pass
        rows += [
            (f"sweep success, {s['x'].size} forward problems", ""),
            ("  ours (converged, residual <= 1e-12)", f"{ours.converged.mean():.2%}"),
            ("  MoorPy (catenary solution, residual <= 1e-6)", f"{ok_mp / s['x'].size:.2%}"),
        ]
    width = max(len(a) for a, _ in rows)
    print(f"{'quantity':<{width}}  value")
    print(f"{'-' * width}  {'-' * 24}")
    for quantity, value in rows:
        print(f"{quantity:<{width}}  {value}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
