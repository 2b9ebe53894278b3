"""The packed problem of the compiled passes: a robot and a problem as one float array.

:func:`pack_certified` is what the certified pass (:mod:`tension_opt.kernels.certified`)
and the compiled Jacobians (:mod:`tension_opt.kernels.sensitivity`) read;
:func:`pack_realtime` is the real-time path's (:mod:`tension_opt.kernels.distributor`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.problem.objectives import Centered, MinMax, MinNorm, MinSum, Pinv

__all__ = ["pack_certified", "pack_realtime"]


def pack_certified(robot: Any, problem: Any, target: float) -> NDArray | None:
    """:func:`~tension_opt.kernels.closed_form.pack_problem` of a robot and a problem
    (no per-pose rows, no smoothing), followed by what the certificate needs: ``target,
    objective code, vmax`` and the objective's weights ``w`` and target tensions ``r``
    (m,) each. None for an objective other than the package's five."""
    from tension_opt.kernels.certified import DISTANCE, LINEAR, MAX
    from tension_opt.kernels.closed_form import HEADER, pack_problem

    m = robot.m
    w = problem.cable_weights(m)
    r = np.zeros(m)
    objective = problem.objective
    if type(objective) is MinSum:
        code = LINEAR
    elif type(objective) is MinMax:
        code = MAX
    elif type(objective) is MinNorm:
        code = DISTANCE
        if problem.reference is not None:
            r = np.broadcast_to(np.asarray(problem.reference, dtype=float), (1, m))[0]
    elif type(objective) is Centered:
        code = DISTANCE
        lb, ub = problem.bounds(robot, 1)
        r = 0.5 * (lb[0] + ub[0])
    elif type(objective) is Pinv:
        code, w = DISTANCE, np.ones(m)
    else:
        return None
    data = pack_problem(robot, problem, target)
    vmax = 0.0
    if code == MAX:
        vmax = float(np.abs(data[HEADER + 8 * m:HEADER + 9 * m]).max(initial=0.0)) or 1.0
    return np.ascontiguousarray(np.concatenate([data, [target, code, vmax], w, r]))


def pack_realtime(robot: Any, problem: Any, target: float) -> NDArray:
    """The packed problem of the real-time path (:mod:`tension_opt.kernels.distributor`):
    :func:`pack_certified`'s layout for any objective the compiled closed form covers,
    smoothing and rate limit included (:func:`~tension_opt.kernels.closed_form.pack`
    holds them). For an objective other than the package's five, whose value the
    kernels do not measure, the objective's code, weights and target tensions are
    stand-ins (min-sum, ones, zeros)."""
    from tension_opt.kernels.certified import LINEAR
    from tension_opt.kernels.closed_form import HEADER, pack_problem

    data = pack_certified(robot, problem, target)
    if data is not None:
        return data
    m = robot.m
    packed = pack_problem(robot, problem, target)
    vmax = 0.0
    if packed[7] != 0.0:  # a min-max term: its largest weight, as pack_certified's
        vmax = float(np.abs(packed[HEADER + 8 * m:HEADER + 9 * m]).max(initial=0.0)) or 1.0
    return np.ascontiguousarray(np.concatenate([packed, [target, LINEAR, vmax], np.ones(m),
                                                np.zeros(m)]))
