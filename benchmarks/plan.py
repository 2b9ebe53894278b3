"""Planning of the benchmark matrix: scenario x problem x backend x setting.

:func:`plan` lists every cell of the matrix in a stable order; :func:`default_suite`
cuts it to the modest suite that ``python -m benchmarks`` runs (:data:`DEFAULT_SUITE`);
:func:`select` picks scenarios or problems by name.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import tension_opt
from benchmarks.scenarios import PROBLEMS, SCENARIOS, ProblemSpec, Scenario, applicable

__all__ = [
    "ALL_SETTINGS",
    "DEFAULT_SUITE",
    "FAST_BACKENDS",
    "KEY",
    "Cell",
    "Setting",
    "SuiteRule",
    "default_suite",
    "plan",
    "select",
    "supports_warm_start",
]

#: Columns that identify a cell's row: (scenario, problem, backend, setting label).
KEY = ("scenario", "problem", "backend", "setting")
#: Backends fast enough for the 10^4-pose scenario in the default suite.
FAST_BACKENDS = ("closed_form", "qpsolvers:daqp")


@dataclass(frozen=True)
class Setting:
    """Solver setting of a cell: accuracy (``"default"`` or ``"high"``) and warm start."""

    accuracy: str = "default"
    warm_start: bool = False

    @property
    def label(self) -> str:
        """E.g. ``"default/cold"``."""
        return f"{self.accuracy}/{'warm' if self.warm_start else 'cold'}"

    @classmethod
    def parse(cls, text: str) -> list[Setting]:
        """Settings from ``"default"`` (cold and warm), ``"high/warm"``, ``"high/cold"`` ..."""
        accuracy, _, start = text.partition("/")
        if accuracy not in ("default", "high"):
            raise ValueError(f"accuracy must be 'default' or 'high', got {accuracy!r}")
        if start in ("", "any"):
            return [cls(accuracy, False), cls(accuracy, True)]
        if start not in ("cold", "warm"):
            raise ValueError(f"start must be 'cold' or 'warm', got {start!r}")
        return [cls(accuracy, start == "warm")]


ALL_SETTINGS = (Setting("default", False), Setting("default", True), Setting("high", False),
                Setting("high", True))


@dataclass(frozen=True)
class Cell:
    """One cell of the matrix."""

    scenario: Scenario
    problem: ProblemSpec
    backend: str
    setting: Setting

    @property
    def key(self) -> tuple[str, str, str, str]:
        """(scenario, problem, backend, setting label): the row's identity in the store."""
        return (self.scenario.name, self.problem.name, self.backend, self.setting.label)


def supports_warm_start(backend: str) -> bool:
    """Whether an installed backend can warm start (False if it is not installed)."""
    try:
        return bool(tension_opt.get_backend(backend).warm_start)
    except Exception:
        return False


def plan(
    scenarios: Iterable[Scenario] | None = None,
    problems: Iterable[ProblemSpec] | None = None,
    backends: Sequence[str] | None = None,
    settings: Sequence[Setting] = ALL_SETTINGS,
) -> list[Cell]:
    """Every cell of the matrix, in a stable order.

    Parameters
    ----------
    scenarios, problems : iterables, optional
        Default: all of :data:`~benchmarks.scenarios.SCENARIOS` / ``PROBLEMS``.
        Sequential problems are posed on trajectories only.
    backends : sequence of str, optional
        Default: :func:`tension_opt.available_backends`. Names not installed are kept
        and become ``not_installed`` rows.
    settings : sequence of Setting
        Warm-start settings are kept only for backends that support warm starts.

    Returns
    -------
    list of Cell
        Ordered by scenario, problem, backend and setting; each once, however often a
        name or setting is given.
    """
    scenarios = _unique(SCENARIOS.values() if scenarios is None else scenarios)
    problems = _unique(PROBLEMS.values() if problems is None else problems)
    backends = list(dict.fromkeys(tension_opt.available_backends() if backends is None
                                  else backends))
    settings = list(dict.fromkeys(settings))
    warm = {b: supports_warm_start(b) for b in backends}
    return [Cell(sc, pr, be, s)
            for sc in scenarios for pr in problems if applicable(sc, pr)
            for be in backends for s in settings if warm[be] or not s.warm_start]


def _unique(items: Iterable[Any]) -> list[Any]:
    """Scenarios or problems, the first of each name, in order."""
    kept: dict[str, Any] = {}
    for item in items:
        kept.setdefault(item.name, item)
    return list(kept.values())


@dataclass(frozen=True)
class SuiteRule:
    """What the default suite keeps of a scenario's cells.

    Attributes
    ----------
    settings : tuple of str
        Setting labels kept.
    backends : tuple of str, optional
        Backends kept (None: all).
    joint : bool
        Whether joint smoothing is kept.
    enabled : bool
        False: the scenario runs only when asked for by name (or with ``--full``).
    """

    settings: tuple[str, ...] = ("default/cold",)
    backends: tuple[str, ...] | None = None
    joint: bool = True
    enabled: bool = True

    def keeps(self, cell: Cell, chosen: Collection[str] = ()) -> bool:
        """Whether the rule keeps ``cell``; dimensions in ``chosen`` are not cut."""
        if not self.enabled and "scenario" not in chosen:
            return False
        if "settings" not in chosen and cell.setting.label not in self.settings:
            return False
        if "backend" in chosen:
            return True
        return ((self.backends is None or cell.backend in self.backends)
                and (self.joint or not cell.problem.joint))


#: The default suite (``python -m benchmarks``): modest, within a few minutes on 2 cores.
#: Scenarios not listed here are kept whole; ``--full`` keeps everything.
DEFAULT_SUITE: dict[str, SuiteRule] = {
    "thesis_snapshots": SuiteRule(("default/cold", "high/cold")),
    "thesis_trajectory": SuiteRule(("default/cold", "default/warm", "high/cold")),
    "thesis_random": SuiteRule(),
    "cogiro_trajectory": SuiteRule(),
    "cogiro_random": SuiteRule(enabled=False),
    "thesis_long": SuiteRule(backends=FAST_BACKENDS, joint=False),
    "random_point3_m6": SuiteRule(),
    "random_point3_m7_symmetric": SuiteRule(),
    "random_spatial6_m7": SuiteRule(),
}


def default_suite(cells: Iterable[Cell], chosen: Collection[str] = ()) -> list[Cell]:
    """The cells of ``cells`` that the default suite runs (see :data:`DEFAULT_SUITE`).

    Parameters
    ----------
    cells : iterable of Cell
    chosen : collection of str
        Dimensions the user chose explicitly, among ``"scenario"``, ``"backend"`` and
        ``"settings"``: the suite's rules do not cut those (a disabled scenario runs when
        named, a backend or setting runs when asked for).

    Returns
    -------
    list of Cell
        The kept cells, in their order.
    """
    kept = []
    for cell in cells:
        rule = DEFAULT_SUITE.get(cell.scenario.name)
        if rule is None or rule.keeps(cell, chosen):
            kept.append(cell)
    return kept


def select(names: Sequence[str] | None, registry: dict[str, Any], what: str) -> list[Any]:
    """Items of ``registry`` by name (all if ``names`` is empty); unknown names raise.

    Raises
    ------
    ValueError
        For a name not in ``registry``, listing the known ones.
    """
    if not names:
        return list(registry.values())
    unknown = [n for n in names if n not in registry]
    if unknown:
        raise ValueError(f"unknown {what} {unknown}; choose from {sorted(registry)}")
    return [registry[n] for n in names]
