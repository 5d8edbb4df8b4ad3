"""The figures of benchmark runs: written beside a run's tables, and `emonav report`.

* `write_run_figures(run_dir)`: `summary.png` (SR with its Wilson 95 % interval, DT and
  IDT per trial with 95 % t intervals: `benchmark_plots.plot_summary`) and `social.png`
  (navigation time over the successes, path length, smallest clearance to a pedestrian,
  share of steps with a time to collision under 3 s; means with 95 % t intervals) beside
  its `tables.md`. `emonav benchmark` calls it when a run ends.
* `write_report(runs, out)`: several run directories side by side — `report.md` (each run's
  settings line and Table II) and `report.png`: SR with its interval and DT per trial for
  every method in every run, and, when the runs differ in their scenario family, a heat
  map of SR (methods × families).

Colours from the shared palette (`palette.py`). The backend is left as it is (a
notebook keeps its inline one; without a display matplotlib draws with Agg), and every
figure is closed once saved.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from emonav_drake import palette
from emonav_drake.evaluation import tables
from emonav_drake.evaluation.benchmark_plots import mean_interval, plot_summary, run_labels
from emonav_drake.navigation.social_metrics import TTC_THRESHOLD
from emonav_drake.palette import INK_RGB

SUMMARY_FIGURE = "summary.png"
SOCIAL_FIGURE = "social.png"
REPORT_FIGURE = "report.png"
REPORT_FILE = "report.md"


def _ran(settings: dict, trials: Sequence[dict]) -> list[str]:
    """The run's methods that have trials, in its order."""
    present = {t["method"] for t in trials}
    return [m for m in settings["planners"] if m in present]


def _save(fig, path: Path) -> Path:  # noqa: ANN001 - a matplotlib Figure
    """Write `fig` as a PNG at `path` (atomically) and close it."""
    import matplotlib.pyplot as plt

    from emonav_drake.atomic_io import atomic_output

    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def _bars(ax, x, values: list[tuple[float, float]], colors, title: str, ylabel: str) -> None:  # noqa: ANN001
    """Bars of means with their 95 % half widths; a NaN mean (no value) drawn as "n/a"."""
    means = np.array([v[0] for v in values], dtype=float)
    half = np.array([v[1] for v in values], dtype=float)
    shown = np.nan_to_num(means)
    ax.bar(x, shown, color=colors)
    ax.errorbar(x, shown, yerr=half, fmt="none", ecolor=INK_RGB, capsize=4)
    for xi, m in zip(x, means, strict=True):
        if math.isnan(m):
            ax.text(xi, 0, "n/a", ha="center", va="bottom", fontsize=8)
    ax.set_title(title)
    ax.set_ylabel(ylabel)
    ax.set_ylim(bottom=0)
    ax.grid(axis="y", alpha=0.3)


def _method_ticks(ax, x, names: Sequence[str]) -> None:  # noqa: ANN001
    """Method names under the bars; slanted (anchored at their end) when there are many."""
    if len(names) > 3:
        ax.set_xticks(x, names, rotation=30, ha="right", rotation_mode="anchor")
    else:
        ax.set_xticks(x, names)


def plot_social(trials: Sequence[dict], methods: Sequence[str], labels: dict[str, str]):
    """NT over the successes, path length, smallest pedestrian clearance and the share of
    steps with a low time to collision, per method (means, 95 % t intervals)."""
    import matplotlib.pyplot as plt

    shown = [labels.get(m, m) for m in methods]
    colors = palette.method_colours(shown)
    per = {m: [t["record"] for t in trials if t["method"] == m] for m in methods}

    def values(m: str, key: str, successes: bool = False) -> tuple[float, float]:
        v = [
            r[key]
            for r in per[m]
            if r.get(key) is not None and (not successes or r["outcome"] == "success")
        ]
        return mean_interval(v) if v else (math.nan, 0.0)

    panels = [
        ("nav_time", True, "NT over the successes", "s"),
        ("path_length", False, "path length", "m"),
        ("min_ped_clearance", False, "smallest clearance to a pedestrian", "m"),
        ("low_ttc_ratio", False, f"share of steps with TTC < {TTC_THRESHOLD:g} s", "share"),
    ]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.4 * len(panels), 3.6))
    x = np.arange(len(methods))
    for ax, (key, successes, title, unit) in zip(axes, panels, strict=True):
        _bars(ax, x, [values(m, key, successes) for m in methods], colors, title, unit)
        _method_ticks(ax, x, shown)
    fig.suptitle("per trial: mean with its 95 % t interval", fontsize=9)
    fig.tight_layout()
    return fig


def write_run_figures(
    run: str | Path, settings: dict | None = None, trials: Sequence[dict] | None = None
) -> list[Path]:
    """Draw `summary.png` and `social.png` into the run directory `run`; their paths. The
    run's `settings` and `trials` when the caller holds them (else read from `run`)."""
    from emonav_drake.evaluation.run_directory import load_run

    run = Path(run)
    if settings is None or trials is None:
        settings, trials = load_run(run)
    methods = _ran(settings, trials)
    if not methods:
        return []
    labels = run_labels(settings)
    return [
        _save(plot_summary(trials, methods, labels), run / SUMMARY_FIGURE),
        _save(plot_social(trials, methods, labels), run / SOCIAL_FIGURE),
    ]


