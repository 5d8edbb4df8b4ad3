"""Sweep the walking stack's rates: controller 1 kHz / 500 Hz / 250 Hz × footstep planner
200 / 100 / 50 Hz, seeded random commands, tracking RMS, falls and real-time factor.

    .venv/bin/python benchmarks/sweep_walking_rates.py --out benchmarks/results/walking_rates.jsonl
        [--seeds 10] [--seconds 10] [--controller-hz 1000 500 250] [--planner-hz 200 100 50]

Resumable: runs already in --out are skipped. Prints the summary table (Markdown) and
writes it beside --out (.md), with a plot (.png). The numbers and the conclusion are in
docs/rates.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.evaluation.walking_sweep import (
    plot_sweep,
    summarize_sweep,
    sweep_table_markdown,
    sweep_walking_rates,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/walking_rates.jsonl"))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--controller-hz", type=float, nargs="+", default=[1000, 500, 250])
    ap.add_argument("--planner-hz", type=float, nargs="+", default=[200, 100, 50])
    args = ap.parse_args()
    rows = sweep_walking_rates(
        [1.0 / h for h in args.controller_hz],
        [1.0 / h for h in args.planner_hz],
        range(args.first_seed, args.first_seed + args.seeds),
        args.seconds,
        args.out,
    )
    table = summarize_sweep(rows)
    md = sweep_table_markdown(table)
    print(md)
    args.out.with_suffix(".md").write_text(md + "\n")
    plot_sweep(table).savefig(args.out.with_suffix(".png"), dpi=120)
    print(f"wrote {args.out.with_suffix('.md')} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
