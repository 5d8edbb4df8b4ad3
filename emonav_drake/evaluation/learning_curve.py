"""A learning curve measured by benchmark runs: one point per training round, paired seeds.

Each point names a method of a benchmark run directory (`LABEL=RUN:METHOD`, e.g.
`round 2=benchmarks/results/digit_learning_curve:round2`); the points may come from
different runs as long as they share the plant and the setting. Every point is summarised
on the seeds that all points ran (so the curve compares like with like), with its Wilson
95 % interval, and each point is compared with the one before it by McNemar's exact test
on those paired seeds. `curve_markdown` writes the table as a `## ` section that the docs
quote (`evaluation/results_doc.py`); `plot_curve` draws it, optionally beside the
per-round success rate the training route measured in its own world (its `history.json`).
"""

from __future__ import annotations

import dataclasses as dc
import json
from collections.abc import Sequence
from pathlib import Path

from emonav_drake.errors import UserError
from emonav_drake.evaluation import tables
from emonav_drake.navigation.metrics import COLLISION, FALL, TIMEOUT


class CurveError(UserError, ValueError):
    """A point that cannot be read or does not fit the others."""


@dc.dataclass(frozen=True)
class CurvePoint:
    """One point of the curve: `method` of the benchmark run directory `run`."""

    label: str
    run: Path
    method: str


def parse_point(text: str) -> CurvePoint:
    """`LABEL=RUN:METHOD` → `CurvePoint` (`CurveError` naming the expected form)."""
    label, eq, rest = text.partition("=")
    run, colon, method = rest.rpartition(":")
    if not (eq and colon and label.strip() and run and method):
        raise CurveError(f"--point {text!r}: expected LABEL=RUN_DIRECTORY:METHOD")
    return CurvePoint(label.strip(), Path(run), method)


@dc.dataclass
class Curve:
    """The points' summaries on their common seeds and the consecutive comparisons."""

    labels: list[str]
    summary: dict[str, dict]  # label → `tables.summarize_methods` entry
    steps: list[dict]  # label k-1 vs label k: `tables.pairwise_comparisons` rows
    seeds: list[int]
    plant: str
    setting: str


def measure(points: Sequence[CurvePoint], seeds: Sequence[int] | None = None) -> Curve:
    """Summarise every point on the seeds all of them ran (restricted to `seeds` if given).

    Raises:
        CurveError: no points, a label twice, a run or method missing, runs of different
            plants or settings, or no seed common to every point.
    """
    from emonav_drake.evaluation.run_directory import load_run

    if not points:
        raise CurveError("no points: give at least one LABEL=RUN:METHOD")
    labels = [p.label for p in points]
    if len(set(labels)) != len(labels):
        raise CurveError(f"a label is given twice: {labels}")
    by_label: dict[str, dict[int, dict]] = {}
    kinds = set()
    for p in points:
        try:
            settings, trials = load_run(p.run)
        except (OSError, ValueError) as e:
            raise CurveError(f"{p.label}: {e}") from None
        if p.method not in settings["planners"]:
            raise CurveError(
                f"{p.label}: {p.run} has no method {p.method!r} "
                f"(it has {', '.join(settings['planners'])})"
            )
        kinds.add((settings["plant"], settings["setting_label"]))
        by_label[p.label] = {t["seed"]: t for t in trials if t["method"] == p.method}
    if len(kinds) != 1:
        raise CurveError(f"the points mix plants or settings: {sorted(kinds)}")
    common = set.intersection(*(set(v) for v in by_label.values()))
    if seeds is not None:
        common &= set(seeds)
    if not common:
        raise CurveError("no seed is common to every point")
    order = sorted(common)
    renamed = [by_label[lab][s] | {"method": lab} for lab in labels for s in order]
    summary = tables.summarize_methods(renamed, labels)
    steps = []
    for a, b in zip(labels, labels[1:], strict=False):
        pair = [t for t in renamed if t["method"] in (a, b)]
        steps += tables.pairwise_comparisons(pair, [a, b])
    plant, setting = kinds.pop()
    return Curve(labels, summary, steps, order, plant, setting)


