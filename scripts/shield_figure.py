"""Draw one walking step of the LGM shield (`planning/lgm_shield.py`) in the robot frame.

    python scripts/shield_figure.py [--seed 700089] [--planner policy_shield] \\
        [--out docs/figures/shield_step.png]

Walks the shielded planner in the LIP world from the (tuning) seed until the first step
where the shield walks another command than the policy would while the robot walks at
`--min-speed` or faster, and draws that step: the LiDAR hits of the newest LGM frame
(still: grey; moving: vermillion), shaded where the CoM may not go (within r_robot + the
hit's margin), every command's predicted path "this command, then stop" (admissible:
light blue; blocked: light grey), the policy's own command (dashed black) and the
shield's (blue). Left: the scene in the world frame up to that step.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from emonav_drake.navigation.lip_world import NavigationWorld  # noqa: E402
from emonav_drake.palette import (  # noqa: E402
    EMOTION_RGB,
    GOAL_RGB,
    INK_RGB,
    OKABE_ITO,
    ROBOT_LIGHT_RGB,
    ROBOT_RGB,
    SHADE_RGB,
    STATIC_RGB,
)
from emonav_drake.params import EmoNavConfig, EpisodeParams  # noqa: E402
from emonav_drake.planners import configure_for, make_planner  # noqa: E402
from emonav_drake.planning.lgm_shield import lgm_hit_points, path_gaps  # noqa: E402
from emonav_drake.scenarios.scenario import sample_scenario  # noqa: E402

MOVING_RGB = OKABE_ITO["vermillion"]
BLOCKED_RGB = SHADE_RGB  # a blocked command's path


def first_override(planner, world: NavigationWorld, min_speed: float, max_steps: int = 200):
    """Step the world with the shielded planner until the shield overrides the policy
    while the robot walks at `min_speed` [m/s] or faster; returns (planner input, memory
    before it, robot path so far) or None."""
    memory, path = planner.initial_memory(), []
    for _ in range(max_steps):
        obs = world.planner_input()
        path.append([obs.robot.x, obs.robot.y])
        u, new_memory = planner.plan_with_memory(obs, memory)
        if obs.robot.speed >= min_speed and not np.array_equal(u, planner.policy.plan(obs)):
            return obs, memory, np.array(path)
        memory = new_memory
        _, outcome = world.step(u)
        if outcome is not None:
            return None
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=700_089)
    ap.add_argument("--planner", default="policy_shield")
    ap.add_argument("--min-speed", type=float, default=0.3, help="draw a step at this speed")
    ap.add_argument("--out", type=Path, default=Path("docs/figures/shield_step.png"))
    args = ap.parse_args()
    cfg0 = EmoNavConfig()
    planner = make_planner(args.planner, cfg0)
    cfg, _ = configure_for(planner, cfg0)
    world = NavigationWorld(
        sample_scenario(args.seed, cfg), cfg, goal_radius=EpisodeParams.eval_goal_radius
    )
    found = first_override(planner, world, args.min_speed)
    if found is None:
        raise SystemExit(f"the shield never overrode the policy on seed {args.seed}")
    obs, memory, path = found
    li, r = cfg.lidar, cfg.robot.radius
    stack = obs.lgm_stack
    points = lgm_hit_points(stack[-1], li.num_beams, li.max_range)
    pose = np.array([obs.robot.x, obs.robot.y, obs.robot.heading])
    margins, _, moving = planner.point_margins(points, pose, memory)
    paths = planner.predicted_paths(obs, memory)
    ok = path_gaps(paths, points, margins) >= r
    scores = planner.policy.command_scores(stack, planner.policy.goal_state(obs), obs.last_command)
    own = int(np.argmax(scores))
    chosen = int(np.argmax(np.where(ok, scores, -np.inf))) if ok.any() else own

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5.2))
    # the scene (world frame)
    crowd = obs.crowd
    for c, rad in zip(crowd.static_centers, crowd.static_radii, strict=True):
        ax0.add_patch(plt.Circle(c, rad, color=STATIC_RGB))
    for c, e in zip(crowd.positions, crowd.emotions, strict=True):
        ax0.add_patch(plt.Circle(c, crowd.radius, color=EMOTION_RGB[int(e)], alpha=0.8))
    ax0.plot(path[:, 0], path[:, 1], color=ROBOT_RGB, lw=1.2)
    ax0.add_patch(plt.Circle(path[-1], r, fill=False, color=ROBOT_RGB, lw=1.5))
    ax0.plot(*obs.goal_xy, marker="*", color=GOAL_RGB, ms=12)
    ax0.set_aspect("equal")
    ax0.set_xlim(pose[0] - 3.0, pose[0] + 3.0)
    ax0.set_ylim(pose[1] - 3.0, pose[1] + 3.0)
    ax0.set_title(f"seed {args.seed}, step {obs.step}: the scene (world frame)")
    ax0.set_xlabel("x [m]")
    ax0.set_ylabel("y [m]")
    # the shield's view (robot frame)
    for c in np.flatnonzero(~ok):
        ax1.plot(paths[c, :, 0], paths[c, :, 1], color=BLOCKED_RGB, lw=0.8)
    for c in np.flatnonzero(ok):
        ax1.plot(paths[c, :, 0], paths[c, :, 1], color=ROBOT_LIGHT_RGB, lw=0.8)
    ax1.plot(paths[own, :, 0], paths[own, :, 1], color=INK_RGB, ls="--", lw=1.8)
    ax1.plot(paths[chosen, :, 0], paths[chosen, :, 1], color=ROBOT_RGB, lw=2.2)
    # where the CoM may not go: within r_robot + its margin of a hit (still / moving)
    gx, gy = np.meshgrid(np.linspace(-0.4, 1.2, 321), np.linspace(-0.8, 0.8, 321))
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    for sel, col in ((~moving, STATIC_RGB), (moving, MOVING_RGB)):
        if sel.any():
            d = np.linalg.norm(grid[:, None, :] - points[sel][None], axis=-1) - margins[sel]
            inside = (d.min(axis=1) < r).reshape(gx.shape).astype(float)
            ax1.contourf(gx, gy, inside, levels=[0.5, 1.5], colors=[col], alpha=0.15)
    ax1.scatter(*points[~moving].T, s=10, color=STATIC_RGB, zorder=3)
    ax1.scatter(*points[moving].T, s=10, color=MOVING_RGB, zorder=3)
    ax1.add_patch(plt.Circle((0, 0), r, fill=False, color=ROBOT_RGB, lw=1.5))
    ax1.set_aspect("equal")
    ax1.set_xlim(-0.4, 1.2)
    ax1.set_ylim(-0.8, 0.8)
    ax1.set_xlabel("x forward [m]")
    ax1.set_ylabel("y left [m]")
    ax1.set_title("the shield's view (robot frame): each command, then stop")
    handles = [
        plt.Line2D([], [], color=STATIC_RGB, marker="o", ls="none", label="LiDAR hit, still"),
        plt.Line2D([], [], color=MOVING_RGB, marker="o", ls="none", label="LiDAR hit, moving"),
        plt.Line2D([], [], color=ROBOT_LIGHT_RGB, label="admissible command"),
        plt.Line2D([], [], color=BLOCKED_RGB, label="blocked command"),
        plt.Line2D([], [], color=INK_RGB, ls="--", label="the policy's own command"),
        plt.Line2D([], [], color=ROBOT_RGB, lw=2.2, label="the shield's command"),
        plt.Rectangle(
            (0, 0), 1, 1, color=MOVING_RGB, alpha=0.15, label="CoM within r_robot + margin"
        ),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(
        f"wrote {args.out}: step {obs.step}, policy {planner.policy.commands[own]}, "
        f"shield {planner.policy.commands[chosen]}, {int(ok.sum())} of {len(ok)} admissible"
    )


if __name__ == "__main__":
    main()
