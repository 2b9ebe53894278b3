"""numba caches made stale by a change to another module are removed
(:mod:`tension_opt.compiled_cache`)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tension_opt import compiled_cache

_HELPER = """
from numba import njit

SCALE = {scale}


@njit(cache=True, inline="always")
def helper(x):
    return x * SCALE
"""
_KERNEL = """
from numba import njit

from fakepkg.helper import helper


@njit(cache=True)
def kernel(x):
    return helper(x) + 1.0
"""
_RUN = """
import sys
from pathlib import Path

sys.path.insert(0, {root!r})
from tension_opt.compiled_cache import guard

if sys.argv[1] == "guard":
    print(guard("fakepkg", {{"fakepkg": Path({root!r}) / "fakepkg"}}), file=sys.stderr)
import fakepkg.kern

print(fakepkg.kern.kernel(2.0))
"""


def _run(root: Path, guarded: bool, env: dict[str, str]) -> float:
    script = root / "run.py"
    script.write_text(_RUN.format(root=str(root)))
    done = subprocess.run([sys.executable, str(script), "guard" if guarded else "plain"],
                          capture_output=True, text=True, env=env, timeout=300, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def _write_helper(package: Path, scale: str, tick: int) -> None:
    path = package / "helper.py"
    path.write_text(textwrap.dedent(_HELPER.format(scale=scale)))
    # A clearly later modification time, as a pull or an edit gives.
    os.utime(path, ns=(tick * 10**9, tick * 10**9))


@pytest.mark.parametrize("user_dir", [False, True], ids=["in-tree", "NUMBA_CACHE_DIR"])
def test_a_change_to_an_inlined_helper_reaches_the_cached_kernel(tmp_path: Path,
                                                                 user_dir: bool) -> None:
    """A kernel cached with a helper it inlines from another module: after the helper
    changes (and the kernel's file does not), numba alone loads the kernel's old
    machine code; with the guard the kernel answers with the new helper."""
    package = tmp_path / "fakepkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "kern.py").write_text(textwrap.dedent(_KERNEL))
    _write_helper(package, "1.0", 1_700_000_000)
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    if user_dir:
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    assert _run(tmp_path, True, env) == 3.0  # compiled and cached
    _write_helper(package, "10.0", 1_800_000_000)
    stale = _run(tmp_path, False, env)
    fresh = _run(tmp_path, True, env)
    assert fresh == 21.0, f"guarded: {fresh} (numba alone: {stale})"
    assert stale == 3.0, "numba now sees the helper's change by itself: the guard is moot"
    # The guard stamped the tree: the next process keeps (and loads) the new caches.
    assert _run(tmp_path, True, env) == 21.0


def test_import_closures_of_the_kernels() -> None:
    """A kernel module depends on the kernel modules it calls and on the modules whose
    constants it reads; the single-cable kernels on nothing of tension_opt."""
    root = Path(compiled_cache.__file__).parent
    files = compiled_cache._modules({"tension_opt": root,
                                     "catenary": root.parent / "catenary"})
    closure = compiled_cache.import_closure(files)
    certified = closure["tension_opt.kernels.certified"]
    assert {"tension_opt.tolerances", "tension_opt.kernels.closed_form",
            "tension_opt.kernels.certificate", "tension_opt.kernels.scaling",
            "tension_opt.kernels.certified_lanes"} <= certified
    # Kernels import only the ground: the layers they twin are not in their closure.
    assert not any(name.split(".")[1] in {"certify", "distribution", "problem", "backends"}
                   for name in certified)
    spans = closure["catenary.solve.kernels"]
    assert {"catenary.solve.kernels_spans", "catenary.solve.kernels_bracket"} <= spans
    assert not any(name.startswith("tension_opt") for name in spans)
    assert "tension_opt.kernels.closed_form" in closure["catenary.thesis_ik_kernels"]
    # A change to the shared tolerances makes the certified kernel stale, and not the
    # catenary's span kernels.
    stale = compiled_cache.stale_modules(files, files, {"tension_opt.tolerances"})
    assert "tension_opt.kernels.certified" in stale
    assert "catenary.solve.kernels" not in stale


def test_an_unchanged_tree_is_left_alone(tmp_path: Path) -> None:
    """The guard checks a package once per process, and deletes nothing where no
    source changed since the record."""
    package = tmp_path / "plainpkg"
    (package / "__pycache__").mkdir(parents=True)
    (package / "__init__.py").write_text("import numba\n")
    cache = package / "__pycache__" / "__init__.f-3.py311.nbi"
    cache.write_text("")
    roots = {"plainpkg": package}
    assert compiled_cache._guard("plainpkg", roots) == ["plainpkg"]
    cache.write_text("")  # numba's new cache
    assert compiled_cache._guard("plainpkg", roots) == []
    assert cache.exists()
    assert compiled_cache.guard("plainpkg", roots) == []  # recorded: nothing to do
    assert compiled_cache.guard("plainpkg", roots) == []  # and once per process
