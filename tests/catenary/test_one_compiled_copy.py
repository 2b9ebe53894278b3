"""Each heavy per-pose kernel is compiled once: numba compiles a kernel per combination
of argument types, and a read-only array or a strided view is another type, so a call
path that passes one compiles (or loads) the whole kernel a second time, tens of
seconds on a first call. The kernels called from Python are checked (a kernel only
called from compiled code lists no signature when its caller came from the cache),
with the user's poses and previous tensions read-only and writable."""

from __future__ import annotations

import numpy as np

import tension_opt as to
from catenary import coupled_ik, thesis_ik_kernels
from catenary.coupled_ik import CoupledIK
from catenary.inverse import inverse_kinematics
from catenary.thesis_ik import ThesisIK
from tension_opt.kernels import distributor as realtime


def _read_only(a: np.ndarray) -> np.ndarray:
    view = np.array(a, dtype=float)
    view.flags.writeable = False
    return view


def test_the_distributors_loops_share_its_one_pose_kernel() -> None:
    robot = to.presets.algae_harvester()
    poses = _read_only([[0.0, 0.0, 0.5], [5.0, 3.0, 1.0], [-10.0, 4.0, 2.0]])
    smoothed = to.Distributor(robot, to.TensionProblem("min_norm", smoothing=1.0))
    smoothed(poses[0])
    smoothed(poses)  # a stream
    smoothed(poses, previous=_read_only(np.full((3, robot.m), 1e3)))  # own previous
    for kernel in (realtime.certified_one, realtime.certified_sequence,
                   realtime.certified_batch_serial):
        assert len(kernel.signatures) == 1, (kernel.py_func.__name__, kernel.signatures)


def test_the_sag_kernels_have_one_signature_whatever_the_poses_flags() -> None:
    robot = to.presets.algae_harvester()
    poses = _read_only([[5.0, 3.0, 0.5], [0.0, 0.0, 1.0]])
    CoupledIK(robot)(poses[0])
    CoupledIK(robot)(np.array(poses[1]))
    inverse_kinematics(robot, poses, model="coupled", compiled=True)
    ThesisIK(robot)(poses[0])
    inverse_kinematics(robot, poses, model="thesis", compiled=True)
    for kernel in (coupled_ik.solve_pose, thesis_ik_kernels.thesis_pose):
        assert len(kernel.signatures) == 1, (kernel.py_func.__name__, kernel.signatures)
