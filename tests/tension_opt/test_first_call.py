"""The size rule of plain calls (tension_opt.kernels.launch.COMPILED_MIN): batches under
it take the numpy references and compile nothing, with the statuses, uniqueness and
tensions (to rounding) of the compiled kernels."""

from __future__ import annotations

import textwrap
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.kernels import launch

DEFAULT_MIN = 16  # the value in tension_opt.kernels.launch (the conftest sets 1)


def test_the_default_rule_is_the_documented_one() -> None:
    assert launch.DEFAULT_COMPILED_MIN == DEFAULT_MIN


@pytest.mark.parametrize("text, value", [("", DEFAULT_MIN), ("1", 1), (" 64 ", 64), ("0", 0)])
def test_the_environment_sets_the_size(text: str, value: int,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TENSION_OPT_COMPILED_MIN", text)
    assert launch.compiled_min_from_environment() == value


@pytest.mark.parametrize("text", ["-1", "many", "1.5"])
def test_a_bad_size_in_the_environment_is_refused(text: str,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TENSION_OPT_COMPILED_MIN", text)
    with pytest.raises(to.InvalidInputError, match="TENSION_OPT_COMPILED_MIN"):
        launch.compiled_min_from_environment()


def test_small_batches_compile_nothing_in_a_fresh_process(
        fresh_process: Callable[[str], str]) -> None:
    """With an empty kernel cache, plain calls on fewer than COMPILED_MIN poses (every
    closed-form objective, a 6-DOF robot, a smoothed sequence, generic backends with
    DAQP's batch among them) start no compilation."""
    script = textwrap.dedent("""
        import numpy as np
        import tension_opt as to
        rng = np.random.default_rng(0)
        study, cogiro = to.presets.algae_harvester(), to.presets.cogiro()
        P = np.column_stack([rng.uniform(-30, 30, 15), rng.uniform(-20, 20, 15),
                             np.full(15, 0.5)])
        H = np.zeros((15, 6))
        H[:, :3] = rng.uniform(-0.5, 0.5, (15, 3))
        for objective in ("min_sum", "min_norm", "min_max"):
            to.distribute(study, P, objective)
        to.distribute(cogiro, H, "min_norm")
        to.distribute(study, P, to.TensionProblem("min_sum", smoothing=1e-3))
        for backend in ("qpsolvers:daqp", "qpsolvers:clarabel", "cvxpy:CLARABEL"):
            to.distribute(study, P[:3], "min_norm", backend)
        print("compiled:", compiled)
    """)
    out = fresh_process(script)
    assert "compiled: []" in out, out[-3000:]


def _poses(robot: to.CableRobot, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if robot.dof == 6:
        poses = np.zeros((count, 6))
        poses[:, :3] = rng.uniform(-1.5, 1.5, (count, 3))  # some beyond the workspace
        poses[:, 3:] = rng.uniform(-0.3, 0.3, (count, 3))
        return poses
    return np.column_stack([rng.uniform(-45, 45, count), rng.uniform(-30, 30, count),
                            rng.uniform(-1, 8, count)])


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), count=st.integers(1, DEFAULT_MIN - 1),
       case=st.sampled_from([("algae_harvester", "min_sum"), ("algae_harvester", "min_norm"),
                             ("algae_harvester", "min_max"), ("cogiro", "min_norm"),
                             ("cogiro", "min_sum")]))
def test_numpy_path_of_small_batches_answers_as_the_kernels(seed: int, count: int,
                                                             case: tuple[str, str]) -> None:
    robot_name, objective = case
    robot = getattr(to.presets, robot_name)()
    poses = _poses(robot, count, seed)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(launch, "COMPILED_MIN", DEFAULT_MIN)
        small = to.distribute(robot, poses, objective)
        assert small.backend == "closed_form"
    compiled = to.distribute(robot, poses, objective)  # the conftest's rule: compiled
    assert list(small.status) == list(compiled.status)
    assert (small.unique == compiled.unique).all()
    solved = np.isfinite(compiled.tensions).all(axis=1)
    scale = np.abs(compiled.tensions[solved]).max(initial=1.0)
    np.testing.assert_allclose(small.tensions[solved], compiled.tensions[solved],
                               rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(small.primal_residual, compiled.primal_residual,
                               rtol=0, atol=1e-9)
