"""Table II on Digit in the deployable setting: every planner on the VLP-16's noisy scan
(`--deployable`) beside the same planner on the exact scan (`ideal`) and, for the
state-based planners, on the simulator's crowd (`truth`), on the same seeds (Wilson
intervals; McNemar exact on success; DT per trial with the Wilcoxon signed-rank test on
the per-seed differences), and what perception costs each planner.

    python scripts/deployable_table.py [--setting var_dd|no_emotion] [--seeds 300] [--write]

The deployable trials are one run directory (`SETTINGS[...]["deployable"]`); the ideal and
truth trials are the runs `scripts/state_source_table.py` reads. A run made at another
commit than the deployable run counts only if its records equal, to the last digit, those
of a run at the deployable run's commit on the seeds both ran (the setting's
`ideal_check` run, seeds 0-29); any difference, or no seed in common, is an error. Prints
Markdown; with --write also writes it to the deployable run's `deployable_table.md`,
which docs/results.md quotes (`tests/test_docs_agree.py` checks the quote).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import state_source_table as sst  # noqa: E402

METHODS = ("policy", "dwa", "mpc", "sarl", "rgl")
TABLE_FILE = "deployable_table.md"  # in the deployable run's directory, with --write
# Per setting: the deployable run; the exact-scan (ideal) runs per method (run, method
# name there); the ideal check run at the deployable run's commit (seeds 0-29); the
# truth runs (scripts/state_source_table.py's setting).
SETTINGS = {
    "var_dd": {
        "deployable": "digit_deployable",
        "ideal": {
            "policy": ("digit_distilled_r2", "distilled_digit_r2"),
            **{m: ("digit_state_lidar", m) for m in sst.PLANNERS},
        },
        "ideal_check": "digit_ideal_check",
        "truth": "var_dd",
    },
    "no_emotion": {
        "deployable": "digit_deployable_ne",
        "ideal": {
            "policy": ("digit_distilled_r2_ne", "distilled_digit_r2"),
            **{m: ("digit_state_lidar_ne", m) for m in sst.PLANNERS},
        },
        "ideal_check": "digit_ideal_check_ne",
        "truth": "no_emotion",
    },
}


def ideal_records(setting: dict, method: str) -> dict[int, dict]:
    """The method's exact-scan trials, checked against the check run if made at another
    commit than the deployable run."""
    run, name = setting["ideal"][method]
    recs = sst.records(run, name)
    if not recs or sst.commit(run) == sst.commit(setting["deployable"]):
        return recs
    check = sst.records(setting["ideal_check"], method)
    sst.check_same_trials(f"{run}:{name}", recs, setting["ideal_check"], check)
    return recs


def _dt(rs: list[dict]) -> float:
    return float(np.mean([r["discomfort_steps"] for r in rs]))


def _idt(rs: list[dict]) -> str:
    """Mean steps inside each emotion's zone per trial: happy / neutral / negative (a
    record's `idt` is [static, happy, neutral, negative])."""
    parts = [np.mean([r["idt"][k] for r in rs]) for k in (1, 2, 3)]
    return " / ".join(f"{v:.2f}" for v in parts)


def _success(rs: list[dict]) -> float:
    return float(np.mean([r["outcome"] == "success" for r in rs]))


def tables(setting_name: str, num_seeds: int) -> str:
    """The two Markdown tables, each under its `## ` heading (the sections
    docs/results.md quotes): every row; what perception costs each planner."""
    setting = SETTINGS[setting_name]
    truth_setting = sst.SETTINGS[setting["truth"]]
    deployable = {m: sst.records(setting["deployable"], m) for m in METHODS}
    seeds_all = list(range(num_seeds))
    rows = [
        "| method | what it read | SR [95 % CI] (n) | NT [s] | DT / trial | IDT / trial "
        "(happy / neutral / negative) | deployable vs this row: success only deployable : "
        "only this, McNemar; DT signed-rank |",
        "|---|---|---|---|---|---|---|",
    ]
    cost = [
        "| method | SR truth → exact scan → VLP-16 | DT / trial truth → exact scan → VLP-16 "
        "| deployable vs the default policy (deployable): only method : only policy, "
        "McNemar; DT |",
        "|---|---|---|---|",
    ]
    policy_dep = deployable["policy"]
    for m in METHODS:
        dep = deployable[m]
        sources = []
        if m != "policy":
            sources.append(
                ("truth: the simulator's crowd (no)", sst.truth_records(truth_setting, m))
            )
        read = "grid maps of" if m == "policy" else "tracks in"
        sources.append((f"{read} the exact scan (no)", ideal_records(setting, m)))
        sources.append((f"{read} the VLP-16 scan (yes)", dep))
        summary = {}
        for label, recs in sources:
            seeds = [s for s in seeds_all if s in recs]
            if not seeds:
                rows.append(f"| {m} | {label} | no trials yet | | | | |")
                continue
            rs = [recs[s] for s in seeds]
            summary[label] = rs
            if recs is dep:
                versus = "—"
            else:
                both = [s for s in seeds if s in dep]
                versus = sst._versus(dep, recs, both) + f" (n = {len(both)})" if both else ""
            rows.append(
                f"| {m} | {label} | {sst._sr(rs)} | {sst._nt(rs)} | {_dt(rs):.2f} | "
                f"{_idt(rs)} | {versus} |"
            )
        chain = list(summary.values())
        sr = " → ".join(f"{_success(rs):.3f}" for rs in chain)
        dt = " → ".join(f"{_dt(rs):.2f}" for rs in chain)
        if m == "policy" or not dep or not policy_dep:
            vs = "—"
        else:
            both = [s for s in seeds_all if s in dep and s in policy_dep]
            vs = sst._versus(dep, policy_dep, both) + f" (n = {len(both)})"
        if m == "policy":
            sr, dt = "— → " + sr, "— → " + dt
        cost.append(f"| {m} | {sr} | {dt} | {vs} |")
    return (
        "## Table II, deployable beside exact\n\n"
        + "\n".join(rows)
        + "\n\n## What perception costs\n\n"
        + "\n".join(cost)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=300, help="seeds 0 … N − 1")
    ap.add_argument("--setting", choices=SETTINGS, default="var_dd")
    ap.add_argument("--write", action="store_true", help=f"also write the run's {TABLE_FILE}")
    args = ap.parse_args()
    text = tables(args.setting, args.seeds)
    print(text)
    if args.write:
        from emonav_drake.atomic_io import write_text_atomic

        out = sst.RESULTS / SETTINGS[args.setting]["deployable"] / TABLE_FILE
        cmd = f"python scripts/deployable_table.py --setting {args.setting} --seeds {args.seeds}"
        write_text_atomic(out, f"Written by `{cmd} --write`.\n\n{text}\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
