"""Multi-target tracking of the discs found in LiDAR scans: the crowd a robot can estimate.

`CrowdTracker.update(t, detections)` takes the discs of one scan
(`sensing.lidar_objects.detect_objects`) and keeps a list of tracks, each a constant-velocity
Kalman filter on ``x = [x, y, vx, vy]`` (world frame, m and m/s):

* **Predict** every track to ``t`` (``dt = t − t_prev``): ``x ← F x``, ``P ← F P Fᵀ + Q``
  with ``F = [[I, dt·I], [0, I]]`` and white-noise acceleration of std ``accel_std``:
  ``Q = accel_std² · G Gᵀ``, ``G = [dt²/2·I; dt·I]``.
* **Gate** each (track, detection) pair by the squared Mahalanobis distance
  ``d² = νᵀ S⁻¹ ν`` of the innovation ``ν = z − H x`` (``H = [I 0]``,
  ``S = H P Hᵀ + measurement_std²·I``); pairs with ``d² > gate`` (chi-square, 2 degrees
  of freedom) are impossible.
* **Assign** with `scipy.optimize.linear_sum_assignment` on the cost ``d² + ln det S``
  (the negative log-likelihood up to a constant: a track that has coasted, with a wide S,
  does not steal the detection of a track that is sure of it); impossible pairs cost
  ``_IMPOSSIBLE``, so the assignment first matches as many gated pairs as it can, and the
  impossible pairs it is forced into are dropped.
* **Update** matched tracks (Joseph form), their hit count, time last seen and radius
  (running mean of the fitted radii); a track with ``confirm_hits`` hits is confirmed.
* **Birth**: every unmatched detection starts a tentative track at its centre with zero
  velocity (std ``initial_speed_std`` per axis).
* **Delete**: a tentative track at its first miss; a confirmed one once it has not been
  seen for more than ``max_coast`` seconds. Until then an unmatched confirmed track
  coasts on its prediction (a pedestrian hidden behind another, or behind a disc).
* **Fixed** (``sticky_fixed``, the leg detector's tracker): a slow track (or a new one)
  matched to a fixed detection (a well-fitted disc or a wall piece) is a static object:
  its velocity is held at zero and it is not predicted (no process noise), so it neither
  drifts while it is unseen nor widens its gate until it takes another object's
  detection; it stays so while matched. A walking person's track that gets one disc-like
  detection is not held (it was not slow).
* **Still**: a track whose estimated speed stays below ``still_speed`` for
  ``still_duration`` seconds is a static obstacle (until it moves again); a track whose
  last detection was a piece of a wall (`Detections.walls`) is one at once.

`snapshot` turns the confirmed tracks into the `CrowdSnapshot` the planners read. The
tracker is a pure function of its inputs (no randomness, no clock); `state_dict` /
`load_state_dict` save and restore it as plain data.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from scipy.optimize import linear_sum_assignment

from emonav_drake.config_fields import setting
from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EmoNavConfig, PerceptionParams
from emonav_drake.sensing.lidar_objects import Detections

# Cost of a pair outside the gate: far above any gated cost (d² ≤ gate, |ln det S| ≲ 50),
# so the assignment never trades a gated pair for an impossible one.
_IMPOSSIBLE = 1e9


@dc.dataclass(frozen=True)
class TrackerParams:
    """Parameters of `CrowdTracker` (SI units)."""

    accel_std: float = setting(2.0, "process noise: white acceleration std", "m/s²")
    measurement_std: float = setting(0.03, "std of a detected centre, per axis", "m")
    initial_speed_std: float = setting(1.5, "velocity std of a new track, per axis", "m/s")
    gate: float = setting(13.8, "chi-square gate on d², 2 dof (13.8 ≈ 99.9 %)")
    confirm_hits: int = setting(
        3, "hits (consecutive: a tentative track dies at a miss) to confirm"
    )
    max_coast: float = setting(1.5, "a confirmed track unseen for longer is deleted", "s")
    still_speed: float = setting(0.1, "a track slower than this is still", "m/s")
    still_duration: float = setting(
        PerceptionParams().still_duration,
        "still for this long: a static obstacle (the configuration's "
        "`perception.still_duration`, described there; `tracker_params` passes it)",
        "s",
    )
    emotion_gate: float = setting(0.5, "an emotion report farther from a track is not its own", "m")
    sticky_fixed: bool = setting(
        False,
        "a track once matched to a fixed detection (`Detections.walls`) stays fixed while it "
        "is slower than `still_speed` (the leg detector's discs: a fit that fails at one scan "
        "does not make the object a pedestrian again); off: fixed only while its last "
        "detection is",
    )

    def validate(self) -> TrackerParams:
        """Raise ValueError naming the field if a value is out of range; returns self."""
        for name in (
            "accel_std",
            "measurement_std",
            "initial_speed_std",
            "gate",
            "max_coast",
            "still_speed",
            "still_duration",
            "emotion_gate",
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ValueError(f"TrackerParams.{name} must be a number, got {v!r}")
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"TrackerParams.{name} must be finite and > 0, got {v!r}")
        v = self.confirm_hits
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(f"TrackerParams.confirm_hits must be an int >= 1, got {v!r}")
        return self


@dc.dataclass
class Track:
    """One tracked disc."""

    id: int  # sequential from 0 after each reset
    x: np.ndarray  # (4,) [x, y, vx, vy] at the tracker's time [m, m/s]
    P: np.ndarray  # (4, 4) covariance of x
    hits: int  # detections matched (birth included)
    misses: int  # consecutive scans without a match
    last_seen: float  # time of the last match [s]
    confirmed: bool  # has had `confirm_hits` hits
    radius: float  # running mean of the fitted radii [m]
    still_since: float | None  # since when the speed has stayed below `still_speed` [s]
    wall: bool = False  # its last detection was a piece of a wall: static at once

    @property
    def position(self) -> np.ndarray:
        """(2,) estimated centre [m]."""
        return self.x[:2].copy()

    @property
    def velocity(self) -> np.ndarray:
        """(2,) estimated velocity [m/s]."""
        return self.x[2:].copy()

    def to_plain(self) -> dict:
        """The track as plain data (lists, floats, ints)."""
        return {
            "id": int(self.id),
            "x": [float(v) for v in self.x],
            "P": [[float(v) for v in row] for row in self.P],
            "hits": int(self.hits),
            "misses": int(self.misses),
            "last_seen": float(self.last_seen),
            "confirmed": bool(self.confirmed),
            "radius": float(self.radius),
            "still_since": None if self.still_since is None else float(self.still_since),
            "wall": bool(self.wall),
        }

    @classmethod
    def from_plain(cls, d: dict) -> Track:
        """Inverse of `to_plain`; ValueError on a missing field or a wrong shape."""
        try:
            x = np.array(d["x"], dtype=np.float64)
            p = np.array(d["P"], dtype=np.float64)
            still = d["still_since"]
            track = cls(
                id=int(d["id"]),
                x=x,
                P=p,
                hits=int(d["hits"]),
                misses=int(d["misses"]),
                last_seen=float(d["last_seen"]),
                confirmed=bool(d["confirmed"]),
                radius=float(d["radius"]),
                still_since=None if still is None else float(still),
                wall=bool(d.get("wall", False)),
            )
        except (KeyError, TypeError) as e:
            raise ValueError(f"track state is incomplete or mistyped: {e}") from None
        if x.shape != (4,) or p.shape != (4, 4):
            raise ValueError(f"track {track.id}: x has shape {x.shape}, P {p.shape}")
        if not (np.isfinite(x).all() and np.isfinite(p).all()):
            raise ValueError(f"track {track.id}: x and P must be finite")
        return track


class CrowdTracker:
    """Constant-velocity Kalman tracks of the discs seen in LiDAR scans (module docstring).

    Args:
        params: noise, gate and track management (`TrackerParams`).
    """

    def __init__(self, params: TrackerParams = TrackerParams()) -> None:
        self.params = params.validate()
        self.reset()

    def reset(self) -> None:
        """Forget every track; ids start again from 0."""
        self._tracks: list[Track] = []
        self._next_id = 0
        self._time: float | None = None

    @property
    def time(self) -> float | None:
        """Time of the last `update` [s] (None before the first)."""
        return self._time

    def all_tracks(self) -> list[Track]:
        """Every track, tentative ones included, by id."""
        return list(self._tracks)

    def tracks(self) -> list[Track]:
        """The confirmed tracks, by id."""
        return [tr for tr in self._tracks if tr.confirmed]

    def is_static(self, track: Track) -> bool:
        """Whether `track` is a piece of a wall, or has been still for `still_duration` by
        the last update."""
        return track.wall or (
            track.still_since is not None
            and self._time is not None
            and self._time - track.still_since >= self.params.still_duration - 1e-9
        )

    # -- update --------------------------------------------------------------------------

    def update(self, t: float, detections: Detections) -> None:
        """Advance every track to time `t` [s] and fold in the discs of one scan.

        `t` must not be earlier than the previous update's time. ValueError on a bad
        time or malformed detections.
        """
        t = float(t)
        if not math.isfinite(t):
            raise ValueError(f"update time must be finite, got {t}")
        if self._time is not None and t < self._time:
            raise ValueError(f"update time {t} is earlier than the last one ({self._time})")
        z, radii = _detection_arrays(detections)
        walls = np.asarray(detections.walls, dtype=bool).reshape(-1)
        dt = 0.0 if self._time is None else t - self._time
        self._time = t
        p = self.params
        tracks = self._tracks
        if tracks:
            x = np.stack([tr.x for tr in tracks])
            cov = np.stack([tr.P for tr in tracks])
            held = np.array([self._held(tr) and _is_held(tr) for tr in tracks], dtype=bool)
            x0, cov0 = x[held], cov[held]
            x, cov = _predict(x, cov, dt, p.accel_std)
            x[held], cov[held] = x0, cov0  # a fixed object does not move
        else:
            x, cov = np.zeros((0, 4)), np.zeros((0, 4, 4))

        rows, cols = self._associate(x, cov, z)
        was_slow = np.hypot(x[:, 2], x[:, 3]) < p.still_speed  # before this scan's update
        if rows.size:
            x[rows], cov[rows] = _correct(x[rows], cov[rows], z[cols], p.measurement_std)
        matched = np.zeros(len(tracks), dtype=bool)
        matched[rows] = True
        for i, tr in enumerate(tracks):
            tr.x, tr.P = x[i].copy(), cov[i].copy()
        for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
            tr = tracks[i]
            tr.hits += 1
            tr.misses = 0
            tr.last_seen = t
            tr.radius += (float(radii[j]) - tr.radius) / tr.hits
            slow = math.hypot(tr.x[2], tr.x[3]) < p.still_speed
            tr.wall = bool(walls[j]) or (p.sticky_fixed and tr.wall and slow)
            tr.confirmed = tr.confirmed or tr.hits >= p.confirm_hits
            if self._held(tr) and was_slow[i]:  # a walking person's one disc-like scan: no
                _hold_still(tr, p.still_speed)

        survivors: list[Track] = []
        for i, tr in enumerate(tracks):
            if not matched[i]:
                tr.misses += 1
                if not tr.confirmed or t - tr.last_seen > p.max_coast + 1e-9:
                    continue
            survivors.append(tr)
        born = np.ones(len(z), dtype=bool)
        born[cols] = False
        for j in np.flatnonzero(born).tolist():
            survivors.append(self._new_track(t, z[j], float(radii[j]), bool(walls[j])))
        for tr in survivors:
            speed = math.hypot(tr.x[2], tr.x[3])
            if speed >= p.still_speed:
                tr.still_since = None
            elif tr.still_since is None:
                tr.still_since = t
        self._tracks = survivors

    def _held(self, track: Track) -> bool:
        """With `sticky_fixed`, a fixed track is a static object: zero velocity, no
        process noise (it neither drifts while unseen nor widens its gate)."""
        return self.params.sticky_fixed and track.wall

    def _associate(
        self, x: np.ndarray, cov: np.ndarray, z: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Gated minimum-cost assignment: (track rows, detection columns) of the pairs."""
        if len(x) == 0 or len(z) == 0:
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        s = cov[:, :2, :2] + self.params.measurement_std**2 * np.eye(2)
        det = s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]
        nu = z[None, :, :] - x[:, None, :2]  # (n, m, 2)
        # νᵀ S⁻¹ ν with the closed-form inverse of each 2 × 2 S.
        d2 = (
            s[:, None, 1, 1] * nu[..., 0] ** 2
            - (s[:, None, 0, 1] + s[:, None, 1, 0]) * nu[..., 0] * nu[..., 1]
            + s[:, None, 0, 0] * nu[..., 1] ** 2
        ) / det[:, None]
        gated = d2 <= self.params.gate
        if not gated.any():
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        cost = np.where(gated, d2 + np.log(det)[:, None], _IMPOSSIBLE)
        rows, cols = linear_sum_assignment(cost)
        keep = gated[rows, cols]
        return rows[keep].astype(np.intp), cols[keep].astype(np.intp)

    def _new_track(self, t: float, z: np.ndarray, radius: float, wall: bool = False) -> Track:
        p = self.params
        tr = Track(
            id=self._next_id,
            x=np.array([z[0], z[1], 0.0, 0.0]),
            P=np.diag([p.measurement_std**2] * 2 + [p.initial_speed_std**2] * 2).astype(np.float64),
            hits=1,
            misses=0,
            last_seen=t,
            confirmed=p.confirm_hits <= 1,
            radius=radius,
            still_since=None,
            wall=wall,
        )
        self._next_id += 1
        if self._held(tr):
            _hold_still(tr, p.still_speed)
        return tr

    # -- output --------------------------------------------------------------------------

    def snapshot(
        self,
        emotion_positions: np.ndarray,
        emotion_codes: np.ndarray,
        emotion_distances: np.ndarray,
        pedestrian_radius: float,
        static_discomfort: float,
        default_code: int,
        track_emotions: dict[int, int] | None = None,
    ) -> CrowdSnapshot:
        """The confirmed tracks as the crowd a planner reads, at the last update's time.

        Moving tracks are pedestrians: estimated position and velocity, the nominal
        `pedestrian_radius`, the emotion code of the nearest entry of
        (`emotion_positions` (E, 2) [m], `emotion_codes` (E,)) within
        `TrackerParams.emotion_gate` (else `default_code`) — or, with `track_emotions`
        (track id → code, e.g. `perception/track_emotions.py`), the code kept for the
        track's id (else `default_code`), and the reports are not read — and its
        discomfort distance ``emotion_distances[code]`` [m]. Still tracks (`is_static`)
        are static discs: estimated centre and the mean fitted radius;
        `static_discomfort` [m] is passed on.
        """
        pos = np.asarray(emotion_positions, dtype=np.float64).reshape(-1, 2)
        codes = np.asarray(emotion_codes).reshape(-1).astype(np.int64)
        if codes.shape[0] != pos.shape[0]:
            raise ValueError(
                f"emotion_codes has {codes.shape[0]} entries, emotion_positions {pos.shape[0]}"
            )
        distances = np.asarray(emotion_distances, dtype=np.float64).reshape(-1)
        confirmed = self.tracks()
        moving = self.moving_tracks()
        still = [tr for tr in confirmed if self.is_static(tr)]
        xs = np.array([tr.x for tr in moving], dtype=np.float64).reshape(-1, 4)
        emotions = np.full(len(moving), int(default_code), dtype=np.int64)
        if track_emotions is not None:
            for i, tr in enumerate(moving):
                emotions[i] = int(track_emotions.get(tr.id, default_code))
        elif len(moving) and len(pos):
            gap = np.hypot(
                xs[:, None, 0] - pos[None, :, 0], xs[:, None, 1] - pos[None, :, 1]
            )  # (tracks, reports)
            nearest = np.argmin(gap, axis=1)
            near = gap[np.arange(len(moving)), nearest] <= self.params.emotion_gate
            emotions[near] = codes[nearest[near]]
        return CrowdSnapshot(
            positions=xs[:, :2].copy(),
            velocities=xs[:, 2:].copy(),
            radius=float(pedestrian_radius),
            emotions=emotions,
            discomfort=distances[emotions],
            static_centers=np.array([tr.x[:2] for tr in still], dtype=np.float64).reshape(-1, 2),
            static_radii=np.array([tr.radius for tr in still], dtype=np.float64),
            static_discomfort=float(static_discomfort),
        )

    # -- state ---------------------------------------------------------------------------

    def moving_tracks(self) -> list[Track]:
        """The confirmed tracks that are not static: the pedestrians of `snapshot`, in
        its order."""
        return [tr for tr in self.tracks() if not self.is_static(tr)]

    def state_dict(self) -> dict:
        """The tracker's state as plain data (lists, floats, ints, None)."""
        return {
            "time": self._time,
            "next_id": self._next_id,
            "tracks": [tr.to_plain() for tr in self._tracks],
        }

    def load_state_dict(self, state: dict) -> None:
        """Restore a `state_dict`; ValueError (state unchanged) if it is malformed."""
        try:
            time = None if state["time"] is None else float(state["time"])
            next_id = int(state["next_id"])
            tracks = [Track.from_plain(d) for d in state["tracks"]]
        except (KeyError, TypeError) as e:
            raise ValueError(f"tracker state is incomplete or mistyped: {e}") from None
        if time is not None and not math.isfinite(time):
            raise ValueError(f"tracker state: time must be finite or None, got {time}")
        ids = [tr.id for tr in tracks]
        if ids != sorted(set(ids)) or (ids and ids[-1] >= next_id):
            raise ValueError(f"tracker state: track ids {ids} must increase and be < {next_id}")
        self._time, self._next_id, self._tracks = time, next_id, tracks


