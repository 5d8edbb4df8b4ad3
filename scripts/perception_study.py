"""Measure the head camera's face pipeline: detection vs geometry, in-loop confusion.

    python scripts/perception_study.py --out benchmarks/results/perception_hd720 \
        --png docs/figures/camera_perception_hd720.png
    python scripts/perception_study.py --camera-width 640 --camera-height 480 --fov-y 45 \
        --out benchmarks/results/perception --png docs/figures/camera_perception.png

Writes into --out: `sweep.jsonl` (one pedestrian placed at a grid of distances, bearings
and facing angles, each emotion; `evaluation.perception_study.sweep`), `episodes.jsonl`
(every pedestrian at every classification of --episodes LIP episodes with camera
emotions, seeds --first-seed …, the MPC planning; `episode_samples`) and `summary.json`
(confusion matrices, detection rates, wall times, the time of one classification).
Seeds 800 000 … are used by default: never used to train, select or evaluate a planner.
--png draws the figure. The camera is `HeadCameraParams` (default: the ZED 2 at HD720,
1280 × 720, 70° vertical) with --camera-width / --camera-height / --fov-y /
--min-face-size; it is recorded in `camera.json`. Resumable: an existing `sweep.jsonl` /
`episodes.jsonl` is reused, and refused if it was made with another camera (a directory
written before `camera.json` existed was made with the 640 × 480, 45° camera).
--timing-only prints the time of one classification at the camera and writes nothing.
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import sys
import time
from pathlib import Path

import numpy as np

from emonav_drake.evaluation.perception_study import (
    classification_seconds,
    confusion_counts,
    episode_samples,
    half_fov_x_deg,
    rate_by,
    sweep,
)
from emonav_drake.params import EMOTION_NAMES, ConfigError
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams, HeadCameraParams

DISTANCES = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0]
BEARINGS = [-28.0, -20.0, -10.0, 0.0, 10.0, 20.0, 28.0]
FACINGS = [0.0, 30.0, 60.0, 90.0, 135.0, 180.0]
DISTANCE_EDGES = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 12.0]
# ≈ half the horizontal field of view of the 640 × 480, 45° camera (28.9°) [deg], the
# in-view filter of its runs: the "central" rates compare cameras over the same bearings
CENTRAL_HALF_FOV_DEG = 29.0


def _write_jsonl(path: Path, rows: list[dict]) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text("".join(json.dumps(r) + "\n" for r in rows))
    tmp.replace(path)


def _read_jsonl(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def check_camera(out: Path, params: EmotionEstimateParams) -> None:
    """Record the camera in `out/camera.json`; `ConfigError` if the directory already
    holds samples of another camera (without camera.json: the 640 × 480, 45° one)."""
    path = out / "camera.json"
    camera = dc.asdict(params.camera)
    if path.is_file():
        recorded = json.loads(path.read_text())
    elif (out / "sweep.jsonl").is_file() or (out / "episodes.jsonl").is_file():
        recorded = dc.asdict(HeadCameraParams.vga())
    else:
        recorded = camera
    if recorded != camera:
        diff = {k: (recorded.get(k), v) for k, v in camera.items() if recorded.get(k) != v}
        raise ConfigError(
            f"--out {out}: its samples were made with another camera "
            f"({', '.join(f'{k} {a} there, {b} now' for k, (a, b) in diff.items())}): "
            "give the same camera flags or another --out"
        )
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(camera, indent=1) + "\n")
    tmp.replace(path)


def run_sweep(out: Path, params: EmotionEstimateParams) -> tuple[list[dict], float]:
    path = out / "sweep.jsonl"
    if path.is_file():
        return _read_jsonl(path), float("nan")
    t0 = time.perf_counter()
    rows = sweep(DISTANCES, BEARINGS, FACINGS, params=params, progress=True)
    _write_jsonl(path, rows)
    return rows, time.perf_counter() - t0


def run_episodes(
    out: Path, first_seed: int, episodes: int, params: EmotionEstimateParams
) -> tuple[list[dict], list, float]:
    from tqdm import tqdm

    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    path, rec_path = out / "episodes.jsonl", out / "episode_records.jsonl"
    if path.is_file() and rec_path.is_file():
        return _read_jsonl(path), _read_jsonl(rec_path), float("nan")
    cfg = EmoNavConfig()
    planner = make_planner("mpc", cfg)
    rows, records = [], []
    t0 = time.perf_counter()
    for seed in tqdm(range(first_seed, first_seed + episodes), desc="camera episodes"):
        record, samples = episode_samples(sample_scenario(seed, cfg), cfg, planner, params)
        rows += samples
        records.append({"seed": seed, **record.to_json()})
    _write_jsonl(path, rows)
    _write_jsonl(rec_path, records)
    return rows, records, time.perf_counter() - t0


def summarise(
    sweep_rows: list[dict],
    episode_rows: list[dict],
    records: list,
    params: EmotionEstimateParams,
) -> dict:
    front = [r for r in sweep_rows if r["facing_deg"] == 0.0 and r["bearing_deg"] == 0.0]
    by_distance = {}
    for e, name in enumerate(EMOTION_NAMES):
        rows = [r for r in front if r["truth"] == e]
        by_distance[name] = {
            f"{r['distance']:g}": {"detected": r["detected"], "estimate": r["estimate"]}
            for r in rows
        }
    c_all = confusion_counts(episode_rows)
    c_seen = confusion_counts(episode_rows, detected_only=True)
    half = half_fov_x_deg(params)
    in_view = [r for r in episode_rows if abs(r["bearing_deg"]) <= half]
    rate, n = rate_by(in_view, "distance", DISTANCE_EDGES)
    central = [r for r in episode_rows if abs(r["bearing_deg"]) <= CENTRAL_HALF_FOV_DEG]
    c_rate, c_n = rate_by(central, "distance", DISTANCE_EDGES)
    rows = c_all.sum(axis=1)
    recognised = {
        name: float(c_all[e, e] / rows[e]) if rows[e] else None
        for e, name in enumerate(EMOTION_NAMES)
    }
    return {
        "sweep_shots": len(sweep_rows),
        "sweep_detection_rate": float(np.mean([r["detected"] for r in sweep_rows])),
        "sweep_front_by_distance": by_distance,
        "episodes": len(records),
        "episode_outcomes": {
            o: sum(r["outcome"] == o for r in records)
            for o in sorted({r["outcome"] for r in records})
        },
        "samples": len(episode_rows),
        "detected_samples": int(sum(r["detected"] for r in episode_rows)),
        "confusion_all": c_all.tolist(),
        "confusion_detected": c_seen.tolist(),
        "recognised_fraction": recognised,
        "in_view_detection_by_distance": {
            "half_fov_deg": half,
            "edges_m": DISTANCE_EDGES,
            "rate": [None if np.isnan(x) else float(x) for x in rate],
            "samples": n.tolist(),
        },
        "central_detection_by_distance": {
            "half_fov_deg": CENTRAL_HALF_FOV_DEG,
            "edges_m": DISTANCE_EDGES,
            "rate": [None if np.isnan(x) else float(x) for x in c_rate],
            "samples": c_n.tolist(),
        },
    }


def plot(
    sweep_rows: list[dict], episode_rows: list[dict], png: Path, params: EmotionEstimateParams
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.palette import EMOTION_RGB, SERIES_RGB

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    ax = axes[0]
    colours = list(SERIES_RGB)
    for i, f in enumerate(FACINGS):
        rows = [r for r in sweep_rows if r["facing_deg"] == f and abs(r["bearing_deg"]) <= 20]
        rate = [np.mean([r["detected"] for r in rows if r["distance"] == d]) for d in DISTANCES]
        style = "o-" if f < 90 else "s--"  # 90°, 135° and 180° all lie on zero
        ax.plot(DISTANCES, rate, style, color=colours[i % len(colours)], label=f"facing {f:g}°")
    ax.set(xlabel="distance to the camera [m]", ylabel="face detection rate", ylim=(-0.03, 1.03))
    ax.set_title("Detection vs distance (bearings ≤ 20°, 3 emotions)")
    ax.legend(fontsize=8)
    ax = axes[1]
    for e, name in enumerate(EMOTION_NAMES):
        rows = [r for r in sweep_rows if r["truth"] == e and r["facing_deg"] == 0.0]
        ok = [
            np.mean([r["detected"] and r["estimate"] == e for r in rows if r["distance"] == d])
            for d in DISTANCES
        ]
        ax.plot(DISTANCES, ok, "o-", color=EMOTION_RGB[e], label=name)
    ax.set(
        xlabel="distance to the camera [m]",
        ylabel="detected and recognised",
        ylim=(-0.03, 1.03),
    )
    ax.set_title("Recognition of a facing pedestrian (all bearings)")
    ax.legend(fontsize=8)
    ax = axes[2]
    c = confusion_counts(episode_rows)
    frac = c / np.maximum(c.sum(axis=1, keepdims=True), 1)
    from matplotlib.colors import LinearSegmentedColormap

    from emonav_drake.palette import INK_RGB, PAPER_RGB

    shade = LinearSegmentedColormap.from_list("paper_to_ink", [PAPER_RGB, INK_RGB])
    ax.imshow(frac, cmap=shade, vmin=0, vmax=1)
    for i in range(3):
        for j in range(3):
            ax.text(
                j,
                i,
                f"{frac[i, j]:.2f}\n({c[i, j]})",
                ha="center",
                va="center",
                color=PAPER_RGB if frac[i, j] > 0.5 else INK_RGB,
            )
    ax.set_xticks(range(3), EMOTION_NAMES)
    ax.set_yticks(range(3), EMOTION_NAMES)
    ax.set(xlabel="perceived (unseen → neutral)", ylabel="true emotion")
    ax.set_title(f"In the loop (LIP, MPC), n = {c.sum()}")
    cam = params.camera
    fig.suptitle(
        f"Head camera {cam.width} × {cam.height} px, {cam.fov_y_deg:g}° vertical "
        f"({2 * half_fov_x_deg(params):.0f}° horizontal), faces ≥ {cam.min_face_size} px"
    )
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    default = HeadCameraParams()
    p.add_argument("--out", type=Path, help="run directory (required unless --timing-only)")
    p.add_argument("--episodes", type=int, default=100, help="LIP episodes with camera emotions")
    p.add_argument("--first-seed", type=int, default=800_000, help="first episode seed")
    p.add_argument("--png", type=Path, help="write the figure here")
    p.add_argument(
        "--camera-width",
        type=int,
        default=default.width,
        help=f"image width [px] ({default.width})",
    )
    p.add_argument(
        "--camera-height",
        type=int,
        default=default.height,
        help=f"image height [px] ({default.height})",
    )
    p.add_argument(
        "--fov-y",
        type=float,
        default=default.fov_y_deg,
        help=f"vertical field of view [deg] ({default.fov_y_deg:g})",
    )
    p.add_argument(
        "--min-face-size",
        type=int,
        default=default.min_face_size,
        help=f"smallest face the cascade accepts [px] ({default.min_face_size})",
    )
    p.add_argument(
        "--timing-only",
        action="store_true",
        help="print the time of one classification at this camera; write nothing",
    )
    args = p.parse_args(argv)
    camera = dc.replace(
        default,
        width=args.camera_width,
        height=args.camera_height,
        fov_y_deg=args.fov_y,
        min_face_size=args.min_face_size,
    )
    try:
        params = EmotionEstimateParams(mode="camera", camera=camera).validate()
        if args.timing_only:
            print(json.dumps({"camera": dc.asdict(camera), **classification_seconds(params)}))
            return 0
        if args.out is None:
            raise ConfigError("--out: required (unless --timing-only)")
        if args.episodes < 1 or args.first_seed < 0:
            raise ConfigError("--episodes must be >= 1 and --first-seed >= 0")
        args.out.mkdir(parents=True, exist_ok=True)
        check_camera(args.out, params)
    except (ConfigError, OSError) as e:
        print(f"perception_study: error: {e}", file=sys.stderr)
        return 2
    timing = classification_seconds(params)
    sweep_rows, sweep_s = run_sweep(args.out, params)
    episode_rows, records, episodes_s = run_episodes(
        args.out, args.first_seed, args.episodes, params
    )
    summary = summarise(sweep_rows, episode_rows, records, params)
    summary["classification_seconds"] = timing
    summary["settings"] = {
        "camera": dc.asdict(camera),
        "distances_m": DISTANCES,
        "bearings_deg": BEARINGS,
        "facings_deg": FACINGS,
        "first_seed": args.first_seed,
        "episodes": args.episodes,
        "planner": "mpc",
        "plant": "lip",
    }
    summary["wall_seconds"] = {"sweep": sweep_s, "episodes": episodes_s}
    old = args.out / "summary.json"
    if old.is_file():  # a resumed part keeps the wall time measured when it ran
        before = json.loads(old.read_text()).get("wall_seconds", {})
        for k, v in summary["wall_seconds"].items():
            if v != v and before.get(k) is not None:
                summary["wall_seconds"][k] = before[k]
        note = json.loads(old.read_text()).get("wall_seconds_note")
        if note is not None:
            summary["wall_seconds_note"] = note
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps({k: summary[k] for k in ("confusion_all", "confusion_detected")}))
    if args.png is not None:
        plot(sweep_rows, episode_rows, args.png, params)
        print(f"figure written to {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
