"""Platform stiffness of one pose, compiled, for control loops: :class:`PoseStiffness`.

The numpy reference is :func:`catenary.stiffness_analysis` (:mod:`catenary.
robot_stiffness`); the kernel is :func:`catenary.stiffness_kernels.stiffness_pose`,
called through its machine-code entry point (no type dispatch per call). Without given
tensions the cable state comes from the real-time classes of the model's own
equilibrium: :class:`tension_opt.Distributor` for straight cables,
:class:`catenary.coupled_ik.CoupledIK` for sagging ones, each certified in its own
terms; the stiffness then takes their status. A pose the kernel leaves (a vertical
cable, a catenary or a limit of the span formulas the compiled code does not settle)
is computed by the numpy reference from the same tensions or catenaries.
"""

from __future__ import annotations

import math
import threading
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot
from tension_opt.kernels.first_use import announce
from tension_opt.kernels.launch import entry_point
from tension_opt.status import STATUS_DTYPE, Status

from .coupled_ik import CoupledIK
from .errors import InvalidCableError
from .geometry import cable_data
from .robot_stiffness import MODELS, StiffnessResult, reference_result, stiffness_analysis
from .stiffness_compiled import CatenaryState, kernel_model, pack
from .stiffness_kernels import (
    COUPLED_STATE,
    FALLBACK,
    INVALID,
    NOT_RUN,
    OK,
    STRAIGHT,
    stiffness_pose,
)

__all__ = ["PoseStiffness"]

FloatArray = NDArray[np.float64]
_SUCCESS = (Status.CONVERGED, Status.OPTIMAL)
#: A status array of one pose per status, copied into each result.
_STATUS = {s: np.array([s.value], dtype=STATUS_DTYPE) for s in Status}


class _Buffers(threading.local):
    """One thread's scratch of the kernel (41,) and the empty catenary state."""

    def __init__(self, m: int) -> None:
        self.scratch = np.empty(41)
        self.none, self.none3 = np.zeros(m), np.zeros((m, 3))


def _result(**fields: Any) -> StiffnessResult:
    """A :class:`StiffnessResult` of ``fields`` (all of them): its frozen ``__init__``
    sets the eight fields one ``object.__setattr__`` at a time, 2 us of a loop's call;
    the instance's dict takes them at once."""
    result = object.__new__(StiffnessResult)
    result.__dict__.update(fields)
    return result


