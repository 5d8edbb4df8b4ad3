"""Full-order Digit speed: walking and navigation, one configuration against another.

    .venv/bin/python benchmarks/bench_digit_speed.py [--configs A.yaml B.yaml ...]
        [--repeats 3] [--walk-seconds 10] [--nav-seeds 1001 1002 1003] [--core N]

For every configuration (default: the 1 ms / 1 kHz reference `configs/walking_1ms.yaml`
and the package default), pinned to one CPU core and interleaved run by run (so a change of
load on the shared machine hits every configuration alike):

* walk: `--repeats` open-loop walks of `--walk-seconds` with seeded random commands
  (seeds 0, 1, ...): real-time factor, tracking RMS (x, y, heading), falls;
* navigation: one DWA navigation episode on Digit per `--nav-seed` and repeat: real-time
  factor of the whole loop (plant, controller, ALIP, crowd, LiDAR grid maps, planner).

Prints each run, then per configuration the medians and the ratio to the first one.
Budgets (docs/facts.md): navigation loop >= 3x real time (aim 5x).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

from emonav_drake.configs import CONFIG_DIR
from emonav_drake.diagrams.navigation_digit import run_digit_episode
from emonav_drake.diagrams.walking import run_walk
from emonav_drake.params import load_config
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.scenarios.scenario import sample_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--configs",
        nargs="+",
        default=[str(CONFIG_DIR / "walking_1ms.yaml"), "default"],
        help="YAML configurations ('default' = the package defaults); the first is the base",
    )
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--walk-seconds", type=float, default=10.0)
    ap.add_argument("--nav-seeds", type=int, nargs="*", default=[1001])
    ap.add_argument("--core", type=int, default=None, help="CPU to pin to (default: last)")
    args = ap.parse_args()
    core = args.core if args.core is not None else max(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    cfgs = {c: load_config() if c == "default" else load_config(c) for c in args.configs}
    walk = {c: [] for c in cfgs}
    nav = {c: [] for c in cfgs}
    for k in range(args.repeats):
        for name, cfg in cfgs.items():
            r = run_walk(args.walk_seconds, seed=k, command="random", config=cfg)
            walk[name].append(r)
            print(
                f"{Path(name).stem}: walk seed {k}: {'FELL ' if r.fell else ''}"
                f"{r.real_time_factor:.2f}x real time, RMS x {100 * r.tracking_rms['x']:.2f} cm "
                f"y {100 * r.tracking_rms['y']:.2f} cm heading "
                f"{1000 * r.tracking_rms['heading']:.1f} mrad",
                flush=True,
            )
            for seed in args.nav_seeds:
                t0 = time.perf_counter()
                rec, _ = run_digit_episode(sample_scenario(seed, cfg), cfg, DwaPlanner(cfg))
                wall = time.perf_counter() - t0
                sim = rec.steps * cfg.robot.step_time
                nav[name].append(sim / wall)
                print(
                    f"{Path(name).stem}: navigation seed {seed}: {rec.outcome} after "
                    f"{rec.steps} steps, {sim / wall:.2f}x real time",
                    flush=True,
                )
    base = args.configs[0]
    b_walk = statistics.median(r.real_time_factor for r in walk[base])
    b_nav = statistics.median(nav[base])
    print(f"\ncore {core}, {args.repeats} repeats; medians (ratio to {Path(base).stem}):")
    for name in cfgs:
        rw = statistics.median(r.real_time_factor for r in walk[name])
        rn = statistics.median(nav[name])
        rms = {
            key: statistics.median(r.tracking_rms[key] for r in walk[name])
            for key in ("x", "y", "heading")
        }
        falls = sum(r.fell for r in walk[name])
        print(
            f"  {Path(name).stem}: walk {rw:.2f}x ({rw / b_walk:.2f}), navigation {rn:.2f}x "
            f"({rn / b_nav:.2f}); RMS x {100 * rms['x']:.2f} cm, y {100 * rms['y']:.2f} cm, "
            f"heading {1000 * rms['heading']:.1f} mrad; falls {falls}"
        )


if __name__ == "__main__":
    main()
