"""`emonav emotion PATH [--json out.json] [--annotate out.png]`: faces and emotions in a file.

PATH is an image (PNG, JPEG, BMP, …) or a video (.mp4, .avi, .mov, .mkv, .webm, …). For
each face: its box (x, y, w, h) [px], the 7 FER-2013 class probabilities, the top class
and the paper's 3-way label; a frame without a face is neutral (paper §IV-G).

--annotate writes the image with boxes and labels drawn. For a video, an image suffix
(.png, .jpg) writes the frame with the most faces (the first such frame), a video
suffix (.mp4, .avi) the whole annotated video.

Large inputs: an image (or video frame) above --max-pixels (default 4096 x 2048) is
classified on a downscaled copy, with a note on stderr; boxes in the printout and the
JSON stay in the original's pixels ("scale" < 1 in the JSON), the annotation is drawn on
the downscaled copy. Images above 268 megapixels are refused from their header.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from emonav_drake.atomic_io import (
    atomic_output,
    check_distinct,
    check_output_file,
    write_bytes_atomic,
    write_json,
)
from emonav_drake.errors import UsageError
from emonav_drake.params import EMOTION_NAMES

IMAGE_WRITE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")
VIDEO_WRITERS = {".mp4": "mp4v", ".avi": "MJPG"}


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav emotion` on the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "emotion",
        help="detect faces and classify their emotions in an image or a video",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("path", type=Path, help="image (PNG/JPEG/…) or video file")
    p.add_argument("--json", type=Path, help="write faces, probabilities and labels as JSON")
    p.add_argument("--annotate", type=Path, help="write the annotated image (or video)")
    p.add_argument("--every", type=int, default=1, help="video: classify every N-th frame")
    p.add_argument("--max-frames", type=int, default=None, help="video: stop after N frames")
    p.add_argument(
        "--smooth",
        type=float,
        default=1.0,
        help="video: weight of the newest frame in each tracked face's moving average "
        "of probabilities (1 = no smoothing)",
    )
    p.add_argument(
        "--detection-scale",
        type=float,
        default=1.0,
        help="run the Haar detector on the image scaled by this factor (1 = fer's; "
        "0.5 is ~3x faster)",
    )
    p.add_argument(
        "--max-pixels",
        type=int,
        default=None,
        help="classify larger images / frames on a copy downscaled to this many pixels "
        "(default 4096 x 2048 = 8388608; 0 = never downscale)",
    )
    p.set_defaults(func=cmd_emotion)
    return p


def _write_image(path: Path, image: np.ndarray) -> None:
    import cv2

    suffix = path.suffix.lower()
    if suffix not in IMAGE_WRITE_SUFFIXES:
        raise UsageError(f"--annotate {path}: use one of {IMAGE_WRITE_SUFFIXES}")
    ok, data = cv2.imencode(suffix, image)
    if not ok:
        raise UsageError(f"--annotate {path}: could not encode the image")
    write_bytes_atomic(path, data.tobytes())


def _original_coordinates(faces: list, scale: float) -> list:
    """Faces found on a copy downscaled by `scale`, with boxes in the original's pixels."""
    from emonav_drake.perception.face_emotion import FaceEmotion
    from emonav_drake.perception.image_io import scale_box

    if scale == 1.0:
        return faces
    return [FaceEmotion(scale_box(f.box, scale), f.probabilities) for f in faces]


def _note_downscaled(path: Path, size: tuple[int, int], shape: tuple, max_pixels: int) -> None:
    w, h = size
    print(
        f"note: {path} is {w}x{h} ({w * h / 1e6:.1f} megapixels): classified on a copy "
        f"downscaled to {shape[1]}x{shape[0]} (--max-pixels {max_pixels}); boxes are given "
        "in the original's pixels, the annotation is drawn on the copy",
        file=sys.stderr,
    )


