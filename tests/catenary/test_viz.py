"""Views of the robot (catenary.viz): what is drawn is what the solvers say.

Numbers: the plotted catenaries end on the drawing and attachment points, sag below
their chords by what the catenary's own forces give, reach the lowest point the
solver's forces put them at; colours map to tensions; one artist or trace per cable;
slack, infeasible and out-of-bounds cables are marked. Pictures: the static views
against baselines in tests/baseline/ (text removed); the HTML views in a real headless
browser where one is installed.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.testing.compare import compare_images

import catenary as cat
import tension_opt as to
from catenary.errors import InvalidCableError, OptionalDependencyError
from catenary.viz import (
    animate,
    animation_figure,
    plot_compliance,
    plot_robot,
    plot_workspace,
    robot_scene,
    robot_scenes,
)
from catenary.viz.overlays import compliance_ellipsoid
from tension_opt.errors import InvalidInputError

BASELINE = Path(__file__).resolve().parents[1] / "baseline"
#: Set to 1 to write the baselines afresh (then review and commit them).
UPDATE = os.environ.get("TENSION_OPT_UPDATE_BASELINES") == "1"
ABOVE_CENTRE = [0.0, 0.0, 2.0]  # 2 m above the pond centre (the origin)
COGIRO_ROTATED = [0.8, -0.5, 2.2, 0.12, -0.18, 0.5]


@pytest.fixture(scope="module")
def study() -> to.CableRobot:
    return to.presets.algae_harvester()


@pytest.fixture(scope="module")
def cogiro() -> to.CableRobot:
    return to.presets.cogiro()


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def cable_lines(fig) -> list:
    return [a for a in fig.axes[0].lines if str(a.get_gid()).startswith("cable ")]


# ----------------------------------------------------------------------- the numbers
@pytest.mark.parametrize("model", ["coupled", "thesis"])
@pytest.mark.parametrize("pose", [ABOVE_CENTRE, [12.0, -9.0, 1.0]])
def test_curves_end_on_the_attachment_and_drawing_points(study, model, pose):
    scene = robot_scene(study, pose, model=model)
    assert scene.status == "converged"
    np.testing.assert_allclose(
        scene.curves[:, 0], study.attachment_points(pose)[0], rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(scene.curves[:, -1], study.anchors, rtol=0, atol=1e-9)
    # The sampled catenary reached the drawing point by itself (before closing onto it).
    assert scene.closure.max() < 1e-9
    # Unstretched lengths are the kinematics' own.
    ik = cat.inverse_kinematics(study, pose, model=model)
    np.testing.assert_allclose(scene.lengths, ik.lengths[0], rtol=1e-12)
    np.testing.assert_allclose(scene.tensions, ik.tensions[0], rtol=1e-12)


def _chord_drop(curve: np.ndarray, anchor: np.ndarray) -> float:
    """Largest vertical drop of a sampled curve (k, 3) below its chord."""
    a = curve[0]
    h = np.linalg.norm(curve[:, :2] - a[:2], axis=1)
    span = np.linalg.norm(anchor[:2] - a[:2])
    chord_z = a[2] + (anchor[2] - a[2]) * h / span
    return float((chord_z - curve[:, 2]).max())


@pytest.mark.parametrize("model", ["coupled", "thesis"])
def test_sag_below_the_chord_is_the_catenary_solvers(study, model):
    pose = [12.0, -9.0, 1.0]
    scene = robot_scene(study, pose, model=model, samples=4001)
    attach = scene.attachments
    x = np.linalg.norm(study.anchors[:, :2] - attach[:, :2], axis=1)
    z = study.anchors[:, 2] - attach[:, 2]
    w = study.cable.weight_per_length(study.g)
    # The forward solver on the plotted lengths, and the inextensible catenary in closed
    # form: z(x) = (H/w) (cosh(w (x - x0)/H) - cosh(w x0/H)), slope V_A/H at A.
    forces = cat.solve_forces(x, z, scene.lengths, w, study.cable.EA)
    H, V_A = forces.H, forces.V_A
    x0 = -(H / w) * np.arcsinh(V_A / H)
    xs = x0 + (H / w) * np.arcsinh(z / x)  # where the slope is the chord's
    zs = (H / w) * (np.cosh(w * (xs - x0) / H) - np.cosh(w * x0 / H))
    expected = z / x * xs - zs
    assert (expected > 0.1).all()  # metres of sag on these 50-90 m steel cables
    np.testing.assert_allclose(scene.sag, expected, rtol=1e-9)
    drawn = [_chord_drop(scene.curves[i], study.anchors[i]) for i in range(4)]
    np.testing.assert_allclose(drawn, expected, rtol=0, atol=1e-6)


def test_lowest_point_is_where_the_solvers_forces_put_it(study):
    # The study's convention above the pond centre: V_A < 0, the cables dip below the
    # platform; the lowest point carries V = 0, z_low = z_A + (H - T_A)/w.
    scene = robot_scene(study, ABOVE_CENTRE, model="thesis", samples=4001)
    ik = cat.inverse_kinematics(study, ABOVE_CENTRE, model="thesis")
    H = ik.horizontal_tensions[0]
    V_A = ik.platform_forces[0, :, 2]
    assert (V_A < 0).all()
    w = study.cable.weight_per_length(study.g)
    z_low = ABOVE_CENTRE[2] + (H - np.hypot(H, V_A)) / w
    # 4001 samples: the lowest sample is within (w/2H) (L/8000)^2 ~ 1e-7 m of the low point.
    np.testing.assert_allclose(scene.curves[..., 2].min(axis=1), z_low, rtol=0, atol=1e-6)
    assert (z_low < ABOVE_CENTRE[2]).all()


def test_straight_cables_are_the_chords_with_the_distributions_tensions(study):
    scene = robot_scene(study, ABOVE_CENTRE, model="straight", samples=5)
    sol = to.distribute(study, ABOVE_CENTRE)
    np.testing.assert_allclose(scene.tensions, sol.tensions[0], rtol=1e-12)
    t = np.linspace(0, 1, 5)[None, :, None]
    expected = scene.attachments[:, None] + t * (study.anchors - scene.attachments)[:, None]
    np.testing.assert_allclose(scene.curves, expected, atol=1e-12)
    assert (scene.sag == 0).all()


def test_colours_map_to_tensions(study):
    tensions = [4000.0, 8000.0, 12000.0, 16000.0]
    fig = plot_robot(
        study, [5.0, 3.0, 2.0], tensions=tensions, tension_range=(0, 20000), cmap="viridis"
    )
    lines = cable_lines(fig)
    viridis = matplotlib.colormaps["viridis"]
    for line, T in zip(lines, tensions, strict=True):
        assert to_rgba(line.get_color()) == pytest.approx(viridis(T / 20000.0))
    bar = fig.axes[-1]
    assert "tension" in bar.get_ylabel()
    assert bar.get_ylim() == pytest.approx((0.0, 20000.0))


@pytest.mark.parametrize("preset", ["algae_harvester", "cogiro", "point_xz_4cable"])
def test_one_artist_and_one_trace_per_cable(preset):
    robot = getattr(to.presets, preset)()
    pose = robot.default_home()
    fig = plot_robot(robot, pose)
    assert [line.get_gid() for line in cable_lines(fig)] == [f"cable {i}" for i in range(robot.m)]
    assert (getattr(fig.axes[0], "name", "") == "3d") == (robot.dof != 2)
    figure = plot_robot(robot, pose, engine="plotly")
    names = [trace.name for trace in figure.data]
    assert [n for n in names if n.startswith("cable ")] == [
        f"cable {i + 1}" for i in range(robot.m)
    ]
    assert "platform" in names and "drawing points" in names


def test_plotly_hover_shows_tension_length_and_sag(study):
    scene = robot_scene(study, ABOVE_CENTRE)
    figure = plot_robot(study, ABOVE_CENTRE, engine="plotly")
    trace = next(t for t in figure.data if t.name == "cable 1")
    text = trace.text[0]
    assert f"{scene.tensions[0]:.1f} N" in text
    assert f"{scene.lengths[0]:.4f} m" in text
    assert f"sag below chord {scene.sag[0]:.4f} m" in text


def test_slack_infeasible_and_out_of_bounds_cables_are_marked(study, cogiro):
    fig = plot_robot(study, [5.0, 3.0, 2.0], tensions=[0.0, 9000.0, 9000.0, 9000.0])
    lines = cable_lines(fig)
    assert lines[0].get_linestyle() == "--" and lines[1].get_linestyle() == "-"
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "slack" in legend
    # Above the towers no tensions hold the platform: every cable infeasible, red dashed.
    high = robot_scene(study, [0.0, 0.0, 30.0])
    assert high.status == "infeasible" and (high.state == "infeasible").all()
    fig = plot_robot(study, [0.0, 0.0, 30.0], model="straight")
    assert all(
        line.get_linestyle() == "--" and to_rgba(line.get_color()) == to_rgba("red")
        for line in cable_lines(fig)
    )
    assert "infeasible (no tensions)" in [
        t.get_text() for t in fig.axes[0].get_legend().get_texts()
    ]
    # CoGiRo's t_max is 5 kN: a 6 kN cable is out of bounds and gets its red halo.
    tensions = [300.0, 6000.0, 300.0, 300.0, 300.0, 300.0, 300.0, 300.0]
    fig = plot_robot(cogiro, COGIRO_ROTATED, tensions=tensions)
    halos = {
        a.get_gid(): a.get_visible()
        for a in fig.axes[0].lines
        if str(a.get_gid()).startswith("halo")
    }
    assert halos == {f"halo {i}": i == 1 for i in range(8)}
    assert "outside [t_min, t_max]" in [t.get_text() for t in fig.axes[0].get_legend().get_texts()]


def test_batch_scenes_match_single_ones(study):
    poses = np.array([[0.0, 0.0, 2.0], [10.0, 5.0, 1.0], [-20.0, 8.0, 3.0]])
    scenes = robot_scenes(study, poses, samples=11)
    for pose, scene in zip(poses, scenes, strict=True):
        single = robot_scene(study, pose, samples=11)
        np.testing.assert_allclose(scene.curves, single.curves, atol=1e-9)


def test_the_platform_is_a_closed_solid(study, cogiro):
    vertices, triangles = robot_scene(cogiro, COGIRO_ROTATED, model="straight").platform()
    corners = cogiro.attachment_points(COGIRO_ROTATED)[0]
    # Every attachment point is on or inside the hull (the hull is their own).
    from scipy.spatial import Delaunay

    assert (Delaunay(vertices).find_simplex(corners, tol=1e-9) >= 0).all()
    assert triangles.shape[1] == 3 and triangles.max() < len(vertices)
    # A point mass is a cube of the given size around its position.
    vertices, _ = robot_scene(study, ABOVE_CENTRE).platform(size=2.0)
    np.testing.assert_allclose(vertices.min(axis=0), [-1.0, -1.0, 1.0])
    np.testing.assert_allclose(vertices.max(axis=0), [1.0, 1.0, 3.0])


# ----------------------------------------------------------------------- overlays
def test_workspace_overlay_colours_feasible_points_by_margin(study):
    grid = to.workspace.workspace_grid([-40, -25, 1.0], [40, 25, 5.0], spacing=[10, 10, 2])
    result = to.workspace.wrench_feasible_workspace(study, grid)
    fig = plot_robot(study, ABOVE_CENTRE, model="straight")
    plot_workspace(result, ax=fig.axes[0])
    points = next(c for c in fig.axes[0].collections if c.get_gid() == "workspace")
    feasible = result.feasible & np.isfinite(result.margin)
    assert 0 < feasible.sum() < result.N
    np.testing.assert_allclose(np.sort(points.get_array()), np.sort(result.margin[feasible]))


def test_compliance_ellipsoid_is_the_stiffness_inverse(cogiro):
    pose = [0.0, 0.0, 2.0, 0.0, 0.0, 0.2]
    centre, semi = compliance_ellipsoid(cogiro, pose, load=100.0)
    K = cat.platform_stiffness(cogiro, pose)[0]
    block = np.linalg.inv(K)[:3, :3]
    np.testing.assert_allclose(
        np.linalg.norm(semi, axis=0), 100.0 * np.linalg.svd(block, compute_uv=False), rtol=1e-10
    )
    np.testing.assert_allclose(centre, [0.0, 0.0, 2.0])
    # Every deflection under a 100 N force lies on the ellipsoid: |S^-1 U^T d| = 1.
    rng = np.random.default_rng(1)
    forces = rng.normal(size=(20, 3))
    forces *= 100.0 / np.linalg.norm(forces, axis=1, keepdims=True)
    d = forces @ block.T
    unit = d @ np.linalg.pinv(semi).T
    np.testing.assert_allclose(np.linalg.norm(unit, axis=1), 1.0, rtol=1e-8)
    fig = plot_compliance(cogiro, pose, ax=plot_robot(cogiro, pose).axes[0], load=100.0, scale=50.0)
    assert any(c.get_gid() == "compliance" for c in fig.axes[0].collections)


# ----------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"model": "sagging"}, "model must be"),
        ({"engine": "bokeh"}, "engine must be"),
        ({"view": "top"}, "view must be"),
        ({"tensions": [1.0, 2.0]}, "tensions must have shape"),
        ({"tensions": [1.0, -2.0, 3.0, 4.0]}, ">= 0"),
        ({"z_scale": 0}, "z_scale must be"),
        ({"samples": 1}, "samples must be"),
        ({"tension_range": (5.0, 1.0)}, "tension_range"),
        ({"cmap": "no such map"}, "cmap must be"),
    ],
)
def test_bad_arguments_are_named(study, kwargs, words):
    with pytest.raises(InvalidCableError, match=re.escape(words)):
        plot_robot(study, ABOVE_CENTRE, **kwargs)


def test_bad_axes_poses_and_paths(study, tmp_path):
    _, flat = plt.subplots()
    with pytest.raises(InvalidCableError, match="projection='3d'"):
        plot_robot(study, ABOVE_CENTRE, model="straight", ax=flat)
    with pytest.raises(InvalidCableError, match="one pose"):
        plot_robot(study, [ABOVE_CENTRE, ABOVE_CENTRE])
    with pytest.raises(InvalidInputError, match="poses"):
        plot_robot(study, [0.0, 0.0])
    with pytest.raises(InvalidCableError, match=r"\.gif, \.mp4 or \.html"):
        animate(study, [ABOVE_CENTRE], tmp_path / "a.avi")
    with pytest.raises(InvalidCableError, match='engine="plotly" draws its own'):
        plot_robot(study, ABOVE_CENTRE, engine="plotly", ax=flat)


def test_missing_plotly_names_the_extra(study, monkeypatch):
    for name in [m for m in sys.modules if m == "plotly" or m.startswith("plotly.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "plotly", None)
    with pytest.raises(OptionalDependencyError, match=re.escape("tension-opt[viz]")):
        plot_robot(study, ABOVE_CENTRE, model="straight", engine="plotly")


def test_import_catenary_imports_no_plotting_library():
    code = (
        "import sys, catenary, catenary.viz; "
        "print(sorted(m for m in ('matplotlib', 'plotly') if m in sys.modules))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert done.stdout.strip() == "[]"


# ----------------------------------------------------------------------- animations
def test_gif_of_thirty_frames_in_seconds(study, tmp_path):
    from PIL import Image

    path = np.linspace([-3.0, -4.0, 1.0], [3.0, 4.0, 2.0], 60)
    robot_scenes(study, path[:2])  # the kernels compiled before the clock starts
    start = time.perf_counter()
    out = animate(study, path, tmp_path / "path.gif", frames=30, dpi=50)
    took = time.perf_counter() - start
    with Image.open(out) as gif:
        assert gif.n_frames == 30
        first = np.asarray(gif.convert("RGB"))
        gif.seek(29)
        last = np.asarray(gif.convert("RGB"))
    assert (first != last).any()  # the platform moved
    assert took < 8.0, f"30 frames took {took:.1f} s"


def test_mp4_needs_ffmpeg_and_says_so(study, tmp_path, monkeypatch):
    from matplotlib import animation

    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    with pytest.raises(OptionalDependencyError, match="ffmpeg"):
        animate(
            study, np.linspace([-3.0, -4.0, 1.0], [3.0, 4.0, 2.0], 3), tmp_path / "a.mp4", samples=5
        )


def test_animation_frame_moves_along_the_path(study):
    path = np.linspace([-3.0, -4.0, 1.0], [3.0, 4.0, 2.0], 7)
    fig = animation_figure(study, path, 3, frames=None, samples=11)
    for line in cable_lines(fig):  # every cable leaves the platform at the fourth pose
        x, y, z = line.get_data_3d()
        np.testing.assert_allclose([x[0], y[0], z[0]], path[3], atol=1e-9)
    cursor = fig.axes[1].lines[-1]  # the tension trace's cursor at the fourth time
    assert cursor.get_xdata()[0] == 3.0


# ----------------------------------------------------------------------- images
def _without_text(fig) -> None:
    """Hide every text so the comparison sees the drawing only (fonts differ)."""
    for text in fig.findobj(matplotlib.text.Text):
        text.set_visible(False)


def _check_image(fig, name: str, tmp_path: Path, tol: float = 3.0) -> None:
    _without_text(fig)
    actual = tmp_path / name
    fig.savefig(actual, dpi=60)
    expected = BASELINE / name
    if UPDATE:
        BASELINE.mkdir(exist_ok=True)
        shutil.copyfile(actual, expected)
    assert expected.exists(), f"no baseline {expected}: run with TENSION_OPT_UPDATE_BASELINES=1"
    result = compare_images(str(expected), str(actual), tol=tol)
    assert result is None, result


@pytest.mark.parametrize(
    ("name", "draw"),
    [
        (
            "study_pond_coupled.png",
            lambda: plot_robot(
                to.presets.algae_harvester(),
                ABOVE_CENTRE,
                reference="straight",
                z_scale=4,
                figsize=(6.0, 4.5),
            ),
        ),
        (
            "study_pond_side.png",
            lambda: plot_robot(
                to.presets.algae_harvester(),
                ABOVE_CENTRE,
                model="thesis",
                reference="coupled",
                view="xz",
                z_scale=4,
                figsize=(6.0, 4.5),
            ),
        ),
        (
            "cogiro_rotated.png",
            lambda: plot_robot(to.presets.cogiro(), COGIRO_ROTATED, figsize=(6.0, 4.5)),
        ),
        (
            "planar_point.png",
            lambda: plot_robot(to.presets.point_xz_4cable(), [0.1, 0.05], figsize=(6.0, 4.5)),
        ),
    ],
)
def test_static_views_match_their_baselines(name, draw, tmp_path):
    _check_image(draw(), name, tmp_path)


# ----------------------------------------------------------------------- browser
def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if found := shutil.which(name):
            return found
    return None


def _plot_data(html: str) -> list[dict]:
    """The traces of the plotly figure of a page written by plotly's write_html."""
    start = html.index("Plotly.newPlot(")
    at = html.index("[", html.index(",", start))
    data, _ = json.JSONDecoder().raw_decode(html, at)
    return data


