"""Is a family's failure the robot's? A robot that stands still, and planners, on a family's
tuning seeds in the LIP world with the true state, with the robot's speed at each collision.

    python scripts/family_feasibility.py --family corner_traffic --episodes 40 \\
        --planners stand,mpc,dwa

`stand` sends (0, 0) at every step: by the paper's rule a pedestrian sees the robot when it
walks faster than the robot, so a standing robot is seen by every walking pedestrian and
avoided by ORCA — if it is still hit, the scene's crowd walks into a robot that does
nothing, and no planner can pass every seed. Other names are planners (`emonav planners`)
with their default checkpoints. Seeds `--first-seed` … (tuning seeds, 700 000 by default;
never the evaluation seeds). Prints, per planner, the outcomes (collisions by what they hit)
and, over the collisions, the robot's speed in the step that ended in one [m/s]: median and
share below 0.1 m/s.
"""

from __future__ import annotations

import argparse
import collections
import math

import numpy as np

from emonav_drake.evaluation.failures import failure_kind, format_counts
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig, EpisodeParams
from emonav_drake.planners import configure_for, make_planner
from emonav_drake.scenarios.scenario import sample_scenario

STAND = "stand"


def run(name: str, family: str, first_seed: int, episodes: int) -> tuple[collections.Counter, list]:
    """Outcomes ('success', 'timeout', or a collision by what it hit: 'pedestrian', 'wall',
    'static') and the robot's speeds at the collisions [m/s]."""
    cfg = EmoNavConfig()
    cfg.crowd.family = family
    planner = None if name == STAND else make_planner(name, cfg, None)
    if planner is not None:
        cfg = configure_for(planner, cfg)[0]
    outcomes: collections.Counter[str] = collections.Counter()
    speeds = []
    for seed in range(first_seed, first_seed + episodes):
        scenario = sample_scenario(seed, cfg)
        world = NavigationWorld(scenario, cfg, goal_radius=EpisodeParams.eval_goal_radius)
        if planner is not None:
            planner.reset()
        outcome, ev = None, None
        while outcome is None:
            before = (world.robot.x, world.robot.y)
            u = np.zeros(2) if planner is None else planner.plan(world.planner_input())
            ev, outcome = world.step(u)
            moved = math.hypot(world.robot.x - before[0], world.robot.y - before[1])
        outcomes[
            failure_kind({"outcome": outcome, "collided_with": ev.collided_with}) or outcome
        ] += 1
        if outcome == "collision":
            speeds.append(moved / cfg.robot.step_time)
    return outcomes, speeds


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", required=True)
    ap.add_argument("--planners", default="stand,mpc,dwa")
    ap.add_argument("--first-seed", type=int, default=700_000)
    ap.add_argument("--episodes", type=int, default=40)
    args = ap.parse_args()
    for name in args.planners.split(","):
        outcomes, speeds = run(name, args.family, args.first_seed, args.episodes)
        line = f"{name} in {args.family} (n = {args.episodes}): {format_counts(outcomes)}"
        if speeds:
            s = np.array(speeds)
            line += (
                f"; robot speed at the collisions: median {np.median(s):.2f} m/s, "
                f"{(s < 0.1).mean():.0%} below 0.1 m/s"
            )
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
