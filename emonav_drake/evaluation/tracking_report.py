"""The LiDAR tracking study's report: its figure and tables, drawn from its summary.

From the summary of `evaluation/tracking_summary.py::summarise`, `plot` draws the figure
(position error and track rates by distance and visibility, what the time occluded does),
`tables_md` writes the tables as Markdown and `csv_rows` rows as CSV
(`scripts/tracking_study.py`, `docs/perception.md`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from emonav_drake.evaluation.scan_visibility import CATEGORY_NAMES
from emonav_drake.evaluation.tracking_summary import DISTANCE_EDGES


def plot(summary: dict, png: Any, title: str | None = None) -> None:
    """Three panels from `summary` (`summarise`): position error vs distance, track and
    detection rates vs distance by visibility, and what occlusion time does."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.palette import DATA_RGB, REFERENCE_RGB, SERIES_RGB, SHADE_RGB

    rows = summary["by_distance"]
    max_range = summary["settings"]["lidar"]["max_range"]

    def series(vis: str, key: str) -> tuple[np.ndarray, np.ndarray]:
        sel = [r for r in rows if r["visibility"] == vis and r[key] is not None]
        x = np.array([(r["distance_from"] + r["distance_to"]) / 2 for r in sel])
        return x, np.array([r[key] for r in sel], dtype=float)

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    ax = axes[0]
    x, med = series("all", "pos_err_median")
    _, p90 = series("all", "pos_err_p90")
    ax.plot(x, 1000 * med, "o-", color=DATA_RGB, label="median")
    ax.plot(x, 1000 * p90, "s--", color=REFERENCE_RGB, label="90th percentile")
    ax.axvspan(max_range, max(DISTANCE_EDGES), color=SHADE_RGB, label="beyond range (coasting)")
    ax.set_yscale("log")
    ax.set(xlabel="distance to the robot [m]", ylabel="position error [mm] (log scale)")
    ax.set_title("Position error of matched pedestrians [mm]")
    ax.legend(fontsize=8, loc="upper left")

    ax = axes[1]
    colours = {
        "visible": SERIES_RGB[0],
        "partly_occluded": SERIES_RGB[4],
        "occluded": SERIES_RGB[3],
        "out_of_range": REFERENCE_RGB,
    }
    for vis, colour in colours.items():
        x, tr = series(vis, "tracked_rate")
        ax.plot(x, tr, "o-", color=colour, label=f"{vis.replace('_', ' ')}: tracked")
        if vis in ("visible", "partly_occluded"):
            x, de = series(vis, "detected_rate")
            ax.plot(x, de, ":", color=colour, label=f"{vis.replace('_', ' ')}: detected")
    ax.axvline(max_range, color=REFERENCE_RGB, lw=0.8)
    ax.set(xlabel="distance to the robot [m]", ylabel="fraction of pedestrian-scans")
    ax.set_ylim(-0.03, 1.03)
    ax.set_title("Pedestrians tracked (a confirmed track ≤ 0.5 m) and detected")
    ax.legend(fontsize=7, loc="lower left")

    ax = axes[2]
    hid = summary["by_hidden_time"]
    x = np.array([r["hidden_s"] for r in hid], dtype=float)
    ax.plot(x, [r["tracked_rate"] for r in hid], "o-", color=DATA_RGB, label="still tracked")
    beams = summary["settings"]["detection"]["min_points"]
    ax.set(xlabel=f"time since it last showed ≥ {beams} beams [s]", ylabel="fraction tracked")
    ax.set_ylim(-0.03, 1.03)
    ax2 = ax.twinx()
    med = [np.nan if r["pos_err_median"] is None else 100 * r["pos_err_median"] for r in hid]
    p90 = [np.nan if r["pos_err_p90"] is None else 100 * r["pos_err_p90"] for r in hid]
    ax2.plot(x, med, "s--", color=SERIES_RGB[4], label="error, median [cm]")
    ax2.plot(x, p90, "^:", color=SERIES_RGB[3], label="error, 90th pct [cm]")
    ax2.set(ylabel="position error of the tracked [cm]", ylim=(0, None))
    coast = summary["settings"]["tracking"]["max_coast"]
    ax.axvline(coast, color=REFERENCE_RGB, lw=0.8)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="lower left")
    last = hid[-1] if hid else None
    if last is not None and str(last["scans_hidden"]).startswith(">="):
        ax.annotate(
            f"≥ {last['hidden_s']:g} s:\ndeleted",
            (last["hidden_s"], last["tracked_rate"]),
            xytext=(-14, 100),
            textcoords="offset points",
            ha="right",
            fontsize=8,
            arrowprops={"arrowstyle": "->", "color": REFERENCE_RGB},
        )
    ax.set_title(f"Occluded pedestrians that were tracked (coast limit {coast:g} s)")
    m = summary["clear_mot"]
    sensor = (summary.get("sensor") or {}).get("preset")
    where = f", sensor {sensor}" if sensor else ""
    where += f", family {summary['family']}" if summary.get("family") else ""
    fig.suptitle(
        title
        or (
            f"LiDAR tracker on {summary['episodes']} LIP episodes (MPC{where}), "
            f"{summary['scans']} scans: MOTA {m['mota']:.3f}, MOTP {100 * m['motp']:.1f} cm, "
            f"{m['num_switches']} ID switches"
        )
    )
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def csv_rows(rows: Sequence[dict]) -> str:
    """`rows` (dicts with the same keys) as CSV text with a header; None → empty."""
    if not rows:
        return ""
    keys = list(rows[0])

    def cell(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, float):
            return f"{v:.6g}"
        return str(v)

    lines = [",".join(keys)] + [",".join(cell(r[k]) for k in keys) for r in rows]
    return "\n".join(lines) + "\n"


