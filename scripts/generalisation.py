"""The generalisation study: every planner we ship on every scenario family.

    python scripts/generalisation.py run [--plant lip] [--trials 200] [--families a,b]
        [--planners a,b] [--study NAME]
    python scripts/generalisation.py table [--plant lip] [--study NAME]

`run` benchmarks `PLANNERS` on each family in turn (`emonav benchmark --family F`), one
run directory per family under `benchmarks/results/families_<plant>/F`, seeds 0 … N − 1
of the family's own stream (never used to train or tune anything: every training and
selection used the paper's family). A run resumes where it stopped (the benchmark's own
resume), so the whole study can be stopped and started again.

`--study NAME` keeps another set of planners apart, under `families_<plant>_NAME/F`
(e.g. `--study mixed`: the policy trained on the mixed family and its control).

`table` reads those run directories and prints a Markdown table (success rate with its
Wilson 95 % interval and n per planner × family, the intrusion ratio beside it) and draws
two heat maps, `docs/figures/generalisation_sr_<plant>.png` and
`docs/figures/generalisation_intrusion_<plant>.png`.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from emonav_drake.evaluation.run_directory import read_trials
from emonav_drake.evaluation.tables import wilson_interval
from emonav_drake.palette import INK_RGB, PAPER_RGB
from emonav_drake.params import SCENARIO_FAMILIES

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
FIGURES = ROOT / "docs" / "figures"
# the default policy, its shielded and guide variants, the model-based and learned baselines
# every family but the training mixture
EVALUATED = tuple(f for f in SCENARIO_FAMILIES if f != "mixed")
PLANNERS = ("policy", "policy_shield", "guide_shield", "mpc", "dwa", "sarl", "lidar_sac")
TABLE_FILE = "table.md"  # `table --write`: beside the families' run directories


def run_dir(plant: str, family: str, study: str = "") -> Path:
    return RESULTS / (f"families_{plant}_{study}" if study else f"families_{plant}") / family


def cmd_run(args: argparse.Namespace) -> int:
    families = args.families.split(",") if args.families else list(EVALUATED)
    for family in families:
        out = run_dir(args.plant, family, args.study)
        out.parent.mkdir(parents=True, exist_ok=True)
        command = [
            sys.executable,
            "-m",
            "emonav_drake.cli",
            "benchmark",
            "--planners",
            ",".join(args.planners.split(",")),
            "--plant",
            args.plant,
            "--trials",
            str(args.trials),
            "--first-seed",
            "0",
            "--family",
            family,
            "--workers",
            str(args.workers),
            "--out",
            str(out),
            "--quiet",
        ]
        for spec in args.checkpoint or []:
            command += ["--checkpoint", spec]
        print(f"[{family}] {' '.join(command[2:])}", flush=True)
        rc = subprocess.call(command)
        if rc != 0:
            print(f"[{family}] benchmark exited with {rc}", flush=True)
            return rc
    return 0


def collect(plant: str, study: str = "") -> tuple[list[str], list[str], dict, dict]:
    """(families, planners, SR cells, intrusion cells) of the run directories that exist:
    SR cell = (successes, n), intrusion cell = mean intrusion ratio (None if unmeasured)."""
    families = [f for f in EVALUATED if (run_dir(plant, f, study) / "trials.jsonl").exists()]
    planners: list[str] = []
    sr: dict[tuple[str, str], tuple[int, int]] = {}
    intrusion: dict[tuple[str, str], float | None] = {}
    for family in families:
        trials = read_trials(run_dir(plant, family, study) / "trials.jsonl")
        by: dict[str, list[dict]] = {}
        for t in trials:
            by.setdefault(t["method"], []).append(t["record"])
        for m, rs in by.items():
            if m not in planners:
                planners.append(m)
            sr[m, family] = (sum(r["outcome"] == "success" for r in rs), len(rs))
            vals = [r["intrusion_ratio"] for r in rs if r.get("intrusion_ratio") is not None]
            intrusion[m, family] = float(np.mean(vals)) if vals else None
    return families, planners, sr, intrusion


def commits(plant: str, families: list[str], study: str = "") -> set[str]:
    out = set()
    for f in families:
        s = json.loads((run_dir(plant, f, study) / "settings.json").read_text())
        out.add(s["package"]["commit"][:10] + ("+dirty" if s["package"]["dirty"] else ""))
    return out


def cmd_table(args: argparse.Namespace) -> int:
    families, planners, sr, intrusion = collect(args.plant, args.study)
    if not families:
        print(f"no run directory under {run_dir(args.plant, '', args.study)}")
        return 1
    done = commits(args.plant, families, args.study)
    print(f"plant {args.plant}; commits {', '.join(sorted(done))}\n")
    rows = ["| family | " + " | ".join(planners) + " |", "|---|" + "---|" * len(planners)]
    for f in families:
        cells = []
        for m in planners:
            if (m, f) not in sr:
                cells.append("—")
                continue
            k, n = sr[m, f]
            lo, hi = wilson_interval(k, n)
            ir = intrusion.get((m, f))
            ir_text = "" if ir is None else f"; IR {ir:.3f}"
            cells.append(f"{k / n:.2f} [{lo:.2f}, {hi:.2f}] ({n}){ir_text}")
        rows.append(f"| {f} | " + " | ".join(cells) + " |")
    text = "\n".join(rows)
    print(text)
    if args.write:  # quoted by docs/results_families.md (tests/test_docs_agree.py checks the quote)
        from emonav_drake.atomic_io import write_text_atomic

        out = run_dir(args.plant, "", args.study) / TABLE_FILE
        cmd = f"python scripts/generalisation.py table --plant {args.plant}"
        cmd += f" --study {args.study}" if args.study else ""
        head = f"Written by `{cmd} --write`; commits {', '.join(sorted(done))}."
        write_text_atomic(out, f"{head}\n\n{text}\n")
        print(f"wrote {out.relative_to(ROOT)}")
    if not args.study:  # the figures are the main study's
        _heat_map(args.plant, families, planners, sr, intrusion)
    return 0


def _heat_map(plant: str, families: list[str], planners: list[str], sr: dict, intrusion: dict):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def grid(cell) -> np.ndarray:
        return np.array(
            [[np.nan if cell(m, f) is None else cell(m, f) for f in families] for m in planners],
            dtype=float,
        )

    rate = grid(lambda m, f: None if (m, f) not in sr else sr[m, f][0] / sr[m, f][1])
    intr = grid(lambda m, f: intrusion.get((m, f)))
    n = min((sr[k][1] for k in sr), default=0)
    for name, values, title, cmap, vmax in (
        ("sr", rate, "success rate", "viridis", 1.0),
        (
            "intrusion",
            intr,
            "intrusion ratio (share of steps < 0.25 m from a pedestrian)",
            "magma_r",
            None,
        ),
    ):
        size = (max(6.0, 1.0 + 0.62 * len(families)), max(3.4, 1.4 + 0.45 * len(planners)))
        fig, ax = plt.subplots(figsize=size)
        im = ax.imshow(values, cmap=cmap, vmin=0.0, vmax=vmax, aspect="auto")
        ax.set_xticks(range(len(families)), families, rotation=40, ha="right")
        ax.set_yticks(range(len(planners)), planners)
        for i in range(len(planners)):
            for j in range(len(families)):
                v = values[i, j]
                if np.isfinite(v):
                    dark = (
                        v < 0.5 * np.nanmax(values)
                        if cmap == "viridis"
                        else v > 0.5 * np.nanmax(values)
                    )
                    ax.text(
                        j,
                        i,
                        f"{v:.2f}",
                        ha="center",
                        va="center",
                        fontsize=8,
                        color=PAPER_RGB if dark else INK_RGB,
                    )
        ax.set_title(f"{title}\n{plant.upper()} plant, {n} or more seeds per cell", fontsize=10)
        fig.colorbar(im, ax=ax, fraction=0.03, pad=0.01)
        fig.tight_layout()
        path = FIGURES / f"generalisation_{name}_{plant}.png"
        fig.savefig(path, dpi=130)
        plt.close(fig)
        print(f"wrote {path.relative_to(ROOT)}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(required=True)
    r = sub.add_parser("run")
    r.add_argument("--plant", default="lip", choices=("lip", "digit"))
    r.add_argument("--trials", type=int, default=200)
    r.add_argument("--families", help="comma-separated (default: every family)")
    r.add_argument("--planners", default=",".join(PLANNERS))
    r.add_argument("--workers", type=int, default=2)
    r.add_argument("--study", default="", help="a separate set of runs: families_<plant>_NAME")
    r.add_argument("--checkpoint", action="append", metavar="NAME=PATH", help="as benchmark's")
    r.set_defaults(func=cmd_run)
    t = sub.add_parser("table")
    t.add_argument("--plant", default="lip", choices=("lip", "digit"))
    t.add_argument("--study", default="", help="the runs of `run --study NAME`")
    t.add_argument("--write", action="store_true", help=f"also write {TABLE_FILE} there")
    t.set_defaults(func=cmd_table)
    args = ap.parse_args()
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
