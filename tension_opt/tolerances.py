"""Every tolerance that a layer shares with its compiled twin, and the accuracy targets.

One place for the numbers that the numpy code and the kernels must agree on (a kernel
imports them from here, never from the layer it twins), and for the vocabulary of the
``accuracy`` option: a target on the certificate of the scaled problem (primal
residual, dual residual, duality gap), ``"default"`` 1e-7, ``"high"`` 1e-10, or a
number.
"""

from __future__ import annotations

from tension_opt.checks import is_number
from tension_opt.errors import InvalidInputError

__all__ = ["ACCURACY_TARGETS", "DEFAULT_TARGET", "FEASIBILITY_TOL", "HIGH_TARGET", "RIDGE",
           "ROW_FLOOR", "SENSITIVITY_ACTIVE_TOL", "SENSITIVITY_COND_MAX",
           "SENSITIVITY_MULTIPLIER_TOL", "UB_SHARE", "accuracy_target"]

#: Target of ``accuracy="default"`` on the three measures of the scaled problem.
DEFAULT_TARGET = 1e-7

#: Target of ``accuracy="high"``.
HIGH_TARGET = 1e-10

#: Accuracy names and their targets.
ACCURACY_TARGETS: dict[str, float] = {"default": DEFAULT_TARGET, "high": HIGH_TARGET}

#: Loosest and tightest numeric targets accepted (below 1e-14 rounding alone fails).
_LOOSEST, _TIGHTEST = 1e-2, 1e-14

#: Ridge of the dual fit, relative to its largest diagonal entry (a rank-deficient
#: structure matrix leaves some equation multipliers free).
RIDGE = 1e-13

#: Relative tolerance (of the typical tension) on equilibrium and bounds of a solution.
FEASIBILITY_TOL = 1e-6

#: Equilibrium rows are scaled to unit length, but by at most ``1 / ROW_FLOOR`` times the
#: longest row's factor (see the module docstring).
ROW_FLOOR = 1e-3

#: The reference tension is at least this share of the largest finite upper bound (see
#: :func:`tension_opt.certify.scaling.form_scaling`).
UB_SHARE = 1e-3


def accuracy_target(accuracy: object) -> float:
    """The target of an ``accuracy`` option: ``"default"`` (or None) 1e-7, ``"high"``
    1e-10, or a number between 1e-14 and 1e-2.

    Raises
    ------
    InvalidInputError
        For another name or a number out of range.
    """
    if accuracy is None:
        return DEFAULT_TARGET
    if isinstance(accuracy, str) and accuracy in ACCURACY_TARGETS:
        return ACCURACY_TARGETS[accuracy]
    if is_number(accuracy) and _TIGHTEST <= float(accuracy) <= _LOOSEST:  # type: ignore[arg-type]
        return float(accuracy)  # type: ignore[arg-type]
    raise InvalidInputError(
        f"accuracy must be one of {list(ACCURACY_TARGETS)} or a number between "
        f"{_TIGHTEST:g} and {_LOOSEST:g} (the target on primal residual, dual residual and "
        f"duality gap of the scaled problem), got {accuracy!r}")

#: The Jacobians' active set (:mod:`tension_opt.distribution.sensitivity` and its
#: compiled twins): distance (scaled: reference tensions) within which a point is on a
#: bound or row, and size (scaled) beyond which a multiplier counts as nonzero.
SENSITIVITY_ACTIVE_TOL = 1e-5
SENSITIVITY_MULTIPLIER_TOL = 1e-5
#: Largest 1-norm condition number of a KKT matrix the Jacobians take as nonsingular.
SENSITIVITY_COND_MAX = 1e10
