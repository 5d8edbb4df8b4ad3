"""The LiDAR tracking study's scoring of one episode: tracker against truth, scan by scan.

`EpisodeEvaluator` is given the world at every scan of an episode (`ScanTruth`; the
episodes are `evaluation/tracking_study.py`'s), runs the scan, the detector and the
tracker on it, scores the tracker's pedestrians against the truth with py-motmetrics and
returns what the episode's scans gave (`EpisodeResult`).

**One scan** (`EpisodeEvaluator.observe`, `ScanTruth`): `sensing/lidar.py::scan_discs` of
every pedestrian, static disc and wall from the robot's pose, `detect_objects`,
`CrowdTracker.update`. Ground truth: every pedestrian (id = its index), its position and
velocity. Hypotheses: the confirmed tracks that are not still (`CrowdTracker.is_static`),
i.e. the pedestrians `CrowdTracker.snapshot` reports. Both go into a
`motmetrics.MOTAccumulator` (py-motmetrics, the field's CLEAR-MOT implementation) with
Euclidean distances, pairs farther apart than `MATCH_DISTANCE` (0.5 m) impossible.

Per pedestrian per scan the evaluator also records its distance to the robot and its
visibility (`visibility`): its own beams (the beams that hit it when it is scanned alone)
and its visible beams (those of its own beams whose range in the full scan equals its own
within 1e-6 m, below the maximum range). Categories: `OUT_OF_RANGE` (centre farther than
`lidar.max_range`), `OCCLUDED` (fewer than `DetectionParams.min_points` visible beams: the
detector drops such a sliver), `PARTLY_OCCLUDED` (some own beams hidden), `VISIBLE`. A miss
gets a cause (`MISS_CAUSES`): out of range, occluded, reported as a static obstacle (a
still confirmed track within the match distance), unconfirmed (a tentative track within
it: the scans before `confirm_hits`), other. A false pedestrian (`FP_CAUSES`): a static
disc not yet still for `still_duration`, a track coasting without a detection, other.

Static discs: whether a still confirmed track lies within the match distance of each disc
at each scan, from the first scan that shows the disc (`min_points` visible beams).
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Any

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.evaluation.scan_visibility import (
    OCCLUDED,
    OUT_OF_RANGE,
    PARTLY_OCCLUDED,
    VISIBLE,
    categories,
    visible_beams,
)
from emonav_drake.params import EmoNavConfig, SensorParams
from emonav_drake.sensing.crowd_tracker import CrowdTracker, TrackerParams, tracker_params
from emonav_drake.sensing.leg_detection import detect_scan, detection_params
from emonav_drake.sensing.lidar import scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams
from emonav_drake.sensing.lidar_sensor import seen_discs, sensed_ranges

MATCH_DISTANCE = 0.5  # a hypothesis farther than this from a pedestrian is not it [m]

MISS_CAUSES = ("out_of_range", "occluded", "unconfirmed", "static", "other")
FP_CAUSES = ("static_disc", "coasting", "other")


def _motmetrics():
    """The py-motmetrics module (a dev dependency: `pip install -e ".[dev]"`)."""
    try:
        import motmetrics
    except ImportError as e:  # pragma: no cover - the dev extra installs it
        raise ImportError(
            "the tracking study needs py-motmetrics: pip install motmetrics (the dev extra)"
        ) from e
    return motmetrics


@dc.dataclass(frozen=True)
class ScanTruth:
    """The world at one scan (world frame, SI units)."""

    time: float  # [s]
    robot_xy: np.ndarray  # (2,) LiDAR position [m]
    heading: float  # robot heading [rad]
    ped_positions: np.ndarray  # (P, 2) pedestrian centres [m]
    ped_velocities: np.ndarray  # (P, 2) [m/s]
    static_centers: np.ndarray  # (S, 2) [m]
    static_radii: np.ndarray  # (S,) [m]
    # (W, 2, 2) walls, segment k from [k, 0] to [k, 1] [m]: they block beams too
    wall_segments: np.ndarray = dc.field(default_factory=lambda: np.zeros((0, 2, 2)))
    # (P,) gait phase [rad] and facing [rad] of each pedestrian (what a sensor that sees
    # legs needs; None: 0 and the walking direction), the scenario's seed (the noise's)
    gait_phase: np.ndarray | None = None
    facing: np.ndarray | None = None
    seed: int = 0

    def snapshot(self, config: EmoNavConfig) -> CrowdSnapshot:
        """The crowd as the sensor model reads it (`sensing/lidar_sensor.py`)."""
        p = len(self.ped_positions)
        return CrowdSnapshot(
            positions=np.asarray(self.ped_positions, dtype=float).reshape(-1, 2),
            velocities=np.asarray(self.ped_velocities, dtype=float).reshape(-1, 2),
            radius=config.crowd.pedestrian_radius,
            emotions=np.zeros(p, dtype=np.int64),
            discomfort=np.zeros(p),
            static_centers=np.asarray(self.static_centers, dtype=float).reshape(-1, 2),
            static_radii=np.asarray(self.static_radii, dtype=float).reshape(-1),
            static_discomfort=0.0,
            wall_segments=self.wall_segments,
            gait_phase=self.gait_phase,
            facing=self.facing,
            time=float(self.time),
            seed=int(self.seed),
        )


def _in_view(
    points: np.ndarray, xy: np.ndarray, heading: float, reach: float, sensor: SensorParams
) -> np.ndarray:
    """Which points (n, 2) [m] lie within `reach` [m] of the LiDAR at `xy` and inside its
    field of view (`sensor.field_of_view_deg`, centred on `heading` [rad])."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    d = points - xy
    inside = np.hypot(d[:, 0], d[:, 1]) <= reach
    if sensor.field_of_view_deg < 360.0:
        bearing = np.arctan2(d[:, 1], d[:, 0]) - heading
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        inside &= np.abs(bearing) <= math.radians(sensor.field_of_view_deg) / 2.0
    return inside


