"""The kernel families of ``catenary`` for ``python -m tension_opt warmup``
(:mod:`tension_opt.warmup`), registered when ``catenary`` is imported: the single
cable (few cables one at a time, batches side by side in the vector unit, the
bracketing search), the thesis convention's sag inverse kinematics of one pose, the
coupled model's, the platform stiffness (one pose, serial and parallel batches) and the
distances between sagging cables."""

from __future__ import annotations

import numpy as np

from tension_opt import warmup

__all__: list[str] = []


def _single_cable() -> None:
    from catenary.solve import solve_forces, solve_length

    for count in (4, 64):  # one at a time, and side by side
        x, z = np.linspace(5.0, 40.0, count), np.linspace(-3.0, 8.0, count)
        w = np.full(count, 1.5)
        for EA in (np.inf, 1e6):
            solve_length(x, z, np.full(count, 2e3), w, EA=EA)
            solve_length(x, z, np.full(count, 2e3), w, EA=EA, end="A")
            solve_forces(x, z, np.hypot(x, z) * 1.01, w, EA=EA)


def _thesis_ik() -> None:
    from catenary.inverse import inverse_kinematics
    from catenary.thesis_ik import ThesisIK
    from tension_opt.robot import presets

    robot = presets.algae_harvester()
    pose = np.array([[5.0, 3.0, 0.5]])
    inverse_kinematics(robot, pose, model="thesis")
    ThesisIK(robot)(pose[0])


def _coupled_ik() -> None:
    from catenary.coupled_ik import CoupledIK
    from catenary.inverse import inverse_kinematics
    from tension_opt.robot import presets

    robot = presets.algae_harvester()
    pose = np.array([[5.0, 3.0, 0.5]])
    inverse_kinematics(robot, pose, model="coupled")
    CoupledIK(robot)(pose[0])


def _stiffness() -> None:
    from catenary.stiffness_compiled import compiled_stiffness, kernel_model, pack
    from catenary.stiffness_kernels import stiffness_batch, stiffness_parallel
    from catenary.stiffness_loop import PoseStiffness
    from tension_opt.robot import presets

    robot = presets.cogiro()
    pose = robot.default_home()
    tensions = np.full(robot.m, 200.0)
    for model in ("straight", "coupled"):
        stiffness = PoseStiffness(robot, model)
        stiffness(pose, tensions)
    code, n, m = kernel_model(robot, "straight", True), robot.dof, robot.m
    out = compiled_stiffness(robot, pack(robot), code, pose[None], np.zeros((1, n)),
                             tensions[None])
    # The parallel variant too (the launch rule picks it for large batches).
    # The argument types compiled_stiffness passes (writable poses).
    for kernel in (stiffness_batch, stiffness_parallel):
        kernel(pack(robot), code, np.array(pose[None]), np.zeros((1, n)), tensions[None],
               np.zeros((1, m)), np.zeros((1, m, 3)), np.zeros((1, m)), out.stiffness,
               out.cable_stiffness, out.platform_forces, out.tensions, out.lengths,
               out.equilibrium_residual, out.codes)

def _interference() -> None:
    from catenary.curves import CatenaryCurves
    from catenary.interference import curve_distance

    # Two hanging cables, the kernel alone (the sag IK is a family of its own).
    curves = [CatenaryCurves(np.array([0.0, y, 0.0]), np.array([1.0, 0.0, 0.0]),
                             np.array(200.0), np.array(-20.0), np.array(10.2), 2.0, EA,
                             np.zeros(3)) for y, EA in ((0.0, np.inf), (0.5, 1e6))]
    curve_distance(curves[0], curves[1], compiled=True)


warmup.register("catenary: single cable", _single_cable)
warmup.register("catenary: thesis sag IK", _thesis_ik)
warmup.register("catenary: coupled sag IK", _coupled_ik)
warmup.register("catenary: platform stiffness", _stiffness)
warmup.register("catenary: sagging-cable interference", _interference)
