"""`emonav emotion PATH [--json out.json] [--annotate out.png]`: faces and emotions in a file.

PATH is an image (PNG, JPEG, BMP, …) or a video (.mp4, .avi, .mov, .mkv, .webm, …). For
each face: its box (x, y, w, h) [px], the 7 FER-2013 class probabilities, the top class
and the paper's 3-way label; a frame without a face is neutral (paper §IV-G).

--annotate writes the image with boxes and labels drawn. For a video, an image suffix
(.png, .jpg) writes the frame with the most faces (the first such frame), a video
suffix (.mp4, .avi) the whole annotated video.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from emonav_drake.params import EMOTION_NAMES

IMAGE_WRITE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")
VIDEO_WRITERS = {".mp4": "mp4v", ".avi": "MJPG"}


def add_emotion_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register the `emotion` sub-command on an argparse sub-parser collection."""
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
    p.set_defaults(func=cmd_emotion)
    return p


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)  # never a half-written result


def _write_image(path: Path, image: np.ndarray) -> None:
    import cv2

    suffix = path.suffix.lower()
    if suffix not in IMAGE_WRITE_SUFFIXES:
        raise ValueError(f"--annotate {path}: use one of {IMAGE_WRITE_SUFFIXES}")
    ok, data = cv2.imencode(suffix, image)
    if not ok:
        raise ValueError(f"--annotate {path}: could not encode the image")
    path.write_bytes(data.tobytes())


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
    from emonav_drake.perception.face_emotion import (
        DetectorParams,
        FaceEmotionClassifier,
        is_video_path,
    )

    if not args.path.is_file():
        raise FileNotFoundError(f"{args.path}: no such file")
    if args.annotate is not None and args.annotate.suffix.lower() not in (
        *IMAGE_WRITE_SUFFIXES,
        *VIDEO_WRITERS,
    ):
        raise ValueError(
            f"--annotate {args.annotate}: use an image suffix {IMAGE_WRITE_SUFFIXES} "
            f"or, for a video, {tuple(VIDEO_WRITERS)}"
        )
    classifier = FaceEmotionClassifier(DetectorParams(detection_scale=args.detection_scale))
    if is_video_path(args.path):
        return _run_video(args, classifier)
    return _run_image(args, classifier)


def _run_image(args: argparse.Namespace, classifier: Any) -> int:
    from emonav_drake.perception.face_emotion import annotate, frame_label, load_image

    image = load_image(args.path)
    t0 = time.perf_counter()
    faces = classifier.classify(image)
    ms = (time.perf_counter() - t0) * 1e3
    label = EMOTION_NAMES[frame_label(faces)]
    h, w = image.shape[:2]
    print(f"{args.path} ({w}x{h}): {len(faces)} face(s) in {ms:.0f} ms, emotion {label}")
    if faces:
        print("\n".join(_face_lines(faces)))
    else:
        print("  no face found: neutral (paper §IV-G)")
    if args.json:
        _write_json(
            args.json,
            {
                "path": str(args.path),
                "kind": "image",
                "width": w,
                "height": h,
                "faces": [f.to_json() for f in faces],
                "label": label,
            },
        )
    if args.annotate:
        if args.annotate.suffix.lower() in VIDEO_WRITERS:
            raise ValueError(f"--annotate {args.annotate}: an image input needs an image suffix")
        _write_image(args.annotate, annotate(image, faces))
        print(f"annotated image written to {args.annotate}")
    return 0


def _run_video(args: argparse.Namespace, classifier: Any) -> int:
    from emonav_drake.perception.face_emotion import (
        EmotionSmoother,
        FaceEmotion,
        FaceTracker,
        annotate,
        frame_label,
        video_frames,
    )

    if args.every < 1:
        raise ValueError(f"--every {args.every}: must be >= 1")
    if not 0.0 < args.smooth <= 1.0:
        raise ValueError(f"--smooth {args.smooth}: must be in (0, 1]")
    tracker, smoother = FaceTracker(), EmotionSmoother(args.smooth)
    frames_out: list[dict] = []
    best: tuple[int, np.ndarray | None] = (-1, None)
    writer = None
    suffix = args.annotate.suffix.lower() if args.annotate else ""
    t0 = time.perf_counter()
    try:
        for index, t, frame in video_frames(args.path, every=args.every):
            if args.max_frames is not None and len(frames_out) >= args.max_frames:
                break
            raw = classifier.classify(frame)
            ids = tracker.update([f.box for f in raw])
            faces = [
                FaceEmotion(f.box, smoother.update(k, f.probabilities))
                for f, k in zip(raw, ids, strict=True)
            ]
            smoother.forget(ids)
            label = EMOTION_NAMES[frame_label(faces)]
            frames_out.append(
                {
                    "index": index,
                    "time": None if np.isnan(t) else round(t, 4),
                    "faces": [{**f.to_json(), "track": k} for f, k in zip(faces, ids, strict=True)],
                    "label": label,
                }
            )
            if suffix in VIDEO_WRITERS:
                drawn = annotate(frame, faces)
                if writer is None:
                    writer = _open_writer(args.annotate, args.path, drawn.shape, args.every)
                writer.write(drawn)
            elif args.annotate and len(faces) > best[0]:
                best = (len(faces), annotate(frame, faces))
    finally:
        if writer is not None:
            writer.release()
    wall = time.perf_counter() - t0
    counts = Counter(f["label"] for f in frames_out)
    with_faces = sum(1 for f in frames_out if f["faces"])
    n = len(frames_out)
    print(
        f"{args.path}: {n} frame(s) classified in {wall:.2f} s "
        f"({n / max(wall, 1e-9):.1f} frames/s), {with_faces} with faces; labels "
        + ", ".join(f"{k} {counts.get(k, 0)}" for k in EMOTION_NAMES)
    )
    if args.json:
        _write_json(
            args.json,
            {
                "path": str(args.path),
                "kind": "video",
                "every": args.every,
                "smooth": args.smooth,
                "frames": frames_out,
                "summary": {
                    "frames": n,
                    "frames_with_faces": with_faces,
                    "labels": {k: counts.get(k, 0) for k in EMOTION_NAMES},
                },
            },
        )
    if args.annotate and suffix not in VIDEO_WRITERS:
        if best[1] is None:
            raise ValueError(f"{args.path}: no frame to annotate")
        _write_image(args.annotate, best[1])
    if args.annotate:
        print(f"annotation written to {args.annotate}")
    return 0


def _open_writer(path: Path, source: Path, shape: tuple, every: int) -> Any:
    import cv2

    cap = cv2.VideoCapture(str(source))
    fps = cap.get(cv2.CAP_PROP_FPS) or 10.0
    cap.release()
    fourcc = cv2.VideoWriter_fourcc(*VIDEO_WRITERS[path.suffix.lower()])
    writer = cv2.VideoWriter(str(path), fourcc, max(fps / every, 1.0), (shape[1], shape[0]))
    if not writer.isOpened():
        raise ValueError(f"--annotate {path}: cannot open a video writer for this format")
    return writer
