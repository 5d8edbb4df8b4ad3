"""BlazeFace (MediaPipe's short-range face detector) on OpenCV's DNN, tiled for small faces.

The network (Bazarevsky et al., "BlazeFace: Sub-millisecond Neural Face Detection on
Mobile GPUs", 2019; MediaPipe's `face_detection_short_range.tflite`, Apache 2.0) reads a
128 × 128 RGB image scaled to [−1, 1] and regresses 896 SSD anchors (16 × 16 cells × 2 at
stride 8, 8 × 8 cells × 6 at stride 16, unit-size anchors at the cell centres): per
anchor a score logit and 16 numbers, the box centre offset, width and height and six
keypoints, in pixels of the 128-pixel input. Its weights come from the `mediapipe`
wheel (installed without its dependencies: only the model file is read; `BUILD.md`);
OpenCV's TFLite importer runs it, nothing else is needed.

It was trained on faces that fill much of a selfie (a face of 128 px at most, about 20 px
at least, in its 128-pixel input). A robot's camera sees people metres away: faces of
20-100 px in a 1280 × 720 frame. `BlazeFaceDetector` therefore runs the network on square
tiles of the frame (side `tile`, overlapping by `overlap`) at native scale, plus the
whole frame shrunk to 128 px for faces larger than a tile (one forward pass each: OpenCV's
TFLite import does not batch this network), maps the boxes back and merges them with
non-maximum suppression. `detect_regions` runs it on given regions only (e.g. around the
heads of tracked people): the cost of a frame is then that of a few tiles.
"""

from __future__ import annotations

import dataclasses as dc
import importlib.util
from pathlib import Path

import cv2
import numpy as np

from emonav_drake.config_fields import setting

INPUT = 128  # the network's input side [px]
MODEL_FILE = "modules/face_detection/face_detection_short_range.tflite"


def blazeface_model_path() -> Path:
    """The short-range BlazeFace model inside the installed `mediapipe` package (found
    without importing it). `FileNotFoundError` with the install line when it is absent."""
    spec = importlib.util.find_spec("mediapipe")
    roots = [] if spec is None else list(spec.submodule_search_locations or [])
    for root in roots:
        path = Path(root) / MODEL_FILE
        if path.is_file():
            return path
    raise FileNotFoundError(
        f"BlazeFace's weights ({MODEL_FILE}) come with the mediapipe wheel: "
        "pip install --no-deps mediapipe==0.10.14 (make does it)"
    )


def anchors() -> np.ndarray:
    """The (896, 2) anchor centres, in [0, 1] of the input: 2 per cell of the 16 × 16
    stride-8 grid, then 6 per cell of the 8 × 8 stride-16 grid, row by row."""
    out = []
    for stride, per_cell in ((8, 2), (16, 6)):
        n = INPUT // stride
        ys, xs = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        centres = np.stack([(xs.ravel() + 0.5) / n, (ys.ravel() + 0.5) / n], axis=1)
        out.append(np.repeat(centres, per_cell, axis=0))
    return np.concatenate(out)


@dc.dataclass(frozen=True)
class BlazeFaceParams:
    """The detector's settings."""

    score_threshold: float = setting(
        0.5, "a box's score must reach this (0.5: MediaPipe's default)"
    )
    nms_threshold: float = setting(0.3, "IoU above which the weaker of two boxes is dropped")
    tile: int = setting(128, "side of the square tiles the frame is cut into", "px")
    overlap: int = setting(40, "how much neighbouring tiles overlap", "px")
    min_face_size: int = setting(12, "boxes with a smaller side are dropped", "px")

    def __post_init__(self) -> None:
        if not 0.0 < self.score_threshold < 1.0:
            raise ValueError(f"score_threshold = {self.score_threshold}: must be in (0, 1)")
        if not 0.0 < self.nms_threshold < 1.0:
            raise ValueError(f"nms_threshold = {self.nms_threshold}: must be in (0, 1)")
        if self.tile < 32 or not 0 <= self.overlap < self.tile:
            raise ValueError(
                f"tile = {self.tile}, overlap = {self.overlap}: need tile >= 32 > overlap >= 0"
            )


