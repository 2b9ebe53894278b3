"""Compiled platform stiffness (catenary.stiffness_kernels, catenary.stiffness_compiled,
catenary.stiffness_loop) against its numpy reference (catenary.robot_stiffness) and the
closed form of straight cables."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import catenary as cat
import tension_opt as to
from catenary import stiffness_compiled
from catenary.stiffness_kernels import COUPLED_B, FALLBACK, OK
from catenary.stiffness_loop import PoseStiffness
from tension_opt import warmup
from tension_opt.kernels import launch
from tension_opt.robot import CableProperties
from tension_opt.workspace.sampling import random_feasible_poses

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
KINDS = ["point3", "planar_point2", "planar3", "spatial6"]


@contextlib.contextmanager
def compiled_from(size: int) -> Iterator[None]:
    """Plain batch calls take the kernels from ``size`` poses on."""
    saved = launch.COMPILED_MIN
    launch.COMPILED_MIN = size
    try:
        yield
    finally:
        launch.COMPILED_MIN = saved


def numpy_analysis(*args: object, **kwargs: object) -> cat.StiffnessResult:
    """``stiffness_analysis`` by its numpy reference alone."""
    with compiled_from(10**9):
        return cat.stiffness_analysis(*args, **kwargs)  # type: ignore[arg-type]


def compiled_analysis(*args: object, **kwargs: object) -> cat.StiffnessResult:
    """``stiffness_analysis`` through the kernels (batches of any size)."""
    with compiled_from(1):
        return cat.stiffness_analysis(*args, **kwargs)  # type: ignore[arg-type]


def random_robot(kind: str, m: int, seed: int) -> to.CableRobot:
    """A random robot of a kind with elastic, weighty cables: drawing points around a
    ring (a line for planar_point2), attachments on a small body facing them."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0.0, 2 * np.pi, m))
    radius = rng.uniform(2.0, 20.0) * rng.uniform(0.85, 1.15, m)
    height = rng.uniform(3.0, 10.0) * rng.uniform(0.85, 1.15, m)
    attachments = np.zeros((m, 3))
    if kind == "planar_point2":
        anchors = np.column_stack([np.sort(rng.uniform(-radius, radius)), np.zeros(m), height])
    elif kind == "planar3":
        anchors = np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(m)])
        attachments = (
            0.1 * radius.min() * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(m)])
        )
    else:
        anchors = np.column_stack([radius * np.cos(angles), radius * np.sin(angles), height])
        if kind == "spatial6":
            attachments = rng.uniform(-0.4, 0.4, (m, 3))
    cable = CableProperties(rng.uniform(0.002, 0.02), rng.uniform(0.01, 3.0), rng.uniform(1e5, 1e8))
    return to.CableRobot(
        anchors, attachments, rng.uniform(1.0, 500.0), kind=kind, g=9.81, cable=cable
    )


def random_poses(robot: to.CableRobot, seed: int, count: int = 12) -> np.ndarray:
    """Poses inside the drawing points' box, below their lowest point."""
    rng = np.random.default_rng(seed)
    low, high = robot.anchors.min(axis=0), robot.anchors.max(axis=0)
    mid, half = 0.5 * (low + high), 0.35 * (high - low)
    position = rng.uniform(mid - half, mid + half, (count, 3))
    position[:, 2] = low[2] - rng.uniform(0.5, 3.0, count)
    poses = {
        "point3": position,
        "planar_point2": position[:, [0, 2]],
        "planar3": np.column_stack([position[:, :2], rng.uniform(-0.3, 0.3, count)]),
        "spatial6": np.column_stack([position, rng.uniform(-0.2, 0.2, (count, 3))]),
    }
    return poses[robot.kind]


def scaled(K: np.ndarray, K_ref: np.ndarray) -> float:
    """Largest entry error over each pose's largest entry (NaN rows must match)."""
    assert np.array_equal(np.isnan(K), np.isnan(K_ref))
    ok = ~np.isnan(K_ref).any(axis=(1, 2))
    if not ok.any():
        return 0.0
    scale = np.abs(K_ref[ok]).max(axis=(1, 2))[:, None, None]
    return float((np.abs(K[ok] - K_ref[ok]) / scale).max())


