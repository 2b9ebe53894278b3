"""The compiled route of the Jacobians of a large batch (:mod:`tension_opt.kernels.sensitivity`).

:func:`tension_opt.distribution.sensitivity.tension_jacobian` takes this route, by a rule
on the call alone (never on what numba happens to have cached), where:

- ``wrt`` is ``"wrench"``, ``"pose"``, ``"t_min"``, ``"t_max"``, ``"drawing_points"``
  or ``"attachment_points"``;
- the solution keeps no form (a batch of more than
  :data:`~tension_opt.distribution.entry.CHUNK_SIZE` poses, solved in chunks), and the
  call gives the ``robot`` and ``poses`` it needs anyway;
- the robot is of a kind the compiled geometry knows (no guide pulleys), the problem is
  one of the package's objectives without min-max term, smoothing, rate limit or bounds
  per pose, and its Hessian is zero (linear) or positive for every cable.

The kernel gives the numpy path's Jacobians to rounding and its statuses (see the
kernel's module for the one difference, the singularity test near its limit). Tasks of
:data:`TASK` poses run side by side on numba's configured threads (the kernel releases
the GIL).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.distribution.packing import pack_certified
from tension_opt.problem.objectives import Centered
from tension_opt.robot import CableRobot

__all__ = ["TASK", "RealtimeJacobian", "compiled_jacobian", "warm_kernel"]

#: Poses per kernel call of a large batch (the threads' unit of work).
TASK = 32768
#: The kernel's code of each ``wrt`` it covers (:mod:`tension_opt.kernels.sensitivity`).
_CODES = {"wrench": 0, "pose": 1, "t_min": 2, "t_max": 3, "drawing_points": 8,
          "attachment_points": 9}


def compiled_jacobian(solution: Any, wrt: str, robot: Any, poses: ArrayLike | None,
                      wrench: ArrayLike | None) -> tuple[NDArray, NDArray] | None:
    """``(jacobian (N, m, n), (N, m, m) or (N, m, m, 3), status codes (N,) of int8)`` of
    ``solution`` by the compiled kernel, or None where the call does not take this route (see the
    module docstring; the numpy path then answers, or raises its error for bad input)."""
    from tension_opt.kernels.geometry import compiled_kind

    if (wrt not in _CODES or solution.form is not None
            or not isinstance(robot, CableRobot) or poses is None
            or solution.multipliers is None or compiled_kind(robot) < 0):
        return None
    data = _covered(robot, solution.problem)
    if data is None:
        return None
    m, n, N = robot.m, robot.dof, solution.N
    arrays = _arrays(solution, robot, poses, wrench, m, n, N)
    if arrays is None:
        return None
    J, codes = _run(data, arrays, _code(wrt, type(solution.problem.objective) is Centered),
                    m, n, N)
    return (J.reshape(N, m, m, 3) if wrt.endswith("points") else J), codes


class RealtimeJacobian:
    """The compiled Jacobian of the pose a :class:`~tension_opt.Distributor`'s kernel just
    solved (:func:`tension_opt.kernels.sensitivity.jacobian_one`), from the tensions and
    the certificate's multipliers the kernel leaves in its thread's work array. Built by
    :meth:`of` where the route applies: the compiled closed form, one of the package's
    objectives without min-max term, smoothing or rate limit, a Hessian zero or positive
    for every cable."""

    def __init__(self, data: NDArray, m: int, n: int, work_size: int,
                 centred: bool = False) -> None:
        from tension_opt.kernels.distributor import multipliers_offset
        from tension_opt.kernels.first_use import announce
        from tension_opt.kernels.launch import entry_point
        from tension_opt.kernels.sensitivity import columns, jacobian_one, work_floats

        announce("Jacobians", jacobian_one)
        self.data, self.m, self.n, self.columns = data, m, n, columns
        self.centred = centred  # the centred cost follows the bounds
        self.offset = multipliers_offset(m, n)
        self.floats, self.shape = int(work_floats(m, n)), (m, n)
        # The machine code for exactly the types the distributor passes (its own data,
        # contiguous float vectors, its work array): no type dispatch per call.
        self.kernel = entry_point(jacobian_one, data, np.zeros(n), np.zeros(m),
                                  np.zeros(work_size), self.offset, True, 0, np.zeros((m, n)),
                                  np.zeros(self.floats), np.zeros(m, dtype=np.int64))

    @classmethod
    def of(cls, robot: CableRobot, problem: Any, data: NDArray | None,
           work_size: int) -> RealtimeJacobian | None:
        """The route for a distributor of ``robot`` and ``problem`` whose packed problem
        is ``data`` (None: the distributor has no compiled closed form), or None."""
        if data is None or _covered(robot, problem) is None:
            return None
        return cls(data, robot.m, robot.dof, work_size, type(problem.objective) is Centered)

    def __call__(self, pose: NDArray, T: NDArray, local: Any, unique: bool,
                 wrt: str) -> tuple[NDArray, int]:
        """``(J (m, n); (m, m) by a bound; (m, m, 3) by the points, status code)`` of the
        pose just solved (contiguous float vectors ``pose`` and ``T``; ``local``: the
        distributor's thread-local state, whose ``work`` the real-time kernel wrote and
        which keeps this thread's buffers)."""
        try:
            floats, free = local.jacobian_work
        except AttributeError:  # this thread's first call
            floats, free = np.empty(self.floats), np.empty(self.m, dtype=np.int64)
            local.jacobian_work = floats, free
        what = _code(wrt, self.centred)
        J: NDArray = np.empty((self.m, self.columns(what, self.m, self.n)))
        code = self.kernel(self.data, pose, T, local.work, self.offset, unique, what, J,
                           floats, free)
        return (J.reshape(self.m, self.m, 3) if wrt.endswith("points") else J), code


def _code(wrt: str, centred: bool) -> int:
    """The kernel's code of ``wrt``; by a bound of the centred objective, with the flag
    (``MOVES_TARGET``, 4) of a cost that follows the bounds."""
    return _CODES[wrt] + (4 if centred and wrt in ("t_min", "t_max") else 0)


def _covered(robot: CableRobot, problem: Any) -> NDArray | None:
    """:func:`pack_certified` of ``robot`` and ``problem`` where the compiled Jacobians
    cover the problem (the module docstring's conditions on it), else None."""
    from tension_opt.kernels.closed_form import HEADER

    # Bounds or a reference per pose: the packed problem holds one row for every pose.
    if problem is None or problem.is_sequential or problem.has_pose_rows:
        return None
    data = pack_certified(robot, problem, 0.0)
    if data is None or data[7] != 0.0:  # another objective, or a min-max term
        return None
    q = data[HEADER + 6 * robot.m:HEADER + 7 * robot.m]  # the form's Hessian diagonal
    return data if (q == 0.0).all() or (q > 0.0).all() else None


def _read_only(a: NDArray, dtype: Any) -> NDArray:
    """``a`` as a read-only C-contiguous array of ``dtype`` (one kernel signature)."""
    view = np.ascontiguousarray(a, dtype=dtype).view()
    view.flags.writeable = False
    return view


def _arrays(solution: Any, robot: CableRobot, poses: ArrayLike, wrench: ArrayLike | None,
            m: int, n: int, N: int) -> tuple[NDArray, ...] | None:
    """The kernel's inputs: poses, wrenches, tensions, bound and equation multipliers,
    and the masks of the optimal and unique poses; None where a shape does not fit (the
    numpy path then raises its error)."""
    p = robot.as_poses(poses)
    mult = solution.multipliers
    if len(p) != N or mult.z.shape != (N, m) or mult.y.shape != (N, n):
        return None
    if wrench is None:
        w = np.zeros((1, n))
    else:
        w = np.asarray(wrench, dtype=float)
        if w.shape not in ((n,), (N, n)):
            return None
        w = w.reshape(-1, n)
    # Finite tensions and multipliers are checked in the kernel.
    return (_read_only(p, float), _read_only(w, float), _read_only(solution.tensions, float),
            _read_only(mult.z, float), _read_only(mult.y, float),
            _read_only(solution.success, bool), _read_only(solution.unique, bool))


def _run(data: NDArray, arrays: tuple[NDArray, ...], wrt: int, m: int, n: int, N: int
         ) -> tuple[NDArray, NDArray]:
    """The kernel over the batch (``arrays``: :func:`_arrays`), in tasks of :data:`TASK`
    poses on numba's threads."""
    from tension_opt.kernels.first_use import announce
    from tension_opt.kernels.launch import configured_threads
    from tension_opt.kernels.sensitivity import jacobian_poses

    announce("Jacobian", jacobian_poses)
    data = _read_only(data, float)
    p, w, T, z, y, solved, unique = arrays
    from tension_opt.kernels.sensitivity import columns

    J = np.empty((N, m, int(columns(wrt, m, n))))
    codes = np.empty(N, dtype=np.int8)

    def task(k: int) -> None:
        sl = slice(k * TASK, min(N, (k + 1) * TASK))
        # side_by_side given: the one signature the tests also call (an omitted default
        # is a type of its own, and another compilation).
        jacobian_poses(data, p[sl], w if len(w) == 1 else w[sl], T[sl], z[sl], y[sl],
                       solved[sl], unique[sl], wrt, J[sl], codes[sl], True)

    tasks = -(-N // TASK)
    threads = min(tasks, max(1, configured_threads()))
    if threads <= 1:
        for k in range(tasks):
            task(k)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(task, range(tasks)))
    return J, codes


def warm_kernel() -> None:
    """Compile the kernels (their one signature each, or load them from numba's cache):
    the batch's on one pose of the study robot, and the real-time path's entry point,
    for the warm-up (:mod:`tension_opt.warmup`)."""
    from tension_opt.kernels.distributor import certified_work_size
    from tension_opt.problem.form import TensionProblem
    from tension_opt.robot import presets

    robot = presets.algae_harvester()
    data = pack_certified(robot, TensionProblem("min_norm"), 0.0)
    assert data is not None
    RealtimeJacobian(data, 4, 3, int(certified_work_size(4, 3)))
    arrays = (np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3)), np.full((1, 4), 1e3),
              np.zeros((1, 4)), np.zeros((1, 3)), np.ones(1, dtype=bool),
              np.ones(1, dtype=bool))
    _run(data, tuple(_read_only(a, a.dtype) for a in arrays), 0, 4, 3, 1)
