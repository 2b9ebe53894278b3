"""Compiling ahead (``python -m tension_opt warmup``) and the notice of a first call
that compiles (:mod:`tension_opt.kernels.first_use`)."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from tension_opt import warmup
from tension_opt.errors import InvalidInputError
from tension_opt.kernels import first_use
from tension_opt.kernels.geometry import robot_geometry


def _kernel(index: Path) -> SimpleNamespace:
    """A stand-in for a numba dispatcher whose disk-cache index is ``index``."""
    return SimpleNamespace(_cache=SimpleNamespace(_cache_file=SimpleNamespace(
        _index_path=str(index))))


@pytest.fixture
def fresh_notice(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(first_use, "_CHECKED", set())
    monkeypatch.setattr(first_use, "_said", [False])


@pytest.mark.usefixtures("fresh_notice")
def test_a_first_call_that_compiles_says_so_once(tmp_path: Path,
                                                  caplog: pytest.LogCaptureFixture) -> None:
    cached = tmp_path / "kernel.nbi"
    cached.write_text("")
    with caplog.at_level(logging.WARNING, logger="tension_opt"):
        first_use.announce("cached family", _kernel(cached))
        assert not caplog.records  # in the cache: nothing to say
        first_use.announce("cold family", _kernel(cached), _kernel(tmp_path / "missing.nbi"))
        first_use.announce("cold family", _kernel(tmp_path / "missing.nbi"))
        first_use.announce("another cold family", _kernel(tmp_path / "gone.nbi"))
    assert len(caplog.records) == 1
    message = caplog.records[0].getMessage()
    assert "cold family" in message and "python -m tension_opt warmup" in message


@pytest.mark.usefixtures("fresh_notice")
def test_a_real_kernel_is_found_in_the_cache(caplog: pytest.LogCaptureFixture) -> None:
    import numpy as np

    import tension_opt as to

    robot = to.presets.algae_harvester()
    robot.equilibrium(np.zeros((1, 3)))  # compiled (or loaded) and cached by now
    assert first_use._cached(robot_geometry)
    with caplog.at_level(logging.WARNING, logger="tension_opt"):
        first_use.announce("robot geometry", robot_geometry)
    assert not caplog.records
    assert first_use._cached(object())  # no cache to look at: nothing is said


def test_warm_runs_the_families_and_times_them(monkeypatch: pytest.MonkeyPatch) -> None:
    ran: list[str] = []
    monkeypatch.setattr(warmup, "FAMILIES", {"a": lambda: ran.append("a"),
                                             "b": lambda: ran.append("b")})
    monkeypatch.setattr(warmup, "PLUGINS", ())
    took = warmup.warm(jobs=1, progress=False)
    assert ran == ["a", "b"] and list(took) == ["a", "b"]
    assert all(seconds >= 0 for seconds in took.values())
    with pytest.raises(InvalidInputError, match="unknown kernel families"):
        warmup.warm(["c"], jobs=1, progress=False)
    with pytest.raises(InvalidInputError, match="jobs"):
        warmup.warm(jobs=0, progress=False)


@pytest.mark.usefixtures("fresh_notice")
def test_the_warm_up_announces_nothing_and_leaves_the_notice_as_it_was(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    cold = _kernel(tmp_path / "missing.nbi")
    monkeypatch.setattr(warmup, "FAMILIES", {"cold": lambda: first_use.announce("cold", cold)})
    monkeypatch.setattr(warmup, "PLUGINS", ())
    with caplog.at_level(logging.WARNING, logger="tension_opt"):
        warmup.warm(jobs=1, progress=False)
        assert not caplog.records
        first_use.announce("another cold family", cold)  # a user's call afterwards
    assert len(caplog.records) == 1 and "another cold family" in caplog.records[0].message


def test_the_distribution_families_are_families_without_catenary_or_timing() -> None:
    assert set(warmup.DISTRIBUTION_FAMILIES) <= set(warmup.every_family())
    assert "catenary: single cable" in warmup.every_family()
    assert not [n for n in warmup.DISTRIBUTION_FAMILIES if "catenary" in n or "timing" in n]


def test_the_plugins_register_their_families() -> None:
    import catenary  # noqa: F401  (registers its families when imported)

    assert {"robot geometry", "closed form", "certified pass", "real-time distributor",
            "catenary: single cable", "catenary: coupled sag IK"} <= set(warmup.FAMILIES)


def test_the_command_line_warms_a_family() -> None:
    done = subprocess.run([sys.executable, "-m", "tension_opt", "warmup", "--family",
                           "robot geometry", "--jobs", "1", "--no-progress"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "robot geometry" in done.stdout and " s" in done.stdout
    bad = subprocess.run([sys.executable, "-m", "tension_opt", "warmup", "--family", "nope",
                          "--jobs", "1", "--no-progress"],
                         capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and "unknown kernel families" in bad.stderr


def test_every_family_has_a_compile_cost_that_orders_the_parallel_warm_up() -> None:
    """The hints name the families there are (a renamed family would start last), and the
    longest of the main job's families starts first."""
    families = warmup.every_family()
    assert set(warmup.COMPILE_SECONDS) == set(families)
    first = max(warmup.DISTRIBUTION_FAMILIES, key=warmup.COMPILE_SECONDS.__getitem__)
    assert first == "certified pass"
