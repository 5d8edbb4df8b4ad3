"""Face textures for the simulated pedestrians: one PNG per emotion, with provenance.

    python scripts/make_face_textures.py [--out DIR] [--check]

Writes `happy.png`, `neutral.png`, `negative.png` (RGB, 256 × 320, portrait) and
`faces.json` into DIR (default `emonav_drake/data/faces`). `--check` builds everything
in memory, prints the report and compares it with the files already in DIR, writing
nothing (exit status 1 if they differ).

* happy: scikit-image's astronaut.png (Eileen Collins, smiling), cropped;
* neutral: matplotlib's grace_hopper.jpg, cropped;
* negative: the neutral crop, geometrically morphed (`cv2.remap` with smooth Gaussian
  displacement fields): mouth corners pulled down, inner brows pulled down and
  together. No photograph of a negative face ships with our wheels, so this one is
  made, not photographed; every morph setting ever tried is in `TRIED_MORPHS`, and
  all of them are run and recorded in faces.json under "tried".

Each crop is the real classifier's Haar box (`FaceEmotionClassifier.detect`) in the
source photograph expanded by fixed factors (`CROP_WIDTH`, `CROP_CENTRE_Y`), so it is
reproducible. The real classifier is then run on every texture and its answer recorded.
Nothing is random: the same run gives byte-identical files.

Image coordinates: pixels, origin at the top-left corner, x to the right, y down; a box
is (x, y, w, h).
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import hashlib
import importlib.metadata
import json
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from emonav_drake.perception.face_emotion import FaceEmotion, FaceEmotionClassifier
from emonav_drake.perception.image_io import to_gray
from emonav_drake.perception.mini_xception import CLASS_NAMES
from emonav_drake.perception.sample_photos import PHOTOS, sample_photo, sample_photo_path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUT = ROOT / "emonav_drake" / "data" / "faces"

# --- Texture size and crop ---------------------------------------------------------------
TEXTURE_WIDTH, TEXTURE_HEIGHT = 256, 320  # [px]; mapped onto a 0.20 m × 0.25 m quad
# The crop is centred horizontally on the Haar box; its width is CROP_WIDTH × the box
# width, its height follows from the texture's aspect ratio, and its vertical centre lies
# CROP_CENTRE_Y × the box height below the box's top edge (the Haar box runs from the
# forehead to just below the mouth, so the centre sits a little low to keep the chin).
CROP_WIDTH = 1.30
CROP_CENTRE_Y = 0.55

# --- Negative morph: where the features are ----------------------------------------------
# Fixed fractions of the Haar face box in the neutral source photograph (x from the box's
# left edge / box width, y from its top edge / box height), checked by eye on the crop.
MOUTH_CORNER_DX = 0.175  # each mouth corner's horizontal offset from the box centre
MOUTH_Y = 0.785  # mouth line
INNER_BROW_DX = 0.090  # each inner brow end's horizontal offset from the box centre
BROW_Y = 0.300  # inner brow ends


@dc.dataclass(frozen=True)
class MorphParams:
    """One setting of the negative morph; lengths are fractions of the face box width.

    Attributes:
        mouth_drop: mouth corners moved down by this much.
        mouth_radius: Gaussian radius (σ) of the mouth-corner displacement.
        brow_drop: inner brow ends moved down by this much.
        brow_pinch: inner brow ends moved toward the face's midline by this much.
        brow_radius: Gaussian radius (σ) of the brow displacement.
    """

    mouth_drop: float
    mouth_radius: float
    brow_drop: float
    brow_pinch: float
    brow_radius: float


# Every setting tried, in the order tried; the last one is shipped. Chosen by looking at
# the morphed image, never by searching for what the classifier likes.
TRIED_MORPHS: tuple[MorphParams, ...] = (
    MorphParams(
        mouth_drop=0.06, mouth_radius=0.07, brow_drop=0.05, brow_pinch=0.04, brow_radius=0.07
    ),
    # Second and last: the first reads only mildly unhappy to a human eye; this one was
    # chosen by eye for an unmistakable frown that still looks like a natural face, and
    # is shipped whatever the classifier says of it.
    MorphParams(
        mouth_drop=0.10, mouth_radius=0.08, brow_drop=0.08, brow_pinch=0.06, brow_radius=0.08
    ),
)
SHIPPED_MORPH = TRIED_MORPHS[-1]
INVERSE_ITERATIONS = 8  # fixed-point steps inverting the forward displacement field


# --- Sources and their licences ----------------------------------------------------------
@dc.dataclass(frozen=True)
class Source:
    """A photograph shipped inside an installed wheel and what its files say of its licence.

    Attributes:
        photo: name in `sample_photos.PHOTOS`.
        subject: who is shown.
        licence: the licence statement, or a sentence saying none was found.
        licence_file: file (relative to site-packages) holding the statement, or "".
        licence_quote: exact text checked to be present in `licence_file`, or "".
        note: what else the installed files say of the photograph's origin.
    """

    photo: str
    subject: str
    licence: str
    licence_file: str
    licence_quote: str
    note: str


SOURCES = {
    "astronaut": Source(
        photo="astronaut",
        subject="Eileen Collins, NASA astronaut, smiling",
        licence="public domain (no known copyright restrictions)",
        licence_file="skimage/data/_fetchers.py",
        licence_quote="No known copyright restrictions, released into the public domain.",
        note=(
            "Docstring of skimage.data.astronaut(): downloaded from the NASA Great Images "
            "database, https://flic.kr/p/r9qvLn."
        ),
    ),
    "grace_hopper": Source(
        photo="grace_hopper",
        subject="Grace Hopper, portrait, neutral expression",
        licence=(
            "public domain in the United States as a US Navy photograph (a work of the US "
            "federal government, 17 U.S.C. 105): the official portrait NH 96919-KN of the "
            "Naval History and Heritage Command; not stated in matplotlib's wheel"
        ),
        licence_file="",
        licence_quote="",
        note=(
            "The JPEG's comment segment reads 'File source: "
            "http://commons.wikimedia.org/wiki/File:Grace_Hopper.jpg'. "
            "mpl-data/sample_data/README.txt only says the files are sample data for "
            "matplotlib's examples; matplotlib's LICENSE (dist-info) covers the software "
            "and its listed third-party parts, not this photograph. Identified as US Navy "
            "photograph NH 96919-KN: Pillow's test image Tests/images/hopper.jpg was cut "
            "from http://www.history.navy.mil/photos/images/h96000/h96919k.jpg (Pillow pull "
            "request number 887) and is the same photograph (compared side by side)."
        ),
    ),
}
EMOTION_SOURCE = {"happy": "astronaut", "neutral": "grace_hopper", "negative": "grace_hopper"}


# --- Helpers ------------------------------------------------------------------------------
def sha256_bytes(data: bytes) -> str:
    """Hex SHA-256 of a byte string."""
    return hashlib.sha256(data).hexdigest()


def encode_png(bgr: np.ndarray) -> bytes:
    """PNG bytes (RGB, 8 bit, fixed compression) of a BGR uint8 image."""
    ok, buf = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    if not ok:
        raise RuntimeError("OpenCV could not encode the PNG")
    return buf.tobytes()


def largest_face(faces: list[FaceEmotion]) -> FaceEmotion | None:
    """The face with the largest box (the one a robot would label), None if no face."""
    return max(faces, key=lambda f: f.box[2] * f.box[3]) if faces else None


def face_box(classifier: FaceEmotionClassifier, bgr: np.ndarray) -> tuple[int, int, int, int]:
    """The largest Haar face box (x, y, w, h) of a photograph.

    Raises:
        RuntimeError: the classifier finds no face.
    """
    boxes = classifier.detect(to_gray(bgr))
    if len(boxes) == 0:
        raise RuntimeError("no face detected in the source photograph")
    x, y, w, h = max(boxes.tolist(), key=lambda b: b[2] * b[3])
    return int(x), int(y), int(w), int(h)


def crop_box(box: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    """The texture's crop (x, y, w, h) in source pixels for a Haar box (x, y, w, h)."""
    x, y, w, h = box
    cw = CROP_WIDTH * w
    ch = cw * TEXTURE_HEIGHT / TEXTURE_WIDTH
    cx, cy = x + 0.5 * w, y + CROP_CENTRE_Y * h
    x0, y0 = round(cx - 0.5 * cw), round(cy - 0.5 * ch)
    return x0, y0, round(cx + 0.5 * cw) - x0, round(cy + 0.5 * ch) - y0