def assert_same(result: cat.StiffnessResult, ref: cat.StiffnessResult, rel: float) -> None:
    """Statuses equal, every array equal to ``rel`` of its scale, NaN where NaN."""
    np.testing.assert_array_equal(result.status, ref.status)
    assert scaled(result.stiffness, ref.stiffness) <= rel
    for name in ("cable_stiffness", "platform_forces", "tensions", "lengths"):
        a, b = getattr(result, name), getattr(ref, name)
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        scale = max(float(np.nanmax(np.abs(b), initial=0.0)), 1e-300)
        np.testing.assert_allclose(
            np.nan_to_num(a), np.nan_to_num(b), rtol=0, atol=rel * scale, err_msg=name
        )
    load = max(float(np.nanmax(np.abs(ref.platform_forces), initial=0.0)), 1.0)
    np.testing.assert_allclose(
        np.nan_to_num(result.equilibrium_residual, nan=-1.0),
        np.nan_to_num(ref.equilibrium_residual, nan=-1.0),
        rtol=0,
        atol=1e-11 * load,
    )


# ------------------------------------------------------------- kernels against numpy
@SETTINGS
@given(
    kind=st.sampled_from(KINDS),
    extra=st.integers(1, 2),
    seed=st.integers(0, 2**31),
    model=st.sampled_from(["straight", "coupled:B", "coupled:A"]),
)
def test_batch_kernel_equals_the_numpy_reference_on_random_robots(kind, extra, seed, model):
    dof = {"point3": 3, "planar_point2": 2, "planar3": 3, "spatial6": 6}[kind]
    robot = random_robot(kind, dof + extra, seed)
    poses = random_poses(robot, seed)
    rng = np.random.default_rng(seed + 1)
    tensions = rng.uniform(0.0, 5.0, (len(poses), robot.m)) * robot.mass * robot.g
    tensions[0, 1] = np.nan  # a row not run
    name, _, end = model.partition(":")
    kwargs = {"end": end} if end else {}
    ref = numpy_analysis(robot, poses, tensions, name, **kwargs)
    result = compiled_analysis(robot, poses, tensions, name, **kwargs)
    assert_same(result, ref, 1e-12 if name == "straight" else 1e-9)
    assert result.status[0] == to.Status.NOT_RUN
    with compiled_from(1):
        K = cat.platform_stiffness(robot, poses, tensions, name, **kwargs)
    np.testing.assert_array_equal(K, result.stiffness)


@pytest.mark.parametrize("preset", ["study", "cogiro"])
@pytest.mark.parametrize("model", ["straight", "coupled"])
def test_batch_with_the_models_own_tensions_equals_the_numpy_reference(preset, model):
    robot = to.presets.algae_harvester(EA=3.14e7) if preset == "study" else to.presets.cogiro()
    poses = random_feasible_poses(robot, 12, seed=3)
    ref = numpy_analysis(robot, poses, None, model)
    result = compiled_analysis(robot, poses, None, model)
    assert_same(result, ref, 1e-12 if model == "straight" else 1e-9)


def test_straight_stiffness_has_its_closed_form() -> None:
    """Point mass at the centre of four symmetric cables: ``K = sum_i (EA / L) u u^T +
    (T / L) I``, written out by hand."""
    anchors = np.array([[10.0, 0.0, 5.0], [-10.0, 0.0, 5.0], [0.0, 10.0, 5.0], [0.0, -10.0, 5.0]])
    EA, T = 2e6, 300.0
    robot = to.CableRobot(
        anchors, np.zeros((4, 3)), 10.0, kind="point3", cable=CableProperties(0.01, 0.5, EA)
    )
    L = np.hypot(10.0, 5.0)
    c, s = 10.0 / L, 5.0 / L  # horizontal and vertical share of each unit vector
    # Two cables along x and two along y, each with the vertical share s.
    expected = np.diag([2 * EA / L * c * c, 2 * EA / L * c * c, 4 * EA / L * s * s])
    expected += 4 * T / L * np.eye(3)
    with compiled_from(1):
        K = cat.platform_stiffness(robot, np.zeros((1, 3)), np.full(4, T), "straight")
    np.testing.assert_allclose(K[0], expected, rtol=1e-13, atol=1e-13 * expected.max())
    one = PoseStiffness(robot, "straight")(np.zeros(3), np.full(4, T))
    np.testing.assert_allclose(one.stiffness[0], expected, rtol=1e-13, atol=1e-13 * expected.max())


def test_a_vertical_cable_is_left_to_the_numpy_reference() -> None:
    robot = to.presets.algae_harvester(EA=3.14e7)
    poses = robot.anchors[:2] - np.array([0.0, 0.0, 3.0])  # right under two anchors
    tensions = np.full((2, robot.m), 4000.0)
    out = stiffness_compiled.compiled_stiffness(
        robot, stiffness_compiled.pack(robot), COUPLED_B, poses, np.zeros((1, 3)), tensions
    )
    assert (out.codes == FALLBACK).all()
    ref = numpy_analysis(robot, poses, tensions, "coupled")
    assert_same(compiled_analysis(robot, poses, tensions, "coupled"), ref, 1e-9)
    one = PoseStiffness(robot, "coupled")(poses[0], tensions[0])
    assert scaled(one.stiffness, ref.stiffness[:1]) <= 1e-12