def _outcomes(s: dict) -> str:
    n = s["episodes"]
    parts = [
        f"{round(s[key] * n)} {name}"
        for key, name in (
            ("collision_rate", COLLISION),
            ("timeout_rate", TIMEOUT),
            ("fall_rate", FALL),
        )
        if s.get(key)
    ]
    return ", ".join(parts) or "none"


def curve_markdown(curve: Curve, title: str) -> str:
    """The curve as a `## title` section: one row per point, then the paired tests."""
    lo, hi = curve.seeds[0], curve.seeds[-1]
    contiguous = len(curve.seeds) == hi - lo + 1
    seeds = f"seeds {lo}–{hi}" if contiguous else f"{len(curve.seeds)} seeds in {lo}–{hi}"
    header = [
        "point",
        "SR [95% CI] (n)",
        "DT / trial",
        "IDT [static; happy, neutral, negative]",
        "failures",
        "vs previous (success only here : only there, McNemar p)",
    ]
    rows = []
    for i, lab in enumerate(curve.labels):
        s = curve.summary[lab]
        lo_ci, hi_ci = s["SR_ci"]
        vs = "—"
        if i:
            st = curve.steps[i - 1]
            p = tables.format_p(st["p_value"])
            vs = f"{st['b_only_success']} : {st['a_only_success']}, p = {p}"
        rows.append(
            [
                lab,
                f"{s['SR']:.3f} [{lo_ci:.3f}, {hi_ci:.3f}] (n={s['episodes']})",
                f"{s['DT_per_trial']:.2f}",
                tables.format_idt(s),
                _outcomes(s),
                vs,
            ]
        )
    return (
        f"## {title}\n\n"
        f"Plant {curve.plant}, setting {curve.setting}, {seeds}, the same seeds for every "
        "point.\n\n" + tables.markdown_table(header, rows) + "\n"
    )


def route_success_rates(history: str | Path) -> dict[int, float]:
    """Round → the success rate a DAgger route measured in its own world (its selection
    seeds), from the route's `history.json`."""
    try:
        rows = json.loads(Path(history).read_text())
        return {int(r["round"]): float(r["eval"]["SR"]) for r in rows}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise CurveError(f"{history}: not a DAgger history.json ({e})") from None


def plot_curve(
    curve: Curve,
    png: str | Path,
    route: dict[str, float] | None = None,
    route_name: str = "training world (selection seeds)",
    title: str = "",
) -> None:
    """SR with its 95 % interval per point (the robot's blue); `route` (label → SR) drawn
    beside it (`palette.REFERENCE_RGB`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.palette import REFERENCE_RGB, ROBOT_RGB

    x = range(len(curve.labels))
    sr = [curve.summary[lab]["SR"] for lab in curve.labels]
    lo = [curve.summary[lab]["SR"] - curve.summary[lab]["SR_ci"][0] for lab in curve.labels]
    hi = [curve.summary[lab]["SR_ci"][1] - curve.summary[lab]["SR"] for lab in curve.labels]
    fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=120)
    n = curve.summary[curve.labels[0]]["episodes"]
    ax.errorbar(
        x, sr, yerr=[lo, hi], fmt="o-", color=ROBOT_RGB, capsize=4,
        label=f"{curve.plant.capitalize()}: SR, 95 % interval (n = {n} paired seeds)",
    )  # fmt: skip
    if route:
        pts = [(i, route[lab]) for i, lab in enumerate(curve.labels) if lab in route]
        if pts:
            ax.plot(*zip(*pts, strict=True), "s--", color=REFERENCE_RGB, label=route_name)
    ax.set_xticks(list(x), curve.labels)
    ax.set_ylabel("success rate")
    lowest = min(curve.summary[lab]["SR_ci"][0] for lab in curve.labels)
    ax.set_ylim(max(0.0, min(0.6, lowest - 0.05)), 1.0)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)