def crop_texture(bgr: np.ndarray, crop: tuple[int, int, int, int]) -> np.ndarray:
    """The crop of a photograph resized to the texture size (area when shrinking, else cubic).

    Raises:
        ValueError: the crop leaves the photograph.
    """
    x, y, w, h = crop
    if x < 0 or y < 0 or x + w > bgr.shape[1] or y + h > bgr.shape[0]:
        raise ValueError(f"crop {crop} leaves the {bgr.shape[1]} × {bgr.shape[0]} photograph")
    interp = cv2.INTER_AREA if w >= TEXTURE_WIDTH else cv2.INTER_CUBIC
    return cv2.resize(
        bgr[y : y + h, x : x + w], (TEXTURE_WIDTH, TEXTURE_HEIGHT), interpolation=interp
    )


def box_in_texture(
    box: tuple[int, int, int, int], crop: tuple[int, int, int, int]
) -> tuple[float, float, float, float]:
    """A source box (x, y, w, h) in texture pixels, for a crop (x, y, w, h)."""
    sx, sy = TEXTURE_WIDTH / crop[2], TEXTURE_HEIGHT / crop[3]
    return (box[0] - crop[0]) * sx, (box[1] - crop[1]) * sy, box[2] * sx, box[3] * sy


def morph_points(
    box: tuple[float, float, float, float], p: MorphParams
) -> list[tuple[float, float, float, float, float]]:
    """Control points (x, y, dx, dy, σ) [px] of the morph for a face box (x, y, w, h) [px]."""
    x, y, w, h = box
    cx = x + 0.5 * w
    pts = []
    for side in (-1.0, 1.0):  # left, right
        pts.append(
            (
                cx + side * MOUTH_CORNER_DX * w,
                y + MOUTH_Y * h,
                0.0,
                p.mouth_drop * w,
                p.mouth_radius * w,
            )
        )
        pts.append(
            (
                cx + side * INNER_BROW_DX * w,
                y + BROW_Y * h,
                -side * p.brow_pinch * w,
                p.brow_drop * w,
                p.brow_radius * w,
            )
        )
    return pts


