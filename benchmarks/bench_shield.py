"""Shield benchmark: what the LGM shield adds to a policy's planning step (one core).

The shielded planner drives the LIP world in closed loop over tuning seeds; at every
walking step the bare policy's `plan` and the shielded planner's `plan_with_memory` are
timed on the same input (thread CPU time, so a shared machine's descheduling does not
count). Printed, as median and 95th percentile [ms]: the policy alone, the policy behind
the shield, the shield's share (their difference), and the LiDAR hits it checked.

Run:  .venv/bin/python benchmarks/bench_shield.py [--episodes 10] [--planner policy_shield]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.navigation.lip_world import NavigationWorld  # noqa: E402
from emonav_drake.params import EmoNavConfig  # noqa: E402
from emonav_drake.planners import configure_for, make_planner  # noqa: E402
from emonav_drake.planning.lgm_shield import lgm_hit_points  # noqa: E402
from emonav_drake.scenarios.scenario import sample_scenario  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=700_000)
    ap.add_argument("--planner", default="policy_shield")
    args = ap.parse_args()
    import torch

    torch.set_num_threads(1)
    cfg0 = EmoNavConfig()
    shield = make_planner(args.planner, cfg0)
    cfg, _ = configure_for(shield, cfg0)
    bare, shielded, hits = [], [], []
    for seed in range(args.first_seed, args.first_seed + args.episodes):
        world = NavigationWorld(sample_scenario(seed, cfg), cfg)
        memory, outcome = shield.initial_memory(), None
        while outcome is None:
            obs = world.planner_input()
            t0 = time.thread_time()
            shield.policy.plan(obs)
            t1 = time.thread_time()
            u, memory = shield.plan_with_memory(obs, memory)
            t2 = time.thread_time()
            bare.append(t1 - t0)
            shielded.append(t2 - t1)
            li = cfg.lidar
            hits.append(len(lgm_hit_points(obs.lgm_stack[-1], li.num_beams, li.max_range)))
            _, outcome = world.step(u)
    b, s = 1e3 * np.array(bare), 1e3 * np.array(shielded)
    print(f"{args.planner}: {len(b)} planning steps over {args.episodes} episodes (LIP world)")
    for name, x in (("policy", b), ("policy + shield", s), ("shield's share", s - b)):
        print(f"  {name:16s} median {np.median(x):6.2f} ms   p95 {np.percentile(x, 95):6.2f} ms")
    print(f"  LiDAR hits checked: median {np.median(hits):.0f}, max {max(hits)}")


if __name__ == "__main__":
    main()