def _validate_emotion_args(args: argparse.Namespace, video: bool) -> None:
    """Every flag checked before the classifier loads or a frame is read."""
    from emonav_drake.perception.image_io import MAX_IMAGE_PIXELS

    if args.path.is_dir():
        raise UsageError(f"{args.path}: is a directory, expected an image or video file")
    if not args.path.is_file():
        raise FileNotFoundError(f"{args.path}: no such file")
    if args.every < 1:
        raise UsageError(f"--every {args.every}: must be >= 1")
    if args.max_frames is not None and args.max_frames < 1:
        raise UsageError(f"--max-frames {args.max_frames}: must be >= 1")
    if not 0.0 < args.smooth <= 1.0:
        raise UsageError(f"--smooth {args.smooth}: must be in (0, 1]")
    if not 0.05 <= args.detection_scale <= 1.0:
        raise UsageError(f"--detection-scale {args.detection_scale}: must be in [0.05, 1]")
    if args.max_pixels is None:
        args.max_pixels = MAX_IMAGE_PIXELS
    if args.max_pixels < 0:
        raise UsageError(f"--max-pixels {args.max_pixels}: must be >= 0 (0 = never downscale)")
    if args.annotate is not None:
        check_output_file(args.annotate, "--annotate")
        suffix = args.annotate.suffix.lower()
        if suffix not in (*IMAGE_WRITE_SUFFIXES, *VIDEO_WRITERS):
            raise UsageError(
                f"--annotate {args.annotate}: use an image suffix {IMAGE_WRITE_SUFFIXES} "
                f"or, for a video, {tuple(VIDEO_WRITERS)}"
            )
        if suffix in VIDEO_WRITERS and not video:
            raise UsageError(f"--annotate {args.annotate}: an image input needs an image suffix")
    if args.json is not None:
        check_output_file(args.json, "--json")
    check_distinct({"--json": args.json, "--annotate": args.annotate, "PATH": args.path})


def _face_lines(faces: list) -> list[str]:
    from emonav_drake.perception.mini_xception import CLASS_NAMES

    lines = []
    for i, f in enumerate(faces, start=1):
        top3 = np.argsort(f.probabilities)[::-1][:3]
        ranked = ", ".join(f"{CLASS_NAMES[k]} {f.probabilities[k]:.2f}" for k in top3)
        lines.append(f"  face {i} at {tuple(f.box)}: {f.label_name} ({ranked})")
    return lines


def cmd_emotion(args: argparse.Namespace) -> int:
    """Run the classifier on an image or a video; print, and write JSON / annotations."""
    from emonav_drake.perception.face_emotion import DetectorParams, FaceEmotionClassifier
    from emonav_drake.perception.image_io import is_video_path

    video = is_video_path(args.path)
    _validate_emotion_args(args, video)
    classifier = FaceEmotionClassifier(DetectorParams(detection_scale=args.detection_scale))
    if video:
        return _run_video(args, classifier)
    return _run_image(args, classifier)


def _run_image(args: argparse.Namespace, classifier: Any) -> int:
    from emonav_drake.perception.face_emotion import annotate, frame_label
    from emonav_drake.perception.image_io import load_image_limited

    image, scale, (w, h) = load_image_limited(args.path, args.max_pixels)
    if scale != 1.0:
        _note_downscaled(args.path, (w, h), image.shape, args.max_pixels)
    t0 = time.perf_counter()
    faces = classifier.classify(image)
    ms = (time.perf_counter() - t0) * 1e3
    label = EMOTION_NAMES[frame_label(faces)]
    reported = _original_coordinates(faces, scale)
    print(f"{args.path} ({w}x{h}): {len(faces)} face(s) in {ms:.0f} ms, emotion {label}")
    if faces:
        print("\n".join(_face_lines(reported)))
    else:
        print("  no face found: neutral (paper §IV-G)")
    if args.json:
        write_json(
            args.json,
            {
                "path": str(args.path),
                "kind": "image",
                "width": w,
                "height": h,
                "scale": round(scale, 6),
                "faces": [f.to_json() for f in reported],
                "label": label,
            },
        )
    if args.annotate:
        _write_image(args.annotate, annotate(image, faces))
        print(f"annotated image written to {args.annotate}")
    return 0


def _run_video(args: argparse.Namespace, classifier: Any) -> int:
    """Classify a video's frames; print the summary, write --json and --annotate."""
    suffix = args.annotate.suffix.lower() if args.annotate else ""
    with contextlib.ExitStack() as stack:
        # an annotated video goes to a temporary sibling, renamed only when complete
        video_out = (
            stack.enter_context(atomic_output(args.annotate)) if suffix in VIDEO_WRITERS else None
        )
        frames_out, best, scale, wall = _classify_video(args, classifier, video_out)
    _report_video(args, frames_out, scale, wall)
    if args.annotate and suffix not in VIDEO_WRITERS:
        if best is None:
            raise UsageError(f"{args.path}: no frame to annotate")
        _write_image(args.annotate, best)
    if args.annotate:
        print(f"annotation written to {args.annotate}")
    return 0


