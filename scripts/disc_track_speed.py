"""What a static disc looks like on the LiDAR tracks before it is reported static: in its
first `perception.still_duration` seconds a disc is a pedestrian at rest; this measures
the estimated speed [m/s] and the centre offset [m] of every such track (a "pedestrian"
track within 0.3 m of a true disc centre) at the planner instants of LIP episodes with
the MPC on the tracks, no-emotion setting, tuning seeds.

    python scripts/disc_track_speed.py [--first-seed 700000] [--episodes 40]

Prints one line: how many sightings, the speed's median / 90th percentile / maximum and
the centre offset's median / 90th percentile (docs/results.md, "Perceived state").
"""

from __future__ import annotations

import argparse

import numpy as np
from pydrake.systems.analysis import Simulator

from emonav_drake.configs import load_setting
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.planners import make_planner
from emonav_drake.scenarios.scenario import sample_scenario


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first-seed", type=int, default=700_000)
    parser.add_argument("--episodes", type=int, default=40)
    args = parser.parse_args()
    cfg = load_setting("no_emotion")
    cfg.perception.state_source = "lidar"
    speeds, offsets = [], []
    T = cfg.robot.step_time
    for seed in range(args.first_seed, args.first_seed + args.episodes):
        scenario = sample_scenario(seed, cfg)
        nav = build_navigation_diagram(scenario, cfg, make_planner("mpc", cfg))
        sim = Simulator(nav.diagram)
        sim.Initialize()
        centers = np.array([o.center for o in scenario.obstacles]).reshape(-1, 2)
        for k in range(1, cfg.episode.max_steps + 1):
            sim.AdvanceTo(k * T)
            ctx = sim.get_context()
            seen = nav.planner.GetInputPort("crowd").Eval(nav.planner.GetMyContextFromRoot(ctx))
            if len(seen.positions) and len(centers):
                d = np.linalg.norm(seen.positions[:, None] - centers[None], axis=-1)
                for a, b in zip(*np.nonzero(d < 0.3), strict=True):
                    speeds.append(float(np.linalg.norm(seen.velocities[a])))
                    offsets.append(float(d[a, b]))
            status = nav.monitor.GetOutputPort("status").Eval(nav.monitor.GetMyContextFromRoot(ctx))
            if status.done:
                break
    s, o = np.array(speeds), np.array(offsets)
    print(
        f"{len(s)} sightings of a disc as a pedestrian in {args.episodes} episodes: speed "
        f"median {np.median(s):.3f}, 90th percentile {np.percentile(s, 90):.3f}, max "
        f"{s.max():.3f} m/s; centre offset median {np.median(o) * 100:.1f}, 90th percentile "
        f"{np.percentile(o, 90) * 100:.1f} cm"
    )


if __name__ == "__main__":
    main()
