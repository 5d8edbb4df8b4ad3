"""Each tracked person's emotion, kept with their LiDAR track.

The camera classifies faces now and then; the LiDAR tracker keeps people's identities
all the time. `TrackEmotionMemory` joins the two: at each classification it assigns
every face to a track (by bearing, and by range when the face's size gives one), fuses
the face's emotion probabilities into that track's running average, and remembers when
it last saw the face. A reading counts by the size of its face (`reading_weight`): the
emotion CNN was trained on 48-px faces and reads nearly every face under ≈ 30 px as
neutral whatever its expression (and faces of 30-40 px often wrongly), so a reading of a
face up to 32 px tall counts nothing (it neither dilutes nor refreshes what the track
learned up close), one of 48 px or more fully, linearly between. A track's emotion is
the most probable one of its average while the last sighting is at most `decay_time`
old, else neutral; a track never seen is neutral (the paper's rule for a pedestrian whose
face is not visible, §IV-G). Memories of tracks the tracker has deleted are dropped.

Everything is a pure function of the inputs (no clock, no randomness): the same
sequence of calls gives the same emotions, in any process. Units: seconds, metres,
radians (bearings counter-clockwise positive, relative to the robot's heading).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.config_fields import setting
from emonav_drake.params import NEUTRAL
from emonav_drake.perception.face_assignment import assign_faces

NUM_EMOTIONS = 3  # HAPPY 0, NEUTRAL 1, NEGATIVE 2 (`params.EMOTION_NAMES`)


@dc.dataclass(frozen=True)
class TrackEmotionParams:
    """How faces are assigned to tracks and how long a track remembers its emotion."""

    decay_time: float = setting(
        10.0, "a track's emotion falls back to neutral this long after its last face", "s"
    )
    window: int = setting(
        5, "the running average weighs the last `window` sightings (a mean until then)"
    )
    bearing_tolerance: float = setting(
        math.radians(3.0), "added to a track's angular radius", "rad"
    )
    range_tolerance: float = setting(0.4, "|face range − track range| ≤ this × track range")
    pedestrian_radius: float = setting(0.3, "a track's radius for its angular size", "m")
    zero_weight_face_px: float = setting(32.0, "a face this tall or smaller adds nothing", "px")
    full_weight_face_px: float = setting(48.0, "a face this tall or taller counts fully", "px")

    def validate(self) -> TrackEmotionParams:
        """Raise ValueError naming the field if a value is out of range; returns self."""
        names = (
            "decay_time",
            "bearing_tolerance",
            "range_tolerance",
            "pedestrian_radius",
            "zero_weight_face_px",
            "full_weight_face_px",
        )
        for name in names:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"TrackEmotionParams.{name} must be a finite number, got {v!r}")
            if v < 0 or (v == 0 and name != "bearing_tolerance"):
                raise ValueError(f"TrackEmotionParams.{name} must be > 0, got {v!r}")
        w = self.window
        if isinstance(w, bool) or not isinstance(w, int) or w < 1:
            raise ValueError(f"TrackEmotionParams.window must be an int >= 1, got {w!r}")
        if not self.zero_weight_face_px < self.full_weight_face_px:
            raise ValueError(
                f"TrackEmotionParams.full_weight_face_px = {self.full_weight_face_px!r}: must "
                f"be > zero_weight_face_px ({self.zero_weight_face_px!r})"
            )
        return self

    def reading_weight(self, face_heights: np.ndarray) -> np.ndarray:
        """How much each face's reading counts (F,) in [0, 1], from its box height [px]:
        0 up to `zero_weight_face_px`, 1 from `full_weight_face_px`, linear between; NaN
        (size unknown) counts fully."""
        h = np.asarray(face_heights, dtype=float)
        lo, hi = self.zero_weight_face_px, self.full_weight_face_px
        return np.where(np.isfinite(h), np.clip((h - lo) / (hi - lo), 0.0, 1.0), 1.0)


@dc.dataclass
class TrackEmotion:
    """What a track remembers of its faces."""

    probabilities: np.ndarray  # (3,) fused happy / neutral / negative probabilities
    sightings: int  # faces fused (with a weight > 0)
    last_seen: float  # time of the last face fused [s]
    weight: float = 0.0  # the readings' weights in the running average, at most `window`


class TrackEmotionMemory:
    """Per-track emotions from faces assigned by bearing and range (module docstring)."""

    def __init__(self, params: TrackEmotionParams = TrackEmotionParams()) -> None:
        self.params = params.validate()
        self._memory: dict[int, TrackEmotion] = {}

    def track_ids(self) -> np.ndarray:
        """The ids of the tracks with a memory, ascending."""
        return np.array(sorted(self._memory), dtype=np.int64)

    def memory(self, track_id: int) -> TrackEmotion | None:
        """The track's memory (None: no face of it seen, or forgotten with its track)."""
        return self._memory.get(int(track_id))

    def update(
        self,
        t: float,
        track_ids: np.ndarray,
        track_bearings: np.ndarray,
        track_distances: np.ndarray,
        face_bearings: np.ndarray,
        face_probabilities: np.ndarray,
        face_distances: np.ndarray | None = None,
        face_heights: np.ndarray | None = None,
    ) -> np.ndarray:
        """Fold one classification in: the index of the track each face went to (−1: none).

        Args:
            t: the classification's time [s].
            track_ids: (T,) the tracker's ids of its tracks now (any other id's memory is
                dropped: its track was deleted).
            track_bearings: (T,) bearing of each track from the camera [rad], NaN where
                the camera cannot see it (behind, out of its field of view or range).
            track_distances: (T,) [m] from the camera.
            face_bearings: (F,) bearing of each face [rad], in the same frame.
            face_probabilities: (F, 3) each face's happy / neutral / negative
                probabilities (`face_emotion.three_way_probabilities`).
            face_distances: (F,) range of each face estimated from its size [m] (NaN or
                None: no range gate).
            face_heights: (F,) each face's box height [px]: its reading's weight
                (`TrackEmotionParams.reading_weight`; None: every reading counts fully).
                A face is assigned whatever its weight; one of weight 0 changes nothing.
        """
        ids = np.asarray(track_ids, dtype=np.int64).reshape(-1)
        bearings = np.asarray(track_bearings, dtype=float).reshape(-1)
        dist = np.asarray(track_distances, dtype=float).reshape(-1)
        fb = np.asarray(face_bearings, dtype=float).reshape(-1)
        probs = np.asarray(face_probabilities, dtype=float).reshape(-1, NUM_EMOTIONS)
        if not (len(ids) == len(bearings) == len(dist)):
            raise ValueError(
                f"{len(ids)} track ids, {len(bearings)} bearings, {len(dist)} distances"
            )
        if len(fb) != len(probs):
            raise ValueError(f"{len(fb)} face bearings, {len(probs)} face probabilities")
        alive = set(ids.tolist())
        self._memory = {k: v for k, v in self._memory.items() if k in alive}
        p = self.params
        gate = np.arctan2(p.pedestrian_radius, np.maximum(dist, 1e-6)) + p.bearing_tolerance
        allowed = None
        if face_distances is not None:
            fd = np.asarray(face_distances, dtype=float).reshape(-1)
            if len(fd) != len(fb):
                raise ValueError(f"{len(fb)} face bearings, {len(fd)} face distances")
            off = np.abs(fd[:, None] - dist[None, :])
            allowed = ~np.isfinite(fd)[:, None] | (off <= p.range_tolerance * dist[None, :])
        owner = assign_faces(fb, bearings, dist, gate, allowed)
        if face_heights is None:
            weights = np.ones(len(fb))
        else:
            heights = np.asarray(face_heights, dtype=float).reshape(-1)
            if len(heights) != len(fb):
                raise ValueError(f"{len(fb)} face bearings, {len(heights)} face heights")
            weights = p.reading_weight(heights)
        for f, k in enumerate(owner.tolist()):
            if k >= 0 and weights[f] > 0.0:
                self._fuse(int(ids[k]), probs[f], float(t), float(weights[f]))
        return owner

    def _fuse(self, track_id: int, probabilities: np.ndarray, t: float, weight: float) -> None:
        """A weighted running average over the last `window` readings' worth of weight: a
        reading of weight 1 into a full window counts 1/window, as an unweighted one."""
        old = self._memory.get(track_id)
        if old is None:
            self._memory[track_id] = TrackEmotion(probabilities.copy(), 1, t, weight)
            return
        total = min(old.weight + weight, float(self.params.window))  # weight <= 1 <= window
        fused = old.probabilities + (weight / total) * (probabilities - old.probabilities)
        self._memory[track_id] = TrackEmotion(fused, old.sightings + 1, t, total)

    def emotions(self, t: float, track_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(codes (T,) int64, confidences (T,)) of the tracks at time `t` [s]: a track
        with a face no older than `decay_time` takes its fused emotion and that emotion's
        probability; any other is NEUTRAL with confidence 0."""
        ids = np.asarray(track_ids, dtype=np.int64).reshape(-1)
        codes = np.full(len(ids), NEUTRAL, dtype=np.int64)
        confidence = np.zeros(len(ids))
        for i, k in enumerate(ids.tolist()):
            m = self._memory.get(k)
            if m is not None and t - m.last_seen <= self.params.decay_time + 1e-9:
                codes[i] = int(np.argmax(m.probabilities))
                confidence[i] = float(m.probabilities[codes[i]])
        return codes, confidence

    def state_dict(self) -> dict:
        """The memory as plain data (ints, floats, lists)."""
        return {
            str(k): {
                "probabilities": v.probabilities.tolist(),
                "sightings": v.sightings,
                "last_seen": v.last_seen,
                "weight": v.weight,
            }
            for k, v in sorted(self._memory.items())
        }

    def load_state_dict(self, state: dict) -> None:
        """Restore a memory written by `state_dict`."""
        self._memory = {
            int(k): TrackEmotion(
                np.asarray(v["probabilities"], dtype=float).reshape(NUM_EMOTIONS),
                int(v["sightings"]),
                float(v["last_seen"]),
                float(v.get("weight", min(int(v["sightings"]), self.params.window))),
            )
            for k, v in state.items()
        }
