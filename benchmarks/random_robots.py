"""Seeded random suspended robots and poses that include near-degenerate ones.

A wider test set than the study's robot and CoGiRo: suspended robots of 4 to 8 cables
moving a point mass (3 DOF, ``"point3"``) or a body (6 DOF, ``"spatial6"``, 7 or 8
cables), their drawing points scattered around a ring above the workspace, some laid
out as a regular polygon (whose symmetric poses have ties of the min-sum LP). Each
robot's poses mix

- poses drawn uniformly in a box and kept where tensions exist
  (:func:`tension_opt.workspace.sampling.random_feasible_poses`);
- **boundary poses**: a feasible and an infeasible draw bisected to within ``2^-steps``
  of the edge of the wrench-feasible workspace (with bounds tightened by
  :data:`EDGE_MARGIN` of the weight, so that they stay feasible at any solver's
  tolerance), where the tensions that hold the weight shrink to almost a single point
  and the optimum is nearly degenerate;
- for a symmetric robot, its centre pose (ties of the min-sum LP).

Everything is a function of the seed, so the set is the same on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot, InvalidInputError
from tension_opt.workspace.sampling import feasible_mask, random_feasible_poses

__all__ = [
    "EDGE_MARGIN",
    "ROBOT_SHAPES",
    "RandomRobot",
    "boundary_poses",
    "random_robot",
    "random_robot_poses",
    "random_robot_set",
]

#: (kind, cables) of the random robots, taken in turn: 3-DOF with 4..8 cables, 6-DOF
#: with 7 and 8.
ROBOT_SHAPES: tuple[tuple[str, int], ...] = (
    ("point3", 4), ("point3", 5), ("point3", 6), ("point3", 7), ("point3", 8),
    ("spatial6", 7), ("spatial6", 8))
#: Tries at a robot whose workspace holds poses before giving up on a seed.
MAX_TRIES = 20
#: Margin of the boundary poses, as a fraction of the platform weight: feasible with
#: every bound tightened by this much, infeasible (nearly) with a little more.
EDGE_MARGIN = 1e-6


@dataclass(frozen=True)
class RandomRobot:
    """A random robot and its poses (m, rad), shape (N, n)."""

    robot: CableRobot
    poses: NDArray
    seed: int


def _check(backend_robot: CableRobot) -> str:
    """The exact feasibility check where the closed form covers the robot, else auto."""
    redundancy = backend_robot.m - backend_robot.dof
    return "closed_form" if redundancy in (1, 2) else "auto"


def random_robot(seed: int, m: int, kind: str = "point3", symmetric: bool = False
                 ) -> CableRobot:
    """A seeded random suspended robot.

    Drawing points on a ring of radius 5..20 m at heights 4..10 m (each up to 15 %
    off; a symmetric robot has a regular polygon at one height), a platform of
    20..500 kg, ``t_min`` between 2 % and 30 % of its weight and ``t_max`` infinite or
    3..8 times it. A 6-DOF platform's attachments lie on the upper half of a box of
    half-size 0.2..0.6 m.

    Parameters
    ----------
    seed : int
    m : int
        Number of cables (at least the degrees of freedom plus one).
    kind : {"point3", "spatial6"}
    symmetric : bool
    """
    rng = np.random.default_rng(seed)
    dof = 3 if kind == "point3" else 6
    if m <= dof:
        raise InvalidInputError(f"a random {kind} robot needs more than {dof} cables, got {m}")
    radius, height = rng.uniform(5.0, 20.0), rng.uniform(4.0, 10.0)
    if symmetric:
        angles = 2 * np.pi * np.arange(m) / m
        heights = np.full(m, height)
        ring = np.full(m, radius)
    else:
        angles = np.sort(rng.uniform(0.0, 2 * np.pi, m))
        heights = height * rng.uniform(0.85, 1.15, m)
        ring = radius * rng.uniform(0.85, 1.15, m)
    anchors = np.column_stack([ring * np.cos(angles), ring * np.sin(angles), heights])
    attachments = np.zeros((m, 3))
    if dof == 6:
        half = rng.uniform(0.2, 0.6)
        attachments = rng.uniform(-half, half, (m, 3))
        attachments[:, 2] = np.abs(attachments[:, 2])
        # Each attachment faces its drawing point, as on suspended robots.
        attachments[:, :2] = np.abs(attachments[:, :2]) * np.sign(anchors[:, :2])
    mass = rng.uniform(20.0, 500.0)
    weight = mass * 9.81
    t_min = weight * rng.uniform(0.02, 0.3)
    t_max = np.inf if rng.random() < 0.5 else weight * rng.uniform(3.0, 8.0)
    home = np.zeros(dof)
    home[2] = 0.4 * height
    return CableRobot(anchors=anchors, attachments=attachments, mass=mass, kind=kind,
                      t_min=t_min, t_max=t_max, home=home,
                      name=f"random {kind} m={m} seed={seed}")


def _box(robot: CableRobot) -> tuple[NDArray, NDArray]:
    """The pose box of a random robot: inside the ring, 10..80 % of its height."""
    radius = float(np.linalg.norm(robot.anchors[:, :2], axis=1).min())
    height = float(robot.anchors[:, 2].min())
    low = [-0.6 * radius, -0.6 * radius, 0.1 * height]
    high = [0.6 * radius, 0.6 * radius, 0.8 * height]
    if robot.dof == 6:
        low += [-0.15] * 3
        high += [0.15] * 3
    return np.array(low), np.array(high)


def boundary_poses(robot: CableRobot, inside: NDArray, outside: NDArray, steps: int = 30
                   ) -> NDArray:
    """Feasible poses within ``2^-steps`` of the workspace's edge, shape (K, n).

    Each feasible pose of ``inside`` (K, n) is bisected toward the infeasible pose of
    ``outside`` (K, n) in the same row, keeping the feasible end (``steps`` rounds of
    one vectorised feasibility check each, with the bounds tightened by
    :data:`EDGE_MARGIN` of the weight). The poses of ``inside`` must be feasible with
    that margin.
    """
    backend = _check(robot)
    low, high = np.array(inside, dtype=float), np.array(outside, dtype=float)
    margin = EDGE_MARGIN * robot.weight
    for _ in range(steps):
        middle = 0.5 * (low + high)
        ok = feasible_mask(robot, middle, backend=backend, margin=margin)
        low[ok], high[~ok] = middle[ok], middle[~ok]
    return low


def random_robot_poses(robot: CableRobot, count: int, seed: int, boundary: float = 0.4,
                       symmetric: bool = False) -> NDArray:
    """``count`` feasible poses of a random robot, a share ``boundary`` of them at the
    edge of its workspace (:func:`boundary_poses`) and, for a symmetric robot, its
    centre pose first; shape (count, n)."""
    rng = np.random.default_rng(seed)
    low, high = _box(robot)
    backend = _check(robot)
    poses = random_feasible_poses(robot, count, seed=rng, low=low, high=high, backend=backend,
                                  margin=EDGE_MARGIN * robot.weight,
                                  batch=max(4 * count, 20), max_draws=400 * count + 400)
    edge = round(boundary * count)
    if edge:
        draws = rng.uniform(low, high, (20 * edge, low.size))
        outside = draws[~feasible_mask(robot, draws, backend=backend)][:edge]
        k = len(outside)
        poses[count - k:] = boundary_poses(robot, poses[count - k:], outside)
    if symmetric:
        centre = np.zeros(low.size)
        centre[2] = 0.5 * (low[2] + high[2])
        if feasible_mask(robot, centre[None], backend=backend)[0]:
            poses[0] = centre
    return poses


def random_robot_set(count: int = 200, poses_per_robot: int = 5, seed: int = 0
                     ) -> list[RandomRobot]:
    """``count`` random robots (shapes of :data:`ROBOT_SHAPES` in turn, every fourth
    symmetric) with their poses; a seed whose robot has too small a workspace is
    replaced by the next one (up to :data:`MAX_TRIES` tries)."""
    out = []
    for i in range(count):
        kind, m = ROBOT_SHAPES[i % len(ROBOT_SHAPES)]
        symmetric = i % 4 == 3
        for attempt in range(MAX_TRIES):
            robot_seed = seed + 1000 * i + attempt
            robot = random_robot(robot_seed, m, kind, symmetric)
            try:
                poses = random_robot_poses(robot, poses_per_robot, robot_seed,
                                           symmetric=symmetric)
            except InvalidInputError:  # too few feasible poses: another draw
                continue
            out.append(RandomRobot(robot, poses, robot_seed))
            break
        else:
            raise InvalidInputError(f"no random {kind} robot with {m} cables and a workspace "
                                    f"in {MAX_TRIES} seeds from {seed + 1000 * i}")
    return out