def _classify_video(
    args: argparse.Namespace, classifier: Any, video_out: Path | None
) -> tuple[list[dict], np.ndarray | None, float, float]:
    """Classify every --every-th frame (up to --max-frames), tracking and smoothing the
    faces; with `video_out`, write each annotated frame to it. Returns the frames' JSON
    entries, the annotated frame with the most faces (image --annotate; else None), the
    last frame's downscaling and the wall time [s]."""
    from emonav_drake.perception.face_emotion import annotate
    from emonav_drake.perception.face_tracking import EmotionSmoother, FaceTracker
    from emonav_drake.perception.image_io import fit_pixels, video_frames

    tracker, smoother = FaceTracker(), EmotionSmoother(args.smooth)
    frames_out: list[dict] = []
    best: tuple[int, np.ndarray | None] = (-1, None)
    scale, size = 1.0, None
    writer = None
    t0 = time.perf_counter()
    try:
        for index, t, frame in video_frames(args.path, every=args.every):
            if args.max_frames is not None and len(frames_out) >= args.max_frames:
                break
            if size is None:
                size = (frame.shape[1], frame.shape[0])
            frame, scale = fit_pixels(frame, args.max_pixels)
            if scale != 1.0 and not frames_out:
                _note_downscaled(args.path, size, frame.shape, args.max_pixels)
            faces, entry = _classify_frame(classifier, (tracker, smoother), frame, scale, index, t)
            frames_out.append(entry)
            if video_out is not None:
                drawn = annotate(frame, faces)
                if writer is None:
                    writer = _open_writer(video_out, args.path, drawn.shape, args.every)
                writer.write(drawn)
            elif args.annotate and len(faces) > best[0]:
                best = (len(faces), annotate(frame, faces))
    finally:
        if writer is not None:
            writer.release()
    wall = time.perf_counter() - t0
    if video_out is not None and writer is None:
        raise UsageError(f"{args.path}: no frame to annotate")
    return frames_out, best[1], scale, wall


def _classify_frame(
    classifier: Any,
    tracking: tuple[Any, Any],
    frame: np.ndarray,
    scale: float,
    index: int,
    t: float,
) -> tuple[list, dict]:
    """Frame `index` at time `t` [s] (NaN if unknown): its faces, tracked and smoothed by
    `tracking` = (`FaceTracker`, `EmotionSmoother`), and its JSON entry (boxes in the
    original's pixels: `frame` is the original downscaled by `scale`)."""
    from emonav_drake.perception.face_emotion import FaceEmotion, frame_label

    tracker, smoother = tracking
    raw = classifier.classify(frame)
    ids = tracker.update([f.box for f in raw])
    faces = [
        FaceEmotion(f.box, smoother.update(k, f.probabilities))
        for f, k in zip(raw, ids, strict=True)
    ]
    smoother.forget(ids)
    label = EMOTION_NAMES[frame_label(faces)]
    reported = _original_coordinates(faces, scale)
    entry = {
        "index": index,
        "time": None if np.isnan(t) else round(t, 4),
        "faces": [{**f.to_json(), "track": k} for f, k in zip(reported, ids, strict=True)],
        "label": label,
    }
    return faces, entry


def _report_video(
    args: argparse.Namespace, frames_out: list[dict], scale: float, wall: float
) -> None:
    """Print the video's summary line and write --json."""
    counts = Counter(f["label"] for f in frames_out)
    with_faces = sum(1 for f in frames_out if f["faces"])
    n = len(frames_out)
    print(
        f"{args.path}: {n} frame(s) classified in {wall:.2f} s "
        f"({n / max(wall, 1e-9):.1f} frames/s), {with_faces} with faces; labels "
        + ", ".join(f"{k} {counts.get(k, 0)}" for k in EMOTION_NAMES)
    )
    if args.json:
        write_json(
            args.json,
            {
                "path": str(args.path),
                "kind": "video",
                "every": args.every,
                "smooth": args.smooth,
                "scale": round(scale, 6),
                "frames": frames_out,
                "summary": {
                    "frames": n,
                    "frames_with_faces": with_faces,
                    "labels": {k: counts.get(k, 0) for k in EMOTION_NAMES},
                },
            },
        )


def _open_writer(path: Path, source: Path, shape: tuple, every: int) -> Any:
    import cv2

    cap = cv2.VideoCapture(str(source))
    fps = cap.get(cv2.CAP_PROP_FPS) or 10.0
    cap.release()
    fourcc = cv2.VideoWriter_fourcc(*VIDEO_WRITERS[path.suffix.lower()])
    writer = cv2.VideoWriter(str(path), fourcc, max(fps / every, 1.0), (shape[1], shape[0]))
    if not writer.isOpened():
        raise UsageError(f"--annotate {path.suffix}: cannot open a video writer for this format")
    return writer
