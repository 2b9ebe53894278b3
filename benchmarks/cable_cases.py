"""Single-cable cases for the catenary benchmark and tests: a sweep of spans, slopes,
weights and stiffnesses (every combination of the grids below), and random inverse
problems."""

from __future__ import annotations

import numpy as np

RATIOS_ELASTIC_ONLY = (1 - 1e-3, 1 - 1e-5, 1.0)
RATIOS = (1 + 1e-9, 1 + 1e-6, 1 + 1e-3, 1.01, 1.1, 1.5, 2.0, 3.0)
ANGLES_DEG = (-90.0, -60.0, -20.0, 0.0, 20.0, 60.0, 89.9, 90.0)
CHORDS = (0.1, 10.0, 1000.0)
WEIGHTS = (1e-6, 1e-3, 1.0, 1e3)
STIFFNESSES = (1e3, 1e6, 1e9, np.inf)


def sweep() -> dict[str, np.ndarray]:
    """Forward problems (x, z, L0, w, EA) over the whole grid, as flat arrays.

    L0/chord below 1 only with finite EA (an inextensible cable cannot be
    shorter than its chord).
    """
    grid = np.array(
        np.meshgrid(
            np.array(RATIOS_ELASTIC_ONLY + RATIOS),
            np.radians(ANGLES_DEG),
            np.array(CHORDS),
            np.array(WEIGHTS),
            np.array(STIFFNESSES),
            indexing="ij",
        )
    ).reshape(5, -1)
    ratio, ang, c, w, EA = grid
    keep = np.isfinite(EA) | (ratio > 1.0)
    ratio, ang, c, w, EA = ratio[keep], ang[keep], c[keep], w[keep], EA[keep]
    x = np.where(ang == np.pi / 2, 0.0, c * np.cos(ang))
    x = np.where(ang == -np.pi / 2, 0.0, x)
    z = c * np.sin(ang)
    return {"x": x, "z": z, "L0": ratio * np.hypot(x, z), "w": w, "EA": EA}


def random_cables(seed: int, count: int = 200) -> tuple[np.ndarray, ...]:
    """Inverse problems ``(x, z, T, w, EA)`` (m, m, N, N/m, N), ``count`` of each, from
    taut to heavily sagging, steep, downhill, weightless, inextensible; some tensions
    too small to hold the cable, and the first five cables vertical (``x = 0``)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.1, 80.0, count)
    z = rng.uniform(-40.0, 40.0, count)
    w = rng.choice([0.0, 0.05, 1.0, 20.0], count) * rng.uniform(0.5, 2.0, count)
    T = 10.0 ** rng.uniform(0.0, 5.0, count)
    EA = rng.choice([np.inf, 1e5, 1e8], count)
    x[:5] = 0.0
    return x, z, T, w, EA