class BlazeFaceDetector:
    """Faces in an RGB (or BGR) image: boxes (x, y, w, h) [px] and scores."""

    def __init__(self, params: BlazeFaceParams = BlazeFaceParams(), model: Path | None = None):
        self.params = params
        self._net = cv2.dnn.readNetFromTFLite(str(model or blazeface_model_path()))
        self._anchors = anchors()
        self._outputs = self._net.getUnconnectedOutLayersNames()

    def tiles(self, height: int, width: int) -> list[tuple[int, int, int]]:
        """(x0, y0, side) of every tile covering the frame, the whole frame last."""
        p = self.params
        step = p.tile - p.overlap

        def starts(n: int) -> list[int]:
            if n <= p.tile:
                return [0]
            s = list(range(0, n - p.tile, step))
            return [*s, n - p.tile]

        out = [(x, y, p.tile) for y in starts(height) for x in starts(width)]
        out.append((0, 0, max(height, width)))  # the whole frame, padded square
        return out

    def detect(self, image: np.ndarray, rgb: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(boxes (F, 4) int64 (x, y, w, h) [px], scores (F,)) of the faces in `image`
        (H, W, 3) uint8, RGB unless `rgb` is False (BGR): every tile of the frame."""
        return self.detect_regions(image, self.tiles(*image.shape[:2]), rgb)

    def detect_regions(
        self, image: np.ndarray, regions: list[tuple[int, int, int]], rgb: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """As `detect`, on the square regions (x0, y0, side) [px] only (parts outside the
        frame are black); each region is scaled to the network's 128 px."""
        img = np.ascontiguousarray(image[:, :, :3] if rgb else image[:, :, 2::-1])
        h, w = img.shape[:2]
        crops, frames = [], [(int(x), int(y), int(s)) for x, y, s in regions]
        for x0, y0, side in frames:
            crop = np.zeros((side, side, 3), np.uint8)
            xa, ya = max(x0, 0), max(y0, 0)
            xb, yb = min(x0 + side, w), min(y0 + side, h)
            if xb > xa and yb > ya:  # else the region lies outside the frame: all black
                crop[ya - y0 : yb - y0, xa - x0 : xb - x0] = img[ya:yb, xa:xb]
            crops.append(cv2.resize(crop, (INPUT, INPUT), interpolation=cv2.INTER_AREA))
        # one forward pass per tile: OpenCV's TFLite import does not batch this network
        scores = np.empty((len(crops), len(self._anchors)), np.float32)
        boxes = np.empty((len(crops), len(self._anchors), 16), np.float32)
        for k, crop in enumerate(crops):
            blob = cv2.dnn.blobFromImage(crop, 1.0 / 127.5, (INPUT, INPUT), (127.5,) * 3)
            self._net.setInput(blob)
            raw = self._net.forward(self._outputs)
            scores[k] = next(r for r in raw if r.shape[-1] == 1).reshape(-1)
            boxes[k] = next(r for r in raw if r.shape[-1] == 16).reshape(-1, 16)
        found_boxes, found_scores = [], []
        p = self.params
        for k, (x0, y0, side) in enumerate(frames):
            prob = 1.0 / (1.0 + np.exp(-np.clip(scores[k], -80.0, 80.0)))
            keep = np.flatnonzero(prob >= p.score_threshold)
            if keep.size == 0:
                continue
            reg = boxes[k, keep]
            centre = reg[:, :2] / INPUT + self._anchors[keep]
            size = reg[:, 2:4] / INPUT
            scale = side  # tile pixels per unit of the network's input
            xy = (centre - size / 2.0) * scale + [x0, y0]
            found_boxes.append(np.hstack([xy, size * scale]))
            found_scores.append(prob[keep])
        if not found_boxes:
            return np.zeros((0, 4), np.int64), np.zeros(0)
        b, s = np.vstack(found_boxes), np.concatenate(found_scores)
        big = np.minimum(b[:, 2], b[:, 3]) >= p.min_face_size
        b, s = b[big], s[big]
        keep = cv2.dnn.NMSBoxes(b.tolist(), s.tolist(), p.score_threshold, p.nms_threshold)
        keep = np.asarray(keep, dtype=np.int64).reshape(-1)
        keep = keep[np.argsort(-s[keep], kind="stable")]
        return np.round(b[keep]).astype(np.int64), s[keep]
