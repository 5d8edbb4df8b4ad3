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
    summarize_sweep,
    sweep_table_markdown,
    sweep_walking_rates,
)


def plot(table: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    planners = sorted({r["planner_hz"] for r in table}, reverse=True)
    for ph in planners:
        rows = sorted(
            (r for r in table if r["planner_hz"] == ph), key=lambda r: -r["controller_hz"]
        )
        hz = [r["controller_hz"] for r in rows]
        axes[0].plot(hz, [100 * r["rms_x"] for r in rows], "o-", label=f"planner {ph} Hz")
        axes[1].plot(hz, [100 * r["rms_y"] for r in rows], "o-", label=f"planner {ph} Hz")
        axes[2].plot(hz, [r["real_time_factor"] for r in rows], "o-", label=f"planner {ph} Hz")
        for r in rows:
            if r["falls"]:
                axes[0].annotate(f"{r['falls']} falls", (r["controller_hz"], 100 * r["rms_x"]))
    ticks = sorted({r["controller_hz"] for r in table})
    for ax, title in zip(
        axes,
        [
            "tracking RMS x [cm]",
            "tracking RMS y [cm]",
            "real-time factor (while the sweep ran)",
        ],
        strict=True,
    ):
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xticks(ticks, [str(t) for t in ticks])
        ax.set_xlabel("controller rate [Hz]")
        ax.set_title(title)
        ax.set_ylim(0.0, 1.3 * ax.get_ylim()[1])
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


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
    plot(table, args.out.with_suffix(".png"))
    print(f"wrote {args.out.with_suffix('.md')} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
