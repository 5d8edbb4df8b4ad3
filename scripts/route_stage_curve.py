"""The learning curve of a training route, stage by stage, in the world it learns in.

    python scripts/route_stage_curve.py \\
        --dagger benchmarks/results/digit_mpc_route/dagger_history.json \\
        --finetune "run 1=benchmarks/results/digit_mpc_route/finetune_history.json" \\
        --finetune "run 2=benchmarks/results/digit_mpc_route/finetune_v2_history.json" \\
        --teacher "MPC (teacher)=0.995" --n 200 \\
        --png docs/figures/digit_mpc_route_stages.png

x: cumulative wall time of the route on one core [min] (each stage's collection, training
and evaluation); y: the success rate on the route's selection seeds with its 95 % Wilson
interval — every DAgger round (`history.json` of `emonav train --algo dagger`), then every
evaluation of the SAC fine-tuning (`history.json` of `emonav train --algo finetune`). A
dashed line marks a reference measured on the same seeds (e.g. the teacher).

`--dagger LABEL=HISTORY` again adds another route on the same seeds (e.g. the same route
with hard and with soft labels), unlabelled, in the next colour. `--then LABEL=HISTORY`
adds a DAgger stage that continues the first route's kept round (a shield distillation
after the MPC's rounds), on the same seeds, after it on the time axis.

`--digit-rounds HISTORY=RUN` adds the Digit rounds that continue the kept round (`emonav
digit-rounds`; HISTORY: a JSON with their `rounds`, as benchmarks/results/
guide_digit_rounds/digit_rounds_history.json) measured on the full-order Digit: RUN is
the `emonav benchmark --plant digit` run on Digit's selection seeds whose method
`--start` is the kept round and r0, r1, … its rounds. Those points are on other seeds
and another plant than the calibrated world's (their own marker, their own n); their x
adds each round's collection (two Ray workers) and training.

    python scripts/route_stage_curve.py \
        --dagger benchmarks/results/guide_route/dagger_history.json \
        --digit-rounds benchmarks/results/guide_digit_rounds/digit_rounds_history.json=\
benchmarks/results/guide_digit_rounds --start emobipednav_guide \
        --title "Guide route: calibrated world, then Digit rounds" \
        --png docs/figures/guide_route_stages.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from emonav_drake import palette  # noqa: E402
from emonav_drake.evaluation.tables import wilson_interval  # noqa: E402


def _dagger(path: Path, start: float = 0.0) -> tuple[list[float], list[float], list[str]]:
    t, xs, sr, labels = start, [], [], []
    for e in json.loads(path.read_text()):
        t += (e["collect_s"] + e["train_s"] + e["eval_s"]) / 60.0
        xs.append(t)
        sr.append(e["eval"]["SR"])
        labels.append(f"r{e['round']}")
    return xs, sr, labels


def _finetune(path: Path, start: float) -> tuple[list[float], list[float], list[str]]:
    xs, sr, labels = [], [], []
    for e in json.loads(path.read_text()):
        xs.append(start + (e["collect_s"] + e["update_s"] + e["eval_s"]) / 60.0)
        sr.append(e["eval"]["SR"])
        labels.append(f"{e['env_steps'] // 1000}k")
    return xs, sr, labels


def _digit_rounds(spec: str, start_method: str, start: float) -> tuple:
    """(x, SR, n, labels) of the kept round and each Digit round on Digit's selection
    seeds (`--digit-rounds`)."""
    from emonav_drake.evaluation.run_directory import read_trials

    history, _, run = spec.partition("=")
    rounds = json.loads(Path(history).read_text())["rounds"]
    trials = read_trials(Path(run) / "trials.jsonl")
    methods = [start_method] + [f"r{e['round']}" for e in rounds]
    xs, t = [start], start
    for e in rounds:
        t += (e["collect_s"] + e["train_s"]) / 60.0
        xs.append(t)
    sr, n = [], []
    for m in methods:
        outcomes = [tr["record"]["outcome"] for tr in trials if tr["method"] == m]
        if not outcomes:
            raise SystemExit(f"--digit-rounds: no trials of method {m!r} in {run}")
        n.append(len(outcomes))
        sr.append(sum(o == "success" for o in outcomes) / len(outcomes))
    labels = ["kept"] + [f"D{e['round']}" for e in rounds]
    return xs, sr, n, labels


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--dagger",
        action="append",
        required=True,
        metavar="[LABEL=]HISTORY",
        help="a DAgger run's history.json; the first is the route the other stages continue, "
        "more are routes compared with it on the same seeds (repeatable)",
    )
    ap.add_argument(
        "--then",
        action="append",
        default=[],
        metavar="[LABEL=]HISTORY",
        help="a DAgger run that continues the first route's kept round (e.g. its shield "
        "distillation), drawn after it on the time axis (repeatable: each after the last)",
    )
    ap.add_argument(
        "--finetune",
        action="append",
        default=[],
        metavar="[LABEL=]HISTORY",
        help="a fine-tuning run's history.json, each starting from the kept round (repeatable)",
    )
    ap.add_argument(
        "--digit-rounds",
        metavar="HISTORY=RUN",
        help="the Digit rounds after the kept round, measured on Digit (see the docstring)",
    )
    ap.add_argument("--start", default="policy", help="RUN's method that is the kept round")
    ap.add_argument(
        "--start-label", default="kept", help="its label, e.g. 'kept = r1' if not the last round"
    )
    ap.add_argument("--teacher", action="append", default=[], help="LABEL=SR on the same seeds")
    ap.add_argument("--n", type=int, default=200, help="selection episodes per point")
    ap.add_argument("--title", default="Digit/Digit route in the calibrated world")
    ap.add_argument("--png", type=Path, required=True)
    args = ap.parse_args()

    compared = len(args.dagger) + len(args.then) > 1  # references and names below
    fig, ax = plt.subplots(figsize=(7.5, 4.8 if compared else 4.0), dpi=150)
    world = f", calibrated world ({args.n} seeds)" if args.digit_rounds else ""
    stages = []
    for spec in args.dagger:
        label, sep, path = spec.rpartition("=")
        name = label if sep else f"DAgger rounds (MPC teacher){world}"
        xs, sr, labels = _dagger(Path(path))
        stages.append((name, (xs, sr, labels if not stages else [""] * len(labels))))
    end = stages[0][1][0][-1]
    for spec in args.then:
        label, sep, path = spec.rpartition("=")
        xs, sr, labels = _dagger(Path(path), end)
        stages.append((label if sep else "the next DAgger stage", (xs, sr, labels)))
        end = xs[-1]
    n_dagger = len(stages)
    for i, spec in enumerate(args.finetune):
        label, sep, path = spec.rpartition("=")
        name = label if sep else "SAC fine-tuning from the kept round"
        xs, sr, labels = _finetune(Path(path), stages[0][1][0][-1])
        labels[0] = ""  # its first evaluation is the student it starts from
        if i > 0:
            labels = [""] * len(labels)  # one run's step labels are enough
        stages.append((name, (xs, sr, labels)))
    colours = [palette.METHOD_RGB["policy"], *palette.METHOD_CYCLE[1:]]
    # round labels above the first route's points, below fine-tuning's; the others unlabelled
    offsets = [7] * n_dagger + [-13] * len(args.finetune)
    for (name, (xs, sr, labels)), colour, dy in zip(stages, colours, offsets, strict=False):
        lo_hi = [wilson_interval(round(s * args.n), args.n) for s in sr]
        err = [[s - lo for s, (lo, _) in zip(sr, lo_hi, strict=True)],
               [hi - s for s, (_, hi) in zip(sr, lo_hi, strict=True)]]  # fmt: skip
        # with routes compared, the first route's points over the others'
        z = {"zorder": 3 if name == stages[0][0] else 2} if compared else {}
        ax.errorbar(xs, sr, yerr=err, fmt="o-", color=colour, capsize=3, label=name, **z)
        for x, s, label in zip(xs, sr, labels, strict=True):
            # beside the point, clear of its vertical error bar, over the lines it crosses
            ground = {"boxstyle": "round,pad=0.15", "fc": palette.PAPER_RGB, "ec": "none"}
            ax.annotate(label, (x, s), textcoords="offset points", xytext=(5, dy // 2),
                        fontsize=7, ha="left", va="center", color=palette.TEXT_RGB, zorder=5,
                        bbox=ground)  # fmt: skip
    if args.digit_rounds:
        xs, sr, n, labels = _digit_rounds(args.digit_rounds, args.start, stages[0][1][0][-1])
        labels[0] = args.start_label
        lo_hi = [wilson_interval(round(s * k), k) for s, k in zip(sr, n, strict=True)]
        err = [[s - lo for s, (lo, _) in zip(sr, lo_hi, strict=True)],
               [hi - s for s, (_, hi) in zip(sr, lo_hi, strict=True)]]  # fmt: skip
        colour = palette.METHOD_CYCLE[len(stages) % len(palette.METHOD_CYCLE)]
        ax.errorbar(xs, sr, yerr=err, fmt="s--", color=colour, capsize=3,
                    label=f"Digit rounds, on Digit ({n[0]} other seeds)")  # fmt: skip
        for x, s, label in zip(xs, sr, labels, strict=True):
            ax.annotate(label, (x, s), textcoords="offset points", xytext=(12, -3), fontsize=7,
                        ha="left", color=palette.TEXT_RGB)  # fmt: skip
    for i, spec in enumerate(args.teacher):
        label, _, value = spec.partition("=")
        if compared:  # in the legend: on the plot the names would cover the first points
            ax.axhline(float(value), ls=("--", ":", "-.")[i % 3], color=palette.INK_RGB, lw=1,
                       label=f"{label}: {float(value):.3f}")  # fmt: skip
            continue
        ax.axhline(float(value), ls="--", color=palette.INK_RGB, lw=1)
        ax.annotate(f"{label}: {float(value):.3f}", (0.01, float(value)), xycoords=("axes fraction",
                    "data"), xytext=(0, 4), textcoords="offset points", fontsize=8)  # fmt: skip
    if args.digit_rounds:
        ax.set_xlabel("cumulative wall time [min] (calibrated world: one core; Digit: two workers)")
        ax.set_ylabel("SR on selection seeds (95 % CI)")
    else:
        ax.set_xlabel("cumulative wall time of the route on one core [min]")
        ax.set_ylabel(f"SR on {args.n} selection seeds (95 % CI)")
    ax.set_title(args.title)
    ax.grid(alpha=0.3)
    if args.digit_rounds:  # room under the points for a legend that hides none of them
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo - 0.35 * (hi - lo), hi)
        left, right = ax.get_xlim()  # and right of the last round for its label
        ax.set_xlim(left, right + 0.04 * (right - left))
    if compared:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=7)
    else:
        ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    args.png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.png)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
