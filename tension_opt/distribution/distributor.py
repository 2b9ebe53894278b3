"""A tension distributor built once and called per pose, for control loops.

:class:`Distributor` holds everything about a problem that does not change from one
pose to the next (the robot's data and the objective's terms packed in one array, the
bounds, the compiled kernels of :mod:`tension_opt.kernels`, one work space per thread,
the last answer of a stream) so that a call costs one compiled call and little else.

- Problems the compiled closed form covers (null space of dimension 1 or 2; min-sum,
  min-norm, pseudo-inverse, centred, and min-max in dimension 1; smoothing and rate
  limits) run in compiled code, allocating nothing but the tensions returned, and each
  answer is certified in the same call as :func:`tension_opt.distribute` certifies it
  (:mod:`tension_opt.kernels.distributor`: the primal residual, dual residual and
  duality gap of the pose's scaled problem at the ``accuracy`` target, with the
  equilibrium and bounds within the feasibility tolerance): ``optimal`` means
  certified, an answer whose certificate misses is ``inaccurate``. A batch of
  independent poses goes through the certified pass of large batches
  (:mod:`tension_opt.distribution.certified`) where the problem has no smoothing or
  rate limit.
- ``backend="qpsolvers:daqp"`` with a quadratic objective (min-norm, pseudo-inverse,
  centred, or any smoothed pose) builds the scaled dense QP in compiled code, keeps a
  DAQP model per thread warm-started from the previous pose, and certifies DAQP's
  answer with its own multipliers (:mod:`tension_opt.kernels.dense_qp`); a smoothed
  stream given as a batch runs pose by pose through it.
- Poses these cannot settle (singular or badly conditioned structure matrices, a
  cable on its drawing point, an infeasible pose or an uncertified answer of DAQP) and
  every other problem or backend go through :func:`tension_opt.distribute`, so the
  statuses are those of the numpy path.

numba compiles the kernels on the first call of the first distributor and keeps the
machine code on disk (``cache=True``): a later process loads it instead of compiling.
A pose of another array type than a writeable, contiguous float64 vector (a read-only
or strided view) compiles (once, then cached) a variant of the kernel.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend
from tension_opt.backends.settings import check_options, solver_options
from tension_opt.checks import as_finite, as_float_array
from tension_opt.distribution.certified import CertifiedPlan, certified_plan
from tension_opt.distribution.entry import CHUNK_SIZE, distribute
from tension_opt.distribution.packing import pack_realtime
from tension_opt.distribution.realtime_result import RealtimeResult
from tension_opt.distribution.sensitivity import SENSITIVITY_STATUSES, jacobian_shape
from tension_opt.distribution.solution import TensionSolution
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import TensionProblem, as_problem
from tension_opt.robot import CableRobot
from tension_opt.status import STATUS_DTYPE, Status
from tension_opt.tolerances import accuracy_target

__all__ = ["Distributor", "RealtimeResult"]

_NAN = float("nan")

_STATUS = (Status.OPTIMAL, Status.INFEASIBLE, Status.UNBOUNDED, Status.INACCURATE,
           Status.SOLVER_ERROR)
_FALLBACK, _BAD_INPUT = 9, 8
_F64 = np.dtype(np.float64)
#: What :meth:`Distributor.with_jacobian` differentiates by (all but the previous
#: tensions, which a stream's pose takes from its own last answer).
_REALTIME_WRT = ("pose", "wrench", "t_min", "t_max", "drawing_points", "attachment_points")
#: Status values by kernel code (a last entry for codes of poses solved otherwise).
_STATUS_VALUES = np.array([s.value for s in _STATUS] + [""], dtype=STATUS_DTYPE)


class Distributor:
    """A tension distribution problem for one robot, built once, called per pose.

    Parameters
    ----------
    robot : CableRobot
    objective : str or TensionProblem
        As in :func:`tension_opt.distribute`.
    backend : str or Backend
        As in :func:`tension_opt.distribute`. ``"auto"`` and ``"closed_form"`` use the
        compiled closed form where it applies, ``"qpsolvers:daqp"`` the compiled DAQP
        path (see the module docstring).
    **options
        Backend options as in :func:`tension_opt.distribute`. ``warm_start`` (default
        True here) starts DAQP from the previous pose's active set.

    Calling
    -------
    ``solver(pose, wrench=None, previous=None)`` with a pose (n,) or poses (N, n), an
    external wrench (n,) or (N, n) (N, N m) and, for smoothed or rate-limited problems,
    the previous tensions (m,) (or (N, m), one row per pose, solved independently).
    Without ``previous``, a smoothed problem continues the stream: each pose is smoothed
    against the last tensions this distributor solved in this thread (optimal, or
    inaccurate by the certificate alone, as a sequence of :func:`tension_opt.distribute`
    goes on; the first pose of a stream is solved unsmoothed, as that sequence does);
    :meth:`reset` starts a new stream. Returns a :class:`RealtimeResult`, whose
    certificate is the one :func:`tension_opt.distribute` computes (``optimal`` only
    where it meets the ``accuracy`` target).

    Threads
    -------
    One instance may be shared by threads: each thread has its own work space (and
    DAQP model), the constant data are never written after construction, and the last
    answer of a stream is kept per thread (each thread's calls form their own stream).
    """

    def __init__(self, robot: CableRobot, objective: str | TensionProblem = "min_sum",
                 backend: str | Backend = "auto", **options: Any) -> None:
        if not isinstance(robot, CableRobot):
            raise InvalidInputError(f"robot must be a CableRobot, got {type(robot).__name__}")
        check_options(options)
        self.robot = robot
        self.problem = as_problem(objective)
        self.backend = backend
        self.options = dict(options)
        self._local = threading.local()
        # Checks the problem against the robot once (bounds, weights, objective).
        form = self.problem.standard_form(robot, robot.default_home()[None, :],
                                          previous=np.zeros(robot.m))
        self._sequential = self.problem.is_sequential
        self._m, self._shape = robot.m, (robot.dof,)
        self._no_wrench, self._no_prev = np.zeros(robot.dof), np.zeros(robot.m)
        self._target = accuracy_target(self.options.get("accuracy"))
        self._data: NDArray | None = None
        self._daqp: dict[str, Any] | None = None
        self._plan: CertifiedPlan | None = None
        self._jacobian_route: Any = None  # built on the first with_jacobian
        closed = self._closed_form_path()
        if form.G is None and (closed or self._daqp_path()):
            from tension_opt.kernels import closed_form
            from tension_opt.kernels import distributor as kernels
            from tension_opt.kernels.first_use import announce

            announce("real-time distributor", kernels.certified_one)
            self._data = pack_realtime(robot, self.problem, self._target)
            self._kernels = kernels
            if closed:
                from tension_opt.kernels.launch import entry_point

                self._work_size = int(kernels.certified_work_size(robot.m, robot.dof))
                self._solve_one = entry_point(
                    kernels.certified_one, self._data, self._no_wrench, self._no_wrench,
                    self._no_prev, False, np.empty(self._work_size), np.empty(robot.m))
                # Independent poses of a problem without smoothing or rate limit: the
                # certified pass of large batches.
                self._plan = certified_plan(robot, self.problem, backend,
                                            self.options.get("accuracy"))
            else:
                self._work_size = int(closed_form.work_size(robot.m, robot.dof))
                self._daqp = {"settings": solver_options("daqp", self.options.get("accuracy")),
                              "warm": bool(self.options.get("warm_start", True))}

    # ------------------------------------------------------------------ setup
    def _kernel_covers(self) -> bool:
        """Whether the robot (kind, no guide pulleys) and the per-pose data suit the
        compiled kernels."""
        problem = self.problem
        if self.robot.kind not in ("point3", "planar_point2", "planar3", "spatial6"):
            return False
        if self.robot.has_pulleys:  # the kernels draw each cable from a fixed point
            return False
        return not any(x is not None and np.ndim(x) > 1
                       for x in (problem.t_min, problem.t_max, problem.reference))

    def _closed_form_path(self) -> bool:
        """Whether the compiled closed form solves this problem exactly as the numpy
        closed form would."""
        robot, problem = self.robot, self.problem
        if not (isinstance(self.backend, str) and self.backend in ("auto", "closed_form")):
            return False
        if set(self.options) - {"accuracy"} or robot.m - robot.dof not in (1, 2):
            return False
        if not self._kernel_covers():
            return False
        if problem.objective.name == "min_max":
            return robot.m - robot.dof == 1 and not problem.smoothing
        return True

    def _daqp_path(self) -> bool:
        """Whether the compiled DAQP path applies: DAQP asked for, a quadratic objective
        (or a smoothed one, quadratic once a stream has begun), no min-max term."""
        if not (isinstance(self.backend, str) and self.backend == "qpsolvers:daqp"):
            return False
        if set(self.options) - {"accuracy", "warm_start"} or not self._kernel_covers():
            return False
        try:
            import daqp  # noqa: F401
        except ImportError:
            return False
        objective = self.problem.objective
        return objective.name != "min_max" and (not objective.linear
                                                or bool(self.problem.smoothing))

    def _thread_work(self) -> Any:
        """This thread's work space (a float array, or the DAQP workspace), made once."""
        if self._daqp is None:
            work: Any = np.empty(self._work_size)
        else:
            from tension_opt.kernels.dense_qp import DaqpPose

            work = DaqpPose(self.robot.m, self.robot.dof, self._daqp["settings"],
                            self._daqp["warm"], self._work_size)
        self._local.work = work
        return work

    @property
    def closed_form_data(self) -> NDArray | None:
        """The packed problem of a distributor that answers by the compiled closed form
        (:func:`tension_opt.distribution.packing.pack_realtime`, whose first part is
        :func:`tension_opt.kernels.closed_form.pack`'s), for compiled callers that call
        :func:`~tension_opt.kernels.closed_form.solve_one` or
        :func:`~tension_opt.kernels.distributor.certified_one` themselves; None for the
        other paths. Read only."""
        return self._data if self._daqp is None else None

    # ------------------------------------------------------------------- calls
    def reset(self) -> None:
        """Forget the last answer of this thread's stream (the next smoothed pose is
        solved unsmoothed, unless given ``previous``)."""
        self._local.last = None

    def __call__(self, pose: ArrayLike, wrench: ArrayLike | None = None,
                 previous: ArrayLike | None = None) -> RealtimeResult:
        """Tensions of one pose (n,) or a batch (N, n); see the class docstring."""
        if (wrench is None and previous is None and type(pose) is np.ndarray
                and pose.dtype is _F64 and pose.shape == self._shape
                and self._data is not None and pose.flags.c_contiguous):
            return self._one(pose, self._no_wrench, None, None)
        return self._general(pose, wrench, previous)

    def with_jacobian(self, pose: ArrayLike, wrt: str = "pose",
                      wrench: ArrayLike | None = None,
                      previous: ArrayLike | None = None) -> RealtimeResult:
        """One pose (n,) solved as a call solves it, with the Jacobian of its optimal
        tensions by ``wrt`` (``"wrench"``, ``"pose"``, ``"t_min"``, ``"t_max"``,
        ``"drawing_points"`` or ``"attachment_points"``) in the result's ``jacobian``
        ((m, n); (m, m) by the bounds; (m, m, 3) by the points) and ``jacobian_status``:
        the compiled kernel's where the pose went through the compiled closed form (the
        package's objectives without min-max term, smoothing or rate limit), else
        :meth:`TensionSolution.jacobian <tension_opt.TensionSolution.jacobian>` of the
        same pose (the same statuses).

        Raises
        ------
        InvalidInputError
            For another ``wrt`` or a batch of poses (use :func:`tension_opt.distribute`
            and ``solution.jacobian``), or bad input as a call raises it.
        """
        if wrt not in _REALTIME_WRT:
            raise InvalidInputError(f"wrt must be one of {list(_REALTIME_WRT)}, got {wrt!r}: "
                                    "for another, solve with tension_opt.distribute and call "
                                    "solution.jacobian")
        route = self._jacobian_route
        if route is None:
            from tension_opt.distribution.compiled_sensitivity import RealtimeJacobian

            route = RealtimeJacobian.of(self.robot, self.problem, self.closed_form_data,
                                        getattr(self, "_work_size", 0)) or False
            self._jacobian_route = route
        if (route and wrench is None and previous is None and type(pose) is np.ndarray
                and pose.dtype is _F64 and pose.shape == self._shape
                and pose.flags.c_contiguous):  # as __call__'s fast test
            p, prev, result = pose, None, self._one(pose, self._no_wrench, None, None)
        else:
            p = np.ascontiguousarray(as_float_array("pose", pose))
            if p.shape != self._shape:
                raise InvalidInputError(f"pose must have shape {self._shape}: with_jacobian"
                                        " takes one pose (a batch: tension_opt.distribute, "
                                        "then solution.jacobian)")
            prev = self._stream_start(previous)
            result = self(p, wrench, prev)
        if result.status is not Status.OPTIMAL:
            J, status = np.full(jacobian_shape(wrt, 1, self.robot.m, self.robot.dof)[1:],
                                np.nan), "not_optimal"
        elif route and result.compiled:
            J, code = route(p, result.tensions, self._local, result.unique, wrt)
            status = SENSITIVITY_STATUSES[code]
        else:
            sol = distribute(self.robot, p[None], self.problem, self.backend,
                             wrench=wrench, previous=prev, **self.options)
            sens = sol.jacobian(wrt, robot=self.robot, poses=p[None], wrench=wrench,
                                previous=prev)
            J, status = sens.jacobian[0], str(sens.status[0])
        result.jacobian, result.jacobian_status = J, status
        return result

    def _general(self, pose: ArrayLike, wrench: ArrayLike | None,
                 previous: ArrayLike | None) -> RealtimeResult:
        """Any call the fast test of :meth:`__call__` turned away."""
        p = np.ascontiguousarray(as_float_array("pose", pose))
        # Read as arrays once, so that anything numpy cannot read is named here.
        wrench = None if wrench is None else as_float_array("wrench", wrench)
        previous = None if previous is None else as_float_array("previous", previous)
        n, m = self.robot.dof, self.robot.m
        if p.shape == (n,) and self._data is not None and (
                wrench is None or wrench.shape == (n,)) and (
                previous is None or previous.shape == (m,)):
            w = self._no_wrench if wrench is None else np.ascontiguousarray(wrench)
            return self._one(p, w, wrench, previous)
        result = self._many(self.robot.as_poses(pose), wrench, previous)
        if p.ndim != 1:
            return result
        return RealtimeResult(result.tensions[0], Status(result.status[0]),
                              bool(result.unique[0]), float(result.residual[0]),
                              float(result.infeasibility[0]), bool(result.compiled[0]),
                              float(result.primal_residual[0]),
                              float(result.dual_residual[0]), float(result.duality_gap[0]))

    def _stream_start(self, previous: ArrayLike | None) -> NDArray | None:
        """The tensions a sequential problem smooths against, or None."""
        if not self._sequential:
            return None
        if previous is not None:
            prev = as_finite("previous", previous)
            if prev.shape != (self.robot.m,):
                raise InvalidInputError(
                    f"previous must have shape ({self.robot.m},), got {prev.shape}")
            return np.ascontiguousarray(prev)
        return getattr(self._local, "last", None)

    def _one(self, p: NDArray, w: NDArray, wrench: ArrayLike | None,
             previous: ArrayLike | None) -> RealtimeResult:
        """One pose through one compiled call (the numpy path where it declines);
        ``w`` the wrench as a float vector, ``wrench`` as given (None for none)."""
        local = self._local
        try:
            work = local.work
        except AttributeError:
            work = self._thread_work()
        prev = None
        if self._sequential:
            prev = self._stream_start(previous)
        T = np.empty(self._m)
        has_prev = prev is not None
        if self._daqp is None:
            # Every argument is a contiguous float64 vector (the callers see to it):
            # the types the entry point was made for.
            code, unique, res, infeas, primal, dual, gap = self._solve_one(
                self._data, p, w, prev if has_prev else self._no_prev, has_prev, work, T)
        else:
            code, res, primal, dual, gap = work.solve(
                self._data, p, w, prev if has_prev else self._no_prev, has_prev,
                self._target, T)
            unique, infeas = True, _NAN
        if code < _BAD_INPUT:
            # A solved pose (optimal, or inaccurate by its certificate) goes on the
            # stream, as the plain sequence goes on from it.
            if self._sequential and (code == 0 or code == 3):
                local.last = T.copy()
            return RealtimeResult(T, _STATUS[code], unique, res, infeas, True, primal, dual,
                                  gap)
        if code == _BAD_INPUT:
            self.robot.as_poses(p)
            as_finite("wrench", w)
        sol = distribute(self.robot, p, self.problem, self.backend, wrench=wrench,
                         previous=prev, **self.options)
        status = Status(sol.status[0])
        self._remember(status, sol.tensions[0])
        return RealtimeResult(sol.tensions[0], status, bool(sol.unique[0]),
                              float(sol.residual[0]), float(sol.infeasibility[0]), False,
                              *_certificate_of(sol, 0))

    def _goes_on(self, status: Any) -> Any:
        """Whether a stream goes on from an answer of the numpy path with this status
        (each of an array): as the plain sequence goes on from every pose its backend
        solved, an optimal one, and on the compiled paths (closed form, DAQP, whose
        backends call every solved pose optimal) also one the certificate downgraded
        to inaccurate."""
        ok = np.asarray(status == Status.OPTIMAL)
        if self._data is not None:
            ok = ok | np.asarray(status == Status.INACCURATE)
        return ok if np.ndim(status) else bool(ok)

    def _remember(self, status: Status, tensions: NDArray) -> None:
        if self._sequential and self._goes_on(status):
            self._local.last = tensions.copy()

    def _many(self, p: NDArray, wrench: ArrayLike | None,
              previous: ArrayLike | None) -> RealtimeResult:
        """A batch: in parallel when poses are independent, in order for a stream."""
        N, n, m = len(p), self.robot.dof, self.robot.m
        for name, value, k in (("wrench", wrench, n), ("previous", previous, m)):
            if value is not None and np.shape(value) not in ((k,), (N, k)):
                raise InvalidInputError(f"{name} must have shape ({k},) or ({N}, {k}) for "
                                        f"{N} poses, got {np.shape(value)}")
        independent = previous is not None and np.ndim(previous) == 2
        stream = self._sequential and not independent
        if self._data is None or (self._daqp is not None and not stream):
            prev = previous if independent else self._stream_start(previous)
            return self._numpy(p, wrench, prev, np.arange(len(p)), None)
        from tension_opt.kernels.arrays import writable

        # Writable arrays: a read-only one (the user's, or broadcast_to's) is another
        # type to numba, which would compile the loops and the pose kernel again.
        p, w = writable(p), writable(self._wrenches(wrench))
        if self._daqp is not None:
            return self._daqp_stream(p, w, wrench, previous)
        if stream:
            return self._sequence(p, w, wrench, self._stream_start(previous))
        if self._plan is not None:
            if independent and previous is not None:
                as_finite("previous", previous)  # checked, as the other paths do
            return self._certified_pass(p, w)
        return self._batch(p, w, wrench, previous if independent else None)

    def _daqp_stream(self, p: NDArray, w: NDArray, wrench: ArrayLike | None,
                     previous: ArrayLike | None) -> RealtimeResult:
        """A stream on the compiled DAQP path: pose by pose, in order, each answered as
        a call with that pose alone would answer it (smoothed against the last solved
        answer, the first one against ``previous`` or the stream's last, each warm
        started from the pose before), so that a batch answers as single calls do."""
        N, m = len(p), self._m
        if previous is not None:
            self._local.last = self._stream_start(previous)  # checked, then streamed
        poses = np.ascontiguousarray(p)
        rows = np.ascontiguousarray(np.broadcast_to(w, (N, w.shape[1])))
        T = np.empty((N, m))
        status = np.empty(N, dtype=STATUS_DTYPE)
        unique, compiled = np.empty(N, dtype=bool), np.empty(N, dtype=bool)
        info = np.empty((N, 5))
        for k in range(N):
            one = self._one(poses[k], rows[k], None if wrench is None else rows[k], None)
            T[k], status[k], unique[k], compiled[k] = (one.tensions, one.status.value,
                                                       one.unique, one.compiled)
            info[k] = (one.residual, one.infeasibility, one.primal_residual,
                       one.dual_residual, one.duality_gap)
        return RealtimeResult(T, status, unique, info[:, 0], info[:, 1], compiled,
                              info[:, 2], info[:, 3], info[:, 4])

    def _wrenches(self, wrench: ArrayLike | None) -> NDArray:
        """External wrenches (N, n) of a batch, or (1, n) for one for every pose (their
        shape checked by :meth:`_many`)."""
        if wrench is None:
            return self._no_wrench[None, :]
        return np.ascontiguousarray(as_finite("wrench", wrench).reshape(-1, self.robot.dof))

    def _certified_pass(self, p: NDArray, w: NDArray) -> RealtimeResult:
        """Independent poses of a problem without smoothing or rate limit through the
        certified pass of large batches (:class:`~tension_opt.distribution.certified.
        CertifiedBatch`, in tasks on up to ``chunk_threads()`` threads, as
        :func:`tension_opt.distribute` runs it); the poses it leaves by the numpy path."""
        from tension_opt.distribution.certified import CertifiedBatch
        from tension_opt.distribution.chunks import (
            CERTIFIED_TASK,
            certified_chunks,
            chunk_threads,
        )

        assert self._plan is not None  # see _many
        batch = CertifiedBatch(self._plan, p, w)
        left: list[NDArray | slice] = []

        def numpy_path(poses: NDArray | slice) -> TensionSolution:
            left.append(poses)  # (list.append holds across the pass's threads)
            rows = w if len(w) == 1 else w[poses]
            return distribute(self.robot, p[poses], self.problem, self.backend,
                              wrench=rows, **self.options)

        sol = certified_chunks(batch, CERTIFIED_TASK, CHUNK_SIZE, chunk_threads(),
                               numpy_path, self.problem)
        compiled = np.ones(len(p), dtype=bool)
        for poses in left:
            compiled[poses] = False
        return RealtimeResult(sol.tensions, sol.status, sol.unique, sol.residual,
                              sol.infeasibility, compiled, sol.primal_residual,
                              sol.dual_residual, sol.duality_gap)

    def _batch(self, p: NDArray, w: NDArray, wrench: ArrayLike | None,
               previous: ArrayLike | None) -> RealtimeResult:
        """Independent poses, each with its own previous tensions (or none), through the
        certified real-time kernel; the poses it leaves by the numpy path."""
        N, m = len(p), self.robot.m
        has_prev = previous is not None
        from tension_opt.kernels.arrays import writable

        # Writable (broadcast_to's view is read-only, another type to numba).
        prev = (writable(np.broadcast_to(as_finite("previous", previous), (N, m)))
                if previous is not None else self._no_prev[None, :])
        T, info = np.empty((N, m)), np.empty((N, self._kernels.INFO))
        codes = np.empty(N, dtype=np.int64)
        from tension_opt.kernels import launch

        launch.run(self._kernels.certified_batch, self._kernels.certified_batch_serial, N,
                   self._data, np.ascontiguousarray(p), w, prev, has_prev, T, info, codes)
        redo = np.flatnonzero(codes >= _BAD_INPUT)
        return self._numpy(p, wrench, previous, redo, (T, info, codes))

    def _numpy(self, p: NDArray, wrench: ArrayLike | None, previous: ArrayLike | None,
               redo: NDArray, compiled: tuple[NDArray, NDArray, NDArray] | None
               ) -> RealtimeResult:
        """Results of a batch: the compiled ones, and ``redo`` poses by the numpy path."""
        N, m = len(p), self.robot.m
        if compiled is None:
            T, info = np.empty((N, m)), np.empty((N, _INFO))
            codes = np.zeros(N, dtype=np.int64)
        else:
            T, info, codes = compiled
        status = _STATUS_VALUES[np.minimum(codes, len(_STATUS))]
        done = np.ones(N, dtype=bool)
        if len(redo):
            sub = lambda x: x if x is None or np.ndim(x) < 2 else np.asarray(x)[redo]  # noqa: E731
            sol = distribute(self.robot, p[redo], self.problem, self.backend,
                             wrench=sub(wrench), previous=sub(previous), **self.options)
            T[redo], status[redo] = sol.tensions, sol.status
            info[redo] = _info_of(sol)
            done[redo] = False
            if self.problem.is_sequential and (previous is None or np.ndim(previous) < 2):
                ok = np.flatnonzero(self._goes_on(sol.status))
                if len(ok):
                    self._local.last = sol.tensions[ok[-1]].copy()
        return _result(T, status, info, done)

    def _sequence(self, p: NDArray, w: NDArray, wrench: ArrayLike | None,
                  start: NDArray | None) -> RealtimeResult:
        """A stream in order through the certified kernel; a pose it declines is solved
        by the numpy path against the same previous tensions, and the stream goes on."""
        N, m = len(p), self.robot.m
        T, info = np.empty((N, m)), np.empty((N, _INFO))
        codes = np.empty(N, dtype=np.int64)
        last = np.full(m, np.nan) if start is None else np.array(start, dtype=float)
        done = np.ones(N, dtype=bool)
        fallback: dict[int, Status] = {}
        work = np.empty(self._work_size)
        poses = np.ascontiguousarray(p)
        data = self._data
        assert data is not None  # the compiled path has its data (see _many)
        k = 0
        while k < N:
            k = self._kernels.certified_sequence(data, poses, w, last,
                                                 bool(np.isfinite(last).all()), T, info,
                                                 codes, k, work)
            if k < N:
                prev = last if np.isfinite(last).all() else None
                # The pose's wrench: its row, or the one for every pose (w is (1, n)).
                sol = distribute(self.robot, p[k], self.problem, self.backend,
                                 wrench=None if wrench is None else w[min(k, len(w) - 1)],
                                 previous=prev, **self.options)
                T[k], info[k] = sol.tensions[0], _info_of(sol)[0]
                fallback[k] = Status(sol.status[0])
                done[k] = False
                if self._goes_on(Status(sol.status[0])):
                    last = sol.tensions[0].copy()
                k += 1
        if np.isfinite(last).all():
            self._local.last = last
        status = _STATUS_VALUES[np.minimum(codes, len(_STATUS))]
        for i, value in fallback.items():
            status[i] = value
        return _result(T, status, info, done)


#: Columns of a batch's per-pose results (:data:`tension_opt.kernels.distributor.INFO`).
_INFO = 6


def _certificate_of(sol: TensionSolution, k: int) -> tuple[float, float, float]:
    """The certificate of pose ``k`` of a solution, as floats."""
    fields = (sol.primal_residual, sol.dual_residual, sol.duality_gap)
    return tuple(_NAN if x is None else float(x[k]) for x in fields)  # type: ignore[return-value]


def _info_of(sol: TensionSolution) -> NDArray:
    """A solution's per-pose results (N, 6): unique, residual, infeasibility and the
    certificate's three measures, the columns of the kernels' ``info``."""
    nan = np.full(sol.N, np.nan)
    return np.column_stack([sol.unique, sol.residual, sol.infeasibility,
                            *(nan if x is None else x for x in (
                                sol.primal_residual, sol.dual_residual, sol.duality_gap))])


def _result(T: NDArray, status: NDArray, info: NDArray, compiled: NDArray) -> RealtimeResult:
    """The :class:`RealtimeResult` of a batch from its per-pose results (:func:`_info_of`)."""
    return RealtimeResult(T, status, info[:, 0] != 0.0, info[:, 1], info[:, 2], compiled,
                          info[:, 3], info[:, 4], info[:, 5])
