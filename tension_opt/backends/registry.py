"""The one list of backends, and the one place a backend is chosen.

Each backend family is a module listed in :data:`FAMILIES`; it defines
``available() -> list[str]`` (the registry names it can serve on this machine) and
``make(solver: str | None) -> Backend``. Modules are imported when first asked for, so
a missing optional solver costs nothing until named. A new backend family is one
module and one line here.

Backend choice (``"auto"``, or the first installed backend that can take a given
problem) is :func:`choose_backend`; every caller goes through it.
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Sequence
from types import ModuleType

from tension_opt.backends.base import Backend
from tension_opt.errors import BackendNotAvailableError, UnsupportedProblemError
from tension_opt.problem.form import StandardForm

#: Backend families: registry prefix -> module.
FAMILIES: dict[str, str] = {
    "closed_form": "tension_opt.backends.closed_form",
    "cvxpy": "tension_opt.backends.cvxpy_backend",
    "qpsolvers": "tension_opt.backends.qpsolvers_backend",
    "scipy": "tension_opt.backends.scipy_backend",
}

#: Preference of ``backend="auto"``: exact first, then the fastest iterative solvers.
AUTO_ORDER: tuple[str, ...] = (
    "closed_form", "qpsolvers:daqp", "qpsolvers:proxqp", "qpsolvers:piqp",
    "qpsolvers:highs", "scipy:highs", "cvxpy:CLARABEL", "cvxpy",
)
#: Preference for linear programs the closed form does not cover (e.g. the margin LP).
LP_ORDER: tuple[str, ...] = (
    "qpsolvers:daqp", "qpsolvers:highs", "scipy:highs", "qpsolvers:piqp",
    "cvxpy:CLARABEL", "cvxpy",
)

_INSTANCES: dict[str, Backend] = {}
_AVAILABLE: list[str] = []
# Re-entrant: get_backend lists the installed backends in its error messages.
_LOCK = threading.RLock()


def _family(prefix: str) -> ModuleType:
    return importlib.import_module(FAMILIES[prefix])


def available_backends() -> list[str]:
    """Names of every installed backend and solver, e.g. ``"qpsolvers:daqp"``.

    Found once per process (asking cvxpy for its solvers tries to import every solver
    it knows, which cost most of a one-pose :func:`~tension_opt.distribute`).
    """
    with _LOCK:
        if not _AVAILABLE:
            for prefix in FAMILIES:
                _AVAILABLE.extend(_family(prefix).available())
        return list(_AVAILABLE)


def get_backend(name: str) -> Backend:
    """Backend instance for a registry name such as ``"cvxpy:CLARABEL"``.

    Backends hold no state of a call (each says how it serves threads), so one instance
    per name is kept and shared by every thread.

    Raises
    ------
    BackendNotAvailableError
        For a name that is not a string, an unknown family, or a solver (suffix) that
        is not installed; the message lists the installed backends.
    """
    if not isinstance(name, str):
        raise BackendNotAvailableError(
            f"backend must be a registry name or a Backend, got {name!r}; "
            f"installed: {available_backends()}")
    with _LOCK:
        if name not in _INSTANCES:
            prefix, _, solver = name.partition(":")
            if prefix not in FAMILIES:
                raise BackendNotAvailableError(
                    f"unknown backend {name!r}; installed: {available_backends()}")
            try:
                _INSTANCES[name] = _family(prefix).make(solver or None)
            except BackendNotAvailableError as error:
                raise BackendNotAvailableError(
                    f"{error}; installed backends: {available_backends()}") from None
        return _INSTANCES[name]


def able_backends(form: StandardForm) -> list[str]:
    """Installed backends that can take ``form``."""
    return [n for n in available_backends() if get_backend(n).unsupported(form) is None]


def choose_backend(backend: str | Backend, form: StandardForm,
                   order: Sequence[str] = AUTO_ORDER, *, what: str = "") -> Backend:
    """The backend for ``form``: the one named (checked), or the first of ``order``
    installed that can take it when ``backend="auto"``.

    Parameters
    ----------
    backend : str or Backend
        ``"auto"``, a registry name or a backend instance.
    form : StandardForm
        A representative problem of the batch.
    order : sequence of str
        Preference of ``"auto"`` (:data:`AUTO_ORDER`, or :data:`LP_ORDER`).
    what : str
        What the problem is, for error messages (default: the problem's name).

    Raises
    ------
    UnsupportedProblemError
        If the named backend cannot take the problem (naming those that can), or no
        installed backend can.
    """
    label = what or (form.problem.name if form.problem is not None else "this problem")
    if isinstance(backend, Backend):
        chosen = backend
    elif isinstance(backend, str) and backend == "auto":
        installed = set(available_backends())
        for name in order:
            if name in installed and get_backend(name).unsupported(form) is None:
                return get_backend(name)
        raise UnsupportedProblemError(
            f"no installed backend solves {label}; pip install 'tension-opt[solvers]'")
    else:
        chosen = get_backend(backend)
    reason = chosen.unsupported(form)
    if reason is not None:
        raise UnsupportedProblemError(
            f"{reason} (problem: {label}; backends that can: {able_backends(form)})")
    return chosen