def morph(bgr: np.ndarray, box: tuple[float, float, float, float], p: MorphParams) -> np.ndarray:
    """The image warped so that each control point's content moves by its displacement.

    The forward warp is x' = x + D(x), D a sum of Gaussian bumps (one per control point,
    `morph_points`); `cv2.remap` needs its inverse, found by fixed-point iteration
    x = x' − D(x) (a contraction: every displacement is well below its radius).
    """
    hgt, wid = bgr.shape[:2]
    gx, gy = np.meshgrid(np.arange(wid, dtype=np.float64), np.arange(hgt, dtype=np.float64))
    pts = morph_points(box, p)

    def displacement(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dx, dy = np.zeros_like(x), np.zeros_like(y)
        for px, py, vx, vy, s in pts:
            g = np.exp(-((x - px) ** 2 + (y - py) ** 2) / (2.0 * s * s))
            dx += vx * g
            dy += vy * g
        return dx, dy

    sx, sy = gx.copy(), gy.copy()
    for _ in range(INVERSE_ITERATIONS):
        dx, dy = displacement(sx, sy)
        sx, sy = gx - dx, gy - dy
    return cv2.remap(
        bgr,
        sx.astype(np.float32),
        sy.astype(np.float32),
        cv2.INTER_CUBIC,
        borderMode=cv2.BORDER_REPLICATE,
    )


def classifier_result(classifier: FaceEmotionClassifier, bgr: np.ndarray) -> dict[str, Any]:
    """What the real classifier says of an image: its largest face's probabilities, top
    class and 3-way label, or `face_detected: false` and NEUTRAL (paper §IV-G) if none."""
    faces = classifier.classify(bgr)
    face = largest_face(faces)
    if face is None:
        return {
            "face_detected": False,
            "faces": 0,
            "box": None,
            "probabilities": None,
            "top_class": None,
            "label": "neutral",
        }
    return {
        "face_detected": True,
        "faces": len(faces),
        "box": [int(v) for v in face.box],
        "probabilities": {
            n: round(float(q), 6) for n, q in zip(CLASS_NAMES, face.probabilities, strict=True)
        },
        "top_class": face.top_class,
        "label": face.label_name,
    }


def _package_info(photo: str) -> dict[str, str]:
    package, rel = PHOTOS[photo]
    dist = {"skimage": "scikit-image", "matplotlib": "matplotlib"}[package]
    path = sample_photo_path(photo)
    return {
        "photo": photo,
        "distribution": dist,
        "version": importlib.metadata.version(dist),
        "package": package,
        "path": f"{package}/{rel}",
        "sha256": sha256_bytes(path.read_bytes()),
    }


def _licence_info(src: Source) -> dict[str, Any]:
    confirmed = False
    if src.licence_file:
        site = sample_photo_path(src.photo).parents[len(Path(PHOTOS[src.photo][1]).parts)]
        text = (site / src.licence_file).read_text(encoding="utf-8")
        confirmed = src.licence_quote in text
    return {
        "licence": src.licence,
        "confirmed_from_installed_files": confirmed,
        "file": src.licence_file or None,
        "quote": src.licence_quote or None,
        "note": src.note,
    }


@dc.dataclass(frozen=True)
class Crop:
    """A source photograph's face crop.

    Attributes:
        haar_box: the largest Haar face box (x, y, w, h) in the source [px].
        crop: the crop (x, y, w, h) in the source [px].
        texture: the crop resized to the texture size, BGR uint8.
        texture_box: the Haar box in texture pixels (x, y, w, h).
    """

    haar_box: tuple[int, int, int, int]
    crop: tuple[int, int, int, int]
    texture: np.ndarray
    texture_box: tuple[float, float, float, float]


def _crop_photo(classifier: FaceEmotionClassifier, photo: str) -> Crop:
    bgr = sample_photo(photo)
    box = face_box(classifier, bgr)
    crop = crop_box(box)
    return Crop(box, crop, crop_texture(bgr, crop), box_in_texture(box, crop))


# --- Build ---------------------------------------------------------------------------------
def build() -> tuple[dict[str, bytes], dict[str, Any]]:
    """The three PNGs (name → bytes) and the faces.json content, computed in memory."""
    classifier = FaceEmotionClassifier()
    pngs: dict[str, bytes] = {}
    entries: dict[str, Any] = {}
    crops = {photo: _crop_photo(classifier, photo) for photo in ("astronaut", "grace_hopper")}

    neutral = crops["grace_hopper"]
    tried = [
        {
            "morph": dc.asdict(p),
            "shipped": p == SHIPPED_MORPH,
            "classifier": classifier_result(
                classifier, morph(neutral.texture, neutral.texture_box, p)
            ),
        }
        for p in TRIED_MORPHS
    ]

    for emotion, photo in EMOTION_SOURCE.items():
        c = crops[photo]
        tex, box, crop = c.texture, c.haar_box, c.crop
        steps = [
            f"crop {list(crop)} (x, y, w, h) from the source: the Haar face box {list(box)} "
            f"expanded to {CROP_WIDTH} × its width, aspect {TEXTURE_WIDTH}:{TEXTURE_HEIGHT}, "
            f"vertical centre {CROP_CENTRE_Y} × its height below its top",
            f"resize to {TEXTURE_WIDTH} × {TEXTURE_HEIGHT} "
            f"({'area' if crop[2] >= TEXTURE_WIDTH else 'bicubic'} interpolation)",
        ]
        if emotion == "negative":
            tex = morph(tex, c.texture_box, SHIPPED_MORPH)
            steps.append(
                "geometric morph (cv2.remap, bicubic, Gaussian displacement fields): mouth "
                "corners down, inner brow ends down and toward the midline; parameters in "
                "'morph' (fractions of the face box width)"
            )
        png = encode_png(tex)
        name = f"{emotion}.png"
        pngs[name] = png
        entry: dict[str, Any] = {
            "file": name,
            "sha256": sha256_bytes(png),
            "size": [TEXTURE_WIDTH, TEXTURE_HEIGHT],
            "source": {**_package_info(photo), "subject": SOURCES[photo].subject},
            "licence": _licence_info(SOURCES[photo]),
            "haar_box_in_source": list(box),
            "crop_box": list(crop),
            "transformation": steps,
            "classifier": classifier_result(classifier, tex),
        }
        if emotion == "negative":
            entry["morph"] = dc.asdict(SHIPPED_MORPH)
            features = (
                "left mouth corner",
                "left inner brow",
                "right mouth corner",
                "right inner brow",
            )
            entry["morph_control_points_px"] = [
                {
                    "feature": f,
                    **{
                        k: round(v, 3)
                        for k, v in zip(("x", "y", "dx", "dy", "sigma"), pt, strict=True)
                    },
                }
                for f, pt in zip(features, morph_points(c.texture_box, SHIPPED_MORPH), strict=True)
            ]
            entry["made_not_photographed"] = True
        entries[emotion] = entry

    meta = {
        "generator": "scripts/make_face_textures.py",
        "texture_size": [TEXTURE_WIDTH, TEXTURE_HEIGHT],
        "crop": {"CROP_WIDTH": CROP_WIDTH, "CROP_CENTRE_Y": CROP_CENTRE_Y},
        "feature_fractions": {
            "MOUTH_CORNER_DX": MOUTH_CORNER_DX,
            "MOUTH_Y": MOUTH_Y,
            "INNER_BROW_DX": INNER_BROW_DX,
            "BROW_Y": BROW_Y,
        },
        "classifier": {
            "module": "emonav_drake.perception.face_emotion.FaceEmotionClassifier",
            "params": dc.asdict(classifier.params),
            "classes": list(CLASS_NAMES),
        },
        "versions": {
            d: importlib.metadata.version(d) for d in ("opencv-python-headless", "numpy", "torch")
        },
        "textures": entries,
        "tried": tried,
    }
    return pngs, meta


def dump_json(meta: dict[str, Any]) -> bytes:
    """faces.json bytes: indented UTF-8 JSON in insertion order, ending in a newline."""
    return (json.dumps(meta, indent=2, ensure_ascii=False) + "\n").encode("utf-8")


def report(meta: dict[str, Any]) -> str:
    """One line per texture and per tried morph: top class, 3-way label, top probability."""

    def line(name: str, r: dict[str, Any]) -> str:
        if not r["face_detected"]:
            return f"{name:>10}: no face detected -> {r['label']}"
        p = r["probabilities"]
        probs = " ".join(f"{k} {v:.4f}" for k, v in p.items())
        return f"{name:>10}: {r['top_class']:>8} -> {r['label']:<8} [{probs}]"

    lines = [line(e, t["classifier"]) for e, t in meta["textures"].items()]
    for i, t in enumerate(meta["tried"]):
        lines.append(line(f"tried {i}", t["classifier"]) + f"  {t['morph']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output directory")
    ap.add_argument("--check", action="store_true", help="report and compare, write nothing")
    args = ap.parse_args(argv)
    pngs, meta = build()
    files = {**pngs, "faces.json": dump_json(meta)}
    print(report(meta))
    if args.check:
        stale = [
            n
            for n, b in files.items()
            if not (args.out / n).is_file() or (args.out / n).read_bytes() != b
        ]
        print(f"{args.out}: " + (f"differs: {', '.join(stale)}" if stale else "up to date"))
        return 1 if stale else 0
    args.out.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        (args.out / name).write_bytes(data)
    print(f"wrote {', '.join(files)} to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
