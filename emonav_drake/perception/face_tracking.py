"""Temporal smoothing of facial emotions across video frames.

`FaceTracker` keeps face identities across frames by greedy box overlap (`box_iou`);
`EmotionSmoother` keeps an exponential moving average of the 7 FER-2013 class
probabilities per key (a tracked face or a pedestrian). Boxes are (x, y, w, h) in pixels
(origin top-left, x right, y down).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


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
