"""Probe the global route layer's settings on tuning seeds (LIP, the planner on true state).

    python scripts/route_probe.py [--families office,doorway,t_junction,corner_traffic]
        [--planners dwa,mpc] [--seeds 8] [--first-seed 700000] [--margin 0.1]
        [--lookahead 2.0] [--plain]

For each family and planner, the outcomes of `--seeds` episodes of the family's seeds from
`--first-seed` (tuning seeds: keep them away from the evaluation seeds 0-299) with a
`GlobalRoutePlanner` planned at the robot's radius + `--margin` [m] (falling back to the
radius) whose sub-goal is `--lookahead` [m] along the route; `--plain` runs without the
route layer. Prints one line per family and planner. For choosing the route layer's
settings, not for reporting results.
"""

from __future__ import annotations

import argparse
import collections
import functools

import numpy as np

import emonav_drake.diagrams.navigation as nav
from emonav_drake.core.global_route import StaticMap
from emonav_drake.core.scenario import Scenario
from emonav_drake.core.scenario_families import sample_family
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import make_planner
from emonav_drake.systems.global_route_planner import GlobalRoutePlanner


def route_planner_factory(margin: float, lookahead: float):
    """A `make_route_planner` with the given clearance margin [m] and look-ahead [m]."""

    def make(scenario: Scenario, config: EmoNavConfig) -> GlobalRoutePlanner:
        static_map = StaticMap.of(
            [[w.start, w.end] for w in scenario.walls],
            [o.center for o in scenario.obstacles],
            [o.radius for o in scenario.obstacles],
        )
        r = config.robot.radius
        goal = np.asarray(scenario.robot_goal, float)
        period = config.robot.step_time
        return GlobalRoutePlanner(
            static_map, goal, r + margin, r, period=period, lookahead=lookahead
        )

    return make


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", default="office,doorway,t_junction,corner_traffic")
    ap.add_argument("--planners", default="dwa,mpc")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=700_000)
    ap.add_argument("--margin", type=float, default=0.1)
    ap.add_argument("--lookahead", type=float, default=2.0)
    ap.add_argument("--plain", action="store_true", help="without the route layer")
    args = ap.parse_args()
    if not args.plain:
        nav.make_route_planner = route_planner_factory(args.margin, args.lookahead)
        nav.AddNavigationStack = functools.partial(nav.AddNavigationStack, global_route=True)
    label = (
        "plain" if args.plain else f"route margin {args.margin} m, look-ahead {args.lookahead} m"
    )
    cfg = EmoNavConfig()
    for family in args.families.split(","):
        for name in args.planners.split(","):
            outcomes = collections.Counter()
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                scene = sample_family(family, seed, cfg)
                record, _ = nav.run_episode(scene, cfg, make_planner(name, cfg), goal_radius=0.2)
                outcomes[record.outcome] += 1
            print(f"{family} {name} ({label}): {dict(outcomes)}", flush=True)


if __name__ == "__main__":
    main()
