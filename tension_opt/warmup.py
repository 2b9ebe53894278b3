"""Compile every kernel ahead: ``python -m tension_opt warmup``.

numba compiles a kernel on its first call and keeps the machine code in its disk cache
(``cache=True``), so each kernel costs its compile time once per installation (and
again after a change to its sources, :mod:`tension_opt.compiled_cache`). Without a
warm-up that time falls on the first call that needs the kernel; this module runs one
small representative call of each *family* of kernels instead, so that later calls,
in any process, load the machine code from the cache.

A family is a name and a function that makes the calls that compile it. The toolkit's
own are in :data:`FAMILIES`; a package built on ``tension_opt`` adds its own with
:func:`register` when it is imported (``catenary`` does), and the command line imports
the installed ones of :data:`PLUGINS` so that ``warmup`` compiles them too. Families
run in separate processes (``jobs``), each compiling its own kernels: on two cores the
warm-up takes about half as long as one after the other.
"""

from __future__ import annotations

import importlib
import importlib.util
import multiprocessing
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed

import numpy as np

__all__ = ["COMPILE_SECONDS", "DISTRIBUTION_FAMILIES", "FAMILIES", "PLUGINS", "every_family",
           "register", "warm", "warm_family"]

#: Packages whose kernel families the command line warms too, where installed.
PLUGINS: tuple[str, ...] = ("catenary",)


#: Poses of a family's batch calls: a plain call on fewer than
#: :data:`~tension_opt.kernels.launch.COMPILED_MIN` takes the numpy path and would
#: compile nothing.
_BATCH = 64