def _f(v: float | None, spec: str, scale: float = 1.0) -> str:
    """`v · scale` formatted with `spec`; "–" for None (nothing to measure)."""
    return "–" if v is None else format(scale * v, spec)


def _n(v: int) -> str:
    """An integer with thin-space thousands (the docs' style: 24 040)."""
    return f"{int(v):,}".replace(",", " ")


def tables_md(summary: dict) -> str:
    """The study's tables as Markdown (`tables.md` of a run directory; the docs quote its
    sections with `evaluation/results_doc.py`)."""
    m, s = summary["clear_mot"], summary
    seeds = s["seeds"]
    matched = m["num_matches"] + m["num_switches"]
    objects = m["num_objects"]
    mc, fc, sw = s["misses_by_cause"], s["false_positives_by_cause"], s["switches_by_gap"]
    pe, ve = s["position_error"], s["velocity_error"]
    coast = s["settings"]["tracking"]["max_coast"]
    still = s["settings"]["tracking"]["still_duration"]
    outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items())

    def pct(a: float, b: float) -> str:
        return f"{100 * a / b:.1f} %" if b else "–"

    def rate(v: float | None) -> str:
        return _f(v, ".3f")

    lines = [
        "# The LiDAR tracker against the true crowd",
        "",
        f"- episodes: {s['episodes']} LIP episodes, the {s.get('planner', 'mpc').upper()} "
        f"on the true crowd, seeds {seeds[0]}–{seeds[-1]} ({outcomes})",
        f"- scans: {_n(s['scans'])} (one per {s['settings']['scan_period_s']:g} s); "
        f"pedestrian-scans {_n(objects)}, {m['num_unique_objects']} pedestrians",
        f"- match: Euclidean distance ≤ {s['settings']['match_distance_m']:g} m "
        "(py-motmetrics CLEAR-MOT)",
    ]
    if "command" in s:
        lines.append(f"- command: `{s['command']}`")
    lines += [
        "",
        "## Tracking quality",
        "",
        "| metric | value |",
        "|---|---|",
        f"| MOTA | {_f(m['mota'], '.3f')} |",
        f"| MOTP (mean distance of the matched pairs) | {_f(m['motp'], '.1f', 1000)} mm |",
        f"| IDF1 | {_f(m['idf1'], '.3f')} |",
        f"| ID switches: swap / re-acquired within {coast:g} s / after the track's deletion "
        f"| {m['num_switches']}: {sw['swap']} / {sw['reacquired']} / {sw['after_deletion']} |",
        f"| pedestrian-scans matched | {_n(matched)} of {_n(objects)} ({pct(matched, objects)}) |",
        "| missed (FN): out of range / occluded / before confirmation / standing, "
        "reported as a static obstacle / other "
        f"| {_n(m['num_misses'])} ({pct(m['num_misses'], objects)}): "
        f"{_n(mc['out_of_range'])} / {_n(mc['occluded'])} / {_n(mc['unconfirmed'])} / "
        f"{_n(mc['static'])} / {_n(mc['other'])} |",
        "| false pedestrians (FP): static disc before its still time / track coasting / other "
        f"| {_n(m['num_false_positives'])} ({pct(m['num_false_positives'], objects)}): "
        f"{_n(fc['static_disc'])} / {_n(fc['coasting'])} / {_n(fc['other'])} |",
        f"| position error of the matched: RMSE / median / 90th percentile "
        f"| {_f(s['position_rmse'], '.1f', 100)} cm / {_f(pe['median'], '.1f', 1000)} mm / "
        f"{_f(pe['p90'], '.1f', 1000)} mm |",
        f"| velocity error of the matched: RMSE / median / 90th percentile "
        f"| {_f(s['velocity_rmse'], '.3f')} / {_f(ve['median'], '.3f')} / "
        f"{_f(ve['p90'], '.3f')} m/s |",
        f"| velocity RMSE of tracks older than {s['settings']['settled_track_age_s']:g} s "
        f"| {_f(s['velocity_rmse_settled'], '.3f')} m/s |",
        f"| fragmentations; pedestrians mostly tracked / partly / mostly lost "
        f"| {m['num_fragmentations']}; {m['mostly_tracked']} / {m['partially_tracked']} / "
        f"{m['mostly_lost']} |",
        "",
        "## Visibility",
        "",
        "| pedestrian-scans | count | share | detected | tracked |",
        "|---|---|---|---|---|",
    ]
    vis = s["visibility"]
    for name in CATEGORY_NAMES:
        c = vis["pedestrian_scans"][name]
        lines.append(
            f"| {name.replace('_', ' ')} | {_n(c)} | {pct(c, objects)} | "
            f"{rate(vis['detected_rate'][name])} | {rate(vis['tracked_rate'][name])} |"
        )
    d = s["static_discs"]
    lines += [
        "",
        "## Static discs",
        "",
        "| static discs | seen | reported as static | delay from first seen, median / max "
        f"| disc-scans from {still:g} s after first seen | reported static among them |",
        "|---|---|---|---|---|---|",
        f"| {d['discs']} | {d['seen']} | {d['reported_static']} | "
        f"{_f(d['delay_s']['median'], '.1f')} / {_f(d['delay_s']['max'], '.1f')} s | "
        f"{_n(d['scans_after_still_time'])} | {rate(d['reported_after_still_time'])} |",
        "",
    ]
    return "\n".join(lines)