def _screenshot(page: Path, shot: Path, home: Path) -> subprocess.Popen:
    """Start the headless browser on a page; it writes the screenshot and exits."""
    command = [
        _browser(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        f"--screenshot={shot}",
        "--window-size=1000,700",
        "--virtual-time-budget=3000",
        page.as_uri(),
    ]
    return subprocess.Popen(
        command,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "HOME": str(home)},
    )


@pytest.mark.skipif(
    _browser() is None, reason="no headless browser (chromium) installed: apt-get install chromium"
)
def test_html_views_render_in_a_headless_browser(study, tmp_path):
    from PIL import Image

    pages = {"view": tmp_path / "view.html", "animation": tmp_path / "animation.html"}
    plot_robot(study, ABOVE_CENTRE, engine="plotly").write_html(
        pages["view"], include_plotlyjs=True
    )
    animate(
        study, np.linspace([-3.0, -4.0, 1.0], [3.0, 4.0, 2.0], 12), pages["animation"], samples=21
    )
    # Both pages at once (a browser start and the page's WebGL take seconds each).
    shots = {kind: tmp_path / f"{kind}.png" for kind in pages}
    running = [_screenshot(pages[kind], shots[kind], tmp_path / kind) for kind in pages]
    for process in running:
        process.wait(timeout=120)
    for kind, page in pages.items():
        html = page.read_text(encoding="utf-8")
        assert "plotly.js" in html and not re.search(r"<script[^>]*src=", html)  # one file
        names = [trace.get("name", "") for trace in _plot_data(html)]
        assert sum(n.startswith("cable ") for n in names) == study.m, kind
        assert shots[kind].exists(), f"the browser wrote no screenshot of the {kind}"
        pixels = np.asarray(Image.open(shots[kind]).convert("RGB")).astype(int)
        ink = (np.abs(pixels - 255).sum(axis=2) > 60).mean()
        assert ink > 0.01, f"the {kind} looks blank ({ink:.2%} of the pixels drawn)"
        # The drawing points are crimson diamonds: the 3-D scene was drawn.
        crimson = (np.abs(pixels - [220, 20, 60]).sum(axis=2) < 60).sum()
        assert crimson > 20, f"no drawing points on the screenshot of the {kind}"
