"""Draw the pictures of the robot views in docs/images/ (run from the repository root).

    python docs/images/make_views.py

study_pond_sag.png       the study robot 2 m above the pond centre, coupled sag against straight
cogiro_rotated.png       CoGiRo at a rotated pose, coupled sag
pick_and_place_frame.png one frame of the animated pick-and-place path
cogiro_interference.png  CoGiRo's interference-free workspace, straight and with coupled sag
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import tension_opt as to
from catenary.viz import animation_figure, plot_robot, robot_scene
from tension_opt import dynamics

HERE = Path(__file__).parent
#: The study's pick-and-place corners: raise 1 m at (-3, -4), cross to (3, 4) at z = 2 m,
#: lower 1 m (notebooks/06_dynamics.ipynb, benchmarks.scenarios.pick_and_place).
CORNERS = np.array([[-3, -4, 1.0], [-3, -4, 2.0], [3, 4, 2.0], [3, 4, 1.0]])


def study_pond_sag(path: Path) -> None:
    """The study robot 2 m above the pond centre: coupled catenaries over the straight chords."""
    robot = to.presets.algae_harvester()
    pose = [0.0, 0.0, 2.0]
    fig = plt.figure(figsize=(13.0, 5.0))
    left = fig.add_subplot(1, 2, 1, projection="3d")
    right = fig.add_subplot(1, 2, 2)
    plot_robot(
        robot,
        pose,
        model="coupled",
        reference="straight",
        ax=left,
        z_scale=4,
        colorbar=False,
        title="3-D view (z drawn \u00d74)",
    )
    coupled = robot_scene(robot, pose, model="coupled")
    straight = robot_scene(robot, pose, model="straight")
    plot_robot(
        robot,
        pose,
        model="coupled",
        reference="straight",
        ax=right,
        view="xz",
        z_scale=4,
        title=(
            f"side view, x-z plane (z drawn \u00d74)\neach cable sags "
            f"{coupled.sag[0]:.2f} m below its chord\nat {coupled.tensions[0] / 1e3:.1f} kN "
            f"(straight cables: {straight.tensions[0] / 1e3:.2f} kN)"
        ),
    )
    fig.subplots_adjust(wspace=0.35)
    fig.suptitle("Study robot at the pond centre (0, 0, 2 m): coupled sag against straight cables")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def cogiro_rotated(path: Path) -> None:
    """CoGiRo at a rotated pose."""
    robot = to.presets.cogiro()
    pose = [0.8, -0.5, 2.2, 0.12, -0.18, 0.5]
    fig = plot_robot(robot, pose, model="coupled", figsize=(8.0, 6.0))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def pick_and_place_frame(path: Path) -> None:
    """One frame of the pick-and-place animation (10 s, rest at each corner)."""
    robot = to.presets.algae_harvester()
    trajectory = dynamics.TimedTrajectory.from_waypoints(
        robot, CORNERS, [2.0, 6.0, 2.0], method="rest", dt=0.05
    )
    fig = animation_figure(
        robot,
        trajectory,
        11,
        frames=30,
        z_scale=3,
        title="algae harvester: pick-and-place path, coupled sag (frame 12 of 30)",
    )
    fig.savefig(path, dpi=100)
    plt.close(fig)


def cogiro_interference(path: Path) -> None:
    """CoGiRo's smallest cable-cable clearance over the x-y plane at z = 2 m, straight and
    with coupled sag, the 0.38 m interference-free boundary on both, and what sag changes."""
    import catenary
    from tension_opt import workspace as ws

    robot = to.presets.cogiro()
    grid = ws.workspace_grid([-3, -2, 2, 0, 0, 0], [3, 2, 2, 0, 0, 0],
                             counts=[31, 21, 1, 1, 1, 1])
    straight = ws.interference_free_workspace(robot, grid, clearance=0.38)
    sag = catenary.interference_free_workspace(robot, grid, 0.38, model="coupled")
    fig, axes = plt.subplots(1, 3, figsize=(17.0, 4.8), layout="constrained")
    for ax, result, name in ((axes[0], straight, "straight cables"),
                             (axes[1], sag, "coupled sag")):
        ws.plot_slice(result, quantity="cable_clearance", ax=ax, show_anchors=False)
        ax.set_title(f"{name}: smallest clearance (m)\nclear of 0.38 m: "
                     f"{result.fraction():.0%} of the slice")
    change = (sag.cable_clearance - straight.cable_clearance).reshape(grid.shape)[:, :, 0, 0, 0, 0]
    x, y = grid.axes[0], grid.axes[1]
    mm = 1e3 * change.T
    norm = matplotlib.colors.TwoSlopeNorm(0.0, min(mm.min(), -1e-3), max(mm.max(), 1e-3))
    mesh = axes[2].pcolormesh(x, y, mm, cmap="coolwarm", norm=norm, shading="nearest")
    fig.colorbar(mesh, ax=axes[2], label="mm")
    axes[2].set(xlabel="x (m)", ylabel="y (m)", aspect="equal",
                title="sag changes the clearance by (mm)")
    fig.suptitle("CoGiRo at z = 2 m, unrotated: cable-cable clearance and the 0.38 m "
                 "interference-free workspace")
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    study_pond_sag(HERE / "study_pond_sag.png")
    cogiro_rotated(HERE / "cogiro_rotated.png")
    pick_and_place_frame(HERE / "pick_and_place_frame.png")
    cogiro_interference(HERE / "cogiro_interference.png")
