"""Why the MPC and RGL spend more steps in the static discs' zones on LiDAR tracks in the
no-emotion setting: the same planner on the simulator's crowd, on the tracks with the
tracker's default `perception.still_duration` (2 s) and with 0.5 s, on the same tuning
seeds (700 000 …, never evaluation seeds).

    python scripts/still_duration_table.py [--plant lip|digit] [--write]

The runs are `benchmarks/results/still_duration_<plant>/<setting>_<source>/`, made with
`emonav benchmark --planners mpc,rgl --plant lip --trials 300 --first-seed 700000
--config benchmarks/results/still_duration_lip/<setting>_<source>.yaml --workers 2
--out …` (Digit: `--planners mpc --plant digit --trials 150`, no-emotion only); a setting
is tabled when its three runs are there, each planner of its truth run. Success: Wilson
intervals, McNemar exact on the paired seeds; DT and the static discs' IDT per trial:
Wilcoxon signed-rank on the per-seed differences. Prints Markdown; with --write also
writes `benchmarks/results/still_duration_<plant>/table.md`, which docs/results.md quotes
(`tests/test_docs_agree.py` checks the quote).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import (
    format_p,
    mcnemar_exact,
    method_reads,
    signed_rank_p,
    wilson_interval,
)
from emonav_drake.params import load_config

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
SETTINGS = ("no_emotion", "var_dd")
LABELS = {"lip": "LIP", "digit": "Digit"}
SOURCES = {"truth": "truth", "lidar2": "tracks, 2 s", "lidar05": "tracks, 0.5 s"}


def _trials(runs: Path, name: str, planner: str) -> dict[int, dict]:
    """Seed → record of `planner` in run `name` of `runs`."""
    rows = read_trials(runs / name / "trials.jsonl")
    return {t["seed"]: t["record"] for t in rows if t["method"] == planner}


def _reads(run: Path) -> str:
    """What the run's crowd-state planners read and whether a robot could run them."""
    settings = json.loads((run / "settings.json").read_text())
    config = load_config(data=settings["config_yaml"])
    return method_reads("state", config.perception.state_source, config.sensor.preset)


def _row(planner: str, source: str, runs: dict[str, dict[int, dict]], reads: str) -> str:
    recs = runs[source]
    seeds = sorted(recs)
    ok = [recs[s]["outcome"] == "success" for s in seeds]
    lo, hi = wilson_interval(sum(ok), len(ok))
    dt = [recs[s]["discomfort_steps"] for s in seeds]
    static = [recs[s]["idt"][0] for s in seeds]
    cells = [
        planner,
        f"{SOURCES[source]}: {reads}",
        f"{np.mean(ok):.3f} [{lo:.3f}, {hi:.3f}] ({len(ok)})",
        f"{np.mean(dt):.2f}",
        f"{sum(static)}",
    ]
    for ref in ("truth", "lidar2"):
        if ref == source or (ref == "lidar2" and source != "lidar05"):
            cells.append("")
            continue
        other = runs[ref]
        common = [s for s in seeds if s in other]
        a = [other[s]["outcome"] == "success" for s in common]
        b = [recs[s]["outcome"] == "success" for s in common]
        lost = sum(x and not y for x, y in zip(a, b, strict=True))
        won = sum(y and not x for x, y in zip(a, b, strict=True))
        p_dt = signed_rank_p(
            [other[s]["discomfort_steps"] for s in common],
            [recs[s]["discomfort_steps"] for s in common],
        )
        p_static = signed_rank_p(
            [other[s]["idt"][0] for s in common], [recs[s]["idt"][0] for s in common]
        )
        cells.append(
            f"{won}:{lost}, p = {format_p(mcnemar_exact(won, lost))}; DT p = {format_p(p_dt)}; "
            f"static p = {format_p(p_static)}"
        )
    return "| " + " | ".join(cells) + " |"


def table(plant: str) -> str:
    runs_dir = RESULTS / f"still_duration_{plant}"
    out = []
    for setting in SETTINGS:
        names = [f"{setting}_{src}" for src in SOURCES]
        if not all((runs_dir / n / "trials.jsonl").is_file() for n in names):
            continue
        truth = read_trials(runs_dir / names[0] / "trials.jsonl")
        planners = list(dict.fromkeys(t["method"] for t in truth))
        seeds = sorted({t["seed"] for t in truth})
        out += [
            f"## {setting} ({LABELS[plant]}, seeds {seeds[0]}-{seeds[-1]})",
            "",
            "| planner | crowd read — could a robot run it? | SR [95 % CI] (n) | DT / trial "
            "| static IDT (sum) "
            "| vs truth (wins:losses) | vs tracks, 2 s |",
            "|---|---|---|---|---|---|---|",
        ]
        for planner in planners:
            runs = {src: _trials(runs_dir, f"{setting}_{src}", planner) for src in SOURCES}
            reads = {src: _reads(runs_dir / f"{setting}_{src}") for src in SOURCES}
            out += [_row(planner, src, runs, reads[src]) for src in SOURCES]
        out.append("")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plant", choices=("lip", "digit"), default="lip")
    parser.add_argument("--write", action="store_true", help="also write table.md")
    args = parser.parse_args()
    text = table(args.plant)
    print(text)
    if args.write:
        (RESULTS / f"still_duration_{args.plant}" / "table.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
