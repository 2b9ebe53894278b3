"""The problem: objectives (:mod:`~tension_opt.problem.objectives`, one class each),
:class:`~tension_opt.problem.form.TensionProblem` and the frozen
:class:`~tension_opt.problem.form.StandardForm` it becomes for a batch of poses, and the
equilibrium's affine set ``T = T0 + Z z`` with the tension scale of a pose
(:mod:`~tension_opt.problem.affine`)."""

from tension_opt.problem.form import Objective, StandardForm, TensionProblem, as_problem

__all__ = ["Objective", "StandardForm", "TensionProblem", "as_problem"]
