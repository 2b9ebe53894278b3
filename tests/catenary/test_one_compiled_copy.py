"""Each heavy per-pose kernel is compiled once: numba compiles a kernel per combination
of argument types, and a read-only array or a strided view is another type, so a call
path that passes one compiles (or loads) the whole kernel a second time, tens of
seconds on a first call. The kernels called from Python are checked (a kernel only
called from compiled code lists no signature when its caller came from the cache, so
a read-only array in a signature counts as a second copy too), with the user's poses
and previous tensions read-only and writable, in a fresh process (other tests call
kernels with types of their own)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import numpy as np
    from numba import types
    import tension_opt as to
    from catenary import coupled_ik, thesis_ik_kernels
    from catenary.coupled_ik import CoupledIK
    from catenary.inverse import inverse_kinematics
    from catenary.thesis_ik import ThesisIK
    from tension_opt.kernels import distributor as realtime

    def read_only(a):
        view = np.array(a, dtype=float)
        view.flags.writeable = False
        return view

    robot = to.presets.algae_harvester()
    poses = read_only([[0.0, 0.0, 0.5], [5.0, 3.0, 1.0], [-10.0, 4.0, 2.0]])
    smoothed = to.Distributor(robot, to.TensionProblem("min_norm", smoothing=1.0))
    smoothed(poses[0])
    smoothed(poses)  # a stream
    smoothed(poses, previous=read_only(np.full((3, robot.m), 1e3)))  # own previous
    CoupledIK(robot)(poses[1])
    CoupledIK(robot)(np.array(poses[2]))
    inverse_kinematics(robot, poses, model="coupled", compiled=True)
    ThesisIK(robot)(poses[1])
    inverse_kinematics(robot, poses, model="thesis", compiled=True)
    for kernel in (realtime.certified_one, realtime.certified_sequence,
                   realtime.certified_batch_serial, coupled_ik.solve_pose,
                   thesis_ik_kernels.thesis_pose):
        # These take only writable arrays, so a read-only one in a signature is the sign
        # of a second copy (a kernel only called from compiled code shows no signature
        # when its caller was cached). ThesisIK passes the robot's read-only anchors on
        # both of its paths.
        readonly = kernel is not thesis_ik_kernels.thesis_pose and any(
            isinstance(t, types.Array) and not t.mutable
            for s in kernel.signatures for t in s)
        print(kernel.py_func.__name__, len(kernel.signatures) + readonly)
""")


def test_every_kernel_called_from_python_has_one_signature() -> None:
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         timeout=900, check=True).stdout
    counts = dict(line.split() for line in out.strip().splitlines())
    assert counts == {"certified_one": "1", "certified_sequence": "1",
                      "certified_batch_serial": "1", "solve_pose": "1",
                      "thesis_pose": "1"}, out
