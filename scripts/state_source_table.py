"""Table II on Digit with perceived state: each state-based planner on the LiDAR tracks
(`--state-source lidar`) against the same planner on the simulator's crowd (`truth`) and
against the default learned policy, on the same seeds (Wilson intervals; McNemar exact on
success; DT per trial with the Wilcoxon signed-rank test on the per-seed differences).

    python scripts/state_source_table.py [--setting var_dd|no_emotion] [--seeds 300] [--write]

A method's truth trials may come from several run directories (`SETTINGS`): a run made at
another commit than the lidar run counts only if its records equal, to the last digit,
those of a run at the lidar run's commit on the seeds both ran (the setting's check run,
seeds 0-29);
any difference, or no seed in common, is an error.
Prints Markdown; with --write also writes it to the lidar run's `state_source_table.md`,
which docs/results.md quotes (`tests/test_docs_agree.py` checks the quote).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import (
    format_p,
    mcnemar_exact,
    signed_rank_p,
    wilson_interval,
)

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
PLANNERS = ("dwa", "mpc", "sarl", "rgl")
TABLE_FILE = "state_source_table.md"  # in the lidar run's directory, with --write
# Per setting: the lidar run; the truth run at the lidar run's commit that checks older
# truth runs (seeds 0-29); the truth trials per method (run directories in order, a seed
# taken from the first that has it); the default policy's run and method.
SETTINGS = {
    "var_dd": {
        "lidar": "digit_state_lidar",
        "check": "digit_state_truth_check",
        "truth": {
            "dwa": ("digit_state_truth_check", "digit_state_truth_200", "digit_table2_v3"),
            "mpc": ("digit_state_truth_check", "digit_table2_v4"),
            "sarl": ("digit_state_truth_check", "digit_state_truth_200", "digit_baselines"),
            "rgl": ("digit_state_truth_check", "digit_state_truth_200", "digit_rgl"),
        },
        "policy": ("digit_distilled_r2", "distilled_digit_r2"),
    },
    "no_emotion": {
        "lidar": "digit_state_lidar_ne",
        "check": "digit_state_truth_ne_check",
        "truth": {
            "dwa": ("digit_state_truth_ne",),
            "mpc": ("digit_state_truth_ne_check", "digit_no_emotion_v4"),
            "sarl": ("digit_state_truth_ne",),
            "rgl": ("digit_state_truth_ne",),
        },
        "policy": ("digit_distilled_r2_ne", "distilled_digit_r2"),
    },
}


def records(run: str, method: str) -> dict[int, dict]:
    """Seed → trial record of `method` in `run` (empty if the run does not exist)."""
    path = RESULTS / run / "trials.jsonl"
    if not path.exists():
        return {}
    return {t["seed"]: t["record"] for t in read_trials(path) if t["method"] == method}


def commit(run: str) -> str:
    """The commit a run directory's trials were made at."""
    import json

    return json.loads((RESULTS / run / "settings.json").read_text())["package"]["commit"]


def check_same_trials(name: str, recs: dict[int, dict], check_run: str, check: dict) -> None:
    """`SystemExit` unless the trials `recs` of `name` (run:method) equal those of the
    check run on every seed both ran, in every field both records hold (a run made
    before a metric was added lacks its field), and they share at least one seed."""
    same = sorted(set(recs) & set(check))
    if not same:
        raise SystemExit(
            f"{name} has no seed in common with {check_run}: unchecked (run the check: "
            f"emonav benchmark ... --out benchmarks/results/{check_run})"
        )

    def differ(a: dict, b: dict) -> bool:
        return any(a[k] != b[k] for k in set(a) & set(b))

    diff = [s for s in same if differ(recs[s], check[s])]
    if diff:
        raise SystemExit(
            f"{name} differs from {check_run} at seeds {diff[:5]}: not the same trials"
        )


def truth_records(setting: dict, method: str) -> dict[int, dict]:
    """The method's truth trials of `setting`, each run made at another commit than the
    lidar run checked against the check run."""
    check_run = setting["check"]
    check = records(check_run, method)
    out: dict[int, dict] = {}
    for run in setting["truth"][method]:
        recs = records(run, method)
        if recs and commit(run) != commit(setting["lidar"]):
            check_same_trials(f"{run}:{method}", recs, check_run, check)
        for seed, rec in recs.items():
            out.setdefault(seed, rec)
    return out