def _scored_hypotheses(
    gap: np.ndarray, ped_scored: np.ndarray, hyp_in_view: np.ndarray, match_distance: float
) -> np.ndarray:
    """Which hypotheses CLEAR-MOT scores, given `gap` (pedestrians × hypotheses) [m]: a
    hypothesis within `match_distance` of a pedestrian takes that nearest pedestrian's
    `ped_scored` (a track of a pedestrian outside the scored region is "don't care", not
    a false track; one just outside the view that follows a scored pedestrian is its
    match, not a miss); any other counts where it is (`hyp_in_view`)."""
    scored = hyp_in_view.copy()
    if gap.size:
        nearest = np.argmin(gap, axis=0)
        near = gap[nearest, np.arange(gap.shape[1])] <= match_distance
        scored[near] = ped_scored[nearest[near]]
    return scored


def _within(a: np.ndarray, b: np.ndarray, d: float) -> np.ndarray:
    """For each point of `a` (n, 2): whether a point of `b` (m, 2) lies within `d`."""
    if len(a) == 0 or len(b) == 0:
        return np.zeros(len(a), dtype=bool)
    gap = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    return (gap <= d).any(axis=1)


@dc.dataclass
class EpisodeResult:
    """What one episode's scans gave (`EpisodeEvaluator.result`)."""

    seed: int
    outcome: str
    steps: int  # walking steps
    scans: int
    pedestrians: int
    discs: int
    accumulator: Any  # motmetrics.MOTAccumulator of the episode
    # One entry per pedestrian per scan (index = scan · pedestrians + pedestrian): scan,
    # time [s], ped, distance [m], own / visible beams, category, detected (a detection
    # within MATCH_DISTANCE), tracked (matched by motmetrics), switch, pos_err [m],
    # vel_err [m/s], track_age [s] (NaN unmatched), miss_cause (index in MISS_CAUSES,
    # −1 if tracked), hidden_s (time since it last showed min_points beams; NaN when it
    # shows them now or never did), hidden_was_tracked (tracked at that last scan),
    # since_match (time since its previous match [s], NaN before the first), speed (its
    # true speed [m/s]), scored (in CLEAR-MOT's counts: within the scored range).
    peds: dict[str, np.ndarray]
    # One entry per static disc per scan: scan, time, disc, visible beams, reported
    # (a still confirmed track within MATCH_DISTANCE), as_pedestrian (a moving one).
    discs_seen: dict[str, np.ndarray]
    false_positives: dict[str, int]  # counts by FP_CAUSES
    per_scan: list[dict]  # one summary row per scan (CSV)
    scored_range: float | None = None  # CLEAR-MOT's scored range [m] (None: everything)


