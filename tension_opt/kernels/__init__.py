"""Compiled (numba) kernels of the real-time path, one pose at a time or in parallel.

Each kernel module is named after the module it twins and imports only the ground
(:mod:`tension_opt.errors`, :mod:`tension_opt.status`, :mod:`tension_opt.checks`,
:mod:`tension_opt.kinds`, :mod:`tension_opt.tolerances`) and other kernels: arrays in,
arrays out.

The numpy implementations (:mod:`tension_opt.robot`, :mod:`tension_opt.backends.closed_form`,
:mod:`tension_opt.certify.scaling`, :mod:`tension_opt.certify.certificate`) are the reference these
kernels are tested against. numba compiles each kernel on its first call and caches the
machine code on disk (``cache=True``), so importing this package compiles nothing;
:mod:`tension_opt.distribution.distributor` imports it only when a
:class:`~tension_opt.distribution.distributor.Distributor` is built.

The one-pose kernels allocate nothing: their temporaries live in a work array the caller
owns (one per thread; :func:`~tension_opt.kernels.closed_form.work_size`), each kernel
taking its own arrays from the front of it and handing the rest to the kernels it calls.
The batch kernels allocate one work array per chunk of poses, and make the reshaped
views of it once per chunk (numba's ``reshape`` costs 15-30 ns, as much as the
arithmetic of a pose). The small functions a per-pose loop calls (geometry, the
four-cable closed form, its checks, the scaling and the pivoting solve) are compiled
``inline="always"``: numba's call of a function taking arrays, and what it prevents
the optimiser from seeing, cost more than their arithmetic (the study robot's
per-pose loop ran twice as fast with them inlined). They return once, at their end, and
read each array argument last outside any branch (where the logic has a branch, the
arrays are read once more after it): numba counts a reference to each array argument
of an inlined function and releases it after the argument's last use, and LLVM's
pruning of these counts gives up where a release sits in a branch or before one of
several exits, leaving two atomic operations per array and call (they cost the study
robot's certified closed form, :mod:`tension_opt.kernels.certified`, a third of its
time). For the same reason a loop calls the compiled functions it does not inline
itself, outside the inlined steps, and takes its arrays as arguments.

- :mod:`tension_opt.kernels.geometry`: structure matrix and required wrench of every
  robot kind;
- :mod:`tension_opt.kernels.affine`, :mod:`tension_opt.kernels.lowdim`: the null
  space and the minimisation over it;
- :mod:`tension_opt.kernels.closed_form`: the exact closed form for null spaces of
  dimension 1 and 2 (every objective it covers, the tie-break, the feasibility check
  of the status), one pose, a parallel batch or a sequence;
- :mod:`tension_opt.kernels.dense_qp`: the scaled dense QP of one pose for DAQP and
  the certificate of DAQP's answer;
- :mod:`tension_opt.kernels.daqp_native`: DAQP's C solver called from compiled code
  (one pose, or the ``qpsolvers:daqp`` backend's batch), checked against ``daqp.solve``;
- :mod:`tension_opt.kernels.scaling`, :mod:`tension_opt.kernels.certificate`: the
  scaling of every problem handed to a generic backend, the three measures of its
  certificate and the cheap dual solve (numpy references:
  :func:`tension_opt.certify.scaling.scaling_reference`,
  :func:`tension_opt.certify.certificate.measures_reference`,
  :func:`tension_opt.certify.certificate.estimate_multipliers_reference`);
- :mod:`tension_opt.kernels.refit`: the certificate's sign-constrained refit of a
  pose's multipliers (a bounded least-squares fit; numpy reference: scipy's in
  :func:`tension_opt.certify.certificate.certify`);
- :mod:`tension_opt.kernels.certified`: the closed form of independent poses with its
  diagnostics and certificate, pose by pose, from the one-pose functions of the
  modules above (the certified path of large batches, :mod:`tension_opt.distribution.certified`);
- :mod:`tension_opt.kernels.certified_lanes`, :mod:`tension_opt.kernels.certified_lane_steps`: the
same
  for a point robot on four cables, poses side by side in the vector unit, bit for bit
  the pose-by-pose loop;
- :mod:`tension_opt.kernels.sensitivity`, :mod:`tension_opt.kernels.sensitivity_lanes`,
  :mod:`tension_opt.kernels.derivatives`: the Jacobians of optimal tensions by the wrench
  and the pose (numpy reference:
  :class:`tension_opt.distribution.sensitivity.KktSystem`), four-cable point robots side
  by side, and the structure matrix's derivatives by the pose (reference:
  :func:`tension_opt.robot.derivatives.pose_derivatives`);
- :mod:`tension_opt.kernels.launch`: when a batch kernel runs in parallel (large
  batches, one launch at a time, never in a forked child of an OpenMP process).
"""
