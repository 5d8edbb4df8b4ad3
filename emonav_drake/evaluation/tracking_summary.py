"""The LiDAR tracking study's numbers: the episodes of `evaluation/tracking_study.py` pooled.

`summarise` gives the CLEAR-MOT numbers of motmetrics (MOTA, MOTP in metres, ID
switches, IDF1, …), position and velocity RMSE of the matched pairs, the causes of misses
and false pedestrians, rates by distance and visibility (`distance_bins`) and by the time a
pedestrian has been occluded (`hidden_bins`), JSON-ready; `evaluation/tracking_report.py`
draws and writes them (`scripts/tracking_study.py`, `docs/perception.md`).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Sequence

import numpy as np

from emonav_drake.evaluation.scan_visibility import CATEGORY_NAMES, OCCLUDED
from emonav_drake.evaluation.tracking_evaluator import (
    FP_CAUSES,
    MATCH_DISTANCE,
    MISS_CAUSES,
    EpisodeResult,
    _motmetrics,
)
from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.crowd_tracker import TrackerParams
from emonav_drake.sensing.lidar_objects import DetectionParams

# Bins of the summaries and the figure: distance to the robot [m] (the range is 6 m).
DISTANCE_EDGES = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 7.0, 8.0, 10.0)
SETTLED_AGE = 1.0  # tracks at least this old [s] give the "settled" velocity error

# The CLEAR-MOT and identity metrics read from motmetrics (its names).
MOT_METRICS = (
    "num_frames",
    "num_objects",
    "num_unique_objects",
    "num_matches",
    "num_switches",
    "num_transfer",
    "num_false_positives",
    "num_misses",
    "num_fragmentations",
    "mostly_tracked",
    "partially_tracked",
    "mostly_lost",
    "mota",
    "motp",
    "idf1",
    "idp",
    "idr",
)


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
    scored = _cat(results, "scored").astype(bool)
    cause = np.where(scored, cause, -1)  # outside the scored range: no miss
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
            "scored_range_m": results[0].scored_range if results else None,
            "settled_track_age_s": SETTLED_AGE,
            "lidar": dc.asdict(cfg.lidar),
            "scan_period_s": cfg.crowd.dt,
            "pedestrian_radius_m": cfg.crowd.pedestrian_radius,
            "detection": dc.asdict(detection),
            "tracking": dc.asdict(tracking),
            "max_steps": cfg.episode.max_steps,
        },
    }
