"""Digit Table II before and after a change of the walking stack: per method, an old run
against a new one on the seeds both ran (Wilson intervals, McNemar exact on success; DT
per trial with the Wilcoxon signed-rank test on the per-seed differences).

    python scripts/compare_digit_tables.py                       # old timing vs the default
    python scripts/compare_digit_tables.py --old digit_table2_v2 # every method vs that run
    python scripts/compare_digit_tables.py --new digit_camera --old digit_table2_v4 \
        --map policy=emobipednav_digit_mpc          # a method named differently in the old run

By default each method's run with the old walking timing (`PAIRS`) against
benchmarks/results/digit_table2_v3; with `--old RUN`, every method of the new run against
the same method in RUN. Prints a Markdown table (quoted in docs/results_methods.md).
"""

from __future__ import annotations

from pathlib import Path

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import (
    format_p,
    mcnemar_exact,
    signed_rank_p,
    wilson_interval,
)

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "results"
NEW = "digit_table2_v3"
# (label, old run, its method name, the method name in the new run)
PAIRS = (
    ("shipped policy (LIP-trained)", "digit_table2", "sac", "policy"),
    ("emobipednav_digit", "digit_table3", "emobipednav_digit", "emobipednav_digit"),
    ("mpc", "digit_table2", "mpc", "mpc"),
    ("dwa", "digit_table2", "dwa", "dwa"),
    ("dwa_digit", "digit_route8", "dwa_digit", "dwa_digit"),
)


def _records(run: str, method: str) -> dict[int, dict]:
    """Seed → the trial record of `method` in run directory `run`."""
    trials = read_trials(RESULTS / run / "trials.jsonl")
    return {t["seed"]: t["record"] for t in trials if t["method"] == method}


def _p(p: float) -> str:
    """ "= 0.29" or "< 1e-4"."""
    text = format_p(p)
    return text if text.startswith("<") else f"= {text}"


def _sr(k: int, n: int) -> str:
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.3f} [{lo:.3f}, {hi:.3f}]"


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--new", default=NEW, help="run directory under benchmarks/results")
    ap.add_argument("--old", default=None, help="compare every method with this run")
    ap.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="NEW=OLD",
        help="with --old: the new run's method NEW is OLD in the old run (repeatable)",
    )
    args = ap.parse_args()
    pairs = PAIRS
    if args.old is not None:
        methods = dict.fromkeys(
            t["method"] for t in read_trials(RESULTS / args.new / "trials.jsonl")
        )
        renamed = dict(m.split("=", 1) for m in args.map)
        pairs = tuple((m, args.old, renamed.get(m, m), m) for m in methods)
    print(
        "| method | seeds (n) | old SR [95 % CI] (run) | new SR [95 % CI] | old only | new only "
        "| DT / trial old → new (signed-rank p) |"
    )
    print("|---|---|---|---|---|---|---|")
    for label, run, old_method, new_method in pairs:
        old_r, new_r = _records(run, old_method), _records(args.new, new_method)
        seeds = sorted(set(old_r) & set(new_r))
        n = len(seeds)
        if not n:  # not in the old run (give --map NEW=OLD), or no seed in common
            print(f"| {label} | none in common with {run}:{old_method} | | | | | |")
            continue
        old = {s: old_r[s]["outcome"] == "success" for s in seeds}
        new = {s: new_r[s]["outcome"] == "success" for s in seeds}
        k_old, k_new = sum(old.values()), sum(new.values())
        b = sum(old[s] and not new[s] for s in seeds)
        c = sum(new[s] and not old[s] for s in seeds)
        dt_old = [old_r[s]["discomfort_steps"] for s in seeds]
        dt_new = [new_r[s]["discomfort_steps"] for s in seeds]
        p_dt = _p(signed_rank_p(dt_old, dt_new))
        print(
            f"| {label} | {seeds[0]}–{seeds[-1]} ({n}) | {_sr(k_old, n)} ({run}) | "
            f"{_sr(k_new, n)} | {b} | {c} (McNemar p {_p(mcnemar_exact(b, c))}) | "
            f"{sum(dt_old) / n:.2f} → {sum(dt_new) / n:.2f} (p {p_dt}) |"
        )


if __name__ == "__main__":
    main()
