"""Issue 38's "train for it": the policy trained on the scenario families against its
control (the same route on the paper's arena alone), the default policy and the MPC, on
the same seeds of every family and of the paper's evaluation seeds.

    python scripts/family_training_table.py [--plant lip|digit] [--write]

Rows: every family with runs of the trained policy (`families_<plant>_mixed/F`, from
`python scripts/generalisation.py run --study mixed ...`) beside the main study's runs
(`families_<plant>/F`), then the paper's evaluation seeds (`PAPER_RUNS`). Cells: success
rate [Wilson 95 % interval] (n); then McNemar exact on the seeds both ran,
"x : y" = seeds only the trained policy passes : seeds only the other passes. With
--write the table is also written to `families_<plant>_mixed/comparison.md`, which
docs/results_families.md quotes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import format_p, mcnemar_exact, wilson_interval

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
TRAINED = "emobipednav_mixed"
CONTROL = "emobipednav_digit_mpc"  # the same route on the paper's arena alone
# (column label, method name in the run, study): the others the trained policy is set against
OTHERS = (("control", CONTROL, "mixed"), ("default policy", "policy", ""), ("MPC", "mpc", ""))
# The paper's evaluation seeds: (run with the trained policy, {method: run}) per plant.
PAPER_RUNS = {
    "lip": (
        "lip_mixed_paper",
        {CONTROL: "lip_table2_all", "policy": "lip_distilled_r2", "mpc": "lip_table2_all"},
    ),
    "digit": (
        "digit_mixed_paper",
        {CONTROL: "digit_table2_v4", "policy": "digit_distilled_r2", "mpc": "digit_table2_v4"},
    ),
}
# a run's name for a method where it differs from the column's method
ALIASES = {
    "lip_distilled_r2": {"policy": "distilled_digit_r2"},
    "digit_distilled_r2": {"policy": "distilled_digit_r2"},
    "lip_table2_all": {CONTROL: "policy"},  # the default when it ran: this file
}
TABLE_FILE = "comparison.md"


def outcomes(run: Path, method: str) -> dict[int, bool]:
    """Seed → success of `method` in run directory `run` (empty if it has none)."""
    path = run / "trials.jsonl"
    if not path.is_file():
        return {}
    name = ALIASES.get(run.name, {}).get(method, method)
    return {
        t["seed"]: t["record"]["outcome"] == "success"
        for t in read_trials(path)
        if t["method"] == name
    }


def cell(ok: dict[int, bool]) -> str:
    if not ok:
        return "—"
    k, n = sum(ok.values()), len(ok)
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.2f} [{lo:.2f}, {hi:.2f}] ({n})"


def versus(mine: dict[int, bool], other: dict[int, bool]) -> str:
    both = sorted(set(mine) & set(other))
    if not both:
        return "—"
    b = sum(mine[s] and not other[s] for s in both)
    c = sum(other[s] and not mine[s] for s in both)
    return f"{b} : {c}, p = {format_p(mcnemar_exact(b, c))}"


def rows(plant: str) -> list[str]:
    def study(name: str) -> str:
        return f"families_{plant}_{name}" if name else f"families_{plant}"

    header = ["family", TRAINED] + [label for label, _, _ in OTHERS]
    header += [f"vs {label}" for label, _, _ in OTHERS]
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    mixed_root = RESULTS / study("mixed")
    families = sorted(p.name for p in mixed_root.iterdir() if (p / "trials.jsonl").is_file())
    lines = []
    for family in families:
        mine = outcomes(mixed_root / family, TRAINED)
        others = [outcomes(RESULTS / study(s) / family, m) for _, m, s in OTHERS]
        lines.append([family, cell(mine), *map(cell, others), *(versus(mine, o) for o in others)])
    paper_run, where = PAPER_RUNS[plant]
    mine = outcomes(RESULTS / paper_run, TRAINED)
    if mine:
        others = [outcomes(RESULTS / where[m], m) for _, m, _ in OTHERS]
        lines.append(
            [
                "**paper's evaluation seeds**",
                cell(mine),
                *map(cell, others),
                *(versus(mine, o) for o in others),
            ]
        )
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", choices=("lip", "digit"), default="lip")
    ap.add_argument("--write", action="store_true", help=f"also write {TABLE_FILE}")
    args = ap.parse_args()
    text = "\n".join(rows(args.plant))
    print(text)
    if args.write:
        from emonav_drake.atomic_io import write_text_atomic

        out = RESULTS / f"families_{args.plant}_mixed" / TABLE_FILE
        cmd = f"python scripts/family_training_table.py --plant {args.plant} --write"
        write_text_atomic(out, f"Written by `{cmd}`.\n\n{text}\n")
        print(f"wrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
