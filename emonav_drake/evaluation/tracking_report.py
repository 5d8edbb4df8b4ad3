"""The tracking study's report: the episodes of `evaluation/tracking_study.py` pooled.

`summarise` gives the CLEAR-MOT numbers of motmetrics (MOTA, MOTP in metres, ID
switches, IDF1, …), position and velocity RMSE of the matched pairs, the causes of misses
and false pedestrians, rates by distance and visibility (`distance_bins`) and by the time a
pedestrian has been occluded (`hidden_bins`); `plot` draws them, `tables_md` and
`csv_rows` write them (`scripts/tracking_study.py`, `docs/perception.md`).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from emonav_drake.core.crowd_tracker import TrackerParams
from emonav_drake.core.lidar_objects import DetectionParams
from emonav_drake.evaluation.scan_visibility import CATEGORY_NAMES, OCCLUDED
from emonav_drake.evaluation.tracking_study import (
    DISTANCE_EDGES,
    FP_CAUSES,
    MATCH_DISTANCE,
    MISS_CAUSES,
    MOT_METRICS,
    SETTLED_AGE,
    EpisodeResult,
    _motmetrics,
)
from emonav_drake.params import EmoNavConfig


def _cat(results: Sequence[EpisodeResult], key: str, where: str = "peds") -> np.ndarray:
    parts = [np.asarray(getattr(r, where)[key]) for r in results]
    return np.concatenate(parts) if parts else np.zeros(0)


def _stats(x: np.ndarray) -> dict:
    """Median, 90th percentile, max and count of the finite values of x."""
    x = x[np.isfinite(x)]
    if not len(x):
        return {"median": None, "p90": None, "max": None, "n": 0}
    return {
        "median": float(np.median(x)),
        "p90": float(np.percentile(x, 90)),
        "max": float(x.max()),
        "n": int(len(x)),
    }


def _rate(x: np.ndarray) -> float | None:
    return float(np.mean(x)) if len(x) else None


def _rmse(x: np.ndarray) -> float | None:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if len(x) else None


def clear_mot(results: Sequence[EpisodeResult]) -> tuple[dict, list[dict]]:
    """motmetrics' `MOT_METRICS` over all episodes, and per episode (seed first)."""
    mm = _motmetrics()
    mh = mm.metrics.create()
    names = [str(r.seed) for r in results]
    df = mh.compute_many(
        [r.accumulator for r in results],
        metrics=list(MOT_METRICS),
        names=names,
        generate_overall=True,
    )

    def row(name: str) -> dict:
        out = {}
        for k in MOT_METRICS:
            v = df.loc[name, k]
            v = float(v) if k in ("mota", "motp", "idf1", "idp", "idr") else int(v)
            out[k] = None if isinstance(v, float) and not math.isfinite(v) else v
        return out

    return row("OVERALL"), [{"seed": r.seed, **row(str(r.seed))} for r in results]


def distance_bins(results: Sequence[EpisodeResult]) -> list[dict]:
    """Per distance bin (`DISTANCE_EDGES`) and visibility category (and "all"): samples,
    detection and track rates, position error [m] (median, p90) and velocity error
    [m/s] (median) of the matched pedestrians."""
    dist, cat = _cat(results, "distance"), _cat(results, "category")
    det, trk = _cat(results, "detected").astype(bool), _cat(results, "tracked").astype(bool)
    pe, ve = _cat(results, "pos_err"), _cat(results, "vel_err")
    idx = np.digitize(dist, DISTANCE_EDGES) - 1
    rows = []
    for b in range(len(DISTANCE_EDGES) - 1):
        for c, name in [*enumerate(CATEGORY_NAMES), (-1, "all")]:
            sel = (idx == b) & ((cat == c) if c >= 0 else True)
            if not sel.any():
                continue
            p, v = _stats(pe[sel & trk]), _stats(ve[sel & trk])
            rows.append(
                {
                    "distance_from": DISTANCE_EDGES[b],
                    "distance_to": DISTANCE_EDGES[b + 1],
                    "visibility": name,
                    "samples": int(sel.sum()),
                    "detected_rate": _rate(det[sel]),
                    "tracked_rate": _rate(trk[sel]),
                    "pos_err_median": p["median"],
                    "pos_err_p90": p["p90"],
                    "vel_err_median": v["median"],
                }
            )
    return rows


def hidden_bins(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    tracking: TrackerParams | None = None,
) -> list[dict]:
    """Occluded pedestrians (in range, fewer than min_points visible beams) that were
    tracked when they last showed: per number of scans since then (1 … coast limit, and
    "more"), samples, track rate and position error [m] (median, p90) of the matches."""
    cfg = config or EmoNavConfig()
    dt = cfg.crowd.dt
    hid, cat = _cat(results, "hidden_s"), _cat(results, "category")
    was, trk = _cat(results, "hidden_was_tracked").astype(bool), _cat(results, "tracked")
    pe = _cat(results, "pos_err")
    sel = (cat == OCCLUDED) & was & np.isfinite(hid)
    k = np.rint(np.where(sel, hid, 0.0) / dt).astype(np.int64)
    limit = round((tracking or TrackerParams()).max_coast / dt)
    rows = []
    for n in range(1, limit + 2):
        s = sel & ((k == n) if n <= limit else (k >= n))
        if not s.any():
            continue
        p = _stats(pe[s & trk.astype(bool)])
        rows.append(
            {
                "scans_hidden": n if n <= limit else f">={n}",
                "hidden_s": round(n * dt, 6),
                "samples": int(s.sum()),
                "tracked_rate": _rate(trk[s].astype(bool)),
                "pos_err_median": p["median"],
                "pos_err_p90": p["p90"],
            }
        )
    return rows