def test_small_plain_batches_stay_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object) -> None:
        raise AssertionError("the kernels were called below the size rule")

    monkeypatch.setattr(stiffness_compiled, "batch_analysis", refuse)
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 3, seed=1)
    with compiled_from(4):
        K = cat.platform_stiffness(robot, poses, np.full(robot.m, 100.0), "straight")
    assert K.shape == (3, 6, 6)


def test_the_warmup_compiles_the_stiffness_kernels() -> None:
    assert "catenary: platform stiffness" in warmup.FAMILIES
    warmup.warm_family("catenary: platform stiffness")


# --------------------------------------------------------------------- PoseStiffness
@pytest.mark.parametrize("model", ["straight", "coupled"])
@pytest.mark.parametrize("with_tensions", [True, False])
def test_pose_stiffness_equals_the_reference_pose_by_pose(model, with_tensions) -> None:
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 6, seed=4)
    tensions = to.distribute(robot, poses, "min_norm").tensions
    stiffness = PoseStiffness(robot, model)
    for k, pose in enumerate(poses):
        T = tensions[k] if with_tensions else None
        result = stiffness(pose, T)
        assert result.stiffness.shape == (1, 6, 6)
        assert_same(result, numpy_analysis(robot, pose, T, model), 1e-9)
        assert result.success[0]


def test_pose_stiffness_reports_a_row_not_run_and_uncovered_robots() -> None:
    robot = to.presets.cogiro()
    pose = robot.default_home()
    T = np.full(robot.m, 150.0)
    T[3] = np.nan
    for model in ("straight", "coupled"):
        result = PoseStiffness(robot, model)(pose, T)
        assert result.status[0] == to.Status.NOT_RUN and np.isnan(result.stiffness).all()
    study = to.presets.algae_harvester(EA=3.14e7)
    assert study.cable is not None
    weightless = study.with_(cable=CableProperties(study.cable.diameter, 0.0, 3.14e7))
    pose = weightless.default_home()
    result = PoseStiffness(weightless, "coupled")(pose, np.full(4, 3000.0))
    assert_same(result, numpy_analysis(weightless, pose, np.full(4, 3000.0), "coupled"), 1e-12)


def test_pose_stiffness_is_thread_safe() -> None:
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 40, seed=8)
    tensions = to.distribute(robot, poses, "min_norm").tensions
    stiffness = PoseStiffness(robot, "coupled")
    expected = [stiffness(p, t).stiffness for p, t in zip(poses, tensions, strict=True)]
    results: dict[int, list[np.ndarray]] = {}

    def work(index: int) -> None:
        order = np.random.default_rng(index).permutation(len(poses))
        results[index] = [np.empty(0)] * len(poses)
        for _ in range(5):
            for k in order:
                results[index][k] = stiffness(poses[k], tensions[k]).stiffness

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for got in results.values():
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_array_equal(a, b)


def test_pose_stiffness_bad_arguments_raise_the_packages_error() -> None:
    robot = to.presets.cogiro()
    stiffness = PoseStiffness(robot, "straight")
    pose, T = robot.default_home(), np.full(robot.m, 100.0)
    with pytest.raises(cat.InvalidCableError, match="pose must have shape"):
        stiffness(np.zeros((2, 6)), T)
    with pytest.raises(cat.InvalidCableError, match="tensions must have shape"):
        stiffness(pose, T[:3])
    with pytest.raises(cat.InvalidCableError, match="tensions must be finite and >= 0"):
        stiffness(pose, -T)
    with pytest.raises(cat.InvalidCableError, match="wrench must be finite"):
        stiffness(pose, T, np.full(6, np.inf))
    with pytest.raises(to.InvalidInputError):
        stiffness(np.full(6, np.nan), T)
    with pytest.raises(cat.InvalidCableError, match="model must be"):
        PoseStiffness(robot, "sagging")  # type: ignore[arg-type]
    with pytest.raises(cat.InvalidCableError, match="end must be"):
        PoseStiffness(robot, "coupled", end="C")  # type: ignore[arg-type]
    with pytest.raises(cat.InvalidCableError, match="finite EA"):
        PoseStiffness(to.presets.algae_harvester(), "straight")


def test_the_kernel_codes_poses_ok() -> None:
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 5, seed=2)
    out = stiffness_compiled.compiled_stiffness(
        robot,
        stiffness_compiled.pack(robot),
        COUPLED_B,
        poses,
        np.zeros((1, 6)),
        np.full((1, robot.m), 200.0),
        full=False,
    )
    assert (out.codes == OK).all() and out.cable_stiffness.shape[0] == 1
