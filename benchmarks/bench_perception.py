"""Perception benchmark: face detection + emotion classification on 640 × 480 frames, one core.

    full pipeline (gray, Haar detection, crops, mini-XCEPTION, 3-way label) per frame:
        budget ≥ 20 Hz (docs/facts.md); the paper runs detection at 10 Hz, emotion at 0.5 Hz
    Haar detection alone, at fer's full resolution and at detection_scale 0.5
    CNN latency alone: one 64 × 64 face, and a batch of 4

Frames are real photographs shipped inside installed packages (matplotlib's Grace Hopper,
scikit-image's astronaut over its coffee photo; see `perception/sample_photos.py`).
Haar cost depends on the image content (textured backgrounds cost more), so every frame
is reported. Medians over `--repeats` runs, OpenCV and torch limited to one thread, so
all work runs in the calling thread: besides wall time, its CPU time (`time.thread_time`)
is reported — the cost on one core, less sensitive to other jobs sharing the machine.

Run:  .venv/bin/python benchmarks/bench_perception.py [--repeats 30] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.perception.face_emotion import (  # noqa: E402
    DetectorParams,
    FaceEmotionClassifier,
)
from emonav_drake.perception.image_io import to_gray  # noqa: E402
from emonav_drake.perception.mini_xception import load_mini_xception  # noqa: E402
from emonav_drake.perception.sample_photos import camera_frame  # noqa: E402

BUDGET_HZ = 20.0


def median_ms(fn: Callable[[], object], repeats: int, clock=time.perf_counter) -> float:
    """Median duration of `fn` [ms] on `clock` (wall by default; `time.thread_time` = CPU)."""
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return 1e3 * statistics.median(times)


def frames() -> dict[str, np.ndarray]:
    return {
        "astronaut on coffee (textured)": camera_frame("astronaut", "coffee", height=480),
        "Grace Hopper on coffee (1 face)": camera_frame("grace_hopper", "coffee", height=480),
        "Grace Hopper small (1 face, 300 px photo)": camera_frame(
            "grace_hopper", "coffee", left=300, height=300
        ),
        "coffee (no face)": camera_frame("coffee", "coffee", height=480),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    torch.set_num_threads(1)
    model = load_mini_xception()
    results: dict[str, object] = {"budget_hz": BUDGET_HZ, "frames": {}}
    print(f"one core (cv2 and torch: 1 thread), medians of {args.repeats} runs, 640 x 480 frames")
    print(
        f"{'frame':42s} {'scale':>5s} {'faces':>5s} {'detect ms':>9s} {'total ms':>8s} "
        f"{'Hz':>6s} {'CPU ms':>7s} {'CPU Hz':>6s}"
    )
    totals: dict[float, list[float]] = {1.0: [], 0.5: []}
    cpu_totals: dict[float, list[float]] = {1.0: [], 0.5: []}
    for name, frame in frames().items():
        gray = to_gray(frame)
        rows = {}
        for scale in (1.0, 0.5):
            clf = FaceEmotionClassifier(DetectorParams(detection_scale=scale), model=model)
            faces = clf.classify(frame)
            det = median_ms(lambda c=clf, g=gray: c.detect(g), args.repeats)
            total = median_ms(lambda c=clf, f=frame: c.classify(f), args.repeats)
            cpu = median_ms(lambda c=clf, f=frame: c.classify(f), args.repeats, time.thread_time)
            totals[scale].append(total)
            cpu_totals[scale].append(cpu)
            rows[str(scale)] = {
                "faces": [(f.box, f.label_name) for f in faces],
                "detect_ms": round(det, 2),
                "total_ms": round(total, 2),
                "hz": round(1e3 / total, 1),
                "cpu_ms": round(cpu, 2),
                "cpu_hz": round(1e3 / cpu, 1),
            }
            print(
                f"{name:42s} {scale:5.2f} {len(faces):5d} {det:9.1f} {total:8.1f} "
                f"{1e3 / total:6.1f} {cpu:7.1f} {1e3 / cpu:6.1f}  {[f.label_name for f in faces]}"
            )
        results["frames"][name] = rows  # type: ignore[index]

    clf = FaceEmotionClassifier(model=model)
    one = np.zeros((1, 64, 64), np.float32)
    four = np.zeros((4, 64, 64), np.float32)
    cnn1 = median_ms(lambda: clf.predict(one), 5 * args.repeats)
    cnn4 = median_ms(lambda: clf.predict(four), 2 * args.repeats)
    cnn1_cpu = median_ms(lambda: clf.predict(one), 5 * args.repeats, time.thread_time)
    print(
        f"CNN alone (mini-XCEPTION, 1 face): {cnn1:.2f} ms wall, {cnn1_cpu:.2f} ms CPU; "
        f"batch of 4: {cnn4:.2f} ms wall"
    )
    for scale in totals:
        for kind, ts in (("wall", totals[scale]), ("CPU", cpu_totals[scale])):
            worst = max(ts)
            verdict = "meets" if 1e3 / worst >= BUDGET_HZ else "misses"
            print(
                f"detection_scale {scale}, {kind:4s}: worst frame {worst:6.1f} ms = "
                f"{1e3 / worst:5.1f} Hz, median over frames {statistics.median(ts):6.1f} ms "
                f"-> {verdict} the {BUDGET_HZ:.0f} Hz budget"
            )
    results["cnn_ms"] = {"batch_1": round(cnn1, 3), "batch_4": round(cnn4, 3)}
    results["cnn_cpu_ms"] = {"batch_1": round(cnn1_cpu, 3)}
    results["worst_hz"] = {str(s): round(1e3 / max(ts), 1) for s, ts in totals.items()}
    results["worst_cpu_hz"] = {str(s): round(1e3 / max(ts), 1) for s, ts in cpu_totals.items()}
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
