"""Face detection against distance and head yaw: the Haar cascade and BlazeFace.

    python scripts/face_detection_study.py --out benchmarks/results/face_detection \
        --png docs/figures/face_detection.png

One pedestrian straight ahead of the LIP robot's head camera (the ZED 2 at HD720 unless
--camera-width/--camera-height/--fov-y say otherwise), at distances 1-6 m and facing
the camera turned by 0-90° (its head yaw seen from the camera), each of the three faces;
every detector runs on the same rendered image (`evaluation/perception_study.py::
detection_sweep`). Detectors: `haar` (OpenCV's frontal-face cascade, minimum face 24 px:
the classifier's), `blazeface` (MediaPipe's short-range BlazeFace on 128-px tiles of the
whole frame) and `blazeface_roi` (BlazeFace on one 128-px region around where the person's
head projects: what it costs when the LiDAR tracks say where people are). Writes
`samples.csv`, `summary.json` (detection rate per detector × distance × yaw bin, median
wall time per frame) and `table.md`; --png draws the rates.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from emonav_drake.atomic_io import atomic_output, write_json, write_text_atomic

DISTANCES = tuple(np.round(np.arange(1.0, 6.01, 0.5), 2))
FACINGS = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0)


ROI_SIDE = 128  # [px] the region around the projected head for blazeface_roi


def detectors(rig) -> dict:
    """name → callable(RGB image, (u, v, face height) [px]) → boxes (F, 4)."""
    from emonav_drake.perception.blazeface import BlazeFaceDetector
    from emonav_drake.perception.image_io import to_gray

    haar = rig.classifier.classifier
    blaze = BlazeFaceDetector()

    def roi(image, hint):
        u, v, _ = hint
        region = (round(u - ROI_SIDE / 2), round(v - ROI_SIDE / 2), ROI_SIDE)
        return blaze.detect_regions(image, [region])[0]

    return {
        "haar": lambda image, hint: haar.detect(to_gray(image, "rgb")),
        "blazeface": lambda image, hint: blaze.detect(image)[0],
        "blazeface_roi": roi,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="directory of the results")
    p.add_argument("--png", type=Path, help="write the figure here")
    p.add_argument("--camera-width", type=int, default=1280, help="image width [px]")
    p.add_argument("--camera-height", type=int, default=720, help="image height [px]")
    p.add_argument("--fov-y", type=float, default=70.0, help="vertical field of view [deg]")
    args = p.parse_args(argv)
    import time

    from emonav_drake.evaluation.perception_study import CameraRig, detection_sweep
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    params = EmotionEstimateParams(mode="camera")
    params.camera.width, params.camera.height = args.camera_width, args.camera_height
    params.camera.fov_y_deg = args.fov_y
    params.validate()
    t0 = time.perf_counter()
    rig = CameraRig(params)  # renders, and its classifier's cascade is the `haar` detector
    samples = detection_sweep(
        DISTANCES, FACINGS, detectors(rig), params=params, progress=True, rig=rig
    )
    wall = time.perf_counter() - t0
    summary = summarise(samples)
    given = sys.argv[1:] if argv is None else argv
    summary["command"] = shlex.join(["python", "scripts/face_detection_study.py", *given])
    summary["camera"] = {
        "width": args.camera_width,
        "height": args.camera_height,
        "fov_y_deg": args.fov_y,
    }
    summary["wall_seconds"] = round(wall, 1)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "summary.json", summary)
    keys = list(samples[0])
    rows = [",".join(keys)] + [",".join(str(s[k]) for k in keys) for s in samples]
    write_text_atomic(args.out / "samples.csv", "\n".join(rows) + "\n")
    write_text_atomic(args.out / "table.md", table_md(summary))
    print(table_md(summary))
    if args.png is not None:
        with atomic_output(args.png) as tmp:
            plot(summary, tmp)
        print(f"figure written to {args.png}")
    return 0


def summarise(samples: list[dict]) -> dict:
    """Detection rate per detector × distance (all yaws) and × yaw (all distances), and
    per detector × distance × yaw; median seconds per frame."""
    names = sorted(
        {s["detector"] for s in samples}, key=["haar", "blazeface", "blazeface_roi"].index
    )
    out: dict = {"detectors": names, "rate": {}, "seconds": {}}
    for n in names:
        mine = [s for s in samples if s["detector"] == n]
        out["seconds"][n] = float(np.median([s["seconds"] for s in mine]))
        grid = {}
        for s in mine:
            grid.setdefault((s["distance"], s["facing_deg"]), []).append(s["detected"])
        out["rate"][n] = [
            {"distance": d, "facing_deg": f, "rate": float(np.mean(v)), "n": len(v)}
            for (d, f), v in sorted(grid.items())
        ]
    return out


def table_md(summary: dict) -> str:
    """Detection rate by distance (columns) and yaw (rows), per detector; cost."""
    lines = []
    for n in summary["detectors"]:
        rows = summary["rate"][n]
        ds = sorted({r["distance"] for r in rows})
        fs = sorted({r["facing_deg"] for r in rows})
        rate = {(r["distance"], r["facing_deg"]): r["rate"] for r in rows}
        ms = 1000 * summary["seconds"][n]
        lines += [f"**{n}** (median {ms:.1f} ms per 1280 × 720 frame)", ""]
        lines.append("| yaw \\ distance [m] | " + " | ".join(f"{d:g}" for d in ds) + " |")
        lines.append("|---" * (len(ds) + 1) + "|")
        for f in fs:
            lines.append(f"| {f:g}° | " + " | ".join(f"{rate[(d, f)]:.2f}" for d in ds) + " |")
        lines.append("")
    return "\n".join(lines)


def plot(summary: dict, png) -> None:
    """One heat map per detector: the share of faces found, head yaw × distance."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LinearSegmentedColormap

    from emonav_drake import palette

    # the share found, from paper (none) to the data colour (all)
    cmap = LinearSegmentedColormap.from_list("found", [palette.PAPER_RGB, palette.DATA_RGB])
    names = summary["detectors"]
    fig, axes = plt.subplots(1, len(names), figsize=(4.6 * len(names), 3.4), sharey=True)
    for ax, n in zip(np.atleast_1d(axes), names, strict=True):
        rows = summary["rate"][n]
        ds = sorted({r["distance"] for r in rows})
        fs = sorted({r["facing_deg"] for r in rows})
        grid = np.zeros((len(fs), len(ds)))
        for r in rows:
            grid[fs.index(r["facing_deg"]), ds.index(r["distance"])] = r["rate"]
        im = ax.imshow(grid, origin="lower", cmap=cmap, vmin=0, vmax=1, aspect="auto")
        for (i, k), v in np.ndenumerate(grid):
            ax.text(
                k,
                i,
                f"{v:.1f}",
                ha="center",
                va="center",
                fontsize=6,
                color=palette.PAPER_RGB if v > 0.5 else palette.INK_RGB,
            )
        ax.set_xticks(range(len(ds)), [f"{d:g}" for d in ds], fontsize=7)
        ax.set_yticks(range(len(fs)), [f"{f:g}°" for f in fs], fontsize=7)
        ax.set_title(f"{n} ({1000 * summary['seconds'][n]:.0f} ms / frame)", fontsize=9)
        ax.set_xlabel("distance [m]")
    np.atleast_1d(axes)[0].set_ylabel("head yaw from the camera")
    fig.colorbar(im, ax=axes, shrink=0.85, label="share of the 3 faces found")
    fig.savefig(png, format="png", dpi=130, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
