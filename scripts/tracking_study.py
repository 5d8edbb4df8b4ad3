"""Measure the LiDAR tracker against the true crowd: CLEAR-MOT over LIP episodes.

    python scripts/tracking_study.py --episodes 100 --first-seed 700000 \
        --out benchmarks/results/tracking --png docs/figures/tracking_quality.png

Runs --episodes LIP episodes (seeds --first-seed …, the MPC on the true crowd) with a
LiDAR scan, detection and tracker update at every crowd period (10 Hz), and scores the
tracker's pedestrians against the truth with py-motmetrics
(`emonav_drake/evaluation/tracking_study.py`). Writes into --out: `summary.json` (every
metric, the seeds, the command, the wall time), `tables.md` (the tables that
docs/perception.md quotes), `episodes.csv` (CLEAR-MOT per episode),
`scans.csv` (one row per scan: visibility counts, detections, tracks, matches, misses,
false pedestrians, switches), `by_distance.csv` and `by_hidden_time.csv` (the binned
data of the figure). --png draws the figure. The evaluation seeds 0-499 are refused:
use seeds that no planner is trained, selected or evaluated on (700 000 … by default).
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import shlex
import sys
import time
from pathlib import Path

from emonav_drake.atomic_io import (
    atomic_output,
    check_output_dir,
    check_output_file,
    write_json,
    write_text_atomic,
)
from emonav_drake.cli.resolve import add_family, add_sensor

EVALUATION_SEEDS = range(0, 500)  # the benchmark's seeds: never measured on here


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=100, help="LIP episodes (100)")
    p.add_argument("--first-seed", type=int, default=700_000, help="first seed (700000)")
    p.add_argument("--out", type=Path, required=True, help="directory of the results")
    p.add_argument("--png", type=Path, help="write the figure here")
    add_family(p)
    add_sensor(p)
    args = p.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    try:
        if args.episodes < 1:
            raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
        if args.first_seed < 0:
            raise ValueError(f"--first-seed must be >= 0, got {args.first_seed}")
        if seeds.start < EVALUATION_SEEDS.stop and EVALUATION_SEEDS.start < seeds.stop:
            raise ValueError(
                f"--first-seed {args.first_seed}: seeds {seeds.start}-{seeds.stop - 1} overlap "
                "the evaluation seeds 0-499; use seeds from 700000 on"
            )
        check_output_dir(args.out, "--out")
        if args.png is not None:
            check_output_dir(args.png.parent, "--png")
            if args.png.parent.is_dir():
                check_output_file(args.png, "--png")
        args.out.mkdir(parents=True, exist_ok=True)
        if args.png is not None:
            args.png.parent.mkdir(parents=True, exist_ok=True)
    except (ValueError, OSError) as e:
        print(f"tracking_study: error: {e}", file=sys.stderr)
        return 2

    from emonav_drake.evaluation.tracking_report import csv_rows, plot, tables_md
    from emonav_drake.evaluation.tracking_study import study
    from emonav_drake.evaluation.tracking_summary import clear_mot, summarise
    from emonav_drake.params import EmoNavConfig, apply_sensor_preset

    cfg = EmoNavConfig()
    if args.family is not None:
        cfg.crowd.family = args.family
    if args.sensor is not None:
        apply_sensor_preset(cfg, args.sensor)
    t0 = time.perf_counter()
    results = study(seeds, cfg, progress=True)
    wall = time.perf_counter() - t0
    summary = summarise(results, cfg)
    given = sys.argv[1:] if argv is None else argv
    summary["command"] = shlex.join(["python", "scripts/tracking_study.py", *given])
    summary["planner"] = "mpc"
    summary["plant"] = "lip"
    summary["family"] = cfg.crowd.family
    summary["sensor"] = dc.asdict(cfg.sensor)
    summary["wall_seconds"] = round(wall, 1)
    _, per_episode = clear_mot(results)
    for row, r in zip(per_episode, results, strict=True):
        row.update(outcome=r.outcome, steps=r.steps, scans=r.scans, discs=r.discs)
    scans = [row for r in results for row in r.per_scan]
    out = args.out
    write_json(out / "summary.json", summary)
    write_text_atomic(out / "tables.md", tables_md(summary))
    write_text_atomic(out / "episodes.csv", csv_rows(per_episode))
    write_text_atomic(out / "scans.csv", csv_rows(scans))
    write_text_atomic(out / "by_distance.csv", csv_rows(summary["by_distance"]))
    write_text_atomic(out / "by_hidden_time.csv", csv_rows(summary["by_hidden_time"]))
    m = summary["clear_mot"]
    print(
        json.dumps(
            {
                "episodes": summary["episodes"],
                "scans": summary["scans"],
                **{k: m[k] for k in ("mota", "motp", "num_switches", "idf1")},
                "position_rmse": summary["position_rmse"],
                "velocity_rmse": summary["velocity_rmse"],
            }
        )
    )
    if args.png is not None:
        with atomic_output(args.png) as tmp:
            plot(summary, tmp)
        print(f"figure written to {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