class EpisodeEvaluator:
    """Scans, detects, tracks and scores one episode, scan by scan (module docstring).

    Args:
        config: the LiDAR (beams, range), the pedestrian radius.
        detection, tracking: the detector's and the tracker's parameters.
        match_distance: the CLEAR-MOT match threshold [m].
        scored_range: CLEAR-MOT scores the pedestrians and the hypotheses within this
            distance [m] of the robot and inside the sensor's field of view (default:
            `lidar.max_range`, the range the tracker is given); the others are in no
            count (no miss, no false pedestrian). None scores all (a pedestrian beyond
            the range is a miss).
    """

    def __init__(
        self,
        config: EmoNavConfig,
        detection: DetectionParams | None = None,
        tracking: TrackerParams | None = None,
        match_distance: float = MATCH_DISTANCE,
        scored_range: float | None = -1.0,
    ) -> None:
        self.config = config
        if scored_range is not None and scored_range < 0:
            scored_range = config.lidar.max_range
        self.scored_range = scored_range
        self.detection = (detection or detection_params(config)).validate()
        self.tracker = CrowdTracker(tracking or tracker_params(config))
        self.match_distance = float(match_distance)
        self.accumulator = _motmetrics().MOTAccumulator(auto_id=False)
        self._peds: dict[str, list] = {k: [] for k in _PED_FIELDS}
        self._discs: dict[str, list] = {k: [] for k in _DISC_FIELDS}
        self._hyps: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self._births: dict[int, float] = {}
        self._fp_near_disc: list[np.ndarray] = []  # per scan: each hypothesis near a disc
        self._per_scan: list[dict] = []
        self._num_peds: int | None = None
        self._num_discs = 0

    def observe(self, truth: ScanTruth) -> None:
        """One scan of `truth`: detection, tracker update, the scan's scores."""
        li, cfg = self.config.lidar, self.config
        t = float(truth.time)
        xy = np.asarray(truth.robot_xy, dtype=float)
        peds = np.asarray(truth.ped_positions, dtype=float).reshape(-1, 2)
        vels = np.asarray(truth.ped_velocities, dtype=float).reshape(-1, 2)
        sc = np.asarray(truth.static_centers, dtype=float).reshape(-1, 2)
        sr = np.asarray(truth.static_radii, dtype=float).reshape(-1)
        if self._num_peds is None:
            self._num_peds = len(peds)
        elif len(peds) != self._num_peds:
            raise ValueError(f"scan at t={t}: {len(peds)} pedestrians, before {self._num_peds}")
        crowd = truth.snapshot(cfg)
        sensed = sensed_ranges(xy, truth.heading, crowd, cfg)
        det = detect_scan(sensed, xy, truth.heading, li.max_range, self.detection)
        self.tracker.update(t, det)
        scan = len(self._per_scan)

        # Visibility from the exact scan of what the sensor sees (legs or discs): a
        # pedestrian's beams are its legs' when it shows as legs.
        centers, radii = seen_discs(crowd, cfg.sensor)
        full = scan_discs(
            xy,
            truth.heading,
            centers,
            radii,
            li.num_beams,
            li.max_range,
            li.min_range,
            segments=truth.wall_segments,
        )
        own, vis = visible_beams(xy, truth.heading, centers, radii, full, cfg)
        parts = len(radii) - len(sr)  # discs of pedestrians: P, or 2P legs
        if parts != len(peds):  # two legs per pedestrian: its beams are both legs'
            own = np.concatenate([own[:parts].reshape(-1, 2).sum(axis=1), own[parts:]])
            vis = np.concatenate([vis[:parts].reshape(-1, 2).sum(axis=1), vis[parts:]])
        cat = categories(xy, peds, own[: len(peds)], vis[: len(peds)], cfg, self.detection)
        for tr in self.tracker.all_tracks():
            self._births.setdefault(tr.id, t)
        confirmed = self.tracker.tracks()
        moving = [tr for tr in confirmed if not self.tracker.is_static(tr)]
        still = [tr for tr in confirmed if self.tracker.is_static(tr)]
        tentative = [tr for tr in self.tracker.all_tracks() if not tr.confirmed]
        h_ids = np.array([tr.id for tr in moving], dtype=np.int64)
        h_pos = np.array([tr.x[:2] for tr in moving], dtype=float).reshape(-1, 2)
        h_vel = np.array([tr.x[2:] for tr in moving], dtype=float).reshape(-1, 2)
        h_coast = np.array([tr.misses > 0 for tr in moving], dtype=bool)
        h_age = np.array([t - self._births[tr.id] for tr in moving], dtype=float)
        self._hyps.append((h_ids, h_pos, h_vel, h_coast, h_age))
        still_pos = np.array([tr.x[:2] for tr in still], dtype=float).reshape(-1, 2)
        tent_pos = np.array([tr.x[:2] for tr in tentative], dtype=float).reshape(-1, 2)

        gap = np.hypot(peds[:, None, 0] - h_pos[None, :, 0], peds[:, None, 1] - h_pos[None, :, 1])
        dists = np.where(gap <= self.match_distance, gap, np.nan)
        o_in = np.ones(len(peds), dtype=bool)
        h_in = np.ones(len(h_ids), dtype=bool)
        if self.scored_range is not None:
            o_in = _in_view(peds, xy, truth.heading, self.scored_range, cfg.sensor)
            h_in = _scored_hypotheses(
                gap,
                o_in,
                _in_view(h_pos, xy, truth.heading, self.scored_range, cfg.sensor),
                self.match_distance,
            )
        self.accumulator.update(
            np.flatnonzero(o_in).tolist(),
            h_ids[h_in].tolist(),
            dists[np.ix_(o_in, h_in)],
            frameid=scan,
        )

        d = self._peds
        d["scan"] += [scan] * len(peds)
        d["time"] += [t] * len(peds)
        d["ped"] += list(range(len(peds)))
        d["distance"] += np.hypot(*(peds - xy).T).tolist() if len(peds) else []
        d["own_beams"] += own[: len(peds)].tolist()
        d["visible_beams"] += vis[: len(peds)].tolist()
        d["category"] += cat.tolist()
        d["detected"] += _within(peds, det.centers, self.match_distance).tolist()
        d["near_static"] += _within(peds, still_pos, self.match_distance).tolist()
        d["near_tentative"] += _within(peds, tent_pos, self.match_distance).tolist()
        d["scored"] += o_in.tolist()
        d["vx"] += vels[:, 0].tolist()
        d["vy"] += vels[:, 1].tolist()

        s = self._discs
        s["scan"] += [scan] * len(sr)
        s["time"] += [t] * len(sr)
        s["disc"] += list(range(len(sr)))
        s["visible_beams"] += vis[len(peds) :].tolist()
        s["reported"] += _within(sc, still_pos, self.match_distance).tolist()
        s["as_pedestrian"] += _within(sc, h_pos, self.match_distance).tolist()
        self._num_discs = len(sr)
        self._fp_near_disc.append(_within(h_pos, sc, self.match_distance))

        self._per_scan.append(
            {
                "scan": scan,
                "time": round(t, 6),
                "pedestrians": len(peds),
                "visible": int((cat == VISIBLE).sum()),
                "partly_occluded": int((cat == PARTLY_OCCLUDED).sum()),
                "occluded": int((cat == OCCLUDED).sum()),
                "out_of_range": int((cat == OUT_OF_RANGE).sum()),
                "detections": len(det),
                "tentative": len(tentative),
                "moving_tracks": len(moving),
                "static_tracks": len(still),
            }
        )

    def result(self, seed: int, outcome: str, steps: int) -> EpisodeResult:
        """The episode's scores: motmetrics' events joined with the recorded scans."""
        n = self._num_peds or 0
        peds = {k: np.asarray(v) for k, v in self._peds.items()}
        m = len(peds["scan"])
        tracked = np.zeros(m, dtype=bool)
        switch = np.zeros(m, dtype=bool)
        pos_err = np.full(m, np.nan)
        vel_err = np.full(m, np.nan)
        age = np.full(m, np.nan)
        fps = dict.fromkeys(FP_CAUSES, 0)
        scan_counts = {k: [0] * len(self._per_scan) for k in ("matches", "switches", "fp")}
        events = self.accumulator.mot_events if self._per_scan else None
        if events is not None and len(events):
            frames = events.index.get_level_values(0).to_numpy()
            kinds = events["Type"].to_numpy()
            oids, hids, ds = (events[c].to_numpy() for c in ("OId", "HId", "D"))
            for f, kind, o, h, dist in zip(frames, kinds, oids, hids, ds, strict=True):
                f = int(f)
                if kind in ("MATCH", "SWITCH"):
                    i = f * n + int(o)
                    ids, _, vel, _, h_age = self._hyps[f]
                    j = int(np.flatnonzero(ids == int(h))[0])
                    tracked[i] = True
                    switch[i] = kind == "SWITCH"
                    pos_err[i] = float(dist)
                    vel_err[i] = math.hypot(vel[j, 0] - peds["vx"][i], vel[j, 1] - peds["vy"][i])
                    age[i] = h_age[j]
                    scan_counts["matches"][f] += 1
                    scan_counts["switches"][f] += int(kind == "SWITCH")
                elif kind == "FP":
                    ids, _, _, coast, _ = self._hyps[f]
                    j = int(np.flatnonzero(ids == int(h))[0])
                    if self._fp_near_disc[f][j]:
                        fps["static_disc"] += 1
                    elif coast[j]:
                        fps["coasting"] += 1
                    else:
                        fps["other"] += 1
                    scan_counts["fp"][f] += 1
        cause = np.full(m, -1, dtype=np.int64)
        missed = ~tracked
        rules = {
            "out_of_range": peds["category"] == OUT_OF_RANGE,
            "occluded": peds["category"] == OCCLUDED,
            "static": peds["near_static"].astype(bool),
            "unconfirmed": peds["near_tentative"].astype(bool),
        }
        for name, rule in rules.items():
            cause[missed & (cause < 0) & rule] = MISS_CAUSES.index(name)
        cause[missed & (cause < 0)] = MISS_CAUSES.index("other")

        # Time since each pedestrian last showed min_points beams, and since its
        # previous match.
        hidden = np.full(m, np.nan)
        was_tracked = np.zeros(m, dtype=bool)
        since_match = np.full(m, np.nan)
        shows = peds["visible_beams"] >= self.detection.min_points if m else np.zeros(0, bool)
        for p in range(n):
            last = matched = None
            for i in range(p, m, n):
                if matched is not None:
                    since_match[i] = peds["time"][i] - peds["time"][matched]
                if tracked[i]:
                    matched = i
                if shows[i]:
                    last = i
                elif last is not None:
                    hidden[i] = peds["time"][i] - peds["time"][last]
                    was_tracked[i] = tracked[last]
        out = {
            k: peds[k]
            for k in ("scan", "time", "ped", "distance", "own_beams", "visible_beams", "category")
        }
        out.update(
            detected=peds["detected"].astype(bool) if m else np.zeros(0, bool),
            tracked=tracked,
            switch=switch,
            pos_err=pos_err,
            vel_err=vel_err,
            track_age=age,
            miss_cause=cause,
            hidden_s=hidden,
            hidden_was_tracked=was_tracked,
            since_match=since_match,
            speed=np.hypot(peds["vx"], peds["vy"]) if m else np.zeros(0),
            scored=peds["scored"].astype(bool) if m else np.zeros(0, bool),
        )
        per_scan = []
        for f, row in enumerate(self._per_scan):
            misses = row["pedestrians"] - scan_counts["matches"][f]
            per_scan.append(
                {
                    "seed": int(seed),
                    **row,
                    "matches": scan_counts["matches"][f],
                    "switches": scan_counts["switches"][f],
                    "misses": misses,
                    "false_positives": scan_counts["fp"][f],
                }
            )
        return EpisodeResult(
            seed=int(seed),
            outcome=str(outcome),
            steps=int(steps),
            scans=len(self._per_scan),
            pedestrians=n,
            discs=self._num_discs,
            accumulator=self.accumulator,
            peds=out,
            discs_seen={k: np.asarray(v) for k, v in self._discs.items()},
            false_positives=fps,
            per_scan=per_scan,
            scored_range=self.scored_range,
        )


_PED_FIELDS = (
    "scan",
    "time",
    "ped",
    "distance",
    "own_beams",
    "visible_beams",
    "category",
    "detected",
    "near_static",
    "near_tentative",
    "scored",
    "vx",
    "vy",
)
_DISC_FIELDS = ("scan", "time", "disc", "visible_beams", "reported", "as_pedestrian")
