"""Draw what the "guide" goal input shows a policy (`navigation/goal_input.py`).

    python scripts/guide_subgoal_figure.py [--seeds 600003 600017] [--out FILE.png]

For each scenario seed: the static discs (their contact and discomfort rings), the MPC's
trajectory in the LIP world, and at every third walking step the bearing a policy reads:
grey to the goal ("goal" input), reddish purple to the guide sub-goal ("guide" input) where the
two differ.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from emonav_drake.navigation.goal_input import guide_subgoal  # noqa: E402
from emonav_drake.navigation.lip_world import NavigationWorld  # noqa: E402
from emonav_drake.palette import (  # noqa: E402
    GOAL_RGB,
    OKABE_ITO,
    REFERENCE_RGB,
    ROBOT_RGB,
    STATIC_RGB,
    ZONE_EDGE_RGB,
)
from emonav_drake.params import EmoNavConfig  # noqa: E402
from emonav_drake.planners.mpc import MpcPlanner  # noqa: E402
from emonav_drake.scenarios.scenario import sample_scenario  # noqa: E402

GUIDE_RGB = OKABE_ITO["reddish_purple"]  # the guide sub-goal's bearing


def draw(ax: plt.Axes, seed: int, cfg: EmoNavConfig) -> None:
    """One scenario's discs, MPC path and goal / guide bearings on `ax`."""
    world = NavigationWorld(sample_scenario(seed, cfg), cfg)
    mpc = MpcPlanner(cfg)
    r = cfg.robot.radius
    crowd = world.planner_input().crowd
    for c, rad in zip(crowd.static_centers, crowd.static_radii, strict=True):
        ax.add_patch(plt.Circle(c, rad, color=STATIC_RGB))
        ax.add_patch(plt.Circle(c, rad + r, fill=False, ls="--", color=STATIC_RGB, lw=0.8))
        zone = rad + r + crowd.static_discomfort
        ax.add_patch(plt.Circle(c, zone, fill=False, ls=":", color=STATIC_RGB, lw=0.8))
    path, k = [], 0
    while True:
        obs = world.planner_input()
        p = np.array([obs.robot.x, obs.robot.y])
        path.append(p)
        if k % 3 == 0:
            g = np.asarray(obs.goal_xy) - p
            g = 0.6 * g / max(np.linalg.norm(g), 1e-9)
            ax.arrow(
                *p, *g, color=REFERENCE_RGB, width=0.01, head_width=0.08, length_includes_head=True
            )
            sub = guide_subgoal(obs.robot, obs.goal_xy, obs.crowd, r)
            if sub is not None:
                d = sub - p
                d = 0.6 * d / max(np.linalg.norm(d), 1e-9)
                ax.arrow(
                    *p,
                    *d,
                    color=GUIDE_RGB,
                    width=0.015,
                    head_width=0.1,
                    length_includes_head=True,
                )
        _, outcome = world.step(mpc.plan(obs))
        k += 1
        if outcome is not None:
            break
    path = np.array(path)
    ax.plot(path[:, 0], path[:, 1], color=ROBOT_RGB, lw=1.2, label=f"MPC ({outcome})")
    goal = np.asarray(world.planner_input().goal_xy)
    ax.plot(*goal, marker="*", color=GOAL_RGB, ms=12, ls="none", label="goal")
    ax.plot(*path[0], marker="s", color=ROBOT_RGB, ms=7, ls="none")
    ax.set_aspect("equal")
    ax.set_title(f"seed {seed}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[600003, 600017])
    ap.add_argument("--out", type=Path, default=Path("docs/figures/guide_subgoal.png"))
    args = ap.parse_args()
    cfg = EmoNavConfig()
    fig, axes = plt.subplots(1, len(args.seeds), figsize=(6.5 * len(args.seeds), 3.8))
    for ax, seed in zip(np.atleast_1d(axes), args.seeds, strict=True):
        draw(ax, seed, cfg)
    handles = [
        plt.Line2D([], [], color=REFERENCE_RGB, lw=2, label='"goal": bearing of the goal'),
        plt.Line2D([], [], color=GUIDE_RGB, lw=2, label='"guide": bearing of the sub-goal'),
        plt.Line2D([], [], color=ROBOT_RGB, lw=1.2, label="MPC path (LIP world)"),
        plt.Line2D([], [], color=STATIC_RGB, ls="--", label="contact (r_disc + r_robot)"),
        plt.Line2D([], [], color=ZONE_EDGE_RGB, ls=":", label="discomfort zone"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8)
    fig.suptitle("The goal a policy reads: goal bearing vs guide sub-goal around static discs")
    fig.tight_layout(rect=(0, 0.11, 1, 0.94))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
