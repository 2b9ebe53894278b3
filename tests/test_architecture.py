"""The layout's rules: layers, module and function sizes, no cycles, no private imports."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tension_opt", "catenary", "benchmarks")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80
# A longer function must say why in its docstring, with these words.
KERNEL_MARK = "hot numerical kernel"


def _modules() -> Iterator[tuple[str, Path]]:
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            yield name, path


def test_the_layer_contract_holds() -> None:
    # import-linter reads the contracts in pyproject.toml.
    command = shutil.which("lint-imports")
    if command is None:
        pytest.skip("import-linter is not installed (pip install -e '.[dev]')")
    done = subprocess.run([command, "--config", str(ROOT / "pyproject.toml")], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]


def test_no_module_is_too_long() -> None:
    long = {name: n for name, path in _modules()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_no_function_is_too_long_unless_it_is_a_kernel_that_says_so() -> None:
    long = {}
    for name, path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                size = (node.end_lineno or node.lineno) - node.lineno + 1
                doc = (ast.get_docstring(node) or "").lower()
                if size > MAX_FUNCTION_LINES and KERNEL_MARK not in doc:
                    long[f"{name}.{node.name}"] = size
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def _imports(name: str, path: Path) -> Iterator[tuple[str, list[str]]]:
    """(imported module, imported names) of every import in a module, made absolute."""
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                keep = len(base) - node.level + (1 if is_package else 0)
                module = ".".join(base[:keep] + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            yield module, [alias.name for alias in node.names]
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, []


def test_no_module_imports_another_modules_private_names() -> None:
    ours = dict(_modules())
    bad = []
    for name, path in ours.items():
        for module, names in _imports(name, path):
            if module.split(".")[0] not in PACKAGES or module == name:
                continue
            private = [n for n in names if n.startswith("_") and n != "__version__"]
            private += [p for p in module.split(".") if p.startswith("_") and p != "__main__"]
            if private:
                bad.append(f"{name} imports {private} from {module}")
    assert not bad, "\n".join(bad)


def test_no_import_cycle_between_modules() -> None:
    ours = dict(_modules())
    graph: dict[str, set[str]] = {name: set() for name in ours}
    for name, path in ours.items():
        for module, names in _imports(name, path):
            targets = [module] + [f"{module}.{n}" for n in names]
            for target in targets:
                if target in ours and target != name:
                    graph[name].add(target)
    # A package's __init__ re-exports its children: edges into it are not cycles of
    # the children, so only module-to-module edges count.
    packages = {n for n, p in ours.items() if p.name == "__init__.py"}
    graph = {n: {t for t in ts if t not in packages} for n, ts in graph.items()
             if n not in packages}
    cycles = _strongly_connected(graph)
    assert not cycles, f"import cycles: {cycles}"


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_mypy_finds_no_error() -> None:
    # The configuration is pyproject.toml's; no module silences its own errors.
    command = shutil.which("mypy")
    if command is None:
        pytest.skip("mypy is not installed (pip install -e '.[dev]')")
    done = subprocess.run([command, "tension_opt", "catenary", "benchmarks"], cwd=ROOT,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]


#: Calls into these modules are not steps of the flow (errors, statuses, checks, the
#: numbers the layers share, the kernels' array helpers, the first-use notice).
GROUND = {"errors", "status", "checks", "kinds", "tolerances", "kernels.arrays",
          "kernels.launch", "kernels.first_use"}


def _modules_visited(call: Callable[[], object]) -> list[str]:
    """The tension_opt modules one call runs through, in order, each time the flow moves
    from one module to another by a call (the ground left out)."""
    trail: list[str] = []

    def profile(frame: FrameType, event: str, arg: object) -> None:
        if event != "call":
            return
        module = frame.f_globals.get("__name__", "")
        if not module.startswith("tension_opt."):
            return
        caller = frame.f_back
        while caller is not None and not caller.f_globals.get(
                "__name__", "").startswith("tension_opt"):
            caller = caller.f_back
        step = module.removeprefix("tension_opt.")
        if (caller is None or caller.f_globals["__name__"] != module) and step not in GROUND \
                and (not trail or trail[-1] != step):
            trail.append(step)

    sys.setprofile(profile)
    try:
        call()
    finally:
        sys.setprofile(None)
    return trail


@pytest.mark.parametrize("robot_name, objective, backend", [
    ("algae_harvester", "min_sum", "auto"),
    ("algae_harvester", "min_norm", "qpsolvers:daqp"),
    ("cogiro", "min_max", "auto"),  # a 6-DOF robot through DAQP, its tie-break and certificate
])
def test_one_distribute_call_comes_back_to_few_modules(robot_name: str, objective: str,
                                                       backend: str) -> None:
    """A call of distribute on a batch goes down the flow: it comes back to a module it
    has left at most 20 times (a reader follows it through one file per step)."""
    import numpy as np

    import tension_opt as to

    if backend != "auto" and backend not in to.available_backends():
        pytest.skip(f"{backend} is not installed")
    robot = getattr(to.presets, robot_name)()
    rng = np.random.default_rng(0)
    if robot.dof == 6:  # the platform level, translated about the centre
        poses = np.zeros((100, 6))
        poses[:, :3] = rng.uniform(-0.5, 0.5, (100, 3))
    else:
        poses = np.column_stack([rng.uniform(-30, 30, 200), rng.uniform(-20, 20, 200),
                                 np.full(200, 0.5)])
    to.distribute(robot, poses, objective, backend)  # compiled and cached first
    trail = _modules_visited(lambda: to.distribute(robot, poses, objective, backend))
    again = len(trail) - len(set(trail))
    assert trail[0] == "distribution.entry" and trail.count("distribution.solution") == 1
    assert again <= 20, " -> ".join(trail)
