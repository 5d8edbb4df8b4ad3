"""Closed-loop walking throughput: real-time factor and controller tick, on one core.

    .venv/bin/python benchmarks/bench_walking.py [--seconds 10] [--repeats 3] [--core N]
        [--config F.yaml] [--controller-hz HZ] [--planner-hz HZ]

Runs the full walking diagram (the configured Digit stack — by default the plant at 10 ms
with SAP and its implicit damping of the hip yaws and knees, the ALIP planner at 50 Hz,
the passivity controller at every plant step (`configs/walking_4ms.yaml`: the 4 ms stack);
`--config emonav_drake/configs/walking_1ms.yaml` for the 1 ms / 200 Hz / 1 kHz one — with
per-step random commands, no Meshcat) `--repeats` times
pinned to one CPU core, and prints per run and as medians: the real-time factor
(simulated / wall seconds) and the controller's median tick (one `actuation` output
evaluation, i.e. all plant queries + the law). Budgets (docs/facts.md): real-time factor
≥ 1 (aim ≥ 3), median tick ≤ 0.3 ms. The machine is shared: read the medians.
"""

from __future__ import annotations

import argparse
import os
import statistics

import numpy as np

from emonav_drake.diagrams.walking import run_walk
from emonav_drake.params import load_config


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--core", type=int, default=None, help="CPU to pin to (default: last)")
    ap.add_argument("--config", default=None, help="YAML configuration (default: the defaults)")
    ap.add_argument("--controller-hz", type=float, default=None, help="controller rate")
    ap.add_argument("--planner-hz", type=float, default=None, help="footstep-planner rate")
    args = ap.parse_args()
    cfg = load_config(args.config) if args.config else load_config()
    if args.controller_hz:
        cfg.walking.controller_period = 1.0 / args.controller_hz
    if args.planner_hz:
        cfg.walking.planner_period = 1.0 / args.planner_hz
    cfg.validate()
    args.controller_hz = 1.0 / cfg.walking.controller_period
    args.planner_hz = 1.0 / cfg.walking.planner_period
    core = args.core if args.core is not None else max(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    rtfs, ticks, p90 = [], [], []
    for k in range(args.repeats):
        r = run_walk(args.seconds, seed=k, command="random", config=cfg, record_timing=True)
        t = np.asarray(r.tick_seconds) * 1e3
        rtfs.append(r.real_time_factor)
        ticks.append(float(np.median(t)))
        p90.append(float(np.percentile(t, 90)))
        print(
            f"run {k}: {'FELL ' if r.fell else ''}{r.sim_seconds:.1f} s simulated in "
            f"{r.wall_seconds:.2f} s -> real-time factor {r.real_time_factor:.2f}x; "
            f"controller tick median {ticks[-1]:.3f} ms, p90 {p90[-1]:.3f} ms "
            f"({len(t)} ticks)"
        )
    print(
        f"controller {args.controller_hz:.0f} Hz, footstep planner {args.planner_hz:.0f} Hz, "
        f"core {core}, {args.repeats} runs x {args.seconds:.0f} s random commands: "
        f"median real-time factor {statistics.median(rtfs):.2f}x (budget >= 1, aim >= 3); "
        f"median controller tick {statistics.median(ticks):.3f} ms (budget <= 0.3 ms); "
        f"p90 tick {statistics.median(p90):.3f} ms"
    )


if __name__ == "__main__":
    main()
