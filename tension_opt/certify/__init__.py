"""The certificate: how a standard form is scaled for the solvers
(:mod:`~tension_opt.certify.scaling`) and how any answer is measured on that scaled
problem (primal residual, dual residual, duality gap;
:mod:`~tension_opt.certify.certificate`)."""

from tension_opt.certify.certificate import Certificate, Multipliers, certify, certify_form
from tension_opt.certify.scaling import ScaledBatch, Scaling, scaled_batch

__all__ = ["Certificate", "Multipliers", "ScaledBatch", "Scaling", "certify", "certify_form",
           "scaled_batch"]
