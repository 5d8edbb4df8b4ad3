"""Which rates does the walking need? A sweep over controller and footstep-planner rates.

`sweep_walking_rates` walks the Digit station under seeded random commands for every
(controller period, footstep-planner period) pair and every seed, and records per run
the tracking RMS against the LIP step map (x, y [m], heading [rad]; `diagrams.walking`),
whether it fell, and the real-time factor. Each run is one JSON line appended to a file
as soon as it finishes, so an interrupted sweep resumes where it stopped (runs already
in the file are not redone). `summarize_sweep` reduces the lines to one row per pair
(medians over seeds, fall count) and `sweep_table_markdown` prints them.
"""

from __future__ import annotations

import dataclasses as dc
import json
import statistics
from collections.abc import Iterable
from pathlib import Path

from emonav_drake.params import EmoNavConfig, load_config


def _key(controller_period: float, planner_period: float, seed: int) -> tuple:
    return (round(controller_period, 6), round(planner_period, 6), int(seed))


def run_one(
    controller_period: float,
    planner_period: float,
    seed: int,
    seconds: float,
    config: EmoNavConfig | None = None,
) -> dict:
    """One walk with the given periods [s]; returns its JSON row. The sweep's plant is the
    1 ms one of `configs/walking_1ms.yaml` unless `config` says otherwise (the default's
    10 ms step would forbid the finer rates)."""
    from emonav_drake.configs import CONFIG_DIR
    from emonav_drake.diagrams.walking import run_walk

    cfg = config if config is not None else load_config(CONFIG_DIR / "walking_1ms.yaml")
    wp = dc.replace(cfg.walking, controller_period=controller_period, planner_period=planner_period)
    cfg = dc.replace(cfg, walking=wp).validate()
    r = run_walk(seconds, seed=seed, command="random", config=cfg)
    return {
        "controller_period": controller_period,
        "planner_period": planner_period,
        "seed": seed,
        "seconds": seconds,
        "fell": r.fell,
        "fall_reason": r.fall_reason,
        "sim_seconds": r.sim_seconds,
        "wall_seconds": r.wall_seconds,
        "real_time_factor": r.real_time_factor,
        "rms_x": r.tracking_rms["x"],
        "rms_y": r.tracking_rms["y"],
        "rms_heading": r.tracking_rms["heading"],
        "steps": len(r.steps),
    }


def read_rows(path: str | Path) -> list[dict]:
    """The rows of a sweep file (a truncated last line, from a kill, is ignored)."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    for line in path.read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def sweep_walking_rates(
    controller_periods: Iterable[float],
    planner_periods: Iterable[float],
    seeds: Iterable[int],
    seconds: float,
    out: str | Path,
    progress: bool = True,
) -> list[dict]:
    """Run every (controller, planner, seed) not yet in `out`; append each row to it."""
    from emonav_drake.progress import progress_bar

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {_key(r["controller_period"], r["planner_period"], r["seed"]) for r in read_rows(out)}
    todo = [
        (c, p, s)
        for c in controller_periods
        for p in planner_periods
        for s in seeds
        if _key(c, p, s) not in done
    ]
    for c, p, s in progress_bar(todo, desc="walking rate sweep", unit="walk", enabled=progress):
        row = run_one(c, p, s, seconds)
        with out.open("a") as f:
            f.write(json.dumps(row) + "\n")
            f.flush()
    return read_rows(out)


def summarize_sweep(rows: list[dict]) -> list[dict]:
    """One row per (controller, planner) pair: rates [Hz], runs, falls, median tracking
    RMS over the runs that did not fall, median real-time factor."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["controller_period"], r["planner_period"]), []).append(r)
    table = []
    for (c, p), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        ok = [r for r in rs if not r["fell"]]

        def med(k: str, rows_: list[dict] = ok) -> float:
            return statistics.median(r[k] for r in rows_) if rows_ else float("nan")

        table.append(
            {
                "controller_hz": round(1.0 / c),
                "planner_hz": round(1.0 / p),
                "runs": len(rs),
                "falls": len(rs) - len(ok),
                "rms_x": med("rms_x"),
                "rms_y": med("rms_y"),
                "rms_heading": med("rms_heading"),
                "max_rms_xy": max((max(r["rms_x"], r["rms_y"]) for r in ok), default=float("nan")),
                "real_time_factor": med("real_time_factor", rs),
            }
        )
    return table


def sweep_table_markdown(table: list[dict]) -> str:
    """The summary as a Markdown table."""
    lines = [
        "| controller | footstep planner | runs | falls | RMS x [cm] | RMS y [cm] "
        "| RMS heading [mrad] | worst RMS x/y [cm] | real-time factor |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in table:
        lines.append(
            f"| {r['controller_hz']} Hz | {r['planner_hz']} Hz | {r['runs']} | {r['falls']} "
            f"| {100 * r['rms_x']:.2f} | {100 * r['rms_y']:.2f} "
            f"| {1000 * r['rms_heading']:.1f} | {100 * r['max_rms_xy']:.2f} "
            f"| {r['real_time_factor']:.2f} |"
        )
    return "\n".join(lines)


def plot_sweep(table: list[dict]):
    """Tracking RMS x, y [cm] and the real-time factor against the controller rate, one
    line per footstep-planner rate; returns the matplotlib figure."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for ph in sorted({r["planner_hz"] for r in table}, reverse=True):
        rows = sorted(
            (r for r in table if r["planner_hz"] == ph), key=lambda r: -r["controller_hz"]
        )
        hz = [r["controller_hz"] for r in rows]
        label = f"footstep planner {ph} Hz"
        axes[0].plot(hz, [100 * r["rms_x"] for r in rows], "o-", label=label)
        axes[1].plot(hz, [100 * r["rms_y"] for r in rows], "o-", label=label)
        axes[2].plot(hz, [r["real_time_factor"] for r in rows], "o-", label=label)
        for r in rows:
            if r["falls"]:
                axes[0].annotate(f"{r['falls']} falls", (r["controller_hz"], 100 * r["rms_x"]))
    ticks = sorted({r["controller_hz"] for r in table})
    titles = ["tracking RMS x [cm]", "tracking RMS y [cm]", "real-time factor (while it ran)"]
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xticks(ticks, [str(t) for t in ticks])
        ax.set_xlabel("controller rate [Hz]")
        ax.set_title(title)
        ax.set_ylim(0.0, 1.3 * ax.get_ylim()[1])
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return fig
