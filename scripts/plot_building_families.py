"""Draw one scene of each building family (`scenarios/scenario_families.py`).

    python scripts/plot_building_families.py [--seed 0] [--out FILE.png]

For `t_junction`, `doorway` and `office`: the walls, the robot's start (its disc and
heading) and goal, its shortest route round the walls (`scenarios/global_route.py`, the
clearance the navigation stack plans with), and every pedestrian's start disc and its
walked polyline start → waypoints → goal, in the colour of its emotion. World frame,
metres.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from emonav_drake.diagrams.navigation import ROUTE_MARGIN  # noqa: E402
from emonav_drake.palette import (  # noqa: E402
    EMOTION_RGB,
    GOAL_RGB,
    INK_RGB,
    ROBOT_RGB,
)
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig  # noqa: E402
from emonav_drake.scenarios.global_route import StaticMap, plan_route  # noqa: E402
from emonav_drake.scenarios.scenario_families import sample_family  # noqa: E402

BUILDINGS = ("t_junction", "doorway", "office")


def draw(ax: plt.Axes, family: str, seed: int, cfg: EmoNavConfig) -> None:
    """The scene of `seed` in `family` on `ax` (world frame, metres)."""
    scene = sample_family(family, seed, cfg)
    for w in scene.walls:
        ax.plot(*np.array([w.start, w.end]).T, color=INK_RGB, lw=2.0, solid_capstyle="butt")
    r, p = cfg.robot.radius, cfg.crowd.pedestrian_radius
    for ped in scene.pedestrians:
        colour = EMOTION_RGB[EMOTION_NAMES.index(ped.emotion)]
        path = np.array([ped.start, *ped.waypoints, ped.goal])
        ax.plot(*path.T, color=colour, lw=1.0, ls="--")
        ax.add_patch(plt.Circle(ped.start, p, color=colour, alpha=0.6))
        ax.plot(*ped.goal, marker="x", color=colour, ms=6, ls="none")
    walls = StaticMap.of([[w.start, w.end] for w in scene.walls])
    route = plan_route(scene.robot_start, scene.robot_goal, walls, r + ROUTE_MARGIN)
    ax.plot(*route.T, color=ROBOT_RGB, lw=1.5)
    ax.add_patch(plt.Circle(scene.robot_start, r, color=ROBOT_RGB, alpha=0.8))
    h = scene.robot_heading
    ax.arrow(
        *scene.robot_start,
        0.6 * math.cos(h),
        0.6 * math.sin(h),
        color=ROBOT_RGB,
        width=0.03,
        head_width=0.15,
        length_includes_head=True,
    )
    ax.plot(*scene.robot_goal, marker="*", color=GOAL_RGB, ms=13, ls="none")
    ax.set_aspect("equal")
    ax.set_title(f"{family}, seed {seed}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("docs/figures/building_families.png"))
    args = ap.parse_args()
    cfg = EmoNavConfig()
    fig, axes = plt.subplots(1, len(BUILDINGS), figsize=(15.0, 5.2))
    for ax, family in zip(axes, BUILDINGS, strict=True):
        draw(ax, family, args.seed, cfg)
    handles = [
        plt.Line2D([], [], color=INK_RGB, lw=2, label="wall"),
        plt.Line2D([], [], color=ROBOT_RGB, marker="o", lw=1.5, label="robot: start, route"),
        plt.Line2D([], [], color=GOAL_RGB, marker="*", ls="none", ms=10, label="robot's goal"),
    ]
    handles += [
        plt.Line2D([], [], color=c, ls="--", marker="o", label=f"pedestrian ({n}): start, path")
        for n, c in zip(EMOTION_NAMES, EMOTION_RGB, strict=True)
    ]
    fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=8)
    fig.suptitle("The building families: walls, the robot's route, the pedestrians' routes")
    fig.tight_layout(rect=(0, 0.07, 1, 0.95))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