def switch_gaps(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    tracking: TrackerParams | None = None,
) -> dict:
    """ID switches by the time since the pedestrian's previous match: "swap" (matched at
    the scan before, to another track), "reacquired" (unmatched for up to `max_coast`:
    its coasting track had drifted beyond the match distance and a new one took it up),
    "after_deletion" (unmatched for longer: its track had been deleted)."""
    dt = (config or EmoNavConfig()).crowd.dt
    coast = (tracking or TrackerParams()).max_coast
    gap = _cat(results, "since_match")[_cat(results, "switch").astype(bool)]
    return {
        "swap": int((gap <= dt + 1e-9).sum()),
        "reacquired": int(((gap > dt + 1e-9) & (gap <= coast + 1e-9)).sum()),
        "after_deletion": int((gap > coast + 1e-9).sum()),
    }


def static_disc_summary(
    results: Sequence[EpisodeResult],
    tracking: TrackerParams | None = None,
    detection: DetectionParams | None = None,
) -> dict:
    """Static discs: how many were seen (min_points visible beams at some scan), reported
    as still obstacles, the delay from first seen to first reported [s], and the share
    of disc-scans reported from `still_duration` after first seen on."""
    tracking, detection = tracking or TrackerParams(), detection or DetectionParams()
    delays, after = [], []
    seen = reported = total = 0
    for r in results:
        d = r.discs_seen
        for disc in range(r.discs):
            total += 1
            sel = d["disc"] == disc
            t, vis, rep = d["time"][sel], d["visible_beams"][sel], d["reported"][sel]
            shows = np.flatnonzero(vis >= detection.min_points)
            if not len(shows):
                continue
            seen += 1
            t0 = t[shows[0]]
            first = np.flatnonzero(rep.astype(bool))
            if len(first):
                reported += 1
                delays.append(float(t[first[0]] - t0))
            after += rep[t - t0 >= tracking.still_duration - 1e-9].astype(bool).tolist()
    return {
        "discs": total,
        "seen": seen,
        "reported_static": reported,
        "delay_s": _stats(np.asarray(delays, dtype=float)),
        "scans_after_still_time": len(after),
        "reported_after_still_time": _rate(np.asarray(after, dtype=bool)),
    }


def summarise(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
) -> dict:
    """Every number of the study, JSON-ready (module docstring)."""
    cfg = config or EmoNavConfig()
    detection, tracking = detection or DetectionParams(), tracking or TrackerParams()
    overall, _ = clear_mot(results)
    cat = _cat(results, "category")
    trk, det = _cat(results, "tracked").astype(bool), _cat(results, "detected").astype(bool)
    pe, ve, age = _cat(results, "pos_err"), _cat(results, "vel_err"), _cat(results, "track_age")
    cause, speed = _cat(results, "miss_cause"), _cat(results, "speed")
    outcomes = sorted({r.outcome for r in results})
    return {
        "episodes": len(results),
        "seeds": [r.seed for r in results],
        "scans": int(sum(r.scans for r in results)),
        "walking_steps": int(sum(r.steps for r in results)),
        "outcomes": {o: sum(r.outcome == o for r in results) for o in outcomes},
        "clear_mot": overall,
        "position_rmse": _rmse(pe),
        "velocity_rmse": _rmse(ve),
        "velocity_rmse_settled": _rmse(ve[age >= SETTLED_AGE - 1e-9]),
        "position_error": _stats(pe),
        "velocity_error": _stats(ve),
        "misses_by_cause": {c: int((cause == i).sum()) for i, c in enumerate(MISS_CAUSES)},
        "static_misses_true_speed": _stats(speed[cause == MISS_CAUSES.index("static")]),
        "switches_by_gap": switch_gaps(results, cfg, tracking),
        "false_positives_by_cause": {
            c: int(sum(r.false_positives[c] for r in results)) for c in FP_CAUSES
        },
        "visibility": {
            "pedestrian_scans": {n: int((cat == i).sum()) for i, n in enumerate(CATEGORY_NAMES)},
            "detected_rate": {n: _rate(det[cat == i]) for i, n in enumerate(CATEGORY_NAMES)},
            "tracked_rate": {n: _rate(trk[cat == i]) for i, n in enumerate(CATEGORY_NAMES)},
        },
        "static_discs": static_disc_summary(results, tracking, detection),
        "by_distance": distance_bins(results),
        "by_hidden_time": hidden_bins(results, cfg, tracking),
        "settings": {
            "match_distance_m": MATCH_DISTANCE,
            "settled_track_age_s": SETTLED_AGE,
            "lidar": dc.asdict(cfg.lidar),
            "scan_period_s": cfg.crowd.dt,
            "pedestrian_radius_m": cfg.crowd.pedestrian_radius,
            "detection": dc.asdict(detection),
            "tracking": dc.asdict(tracking),
            "max_steps": cfg.episode.max_steps,
        },
    }


# -- figure ------------------------------------------------------------------------------


def plot(summary: dict, png: Any, title: str | None = None) -> None:
    """Three panels from `summary` (`summarise`): position error vs distance, track and
    detection rates vs distance by visibility, and what occlusion time does."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.core.palette import DATA_RGB, REFERENCE_RGB, SERIES_RGB, SHADE_RGB

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
    fig.suptitle(
        title
        or (
            f"LiDAR tracker on {summary['episodes']} LIP episodes (MPC), {summary['scans']} "
            f"scans: MOTA {m['mota']:.3f}, MOTP {100 * m['motp']:.1f} cm, "
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
