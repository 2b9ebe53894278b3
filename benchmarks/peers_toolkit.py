"""The toolkit's side of :mod:`benchmarks.bench_peers`: the robots and poses compared
with WireX, the same data in WireX's terms, and the toolkit's timings.

Cases (each a robot and ``N`` seeded random poses, wrench-feasible):

``cogiro_inside``
    CoGiRo (:func:`tension_opt.presets.cogiro`), poses whose centred closed form (the
    tensions nearest the middle of the bounds, bounds ignored) lies strictly inside the
    bounds: the closed form is the answer and no bound is active.
``cogiro_active``
    CoGiRo, poses where that closed form leaves the bounds: the bounded problem has
    active bounds.
``ipanema_active``
    IPAnema 3 (:func:`tension_opt.presets.ipanema3`), poses with active bounds.
``cogiro_stiffness``
    CoGiRo, the poses of ``cogiro_inside`` with their tensions given: the stiffness
    matrix of straight elastic cables.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import catenary
import tension_opt as to
from catenary.stiffness_loop import PoseStiffness
from tension_opt import presets
from tension_opt.workspace.sampling import random_feasible_poses

from .wirex_driver import Case

__all__ = [
    "PeerCase",
    "centred_unbounded",
    "peer_cases",
    "select_poses",
    "time_toolkit",
    "wirex_case",
]

FloatArray = NDArray[np.float64]
#: Relative margin (of ``t_max - t_min``) that "strictly inside the bounds" keeps.
INSIDE_MARGIN = 1e-6


@dataclass(frozen=True)
class PeerCase:
    """A robot, its poses and what is timed on them.

    Attributes
    ----------
    name : str
        Key of the case (``cogiro_inside``, ...).
    robot : CableRobot
    poses : ndarray, shape (N, 6)
    tensions : ndarray, shape (N, m)
        The toolkit's ``"centered"`` closed-form tensions (the stiffness case's given
        tensions).
    works : tuple of str
        ``"distribution"`` and/or ``"stiffness"``.
    solved : int
        Poses whose tensions the toolkit certified optimal.
    """

    name: str
    robot: to.CableRobot
    poses: FloatArray
    tensions: FloatArray
    works: tuple[str, ...]
    solved: int


def centred_unbounded(robot: to.CableRobot, poses: FloatArray) -> FloatArray:
    """The centred closed form without bounds, (N, m): ``t_ref - A^+ (A t_ref - w)``,
    ``t_ref = (t_min + t_max) / 2`` (WireX's closed form)."""
    A = robot.structure_matrices(poses)
    w = robot.required_wrench(poses)
    ref = 0.5 * (robot.t_min + robot.t_max)
    residual = np.einsum("nij,j->ni", A, ref) - w
    return ref - np.einsum("nij,nj->ni", np.linalg.pinv(A), residual)


def select_poses(robot: to.CableRobot, n: int, inside: bool, seed: int) -> FloatArray:
    """``n`` wrench-feasible poses of ``robot`` whose unbounded centred closed form is
    strictly inside the bounds (``inside``) or leaves them (otherwise), in the order of
    seeded draws from the default box.

    Raises
    ------
    RuntimeError
        If 50 rounds of draws do not give ``n`` such poses.
    """
    rng = np.random.default_rng(seed)
    margin = INSIDE_MARGIN * float(np.max(robot.t_max - robot.t_min))
    found: list[FloatArray] = []
    for _ in range(50):
        draws = random_feasible_poses(robot, max(2 * n, 64), seed=rng)
        t = centred_unbounded(robot, draws)
        strictly = np.all((t > robot.t_min + margin) & (t < robot.t_max - margin), axis=1)
        found.append(draws[strictly if inside else ~strictly])
        if sum(len(f) for f in found) >= n:
            return np.ascontiguousarray(np.concatenate(found)[:n])
    raise RuntimeError(
        f"{robot.name}: fewer than {n} poses with the closed form "
        f"{'inside' if inside else 'outside'} the bounds in 50 rounds"
    )


def peer_cases(n: int, seed: int = 0) -> list[PeerCase]:
    """The cases of the comparison (module docstring), ``n`` poses each."""
    cogiro = presets.cogiro()
    robots = [("cogiro_inside", cogiro, True), ("cogiro_active", cogiro, False)]
    if hasattr(presets, "ipanema3"):
        robots.append(("ipanema_active", presets.ipanema3(), False))
    cases = []
    for k, (name, robot, inside) in enumerate(robots):
        poses = select_poses(robot, n, inside, seed + k)
        solution = to.distribute(robot, poses, "centered", "closed_form")
        cases.append(
            PeerCase(
                name,
                robot,
                poses,
                np.ascontiguousarray(solution.tensions),
                ("distribution",),
                int(np.sum(solution.success)),
            )
        )
    first = cases[0]
    cases.append(
        PeerCase(
            "cogiro_stiffness",
            first.robot,
            first.poses,
            first.tensions,
            ("stiffness",),
            first.solved,
        )
    )
    return cases


def wirex_case(case: PeerCase) -> Case:
    """``case`` in WireX's terms: the applied wrench (minus the required one), the
    rotation matrices of the poses, the cables' ``EA`` (0 if inextensible)."""
    robot = case.robot
    positions, rotations = robot.frames(case.poses)
    EA = robot.cable.EA if robot.cable is not None else np.inf
    return Case(
        case.name,
        np.asarray(robot.anchors, float),
        np.asarray(robot.attachments, float),
        np.asarray(robot.t_min, float),
        np.asarray(robot.t_max, float),
        np.ascontiguousarray(positions, float),
        np.ascontiguousarray(rotations, float),
        -robot.required_wrench(case.poses),
        case.tensions,
        float(EA) if np.isfinite(EA) else 0.0,
        case.works,
    )


def _calls(case: PeerCase) -> dict[str, Callable[[], object]]:
    """The toolkit's timed calls of ``case``, each a pass over all its poses."""
    robot, poses, tensions = case.robot, case.poses, case.tensions
    if "stiffness" in case.works:
        loop = PoseStiffness(robot, "straight")

        def stiffness_loop() -> None:
            for i in range(len(poses)):
                loop(poses[i], tensions[i])

        return {
            "stiffness_batch": lambda: catenary.platform_stiffness(
                robot, poses, tensions, "straight"
            ),
            "stiffness_loop": stiffness_loop,
        }
    solver = to.Distributor(robot, "centered", "closed_form")

    def distributor_loop() -> None:
        for i in range(len(poses)):
            solver(poses[i])

    return {
        "batch": lambda: to.distribute(robot, poses, "centered", "closed_form"),
        "loop": distributor_loop,
    }


def time_toolkit(cases: list[PeerCase], repeats: int) -> dict[tuple[str, str], float]:
    """Time per pose (ns) of each toolkit call on each case: ``(case, work) -> ns``.

    Each call passes over all poses of its case; the figure is the median over
    ``repeats`` rounds (after one untimed call of each) of its wall time divided by the
    number of poses. The calls of a case take turns within a round, so that a slow
    spell of a shared machine falls on all of them alike. Works: ``"batch"``
    (``distribute(..., "centered", "closed_form")``), ``"loop"`` (a
    :class:`tension_opt.Distributor` called per pose), ``"stiffness_batch"``
    (:func:`catenary.platform_stiffness`, straight, tensions given) and
    ``"stiffness_loop"`` (:class:`catenary.PoseStiffness` called per pose).
    """
    out: dict[tuple[str, str], float] = {}
    for case in cases:
        calls = _calls(case)
        for fn in calls.values():
            fn()
        times: dict[str, list[float]] = {name: [] for name in calls}
        for _ in range(repeats):
            for name, fn in calls.items():
                t0 = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
        for name, t in times.items():
            out[(case.name, name)] = float(np.median(t)) / len(case.poses) * 1e9
    return out
