"""`emonav lgm`: a scenario's LiDAR grid map and OGM (the paper's Fig. 3) as a PNG.

emonav lgm  --seed S --png out.png [--steps K] [--scenario F.yaml] [--config F.yaml]
            [--time-varying]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.atomic_io import atomic_output
from emonav_drake.cli.common import SeedArg, check_outputs
from emonav_drake.cli.resolve import CONFIG_HELP, resolve_config, resolve_scenario
from emonav_drake.params import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav lgm` on the CLI's sub-parsers."""
    g = subparsers.add_parser("lgm", help="render a scenario's LiDAR grid map and OGM as a PNG")
    g.add_argument("--seed", action=SeedArg, default=0, help="scenario seed, in [0, 2**64 - 1]")
    g.add_argument(
        "--scenario",
        help="YAML scenario file instead of a sampled one, or the name of a shipped example",
    )
    g.add_argument("--steps", type=int, default=8, help="DWA steps to walk before the snapshot")
    g.add_argument("--png", type=Path, required=True, help="output image (a .png file)")
    g.add_argument("--config", type=Path, help=CONFIG_HELP)
    g.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (as in `sim --time-varying`)",
    )
    g.set_defaults(func=cmd_lgm)
    return g


def cmd_lgm(args: argparse.Namespace) -> int:
    """Walk `--steps` DWA steps in the scenario, then draw the grid maps."""
    if args.steps < 0:
        raise ConfigError(f"--steps {args.steps}: must be >= 0")
    check_outputs(args, "--png")
    if args.png.suffix.lower() != ".png":
        raise ConfigError(f"--png {args.png}: the file name must end in .png")
    import numpy as np

    from emonav_drake.crowd.crowd import obstacle_discs
    from emonav_drake.evaluation.grid_map_figure import render_grid_map_figure
    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.planners.dwa import DwaPlanner

    resolved = resolve_config(args)
    cfg = resolved.config
    world = NavigationWorld(resolve_scenario(args, resolved), cfg, grid_kind=None)
    planner = DwaPlanner(cfg)
    for _ in range(args.steps):  # walk a little so the crowd comes close
        _, outcome = world.step(planner.plan(world.planner_input()))
        if outcome is not None:
            break
    obs = world.planner_input()
    centers, radii, margins = obstacle_discs(obs.crowd)
    kinds = np.concatenate(
        [np.ones(len(obs.crowd.positions), int), np.zeros(len(obs.crowd.static_radii), int)]
    )
    emotions = np.concatenate([obs.crowd.emotions, np.full(len(obs.crowd.static_radii), -1)])
    with atomic_output(args.png) as tmp:
        render_grid_map_figure(
            tmp,
            np.array([obs.robot.x, obs.robot.y]),
            obs.robot.heading,
            centers,
            radii,
            margins,
            kinds,
            goal_xy=obs.goal_xy,
            grid_size=cfg.lidar.grid_size,
            num_beams=cfg.lidar.num_beams,
            max_range=cfg.lidar.max_range,
            min_range=cfg.lidar.min_range,
            robot_radius=cfg.robot.radius,
            title=f"seed {world.scenario.seed}: t = {world.step_count * cfg.robot.step_time:.1f} s "
            f"(after {world.step_count} DWA steps)",
            emotions=emotions,
            segments=obs.crowd.wall_segments,
            segment_margin=obs.crowd.static_discomfort,
        )
    print(f"wrote {args.png} (seed {args.seed}, after {world.step_count} steps)")
    return 0