class PoseStiffness:
    """``catenary.stiffness_analysis(robot, pose, tensions, model, ...)`` for one pose at
    a time, built once per robot and model, called per pose.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable``: a finite ``EA`` for ``"straight"``; a weight or a finite
        ``EA`` for ``"coupled"``.
    model : {"coupled", "straight"}
        Sagging elastic catenaries or straight elastic cables.
    objective, backend, **options
        How tensions are found where none are given: a
        :class:`tension_opt.Distributor` (``"straight"``) or a
        :class:`catenary.coupled_ik.CoupledIK` (``"coupled"``) built on first need with
        these arguments.
    end : {"B", "A"}
        ``"coupled"`` with given tensions: where they act along a catenary, the drawing
        point (default) or the platform.

    Calling
    -------
    ``stiffness(pose, tensions=None, wrench=None)``, a pose (n,) (m, rad), tensions (m,)
    (N, >= 0; NaN marks a pose without tensions) and an external wrench (n,) (N, N m),
    returns the :class:`~catenary.robot_stiffness.StiffnessResult` of the pose (arrays
    with a first axis of length 1), the reference's to rounding: status
    ``"converged"`` for given tensions (``"not_run"`` with NaN, ``"catenary_failed"``
    where no taut catenary carries one), else the status of the distribution or the
    coupled inverse kinematics. Robots of other kinds, weightless catenaries and step
    maps of their own run the numpy reference.

    Thread-safe: each thread has its own scratch; the results are fresh arrays.

    Raises
    ------
    InvalidCableError
        For an unknown model or ``end``, a robot without suitable cable properties, or
        a pose, tensions or wrench that are not one finite vector of the right length
        (tensions >= 0).
    """

    def __init__(
        self,
        robot: CableRobot,
        model: Literal["coupled", "straight"] = "coupled",
        objective: Any = "min_sum",
        backend: Any = "auto",
        *,
        end: Literal["A", "B"] = "B",
        **options: Any,
    ) -> None:
        if model not in MODELS:
            raise InvalidCableError(f'model must be "coupled" or "straight"; got model={model!r}')
        if end not in ("A", "B"):
            raise InvalidCableError(f'end must be "A" or "B"; got end={end!r}')
        w, EA = cable_data(robot)
        if model == "straight" and not math.isfinite(EA):
            raise InvalidCableError(
                "the straight model needs elastic cables (finite EA): give the robot "
                "cable=CableProperties(..., EA=...) or use model='coupled'"
            )
        if model == "coupled" and w == 0.0 and not math.isfinite(EA):
            raise InvalidCableError(
                "weightless inextensible cables are rigid: give the robot a cable weight "
                "or a finite EA"
            )
        self.robot, self.model, self.end, self._w = robot, model, end, w
        self.objective, self.backend, self.options = objective, backend, dict(options)
        self._given = kernel_model(robot, model, True, end)
        self._state = kernel_model(robot, model, False)
        self._source: Any = None
        self._lock = threading.Lock()
        self._local = _Buffers(robot.m)
        self._kernel: Any = None
        if self._given >= 0:
            self._data = pack(robot)
            announce("platform stiffness", stiffness_pose)
            m, n = robot.m, robot.dof
            self._kernel = entry_point(
                stiffness_pose,
                self._data,
                0,
                np.zeros(n),
                np.zeros(n),
                np.zeros(m),
                np.zeros(m),
                np.zeros((m, 3)),
                np.zeros(m),
                np.empty((n, n)),
                np.empty((m, 3, 3)),
                np.empty((m, 3)),
                np.empty(m),
                np.empty(m),
                np.empty(41),
            )
        self._no_wrench = np.zeros(robot.dof)

    def __call__(
        self, pose: ArrayLike, tensions: ArrayLike | None = None, wrench: ArrayLike | None = None
    ) -> StiffnessResult:
        """Stiffness of one pose (see the class docstring)."""
        p = self._vector("pose", pose, self.robot.dof)
        wr = self._no_wrench if wrench is None else self._vector("wrench", wrench, self.robot.dof)
        if self._kernel is None:
            return self._numpy(p, tensions, wrench)
        local = self._local
        if tensions is not None:
            T = self._vector("tensions", tensions, self.robot.m)
            return self._run(self._given, p, wr, T, None, Status.CONVERGED, wrench)
        source = self._source or self._default()
        if self._state == COUPLED_STATE:
            ik = source(p, wrench)
            state = (ik.horizontal_tensions[0], ik.platform_forces[0], ik.lengths[0])
            return self._run(COUPLED_STATE, p, wr, local.none, state, ik.status[0], wrench)
        sol = source(p, wrench)
        return self._run(
            self._given, p, wr, np.asarray(sol.tensions, dtype=float), None, sol.status, wrench
        )

    def _run(
        self,
        model: int,
        p: FloatArray,
        wr: FloatArray,
        T: FloatArray,
        state: CatenaryState | None,
        status: Any,
        wrench: ArrayLike | None,
    ) -> StiffnessResult:
        """The kernel on one pose, the numpy reference where it leaves the pose."""
        m, n = self.robot.m, self.robot.dof
        K, Kc, forces = np.empty((1, n, n)), np.empty((1, m, 3, 3)), np.empty((1, m, 3))
        tens, lengths = np.empty((1, m)), np.empty((1, m))
        local = self._local
        H, F, L0 = (local.none, local.none3, local.none) if state is None else state
        code, res = self._kernel(
            self._data,
            model,
            p,
            wr,
            T,
            H,
            F,
            L0,
            K[0],
            Kc[0],
            forces[0],
            tens[0],
            lengths[0],
            local.scratch,
        )
        if code == INVALID:
            self.robot.as_poses(p)  # raises the robot's error naming the pose
            if not np.isfinite(wr).all():
                raise InvalidCableError(f"wrench must be finite; got wrench={wrench!r}")
            raise InvalidCableError(
                "tensions must be finite and >= 0 (N): cables only "
                f"pull (NaN marks a pose without tensions); got {T!r}"
            )
        if code == NOT_RUN and model != COUPLED_STATE and status == Status.CONVERGED:
            status = Status.NOT_RUN
        codes = (
            _STATUS[status].copy()
            if status in _STATUS
            else np.array([str(status)], dtype=STATUS_DTYPE)
        )
        if code == FALLBACK:
            given = None if state is not None else T[None].copy()
            one = None if state is None else (state[0][None], state[1][None], state[2][None])
            return reference_result(
                self.robot, p[None], self.model, codes, given, one, self.end, wrench
            )
        if code != OK and not (code == NOT_RUN and model == STRAIGHT):
            for a in (Kc, forces, tens, lengths):
                a.fill(np.nan)
        if code != OK or status not in _SUCCESS:
            K.fill(np.nan)
        return _result(
            stiffness=K,
            cable_stiffness=Kc,
            platform_forces=forces,
            tensions=tens,
            lengths=lengths,
            equilibrium_residual=np.array([res]),
            status=codes,
            model=self.model,
        )

    def _default(self) -> Any:
        """The real-time class of the model's own equilibrium, built on first need."""
        with self._lock:
            if self._source is None:
                if self.model == "straight":
                    self._source = tension_opt.Distributor(
                        self.robot, self.objective, self.backend, **self.options
                    )
                else:
                    self._source = CoupledIK(
                        self.robot, self.objective, self.backend, **self.options
                    )
            return self._source

    def _numpy(
        self, p: FloatArray, tensions: ArrayLike | None, wrench: ArrayLike | None
    ) -> StiffnessResult:
        """The numpy reference (robots and models the kernel does not cover)."""
        return stiffness_analysis(
            self.robot,
            p[None],
            tensions,
            self.model,  # type: ignore[arg-type]
            end=self.end,
            wrench=wrench,
            objective=self.objective,
            backend=self.backend,
            **self.options,
        )

    def _vector(self, name: str, value: ArrayLike, size: int) -> FloatArray:
        """``value`` as a float vector of ``size`` entries, or the error naming it."""
        try:
            v = np.ascontiguousarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InvalidCableError(f"{name} must be numbers; got {name}={value!r}") from exc
        if v.shape != (size,):
            raise InvalidCableError(
                f"{name} must have shape ({size},) (one pose of this robot); got shape "
                f"{v.shape}: use catenary.stiffness_analysis for a batch of poses"
            )
        return v
