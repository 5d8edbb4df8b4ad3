"""Does Digit still walk as well? The walking-quality checks of a faster configuration.

    .venv/bin/python benchmarks/walking_quality.py [--configs default B.yaml ...]
        [--seeds 20] [--seconds 60] [--nav-episodes 20] [--workers 2] [--out DIR]

For every configuration ('default' = the package defaults; the first is the base):

* open loop: one walk of `--seconds` with seeded random commands (a new command within
  the paper's bounds every step) per seed 0 … `--seeds` − 1: falls, and the tracking RMS
  of x, y and heading against the LIP step map (`diagrams/walking.run_walk`);
* in navigation: `--nav-episodes` traced DWA episodes on Digit (seeds 3 200 000 + i, the
  step-timing seeds, used for nothing else) and the per-step regression of
  `evaluation/step_timing.py`: the in-step heading gain a (heading change of step k =
  a u_Δθ,k + b u_Δθ,k−1; 1.002 on the default of December 2026) and the heading error RMS.

Prints a table (median and worst RMS over the seeds, the ratio of the medians to the
base's) and, with `--out`, writes `walking_quality.json` and `.md` there. What the speed
work must hold (issue 50): no fall, the RMS within 10 % of the base's, a ≥ 0.85.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path

from emonav_drake.diagrams.walking import run_walk
from emonav_drake.evaluation.step_timing import fit_step_timing, read_traces
from emonav_drake.learning.calibration import collect_traces
from emonav_drake.params import load_config
from emonav_drake.progress import progress_bar

NAV_FIRST_SEED = 3_200_000
KEYS = ("x", "y", "heading")


def open_loop(config_name: str, seeds: int, seconds: float) -> dict:
    cfg = load_config() if config_name == "default" else load_config(config_name)
    rows = []
    for seed in progress_bar(range(seeds), desc=f"{Path(config_name).stem}: walks"):
        r = run_walk(seconds, seed=seed, command="random", config=cfg, progress=False)
        rows.append({"seed": seed, "fell": r.fell, **{k: r.tracking_rms[k] for k in KEYS}})
    return {
        "walks": rows,
        "falls": sum(r["fell"] for r in rows),
        "median": {k: statistics.median(r[k] for r in rows) for k in KEYS},
        "worst": {k: max(r[k] for r in rows) for k in KEYS},
    }


def in_navigation(config_name: str, episodes: int, workers: int) -> dict:
    cfg = load_config() if config_name == "default" else load_config(config_name)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "traces.jsonl"
        collect_traces(out, "dwa", episodes, NAV_FIRST_SEED, 0.0, workers, config=cfg)
        fit = fit_step_timing(read_traces([out]))
    return {
        "episodes": fit.episodes,
        "steps": fit.steps,
        "heading_gain": fit.turn[0],
        "heading_gain_se": fit.turn_se[0],
        "previous_step_gain": fit.turn[1],
        "heading_rms": fit.heading_rms,
    }


def table(results: dict[str, dict], base: str) -> str:
    b = results[base]["open_loop"]["median"]
    lines = [
        "| configuration | walks | falls | RMS x [cm] | RMS y [cm] | RMS heading [mrad] "
        "| worst x / y [cm] | in-step heading gain | heading RMS in navigation [mrad] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, r in results.items():
        ol, nav = r["open_loop"], r.get("navigation")
        m, w = ol["median"], ol["worst"]
        cells = [
            f"{100 * m['x']:.2f} ({m['x'] / b['x']:.2f})",
            f"{100 * m['y']:.2f} ({m['y'] / b['y']:.2f})",
            f"{1000 * m['heading']:.1f} ({m['heading'] / b['heading']:.2f})",
            f"{100 * w['x']:.2f} / {100 * w['y']:.2f}",
        ]
        gain = rms = "-"
        if nav:
            gain = f"{nav['heading_gain']:.3f} (±{nav['heading_gain_se']:.3f})"
            rms = f"{1000 * nav['heading_rms']:.1f}"
        lines.append(
            f"| {Path(name).stem} | {len(ol['walks'])} | {ol['falls']} | "
            + " | ".join(cells)
            + f" | {gain} | {rms} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", nargs="+", default=["default"])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--nav-episodes", type=int, default=20, help="0: skip the navigation fit")
    ap.add_argument("--workers", type=int, default=2, help="Ray workers of the navigation fit")
    ap.add_argument("--out", default=None, help="directory for walking_quality.json and .md")
    args = ap.parse_args()
    results: dict[str, dict] = {}
    for name in args.configs:
        results[name] = {"open_loop": open_loop(name, args.seeds, args.seconds)}
        if args.nav_episodes:
            results[name]["navigation"] = in_navigation(name, args.nav_episodes, args.workers)
    text = table(results, args.configs[0])
    print(text)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "walking_quality.json").write_text(json.dumps(results, indent=1) + "\n")
        (out / "walking_quality.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