def _sr(rs: list[dict]) -> str:
    k, n = sum(r["outcome"] == "success" for r in rs), len(rs)
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.3f} [{lo:.3f}, {hi:.3f}] ({n})"


def _nt(rs: list[dict]) -> str:
    t = [r["nav_time"] for r in rs if r["outcome"] == "success"]
    return f"{np.mean(t):.2f} ± {np.std(t):.2f}" if t else "—"


def _versus(a: dict[int, dict], b: dict[int, dict], seeds: list[int]) -> str:
    """McNemar (a only : b only successes, p) and the DT signed-rank p, a vs b."""
    ok = lambda r: r["outcome"] == "success"  # noqa: E731
    only_a = sum(ok(a[s]) and not ok(b[s]) for s in seeds)
    only_b = sum(ok(b[s]) and not ok(a[s]) for s in seeds)
    p = mcnemar_exact(only_a, only_b)
    dt = signed_rank_p(
        [b[s]["discomfort_steps"] for s in seeds], [a[s]["discomfort_steps"] for s in seeds]
    )
    return f"{only_a}:{only_b}, p {_p(p)}; DT p {_p(dt)}"


def _p(p: float) -> str:
    """ "= 0.29" or "< 1e-4"."""
    text = format_p(p)
    return text if text.startswith("<") else f"= {text}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=300, help="seeds 0 … N − 1")
    ap.add_argument("--setting", choices=SETTINGS, default="var_dd")
    ap.add_argument("--write", action="store_true", help=f"also write the lidar run's {TABLE_FILE}")
    args = ap.parse_args()
    setting = SETTINGS[args.setting]
    policy_run = setting["policy"]
    policy = records(*policy_run)
    rows = []
    header = (
        "| method | state (deployable?) | SR [95 % CI] (n) | NT [s] | DT / trial "
        "| lidar vs truth: success only lidar : only truth, McNemar; DT signed-rank "
        "| vs the default policy: only method : only policy, McNemar; DT |"
    )
    rows.append(header)
    rows.append("|---|---|---|---|---|---|---|")
    seeds_all = list(range(args.seeds))
    pol = [policy[s] for s in seeds_all if s in policy]
    rows.append(
        f"| policy (default, `{policy_run[1]}`) | its LiDAR grid maps (yes) | {_sr(pol)} | "
        f"{_nt(pol)} | {np.mean([r['discomfort_steps'] for r in pol]):.2f} | — | — |"
    )
    for m in PLANNERS:
        lidar, truth = records(setting["lidar"], m), truth_records(setting, m)
        for name, recs, label in ((m, truth, "truth (no)"), (m, lidar, "lidar (yes)")):
            seeds = [s for s in seeds_all if s in recs]
            if not seeds:
                rows.append(f"| {name} | {label} | no trials yet | | | | |")
                continue
            rs = [recs[s] for s in seeds]
            both = [s for s in seeds if s in lidar and s in truth]
            vs_truth = (
                _versus(lidar, truth, both) + f" (n = {len(both)})" if label[0] == "l" else ""
            )
            pol_seeds = [s for s in seeds if s in policy]
            vs_pol = _versus(recs, policy, pol_seeds) + f" (n = {len(pol_seeds)})"
            dt = np.mean([r["discomfort_steps"] for r in rs])
            rows.append(
                f"| {name} | {label} | {_sr(rs)} | {_nt(rs)} | {dt:.2f} | {vs_truth} | {vs_pol} |"
            )
    text = "\n".join(rows)
    print(text)
    if args.write:
        from emonav_drake.atomic_io import write_text_atomic

        out = RESULTS / setting["lidar"] / TABLE_FILE
        cmd = "python scripts/state_source_table.py"
        cmd += f" --setting {args.setting} --seeds {args.seeds} --write"
        write_text_atomic(out, f"Written by `{cmd}`.\n\n{text}\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