def _detection_arrays(detections: Detections) -> tuple[np.ndarray, np.ndarray]:
    """Validated (centres (m, 2), radii (m,)) of `detections`."""
    z = np.asarray(detections.centers, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(detections.radii, dtype=np.float64).reshape(-1)
    if r.shape[0] != z.shape[0]:
        raise ValueError(f"detections: {z.shape[0]} centres but {r.shape[0]} radii")
    if not (np.isfinite(z).all() and np.isfinite(r).all()):
        raise ValueError("detections must be finite")
    return z, r


def _is_held(track: Track) -> bool:
    """Whether `_hold_still` made `track` a static object's (zero velocity, uncorrelated)."""
    return not track.x[2:].any() and not track.P[:2, 2:].any()


def _hold_still(track: Track, still_speed: float) -> None:
    """Make `track` a static object's, in place: zero velocity, uncorrelated with the
    position, with a velocity std of half `still_speed` per axis."""
    track.x[2:] = 0.0
    track.P[2:, :] = 0.0
    track.P[:, 2:] = 0.0
    track.P[2, 2] = track.P[3, 3] = (0.5 * still_speed) ** 2


def _predict(
    x: np.ndarray, cov: np.ndarray, dt: float, accel_std: float
) -> tuple[np.ndarray, np.ndarray]:
    """Constant-velocity prediction of n states (n, 4) and covariances (n, 4, 4) by dt."""
    if dt == 0.0:
        return x.copy(), cov.copy()
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    g = np.array([[dt * dt / 2, 0.0], [0.0, dt * dt / 2], [dt, 0.0], [0.0, dt]])
    q = accel_std**2 * (g @ g.T)
    return x @ f.T, f @ cov @ f.T + q


def _correct(
    x: np.ndarray, cov: np.ndarray, z: np.ndarray, measurement_std: float
) -> tuple[np.ndarray, np.ndarray]:
    """Kalman update of n states (n, 4), covariances (n, 4, 4) with positions z (n, 2)."""
    r = measurement_std**2 * np.eye(2)
    s = cov[:, :2, :2] + r
    gain = np.linalg.solve(s, cov[:, :2, :]).transpose(0, 2, 1)  # P Hᵀ S⁻¹ (S symmetric)
    nu = z - x[:, :2]
    x = x + np.einsum("nij,nj->ni", gain, nu)
    ikh = np.eye(4) - np.concatenate([gain, np.zeros_like(gain)], axis=2)  # I − K H
    cov = ikh @ cov @ ikh.transpose(0, 2, 1) + gain @ r @ gain.transpose(0, 2, 1)
    return x, cov


# The tracker's per-axis std of a detected person's centre when people are legs [m]: a pair's
# midpoint is within a few centimetres, a lone leg up to 0.22 m off (tuned on the tracking
# study's seeds 700 000 and up, docs/perception.md).
LEG_MEASUREMENT_STD = 0.1


def tracker_params(config: EmoNavConfig) -> TrackerParams:
    """The tracker for the configured sensor and `perception.still_duration`."""
    still = config.perception.still_duration
    if config.sensor.people_as == "legs":
        return TrackerParams(
            still_duration=still, measurement_std=LEG_MEASUREMENT_STD, sticky_fixed=True
        )
    return TrackerParams(still_duration=still)
