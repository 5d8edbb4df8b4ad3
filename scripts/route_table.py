"""The building families on Digit with the global route layer (docs/global_route.md).

    python scripts/route_table.py [--write]

Reads the run directories `benchmarks/results/route_digit/{truth,deployable,
deployable_known_walls}_FAMILY` (the last: on tracks again once the tracker knew the
map's walls, commit 05bae08)
(`emonav benchmark --planners policy,mpc,dwa --plant digit --family FAMILY --first-seed 0
--trials 100 [--deployable] --out …`) and prints, per setting, success with its Wilson
95 % interval and n per family and planner, the failures' outcomes beside it; then
`corner_traffic` before the route layer (`benchmarks/results/families_digit/
corner_traffic`, true state, the same seeds 0–99) and after it, paired seed by seed
(McNemar's exact test). A run still under way is tabled with the trials it has. With
`--write`, also `benchmarks/results/route_digit/table.md`, which the docs quote.
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import format_p, mcnemar_exact, method_reads, wilson_interval

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
RUNS = RESULTS / "route_digit"
BEFORE = RESULTS / "families_digit" / "corner_traffic"
FAMILIES = ("t_junction", "doorway", "office", "corner_traffic")
PLANNERS = ("policy", "mpc", "dwa")
SETTINGS = {  # setting: (what the planners read, its state source and sensor)
    "truth": ("true state", "truth", "ideal"),
    "deployable": (
        "deployable: LiDAR tracks of the VLP-16 scan, camera emotions",
        "lidar",
        "vlp16",
    ),
    "deployable_known_walls": (
        "deployable, the tracker given the map's walls (05bae08): LiDAR tracks of the VLP-16 "
        "scan, camera emotions",
        "lidar",
        "vlp16",
    ),
}
OBSERVATION = {"policy": "LGM", "mpc": "state", "dwa": "state"}


def _records(run: Path) -> dict[str, dict[int, dict]]:
    """Method → seed → record of a run directory (empty when it is not there yet)."""
    out: dict[str, dict[int, dict]] = collections.defaultdict(dict)
    if (run / "trials.jsonl").is_file():
        for t in read_trials(run / "trials.jsonl"):
            out[t["method"]][t["seed"]] = t["record"]
    return out


def _cell(recs: dict[int, dict]) -> str:
    if not recs:
        return "not run yet"
    outcomes = collections.Counter(r["outcome"] for r in recs.values())
    n, ok = len(recs), outcomes["success"]
    lo, hi = wilson_interval(ok, n)
    failed = ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()) if k != "success")
    return f"{ok / n:.2f} [{lo:.2f}, {hi:.2f}] ({n})" + (f"; {failed}" if failed else "")


def setting_table(setting: str) -> str:
    what, source, sensor = SETTINGS[setting]
    heads = [f"{p} ({method_reads(OBSERVATION[p], source, sensor)})" for p in PLANNERS]
    lines = [
        f"## {setting}",
        "",
        f"Digit, {what}; seeds 0–99 of each family's stream; the global route layer on "
        "(its defaults). Each column names what the planner reads — could a robot run it?",
        "",
        "| family | " + " | ".join(heads) + " |",
        "|---|" + "---|" * len(PLANNERS),
    ]
    for family in FAMILIES:
        recs = _records(RUNS / f"{setting}_{family}")
        lines.append(f"| {family} | " + " | ".join(_cell(recs.get(p, {})) for p in PLANNERS) + " |")
    return "\n".join(lines)


def corner_table() -> str:
    before, after = _records(BEFORE), _records(RUNS / "truth_corner_traffic")
    lines = [
        "## corner_traffic before and after",
        "",
        "Digit, true state, the same seeds: before, no route layer (`families_digit/"
        "corner_traffic`); after, the route layer on (`route_digit/truth_corner_traffic`). "
        "Reads: the simulator's crowd (DWA, MPC) and LiDAR grid maps of the exact scan (the "
        "policy) — privileged and upper bound.",
        "",
        "| planner | reads — could a robot run it? | before | after | seeds only after : only "
        "before, McNemar |",
        "|---|---|---|---|---|",
    ]
    for p in PLANNERS:
        reads = method_reads(OBSERVATION[p], "truth", "ideal")
        seeds = sorted(set(before.get(p, {})) & set(after.get(p, {})))
        if not seeds:
            lines.append(f"| {p} | {reads} | {_cell(before.get(p, {}))} | not run yet | |")
            continue
        b = {s: before[p][s] for s in seeds}
        a = {s: after[p][s] for s in seeds}
        ok_b = {s for s in seeds if b[s]["outcome"] == "success"}
        ok_a = {s for s in seeds if a[s]["outcome"] == "success"}
        gained, lost = len(ok_a - ok_b), len(ok_b - ok_a)
        test = f"{gained} : {lost}, p = {format_p(mcnemar_exact(gained, lost))}"
        lines.append(f"| {p} | {reads} | {_cell(b)} | {_cell(a)} | {test} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="also write route_digit/table.md")
    args = ap.parse_args()
    tables = [setting_table(s) for s in SETTINGS]
    text = "\n\n".join([*tables, corner_table()])
    print(text)
    if args.write:
        (RUNS / "table.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