def run_family(settings: dict) -> str:
    """The scenario family of a run, from its recorded configuration ("paper" if none)."""
    from emonav_drake.params import ConfigError, load_config

    try:
        return load_config(data=settings["config_yaml"]).crowd.family
    except (KeyError, ConfigError):
        return "paper"


def plot_report(runs: Sequence[tuple[Path, dict, list[dict]]]):
    """SR (Wilson 95 %) and DT per trial (95 % t) of every method in every run, grouped by
    method; with runs of several families, a heat map of SR (methods × families)."""
    import matplotlib.pyplot as plt

    methods: list[str] = []
    for _, s, _ in runs:
        methods += [m for m in s["planners"] if m not in methods]
    families = [run_family(s) for _, s, _ in runs]
    run_names = [
        p.name if f == "paper" else f"{p.name} ({f})"
        for (p, _, _), f in zip(runs, families, strict=True)
    ]
    summaries = [tables.summarize_methods(t, _ran(s, t)) for _, s, t in runs]
    heat = len(set(families)) > 1
    fig, axes = plt.subplots(1, 3 if heat else 2, figsize=(15 if heat else 11, 4.2), squeeze=False)
    axes = axes[0]
    colors = palette.method_colours(list(run_names))  # one colour per run
    width = 0.8 / len(runs)
    x = np.arange(len(methods))
    for j, (name, summary) in enumerate(zip(run_names, summaries, strict=True)):
        pos = x + (j - (len(runs) - 1) / 2) * width
        sr = [summary[m]["SR"] if m in summary else math.nan for m in methods]
        lo = [summary[m]["SR_ci"][0] if m in summary else math.nan for m in methods]
        hi = [summary[m]["SR_ci"][1] if m in summary else math.nan for m in methods]
        srv, lov, hiv = (np.array(v, dtype=float) for v in (sr, lo, hi))
        axes[0].bar(pos, np.nan_to_num(srv), width, color=colors[j], label=name)
        axes[0].errorbar(
            pos, srv, yerr=[srv - lov, hiv - srv], fmt="none", ecolor=INK_RGB, capsize=3
        )
        dt = [summary[m]["DT_per_trial"] if m in summary else math.nan for m in methods]
        axes[1].bar(pos, np.nan_to_num(np.array(dt, dtype=float)), width, color=colors[j])
    axes[0].set_title("SR (95 % Wilson interval)")
    axes[0].set_ylim(0, 1.05)
    axes[1].set_title("DT per trial")
    for ax in axes[:2]:
        _method_ticks(ax, x, methods)
        ax.grid(axis="y", alpha=0.3)
    # the runs' legend above the axes, never over the bars
    fig.legend(
        *axes[0].get_legend_handles_labels(),
        loc="upper center",
        ncol=min(len(runs), 4),
        fontsize=9,
        frameon=False,
    )
    if heat:
        grid = np.array(
            [[s[m]["SR"] if m in s else np.nan for s in summaries] for m in methods],
            dtype=float,
        )
        ax = axes[2]
        im = ax.imshow(grid, vmin=0, vmax=1, cmap=palette.RATE_CMAP, aspect="auto")
        ax.set_xticks(range(len(runs)), families, rotation=30, ha="right")
        ax.set_yticks(range(len(methods)), methods)
        for i in range(len(methods)):
            for j in range(len(runs)):
                if not math.isnan(grid[i, j]):
                    dark = grid[i, j] < palette.RATE_LABEL_SWITCH
                    ink = palette.PAPER_RGB if dark else INK_RGB
                    ax.text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", fontsize=8,
                            color=ink)  # fmt: skip
        ax.set_title("SR per family")
        fig.colorbar(im, ax=ax, fraction=0.046)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    return fig


def write_report(runs: Sequence[str | Path], out: str | Path) -> Path:
    """`report.md` and `report.png` comparing the run directories `runs` in `out`."""
    from emonav_drake.atomic_io import write_text_atomic
    from emonav_drake.evaluation.run_directory import load_run, method_reads_of

    out = Path(out)
    loaded = [(Path(r), *load_run(r)) for r in runs]
    out.mkdir(parents=True, exist_ok=True)
    _save(plot_report(loaded), out / REPORT_FIGURE)
    lines = ["# Report", "", f"![SR and DT of every run]({REPORT_FIGURE})", ""]
    for path, settings, trials in loaded:
        summary = tables.summarize_methods(trials, _ran(settings, trials))
        lines += [
            f"## {path.name}",
            "",
            f"- {settings['plant']}; {settings['setting_label']}; seeds "
            f"{settings['first_seed']}–{settings['first_seed'] + settings['trials'] - 1}",
            f"- from `{path}`",
            "",
            tables.markdown_table(*tables.table2_rows(summary, method_reads_of(settings))),
            "",
        ]
    write_text_atomic(out / REPORT_FILE, "\n".join(lines))
    return out / REPORT_FILE
