"""Estimated emotions through a confusion matrix: misclassification for the robustness study.

The paper (§IV-F) tests its policy with emotions that change over time because a real
facial-emotion classifier fluctuates and errs. This module models the classifier's
errors directly: the estimate of a pedestrian whose true emotion is i is j with
probability C[i, j] (a row-stochastic 3 × 3 confusion matrix over HAPPY 0, NEUTRAL 1,
NEGATIVE 2).

Draws are deterministic: draw k of a run seeded `seed` uses the generator
`np.random.default_rng([seed, k])`, one uniform number per pedestrian, mapped through
the cumulative row of its true emotion. So the estimate is a pure function of
(seed, k, true emotions) — a Drake output can compute it from the time (k = ⌊t / period⌋)
with no state, a Monte Carlo run repeats exactly, and, within one draw period, a
pedestrian whose true emotion changes gets the estimate of its new row at once.

numpy only (no drake, no torch).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc

import numpy as np

from emonav_drake.config_fields import SEED_RANGE, setting
from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EMOTION_NAMES, ConfigError
from emonav_drake.perception.track_emotions import TrackEmotionParams
from emonav_drake.typed_yaml import validate_fields

NUM_EMOTIONS = len(EMOTION_NAMES)
ESTIMATE_MODES = ("ground_truth", "confusion", "classifier", "camera", "camera_tracks")
CAMERA_MODES = ("camera", "camera_tracks")  # the modes that render faces for the head camera
FACE_DETECTORS = ("haar", "blazeface")


def validate_confusion(matrix: object, name: str = "confusion") -> np.ndarray:
    """The matrix as a float (3, 3) array; `ConfigError` unless rows are distributions."""
    try:
        c = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError) as e:
        raise ConfigError(f"{name}: not a numeric 3 × 3 matrix ({e})") from e
    if c.shape != (NUM_EMOTIONS, NUM_EMOTIONS):
        raise ConfigError(f"{name}: shape {c.shape}, expected (3, 3) (rows: true emotion)")
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise ConfigError(f"{name}: entries must be finite and >= 0, got {c.tolist()}")
    sums = c.sum(axis=1)
    if np.any(np.abs(sums - 1.0) > 1e-6):
        raise ConfigError(f"{name}: every row must sum to 1, row sums are {sums.tolist()}")
    return c


def confusion_from_accuracy(accuracy: float) -> np.ndarray:
    """A 3 × 3 confusion matrix with `accuracy` on the diagonal, errors spread evenly."""
    if not 0.0 <= accuracy <= 1.0:
        raise ConfigError(f"accuracy = {accuracy}: must be in [0, 1]")
    off = (1.0 - accuracy) / (NUM_EMOTIONS - 1)
    return np.full((NUM_EMOTIONS, NUM_EMOTIONS), off) + np.eye(NUM_EMOTIONS) * (accuracy - off)


class ConfusionEmotionModel:
    """Seeded misclassification of true emotion codes through a confusion matrix.

    Args:
        confusion: row-stochastic (3, 3); C[i, j] = P(estimate j | true i).
        seed: the run's seed.
    """

    def __init__(self, confusion: object, seed: int = 0) -> None:
        self.confusion = validate_confusion(confusion)
        self.seed = int(seed)
        if self.seed < 0:
            raise ConfigError(f"seed = {seed}: must be >= 0")
        self._cdf = np.cumsum(self.confusion, axis=1)
        self._cdf[:, -1] = 1.0  # guard against round-off: every u < 1 lands in a column

    def estimate(self, true_emotions: np.ndarray, draw: int) -> np.ndarray:
        """Estimated codes (P,) int64 for true codes (P,), draw number `draw` (>= 0)."""
        truth = np.asarray(true_emotions, dtype=np.int64).reshape(-1)
        if truth.size and (truth.min() < 0 or truth.max() >= NUM_EMOTIONS):
            raise ValueError(f"true emotions {truth.tolist()}: codes must be 0, 1 or 2")
        u = np.random.default_rng([self.seed, int(draw)]).random(truth.size)
        rows = self._cdf[truth]
        return (u[:, None] >= rows).sum(axis=1).astype(np.int64)


def empirical_confusion(true_emotions: np.ndarray, estimated: np.ndarray) -> np.ndarray:
    """Row-normalised confusion counts (3, 3) of estimates against truths (NaN rows if unseen)."""
    t = np.asarray(true_emotions, dtype=np.int64).reshape(-1)
    e = np.asarray(estimated, dtype=np.int64).reshape(-1)
    counts = np.zeros((NUM_EMOTIONS, NUM_EMOTIONS))
    np.add.at(counts, (t, e), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return counts / counts.sum(axis=1, keepdims=True)


def replace_emotions(
    snapshot: CrowdSnapshot, emotions: np.ndarray, emotion_distances: np.ndarray
) -> CrowdSnapshot:
    """The snapshot with `emotions` in force and the matching discomfort distances.

    Args:
        snapshot: the crowd as simulated (ground-truth emotions).
        emotions: (P,) estimated codes, one per pedestrian of the snapshot.
        emotion_distances: discomfort distance per code (HAPPY, NEUTRAL, NEGATIVE) [m].
    """
    e = np.asarray(emotions, dtype=np.int64).reshape(-1)
    if e.shape != (len(snapshot.positions),):
        raise ValueError(
            f"{e.size} estimated emotions for {len(snapshot.positions)} pedestrians in the crowd"
        )
    if e.size and (e.min() < 0 or e.max() >= NUM_EMOTIONS):
        raise ValueError(f"estimated emotions {e.tolist()}: codes must be 0, 1 or 2")
    return dc.replace(
        snapshot, emotions=e, discomfort=np.asarray(emotion_distances, dtype=float)[e]
    )


@dc.dataclass
class HeadCameraParams:
    """The robot's head camera and the face pipeline on its images (mode "camera").

    The default is the paper's robot's camera, a ZED stereo camera, in its HD720 mode
    (one lens; ZED 2 HD720: 1280 × 720 px, 70° vertical field of view — the ZED 2 / 2i
    datasheet's 110° H × 70° V; as the rectified pinhole image Drake renders, 70° vertical
    at 16:9 is ≈ 102° horizontal, f ≈ 514 px). `vga()` is the earlier 640 × 480 camera
    with a 45° vertical field of view (≈ 58° horizontal, f ≈ 579 px); in YAML:
    `camera: {width: 640, height: 480, fov_y_deg: 45}`.

    `min_face_size` 24 is the Haar cascade's own window, the smallest face it can find at
    all: a face facing the camera is found up to ≈ 3.5 m with the ZED 2 HD720 intrinsics,
    ≈ 4 m at 640 × 480 / 45° (the wider field spreads fewer pixels over a face).
    """

    width: int = setting(1280, "image width", "px", (16, 4096))
    height: int = setting(720, "image height", "px", (16, 4096))
    fov_y_deg: float = setting(70.0, "vertical field of view", "deg", (1.0, 170.0))
    lip_height: float = setting(
        1.45, "camera height above the ground on the LIP robot", "m", (0.1, 3.0)
    )
    digit_offset: list[float] = setting(
        [0.05, 0.0, 0.45],
        "camera origin in Digit's torso frame (x forward, y left, z up); the optical axis "
        "is the torso's x axis",
        "m",
        (3, -2.0, 2.0),
    )
    near: float = setting(0.1, "rendering clipping range: near", "m", (0.001, 100.0))
    far: float = setting(15.0, "rendering clipping range: far", "m", (0.01, 1000.0))
    min_face_size: int = setting(24, "smallest face the Haar cascade accepts", "px", (8, 4096))
    max_range: float = setting(6.0, "pedestrians farther than this get no face", "m", (0.1, 100.0))
    face_detector: str = setting(
        "haar",
        "\"haar\" (OpenCV's frontal-face cascade on the whole image: the paper's) or "
        "\"blazeface\" (MediaPipe's BlazeFace on a region at each pedestrian's head: faces to "
        "6 m, perception/blazeface.py)",
    )

    @classmethod
    def vga(cls, **overrides: object) -> "HeadCameraParams":
        """The earlier head camera: 640 × 480 px, 45° vertical field of view (≈ 58°
        horizontal); the other fields as the default, or `overrides`."""
        return cls(**{"width": 640, "height": 480, "fov_y_deg": 45.0, **overrides})

    def validate(self) -> "HeadCameraParams":
        """Raise `ConfigError` naming the field if a value is invalid: the fields' ranges,
        near < far, a face fits the image."""
        pre = "emotion_estimate.camera"
        validate_fields(self, f"{pre}.")
        if not self.near < self.far:
            raise ConfigError(f"{pre}: near {self.near!r}, far {self.far!r}: 0 < near < far")
        if self.face_detector not in FACE_DETECTORS:
            raise ConfigError(
                f"{pre}.face_detector = {self.face_detector!r}: one of {FACE_DETECTORS}"
            )
        if not self.min_face_size <= min(self.width, self.height):
            raise ConfigError(
                f"{pre}.min_face_size = {self.min_face_size}: at most the image's "
                f"{min(self.width, self.height)} px"
            )
        return self


# `EmotionEstimateParams.tracked_faces` classifies at the planner's 2.5 Hz: BlazeFace on a
# region per tracked person and the CNN on each face cost a few ms per person
# (docs/perception.md), and a face seen more often is more often seen close, where the CNN
# reads it right (the paper's 0.5 Hz was the rate of its cascade on whole frames)
CAMERA_TRACKS_PERIOD = 0.4  # [s]


@dc.dataclass
class EmotionEstimateParams:
    """Where the emotions that shape the discomfort zones come from (YAML-loadable).

    The confusion matrix's rows must also sum to 1 (`validate_confusion`).
    """

    mode: str = setting(
        "ground_truth",
        '"ground_truth" (simulation default), "confusion" (truth through `confusion`, '
        'seeded), "classifier" (the estimates of a face classifier the caller wires in) or '
        "\"camera\" (the robot's head camera renders the crowd's faces and the face classifier "
        'reads them: `diagrams/camera_perception.py`) or "camera_tracks" (the same faces, '
        "each kept with the LiDAR track it is assigned to: `systems/track_emotion_fusion.py`; "
        "needs the LiDAR state source)",
    )
    confusion: list[list[float]] = setting(
        np.eye(NUM_EMOTIONS).tolist(),
        "confusion matrix: rows = true happy / neutral / negative, columns = estimate",
        "",
        (3, 0.0, 1.0),
    )
    seed: int = setting(0, "seed of the confusion draws", "", SEED_RANGE)
    period: float = setting(
        2.0,
        "a new confusion draw, or a new camera classification, every `period` (0.5 Hz, the "
        "paper's emotion rate)",
        "s",
        (0.01, 100.0),
    )
    camera: HeadCameraParams = setting(
        doc='the head camera of mode "camera"', factory=HeadCameraParams
    )
    track_decay: float = setting(
        10.0,
        'mode "camera_tracks": a track\'s emotion falls back to neutral this long after its '
        "last face",
        "s",
        (0.1, 1000.0),
    )

    track_zero_weight_px: float = setting(
        32.0,
        'mode "camera_tracks": a face this tall or smaller adds nothing to its track\'s '
        "emotion (the CNN reads small faces as neutral whatever they show)",
        "px",
        (1.0, 1000.0),
    )
    track_full_weight_px: float = setting(
        48.0,
        'mode "camera_tracks": a face this tall or taller counts fully (linear between)',
        "px",
        (1.0, 1000.0),
    )

    @classmethod
    def tracked_faces(cls) -> "EmotionEstimateParams":
        """What `--emotion-source camera_tracks` (and `--deployable`) runs: emotions kept per
        LiDAR track, BlazeFace at each tracked head, a classification every
        `CAMERA_TRACKS_PERIOD` (validated)."""
        params = cls(mode="camera_tracks", period=CAMERA_TRACKS_PERIOD)
        params.camera.face_detector = "blazeface"
        return params.validate()

    def track_params(self, pedestrian_radius: float) -> TrackEmotionParams:
        """The per-track memory's parameters of mode "camera_tracks"."""
        return TrackEmotionParams(
            decay_time=self.track_decay,
            pedestrian_radius=pedestrian_radius,
            zero_weight_face_px=self.track_zero_weight_px,
            full_weight_face_px=self.track_full_weight_px,
        )

    def validate(self) -> "EmotionEstimateParams":
        """Raise `ConfigError` naming the field if a value is invalid (the fields' ranges,
        the camera's included; seeds in [0, 2**64 - 1])."""
        if self.mode not in ESTIMATE_MODES:
            raise ConfigError(f"emotion_estimate.mode = {self.mode!r}: one of {ESTIMATE_MODES}")
        validate_confusion(self.confusion, "emotion_estimate.confusion")
        validate_fields(self, "emotion_estimate.")
        if not self.track_zero_weight_px < self.track_full_weight_px:
            raise ConfigError(
                f"emotion_estimate.track_full_weight_px = {self.track_full_weight_px!r}: must "
                f"be > track_zero_weight_px ({self.track_zero_weight_px!r})"
            )
        self.camera.validate()
        return self