def _study_poses(count: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    return np.column_stack([rng.uniform(-30, 30, count), rng.uniform(-20, 20, count),
                            np.full(count, 0.5)])


def _spatial_poses(count: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    poses = np.zeros((count, 6))
    poses[:, :3] = rng.uniform(-0.3, 0.3, (count, 3))
    return poses


def _geometry() -> None:
    from tension_opt.robot import presets

    for robot, poses in ((presets.algae_harvester(), _study_poses(_BATCH)),
                         (presets.cogiro(), _spatial_poses(_BATCH))):
        robot.equilibrium(poses)


def _closed_form() -> None:
    from tension_opt.distribution.entry import distribute
    from tension_opt.problem.form import TensionProblem
    from tension_opt.robot import presets

    study, cogiro = presets.algae_harvester(), presets.cogiro()
    distribute(study, _study_poses(_BATCH), "min_sum", "closed_form")
    distribute(cogiro, _spatial_poses(_BATCH), "min_norm", "closed_form")
    smoothed = TensionProblem("min_norm", smoothing=1.0)
    distribute(study, _study_poses(_BATCH), smoothed, "closed_form")


def _certified_pass() -> None:
    from tension_opt.distribution.entry import distribute
    from tension_opt.robot import presets

    # Beyond one chunk (4096 poses): the certified compiled pass, with its lanes.
    distribute(presets.algae_harvester(), _study_poses(4200), chunk_size=4096)
    distribute(presets.cogiro(), _spatial_poses(4200), chunk_size=4096)


def _jacobians() -> None:
    from tension_opt.distribution.compiled_sensitivity import warm_kernel

    warm_kernel()  # the Jacobians of a batch solved in chunks


def _distributor() -> None:
    from tension_opt.backends.registry import available_backends
    from tension_opt.distribution.distributor import Distributor
    from tension_opt.problem.form import TensionProblem
    from tension_opt.robot import presets

    study, cogiro = presets.algae_harvester(), presets.cogiro()
    # The certified kernel of one pose (tension_opt.kernels.distributor), and DAQP's.
    Distributor(study)(_study_poses(1)[0])
    Distributor(cogiro, "min_norm")(_spatial_poses(1)[0])
    if "qpsolvers:daqp" in available_backends():  # the compiled DAQP path
        Distributor(study, "min_norm", "qpsolvers:daqp")(_study_poses(1)[0])
    # A stream, and independent poses each with its own previous tensions: loops that
    # call the one-pose kernel, so they belong with it.
    smoothed = Distributor(study, TensionProblem("min_norm", smoothing=1.0))
    poses = _study_poses(4)
    smoothed(poses)
    smoothed(poses, previous=np.full((len(poses), study.m), 1e3))


def _generic_backends() -> None:
    from tension_opt.backends.registry import available_backends
    from tension_opt.distribution.entry import distribute
    from tension_opt.problem.form import TensionProblem
    from tension_opt.robot import presets

    study, poses = presets.algae_harvester(), _study_poses(_BATCH)
    installed = set(available_backends())
    backend = "qpsolvers:daqp" if "qpsolvers:daqp" in installed else "auto"
    # The scaling and certificate kernels of every generic solve, and DAQP's own.
    distribute(study, poses, "min_norm", backend)
    smoothed = TensionProblem("min_norm", smoothing=1.0)
    distribute(study, poses, smoothed, backend)
    if "scipy:highs" in installed:
        distribute(study, poses, "min_sum", "scipy:highs")
    # The other qpsolvers' sequence loop (its compiled QP and verdict), one serves all;
    # like a batch, a sequence takes it from COMPILED_MIN poses on.
    other = [b for b in ("qpsolvers:piqp", "qpsolvers:osqp", "qpsolvers:clarabel")
             if b in installed][:1]
    for name in other:
        distribute(study, poses, smoothed, name)


def _timing() -> None:
    from tension_opt.dynamics.timing import time_optimal
    from tension_opt.robot import presets

    # The compiled reachability passes and the facet rows of the checks between grid
    # points (tension_opt.kernels.point_rows; the certified pass of the tensions is the
    # family of its own).
    path = np.array([[-20.0, -10.0, 1.0], [0.0, 0.0, 3.0], [20.0, 10.0, 1.0]])
    time_optimal(presets.algae_harvester(t_max=15e3), path, gridpoints=_BATCH,
                 method="reachability")


def _facet_normals() -> None:
    from tension_opt.robot import presets
    from tension_opt.workspace.hyperplane import wrench_space_margin
    from tension_opt.workspace.wrench_set import WrenchPolytope

    # The facet normals of the wrench-space margin (tension_opt.kernels.facets).
    robot = presets.cogiro()
    box = WrenchPolytope.box(-np.ones(robot.dof), np.ones(robot.dof))
    wrench_space_margin(robot, np.tile(robot.default_home(), (_BATCH, 1)), box)


#: The toolkit's kernel families, in the order the command line runs them.
FAMILIES: dict[str, Callable[[], None]] = {
    "robot geometry": _geometry,
    "closed form": _closed_form,
    "certified pass": _certified_pass,
    "Jacobians": _jacobians,
    "real-time distributor": _distributor,
    "certificate of generic solvers": _generic_backends,
    "time-optimal timing": _timing,
    "wrench-space margin": _facet_normals,
}


#: Typical compile seconds of a family on an empty cache (2-core machine): parallel
#: warm-ups start the longest first, so that no long family starts last and runs
#: alone. Only the order depends on them; a family not named here starts last.
COMPILE_SECONDS: dict[str, float] = {
    "catenary: coupled sag IK": 70.0,
    "real-time distributor": 60.0,
    "certified pass": 55.0,
    "catenary: single cable": 40.0,
    "closed form": 36.0,
    "catenary: platform stiffness": 35.0,
    "catenary: thesis sag IK": 24.0,
    "catenary: sagging-cable interference": 8.0,
    "certificate of generic solvers": 17.0,
    "time-optimal timing": 15.0,
    "Jacobians": 50.0,
    "robot geometry": 2.0,
    "wrench-space margin": 2.0,
}


#: The families a plain ``distribute`` runs (the backends' certificates and sequence
#: loops included; the ``Distributor``'s own kernels are apart): all the tension
#: distribution a benchmark cell of ``python -m benchmarks`` runs.
DISTRIBUTION_FAMILIES: tuple[str, ...] = (
    "robot geometry",
    "closed form",
    "certified pass",
    "certificate of generic solvers",
)


def register(name: str, compile_family: Callable[[], None]) -> None:
    """Add a kernel family to :data:`FAMILIES` (a package built on ``tension_opt``
    registers its own when imported)."""
    FAMILIES[name] = compile_family


def _load_plugins() -> None:
    for name in PLUGINS:
        if importlib.util.find_spec(name) is not None:
            importlib.import_module(name)


def every_family() -> list[str]:
    """Names of every family: the toolkit's and the installed plugins'."""
    _load_plugins()
    return list(FAMILIES)


def warm_family(name: str) -> float:
    """Run family ``name``'s calls in this process; the seconds they took."""
    from tension_opt.kernels.first_use import compiling_ahead

    _load_plugins()
    start = time.perf_counter()
    with compiling_ahead():
        FAMILIES[name]()
    return time.perf_counter() - start


def warm(names: Sequence[str] | None = None, jobs: int = 2,
         progress: bool = True) -> dict[str, float]:
    """Compile the kernels of the families ``names`` (default: every one), in up to
    ``jobs`` fresh processes at once.

    Parameters
    ----------
    names : sequence of str, optional
        Families of :data:`FAMILIES` (after the installed plugins registered theirs).
    jobs : int
        Processes at once (1: in this process, one family after the other; more: the
        longest families by :data:`COMPILE_SECONDS` start first).
    progress : bool
        Show a progress bar (tqdm, on standard error).

    Returns
    -------
    dict
        Seconds each family took, by name, in the order of ``names``.
    """
    from tqdm.auto import tqdm

    from tension_opt.checks import whole_positive
    from tension_opt.errors import InvalidInputError

    jobs = whole_positive("jobs", jobs)
    _load_plugins()
    chosen = list(FAMILIES) if names is None else list(names)
    unknown = [n for n in chosen if n not in FAMILIES]
    if unknown:
        raise InvalidInputError(f"unknown kernel families {unknown}; known: {list(FAMILIES)}")
    took: dict[str, float] = {}
    bar = tqdm(total=len(chosen), desc="compiling kernels", unit="family",
               disable=not progress)
    if jobs == 1:
        for name in chosen:
            bar.set_postfix_str(name)
            took[name] = warm_family(name)
            bar.update()
    else:
        # Fresh interpreters (spawn): no forked copy of a parent's threading layer.
        context = multiprocessing.get_context("spawn")
        longest_first = sorted(chosen, key=lambda n: -COMPILE_SECONDS.get(n, 0.0))
        with ProcessPoolExecutor(jobs, mp_context=context) as pool:
            futures = {pool.submit(warm_family, name): name for name in longest_first}
            for future in as_completed(futures):
                took[futures[future]] = future.result()
                bar.set_postfix_str(futures[future])
                bar.update()
    bar.close()
    return {name: took[name] for name in chosen}
