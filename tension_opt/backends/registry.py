"""The one list of backends, and the one place a backend is chosen.

Each backend family is a module listed in :data:`FAMILIES`; it defines
``available() -> list[str]`` (the registry names it can serve on this machine) and
``make(solver: str | None) -> Backend``. Modules are imported when first asked for, so
a missing optional solver costs nothing until named. A new backend family is one
module and one line here.

Which backend solves a batch is decided here and nowhere else: :func:`choose_backend`
(a named backend, checked, or for ``"auto"`` the first installed backend of an order
that can take the problem), :func:`route` (that choice for a call of
:func:`~tension_opt.distribute`, with the automatic fallback and the hand-over of a
form a named backend cannot take) and :func:`solve_routed` (the solve, with the poses
the backend leaves ``SOLVER_ERROR`` solved again by the next able backend of
:data:`AUTO_ORDER`).
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from tension_opt.backends.base import Backend, RawResult
from tension_opt.errors import BackendNotAvailableError, UnsupportedProblemError
from tension_opt.problem.form import StandardForm
from tension_opt.status import Status

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


def _label(form: StandardForm, what: str) -> str:
    """What the problem is, for an error message (built only when one is raised)."""
    return what or (form.problem.name if form.problem is not None else "this problem")


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
    if isinstance(backend, Backend):
        chosen = backend
    elif isinstance(backend, str) and backend == "auto":
        installed = set(available_backends())
        for name in order:
            if name in installed and get_backend(name).unsupported(form) is None:
                return get_backend(name)
        raise UnsupportedProblemError(
            f"no installed backend solves {_label(form, what)}; "
            "pip install 'tension-opt[solvers]'")
    else:
        chosen = get_backend(backend)
    reason = chosen.unsupported(form)
    if reason is not None:
        raise UnsupportedProblemError(
            f"{reason} (problem: {_label(form, what)}; backends that can: "
            f"{able_backends(form)})")
    return chosen


@dataclass(frozen=True)
class Route:
    """How a batch is solved: by ``backend``, and, with ``fallback``, the poses it
    leaves ``SOLVER_ERROR`` (a pose its method does not cover, such as a rank-deficient
    structure matrix in the closed form) by the next able backends of
    :data:`AUTO_ORDER`."""

    backend: Backend
    fallback: bool


def route(backend: str | Backend, form: StandardForm, *, hand_over: bool = False,
          fallback: bool = False) -> Route:
    """The route of ``form`` for a call that asked for ``backend``.

    ``"auto"`` is the first able backend of :data:`AUTO_ORDER`, with the fallback. A
    named backend (or an instance) solves alone; with ``hand_over`` a form it cannot
    take goes to the automatic choice instead of raising (the unsmoothed first pose of a
    smoothed sequence, an LP, on a QP-only solver). ``fallback`` asks for the fallback
    whatever the backend (the poses of a sequence whose call said ``"auto"``).

    Raises
    ------
    UnsupportedProblemError, BackendNotAvailableError
        As :func:`choose_backend`.
    """
    auto = isinstance(backend, str) and backend == "auto"
    if hand_over and not auto:
        named = backend if isinstance(backend, Backend) else get_backend(backend)
        if named.unsupported(form) is not None:
            return Route(choose_backend("auto", form), True)
        return Route(named, fallback)
    return Route(choose_backend(backend, form), auto or fallback)


def solve_routed(way: Route, form: StandardForm, options: dict[str, Any]) -> RawResult:
    """``way.backend.solve(form, **options)``; with the fallback, the poses it reports
    ``SOLVER_ERROR`` solved again by each later able backend of :data:`AUTO_ORDER` in
    turn, their answers, certificates and times merged in (``extras["fallback"]``:
    ``{backend: [poses]}``)."""
    backend = way.backend
    raw = backend.solve(form, **options)
    if not way.fallback or not (raw.status == Status.SOLVER_ERROR).any():
        return raw
    order = list(AUTO_ORDER)
    later = order[order.index(backend.name) + 1:] if backend.name in order else order
    installed = set(available_backends())
    for name in later:
        failed = np.flatnonzero(raw.status == Status.SOLVER_ERROR)
        if not len(failed):
            break
        other = get_backend(name) if name in installed else None
        sub = form.subset(failed)
        if other is None or other.unsupported(sub) is not None:
            continue
        again = other.solve(sub, **options)
        raw.put(failed, again)
        answered = failed[again.status != Status.SOLVER_ERROR]
        if len(answered):
            raw.extras.setdefault("fallback", {})[name] = answered.tolist()
    return raw
