"""How well the LiDAR tracker follows the crowd: CLEAR-MOT on LIP episodes.

`config.perception.state_source = "lidar"` gives the state-based planners the crowd as
`systems/crowd_tracker_system.py` estimates it: every scan (10 Hz) is segmented into
discs (`core/lidar_objects.py::detect_objects`) and folded into a multi-target tracker
(`core/crowd_tracker.py::CrowdTracker`). This module measures that estimate against the
simulator's truth.

**Episodes** (`run_episode`): the fast LIP world (`core/navigation.py::NavigationWorld`,
no map), the robot driven by a planner on the TRUE crowd (by default the MPC), so it
moves as in a real episode whatever the tracker makes of the crowd. The world is stepped
as usual; before each walking step the crowd periods of that step are replayed on a copy
of the crowd state with the robot where `robot_at_substep` has it, exactly as
`NavigationWorld.step` does, and one scan is taken at each period's start — the
`CrowdTrackerSystem`'s timing (a scan at t = j·dt of the robot pose at t and the crowd at
t, before the crowd's update at t). After the walking step the replayed crowd is checked
to be the world's, bit for bit.

**One scan** (`EpisodeEvaluator.observe`, `ScanTruth`): `core/lidar.py::scan_discs` of
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

`summarise` pools the episodes: the CLEAR-MOT numbers of motmetrics (MOTA, MOTP in
metres, ID switches, IDF1, …), position and velocity RMSE of the matched pairs, the
causes, rates by distance and visibility (`distance_bins`) and by the time a pedestrian
has been occluded (`hidden_bins`). `plot` draws them.
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from emonav_drake.core.crowd_tracker import CrowdTracker, TrackerParams
from emonav_drake.core.lidar import scan_discs
from emonav_drake.core.lidar_objects import DetectionParams, detect_objects
from emonav_drake.core.lip import lip_velocity
from emonav_drake.core.navigation import (
    NavigationWorld,
    check_command,
    robot_at_substep,
    substeps_per_step,
)
from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EmoNavConfig

MATCH_DISTANCE = 0.5  # a hypothesis farther than this from a pedestrian is not it [m]
SAME_RANGE = 1e-6  # a beam shows an object when the full scan's range equals its own [m]

VISIBLE, PARTLY_OCCLUDED, OCCLUDED, OUT_OF_RANGE = 0, 1, 2, 3
CATEGORY_NAMES = ("visible", "partly_occluded", "occluded", "out_of_range")
MISS_CAUSES = ("out_of_range", "occluded", "unconfirmed", "static", "other")
FP_CAUSES = ("static_disc", "coasting", "other")

# Bins of the summaries and the figure: distance to the robot [m] (the range is 6 m).
DISTANCE_EDGES = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 7.0, 8.0, 10.0)
SETTLED_AGE = 1.0  # tracks at least this old [s] give the "settled" velocity error

# The CLEAR-MOT and identity metrics read from motmetrics (its names).
MOT_METRICS = (
    "num_frames",
    "num_objects",
    "num_unique_objects",
    "num_matches",
    "num_switches",
    "num_transfer",
    "num_false_positives",
    "num_misses",
    "num_fragmentations",
    "mostly_tracked",
    "partially_tracked",
    "mostly_lost",
    "mota",
    "motp",
    "idf1",
    "idp",
    "idr",
)


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


def _visible_beams(
    robot_xy: np.ndarray,
    heading: float,
    centers: np.ndarray,
    radii: np.ndarray,
    full: np.ndarray,
    config: EmoNavConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """(own beams, visible beams) of each disc in the full scan `full`."""
    li = config.lidar
    own = np.zeros(len(radii), dtype=np.int64)
    vis = np.zeros(len(radii), dtype=np.int64)
    for i in range(len(radii)):
        one, r = centers[i : i + 1], radii[i : i + 1]
        alone = scan_discs(robot_xy, heading, one, r, li.num_beams, li.max_range, li.min_range)
        hits = alone < li.max_range
        own[i] = int(hits.sum())
        vis[i] = int((hits & (np.abs(full - alone) <= SAME_RANGE)).sum())
    return own, vis


def visibility(
    robot_xy: np.ndarray,
    heading: float,
    ped_positions: np.ndarray,
    ped_radius: float,
    static_centers: np.ndarray,
    static_radii: Sequence[float] | np.ndarray,
    config: EmoNavConfig,
    detection: DetectionParams | None = None,
    wall_segments: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How much of each pedestrian the scan from (`robot_xy` [m], `heading` [rad]) shows.

    Returns (own beams (P,), visible beams (P,), category (P,)): own = beams that hit
    the pedestrian scanned alone; visible = those whose range in the scan of every
    pedestrian (radius `ped_radius` [m]), disc and wall (`wall_segments` (W, 2, 2) [m],
    optional) equals its own (`SAME_RANGE`);
    category `OUT_OF_RANGE` (centre beyond `lidar.max_range`), `OCCLUDED` (fewer than
    `detection.min_points` visible), `PARTLY_OCCLUDED` (some own beams hidden), `VISIBLE`.
    """
    robot_xy = np.asarray(robot_xy, dtype=float)
    peds = np.asarray(ped_positions, dtype=float).reshape(-1, 2)
    centers = np.vstack([peds, np.asarray(static_centers, dtype=float).reshape(-1, 2)])
    radii = np.concatenate([np.full(len(peds), float(ped_radius)), np.asarray(static_radii, float)])
    li = config.lidar
    full = scan_discs(
        robot_xy,
        heading,
        centers,
        radii,
        li.num_beams,
        li.max_range,
        li.min_range,
        segments=wall_segments,
    )
    own, vis = _visible_beams(robot_xy, heading, peds, radii[: len(peds)], full, config)
    return own, vis, _categories(robot_xy, peds, own, vis, config, detection or DetectionParams())


def _categories(
    robot_xy: np.ndarray,
    peds: np.ndarray,
    own: np.ndarray,
    vis: np.ndarray,
    config: EmoNavConfig,
    detection: DetectionParams,
) -> np.ndarray:
    dist = np.hypot(*(peds - robot_xy).T) if len(peds) else np.zeros(0)
    cat = np.full(len(peds), VISIBLE, dtype=np.int64)
    cat[vis < own] = PARTLY_OCCLUDED
    cat[vis < detection.min_points] = OCCLUDED
    cat[dist > config.lidar.max_range] = OUT_OF_RANGE
    return cat


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
    # true speed [m/s]).
    peds: dict[str, np.ndarray]
    # One entry per static disc per scan: scan, time, disc, visible beams, reported
    # (a still confirmed track within MATCH_DISTANCE), as_pedestrian (a moving one).
    discs_seen: dict[str, np.ndarray]
    false_positives: dict[str, int]  # counts by FP_CAUSES
    per_scan: list[dict]  # one summary row per scan (CSV)


class EpisodeEvaluator:
    """Scans, detects, tracks and scores one episode, scan by scan (module docstring).

    Args:
        config: the LiDAR (beams, range), the pedestrian radius.
        detection, tracking: the detector's and the tracker's parameters.
        match_distance: the CLEAR-MOT match threshold [m].
    """

    def __init__(
        self,
        config: EmoNavConfig,
        detection: DetectionParams | None = None,
        tracking: TrackerParams | None = None,
        match_distance: float = MATCH_DISTANCE,
    ) -> None:
        self.config = config
        self.detection = (detection or DetectionParams()).validate()
        self.tracker = CrowdTracker(tracking or TrackerParams())
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
        centers = np.vstack([peds, sc])
        radii = np.concatenate([np.full(len(peds), cfg.crowd.pedestrian_radius), sr])
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
        det = detect_objects(full, xy, truth.heading, li.max_range, self.detection)
        self.tracker.update(t, det)
        scan = len(self._per_scan)

        own, vis = _visible_beams(xy, truth.heading, centers, radii, full, cfg)
        cat = _categories(xy, peds, own[: len(peds)], vis[: len(peds)], cfg, self.detection)
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
        self.accumulator.update(list(range(len(peds))), h_ids.tolist(), dists, frameid=scan)

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
    "vx",
    "vy",
)
_DISC_FIELDS = ("scan", "time", "disc", "visible_beams", "reported", "as_pedestrian")


def run_episode(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Any,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
) -> EpisodeResult:
    """One LIP episode of `planner` on the true crowd, with a scan at every crowd period
    (module docstring); returns its `EpisodeResult`."""
    world = NavigationWorld(scenario, config, grid_kind=None)
    ev = EpisodeEvaluator(config, detection, tracking)
    memory = planner.initial_memory()
    crowd_model, dt = world.crowd, config.crowd.dt
    outcome = None
    while outcome is None:
        command, memory = planner.plan_with_memory(world.planner_input(), memory)
        u, _ = check_command(command, config.robot)
        start, crowd = world.robot, world.crowd_state
        for j in range(substeps_per_step(config)):
            seen = robot_at_substep(start, u, j, config)
            xy = np.array([seen.x, seen.y])
            ev.observe(
                ScanTruth(
                    time=crowd.substep * dt,
                    robot_xy=xy,
                    heading=seen.heading,
                    ped_positions=crowd.positions,
                    ped_velocities=crowd.velocities,
                    static_centers=crowd_model.static_centers,
                    static_radii=crowd_model.static_radii,
                    wall_segments=crowd_model.wall_segments,
                )
            )
            crowd = crowd_model.step(crowd, xy, lip_velocity(seen))
        _, outcome = world.step(u)
        if not np.array_equal(crowd.positions, world.crowd_state.positions):
            raise RuntimeError(f"seed {scenario.seed}: the replayed crowd left the world's")
    return ev.result(scenario.seed, outcome, world.step_count)


def study(
    seeds: Iterable[int],
    config: EmoNavConfig | None = None,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
    planner_name: str = "mpc",
    progress: bool = False,
) -> list[EpisodeResult]:
    """`run_episode` on the scenario `sample_scenario(seed, config)` of each seed."""
    from emonav_drake.core.scenario import sample_scenario
    from emonav_drake.planners import make_planner

    cfg = config or EmoNavConfig()
    planner = make_planner(planner_name, cfg)
    seeds = list(seeds)
    if progress:
        from emonav_drake.progress import progress_bar

        seeds = progress_bar(seeds, desc="tracking episodes", unit="episode")
    return [run_episode(sample_scenario(s, cfg), cfg, planner, detection, tracking) for s in seeds]


# -- summaries ---------------------------------------------------------------------------


def _cat(results: Sequence[EpisodeResult], key: str, where: str = "peds") -> np.ndarray:
    parts = [np.asarray(getattr(r, where)[key]) for r in results]
    return np.concatenate(parts) if parts else np.zeros(0)


def _stats(x: np.ndarray) -> dict:
    """Median, 90th percentile, max and count of the finite values of x."""
    x = x[np.isfinite(x)]
    if not len(x):
        return {"median": None, "p90": None, "max": None, "n": 0}
    return {
        "median": float(np.median(x)),
        "p90": float(np.percentile(x, 90)),
        "max": float(x.max()),
        "n": int(len(x)),
    }


def _rate(x: np.ndarray) -> float | None:
    return float(np.mean(x)) if len(x) else None


def _rmse(x: np.ndarray) -> float | None:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if len(x) else None


def clear_mot(results: Sequence[EpisodeResult]) -> tuple[dict, list[dict]]:
    """motmetrics' `MOT_METRICS` over all episodes, and per episode (seed first)."""
    mm = _motmetrics()
    mh = mm.metrics.create()
    names = [str(r.seed) for r in results]
    df = mh.compute_many(
        [r.accumulator for r in results],
        metrics=list(MOT_METRICS),
        names=names,
        generate_overall=True,
    )

    def row(name: str) -> dict:
        out = {}
        for k in MOT_METRICS:
            v = df.loc[name, k]
            v = float(v) if k in ("mota", "motp", "idf1", "idp", "idr") else int(v)
            out[k] = None if isinstance(v, float) and not math.isfinite(v) else v
        return out

    return row("OVERALL"), [{"seed": r.seed, **row(str(r.seed))} for r in results]


def distance_bins(results: Sequence[EpisodeResult]) -> list[dict]:
    """Per distance bin (`DISTANCE_EDGES`) and visibility category (and "all"): samples,
    detection and track rates, position error [m] (median, p90) and velocity error
    [m/s] (median) of the matched pedestrians."""
    dist, cat = _cat(results, "distance"), _cat(results, "category")
    det, trk = _cat(results, "detected").astype(bool), _cat(results, "tracked").astype(bool)
    pe, ve = _cat(results, "pos_err"), _cat(results, "vel_err")
    idx = np.digitize(dist, DISTANCE_EDGES) - 1
    rows = []
    for b in range(len(DISTANCE_EDGES) - 1):
        for c, name in [*enumerate(CATEGORY_NAMES), (-1, "all")]:
            sel = (idx == b) & ((cat == c) if c >= 0 else True)
            if not sel.any():
                continue
            p, v = _stats(pe[sel & trk]), _stats(ve[sel & trk])
            rows.append(
                {
                    "distance_from": DISTANCE_EDGES[b],
                    "distance_to": DISTANCE_EDGES[b + 1],
                    "visibility": name,
                    "samples": int(sel.sum()),
                    "detected_rate": _rate(det[sel]),
                    "tracked_rate": _rate(trk[sel]),
                    "pos_err_median": p["median"],
                    "pos_err_p90": p["p90"],
                    "vel_err_median": v["median"],
                }
            )
    return rows


def hidden_bins(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    tracking: TrackerParams | None = None,
) -> list[dict]:
    """Occluded pedestrians (in range, fewer than min_points visible beams) that were
    tracked when they last showed: per number of scans since then (1 … coast limit, and
    "more"), samples, track rate and position error [m] (median, p90) of the matches."""
    cfg = config or EmoNavConfig()
    dt = cfg.crowd.dt
    hid, cat = _cat(results, "hidden_s"), _cat(results, "category")
    was, trk = _cat(results, "hidden_was_tracked").astype(bool), _cat(results, "tracked")
    pe = _cat(results, "pos_err")
    sel = (cat == OCCLUDED) & was & np.isfinite(hid)
    k = np.rint(np.where(sel, hid, 0.0) / dt).astype(np.int64)
    limit = round((tracking or TrackerParams()).max_coast / dt)
    rows = []
    for n in range(1, limit + 2):
        s = sel & ((k == n) if n <= limit else (k >= n))
        if not s.any():
            continue
        p = _stats(pe[s & trk.astype(bool)])
        rows.append(
            {
                "scans_hidden": n if n <= limit else f">={n}",
                "hidden_s": round(n * dt, 6),
                "samples": int(s.sum()),
                "tracked_rate": _rate(trk[s].astype(bool)),
                "pos_err_median": p["median"],
                "pos_err_p90": p["p90"],
            }
        )
    return rows


def switch_gaps(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    tracking: TrackerParams | None = None,
) -> dict:
    """ID switches by the time since the pedestrian's previous match: "swap" (matched at
    the scan before, to another track), "reacquired" (unmatched for up to `max_coast`:
    its coasting track had drifted beyond the match distance and a new one took it up),
    "after_deletion" (unmatched for longer: its track had been deleted)."""
    dt = (config or EmoNavConfig()).crowd.dt
    coast = (tracking or TrackerParams()).max_coast
    gap = _cat(results, "since_match")[_cat(results, "switch").astype(bool)]
    return {
        "swap": int((gap <= dt + 1e-9).sum()),
        "reacquired": int(((gap > dt + 1e-9) & (gap <= coast + 1e-9)).sum()),
        "after_deletion": int((gap > coast + 1e-9).sum()),
    }


def static_disc_summary(
    results: Sequence[EpisodeResult],
    tracking: TrackerParams | None = None,
    detection: DetectionParams | None = None,
) -> dict:
    """Static discs: how many were seen (min_points visible beams at some scan), reported
    as still obstacles, the delay from first seen to first reported [s], and the share
    of disc-scans reported from `still_duration` after first seen on."""
    tracking, detection = tracking or TrackerParams(), detection or DetectionParams()
    delays, after = [], []
    seen = reported = total = 0
    for r in results:
        d = r.discs_seen
        for disc in range(r.discs):
            total += 1
            sel = d["disc"] == disc
            t, vis, rep = d["time"][sel], d["visible_beams"][sel], d["reported"][sel]
            shows = np.flatnonzero(vis >= detection.min_points)
            if not len(shows):
                continue
            seen += 1
            t0 = t[shows[0]]
            first = np.flatnonzero(rep.astype(bool))
            if len(first):
                reported += 1
                delays.append(float(t[first[0]] - t0))
            after += rep[t - t0 >= tracking.still_duration - 1e-9].astype(bool).tolist()
    return {
        "discs": total,
        "seen": seen,
        "reported_static": reported,
        "delay_s": _stats(np.asarray(delays, dtype=float)),
        "scans_after_still_time": len(after),
        "reported_after_still_time": _rate(np.asarray(after, dtype=bool)),
    }


def summarise(
    results: Sequence[EpisodeResult],
    config: EmoNavConfig | None = None,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
) -> dict:
    """Every number of the study, JSON-ready (module docstring)."""
    cfg = config or EmoNavConfig()
    detection, tracking = detection or DetectionParams(), tracking or TrackerParams()
    overall, _ = clear_mot(results)
    cat = _cat(results, "category")
    trk, det = _cat(results, "tracked").astype(bool), _cat(results, "detected").astype(bool)
    pe, ve, age = _cat(results, "pos_err"), _cat(results, "vel_err"), _cat(results, "track_age")
    cause, speed = _cat(results, "miss_cause"), _cat(results, "speed")
    outcomes = sorted({r.outcome for r in results})
    return {
        "episodes": len(results),
        "seeds": [r.seed for r in results],
        "scans": int(sum(r.scans for r in results)),
        "walking_steps": int(sum(r.steps for r in results)),
        "outcomes": {o: sum(r.outcome == o for r in results) for o in outcomes},
        "clear_mot": overall,
        "position_rmse": _rmse(pe),
        "velocity_rmse": _rmse(ve),
        "velocity_rmse_settled": _rmse(ve[age >= SETTLED_AGE - 1e-9]),
        "position_error": _stats(pe),
        "velocity_error": _stats(ve),
        "misses_by_cause": {c: int((cause == i).sum()) for i, c in enumerate(MISS_CAUSES)},
        "static_misses_true_speed": _stats(speed[cause == MISS_CAUSES.index("static")]),
        "switches_by_gap": switch_gaps(results, cfg, tracking),
        "false_positives_by_cause": {
            c: int(sum(r.false_positives[c] for r in results)) for c in FP_CAUSES
        },
        "visibility": {
            "pedestrian_scans": {n: int((cat == i).sum()) for i, n in enumerate(CATEGORY_NAMES)},
            "detected_rate": {n: _rate(det[cat == i]) for i, n in enumerate(CATEGORY_NAMES)},
            "tracked_rate": {n: _rate(trk[cat == i]) for i, n in enumerate(CATEGORY_NAMES)},
        },
        "static_discs": static_disc_summary(results, tracking, detection),
        "by_distance": distance_bins(results),
        "by_hidden_time": hidden_bins(results, cfg, tracking),
        "settings": {
            "match_distance_m": MATCH_DISTANCE,
            "settled_track_age_s": SETTLED_AGE,
            "lidar": dc.asdict(cfg.lidar),
            "scan_period_s": cfg.crowd.dt,
            "pedestrian_radius_m": cfg.crowd.pedestrian_radius,
            "detection": dc.asdict(detection),
            "tracking": dc.asdict(tracking),
            "max_steps": cfg.episode.max_steps,
        },
    }


# -- figure ------------------------------------------------------------------------------


def plot(summary: dict, png: Any, title: str | None = None) -> None:
    """Three panels from `summary` (`summarise`): position error vs distance, track and
    detection rates vs distance by visibility, and what occlusion time does."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.core.palette import DATA_RGB, REFERENCE_RGB, SERIES_RGB, SHADE_RGB

    rows = summary["by_distance"]
    max_range = summary["settings"]["lidar"]["max_range"]

    def series(vis: str, key: str) -> tuple[np.ndarray, np.ndarray]:
        sel = [r for r in rows if r["visibility"] == vis and r[key] is not None]
        x = np.array([(r["distance_from"] + r["distance_to"]) / 2 for r in sel])
        return x, np.array([r[key] for r in sel], dtype=float)

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    ax = axes[0]
    x, med = series("all", "pos_err_median")
    _, p90 = series("all", "pos_err_p90")
    ax.plot(x, 1000 * med, "o-", color=DATA_RGB, label="median")
    ax.plot(x, 1000 * p90, "s--", color=REFERENCE_RGB, label="90th percentile")
    ax.axvspan(max_range, max(DISTANCE_EDGES), color=SHADE_RGB, label="beyond range (coasting)")
    ax.set_yscale("log")
    ax.set(xlabel="distance to the robot [m]", ylabel="position error [mm] (log scale)")
    ax.set_title("Position error of matched pedestrians [mm]")
    ax.legend(fontsize=8, loc="upper left")

    ax = axes[1]
    colours = {
        "visible": SERIES_RGB[0],
        "partly_occluded": SERIES_RGB[4],
        "occluded": SERIES_RGB[3],
        "out_of_range": REFERENCE_RGB,
    }
    for vis, colour in colours.items():
        x, tr = series(vis, "tracked_rate")
        ax.plot(x, tr, "o-", color=colour, label=f"{vis.replace('_', ' ')}: tracked")
        if vis in ("visible", "partly_occluded"):
            x, de = series(vis, "detected_rate")
            ax.plot(x, de, ":", color=colour, label=f"{vis.replace('_', ' ')}: detected")
    ax.axvline(max_range, color=REFERENCE_RGB, lw=0.8)
    ax.set(xlabel="distance to the robot [m]", ylabel="fraction of pedestrian-scans")
    ax.set_ylim(-0.03, 1.03)
    ax.set_title("Pedestrians tracked (a confirmed track ≤ 0.5 m) and detected")
    ax.legend(fontsize=7, loc="lower left")

    ax = axes[2]
    hid = summary["by_hidden_time"]
    x = np.array([r["hidden_s"] for r in hid], dtype=float)
    ax.plot(x, [r["tracked_rate"] for r in hid], "o-", color=DATA_RGB, label="still tracked")
    beams = summary["settings"]["detection"]["min_points"]
    ax.set(xlabel=f"time since it last showed ≥ {beams} beams [s]", ylabel="fraction tracked")
    ax.set_ylim(-0.03, 1.03)
    ax2 = ax.twinx()
    med = [np.nan if r["pos_err_median"] is None else 100 * r["pos_err_median"] for r in hid]
    p90 = [np.nan if r["pos_err_p90"] is None else 100 * r["pos_err_p90"] for r in hid]
    ax2.plot(x, med, "s--", color=SERIES_RGB[4], label="error, median [cm]")
    ax2.plot(x, p90, "^:", color=SERIES_RGB[3], label="error, 90th pct [cm]")
    ax2.set(ylabel="position error of the tracked [cm]", ylim=(0, None))
    coast = summary["settings"]["tracking"]["max_coast"]
    ax.axvline(coast, color=REFERENCE_RGB, lw=0.8)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="lower left")
    last = hid[-1] if hid else None
    if last is not None and str(last["scans_hidden"]).startswith(">="):
        ax.annotate(
            f"≥ {last['hidden_s']:g} s:\ndeleted",
            (last["hidden_s"], last["tracked_rate"]),
            xytext=(-14, 100),
            textcoords="offset points",
            ha="right",
            fontsize=8,
            arrowprops={"arrowstyle": "->", "color": REFERENCE_RGB},
        )
    ax.set_title(f"Occluded pedestrians that were tracked (coast limit {coast:g} s)")
    m = summary["clear_mot"]
    fig.suptitle(
        title
        or (
            f"LiDAR tracker on {summary['episodes']} LIP episodes (MPC), {summary['scans']} "
            f"scans: MOTA {m['mota']:.3f}, MOTP {100 * m['motp']:.1f} cm, "
            f"{m['num_switches']} ID switches"
        )
    )
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def csv_rows(rows: Sequence[dict]) -> str:
    """`rows` (dicts with the same keys) as CSV text with a header; None → empty."""
    if not rows:
        return ""
    keys = list(rows[0])

    def cell(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, float):
            return f"{v:.6g}"
        return str(v)

    lines = [",".join(keys)] + [",".join(cell(r[k]) for k in keys) for r in rows]
    return "\n".join(lines) + "\n"


def _f(v: float | None, spec: str, scale: float = 1.0) -> str:
    """`v · scale` formatted with `spec`; "–" for None (nothing to measure)."""
    return "–" if v is None else format(scale * v, spec)


def _n(v: int) -> str:
    """An integer with thin-space thousands (the docs' style: 24 040)."""
    return f"{int(v):,}".replace(",", " ")


def tables_md(summary: dict) -> str:
    """The study's tables as Markdown (`tables.md` of a run directory; the docs quote its
    sections with `evaluation/results_doc.py`)."""
    m, s = summary["clear_mot"], summary
    seeds = s["seeds"]
    matched = m["num_matches"] + m["num_switches"]
    objects = m["num_objects"]
    mc, fc, sw = s["misses_by_cause"], s["false_positives_by_cause"], s["switches_by_gap"]
    pe, ve = s["position_error"], s["velocity_error"]
    coast = s["settings"]["tracking"]["max_coast"]
    still = s["settings"]["tracking"]["still_duration"]
    outcomes = ", ".join(f"{k} {v}" for k, v in s["outcomes"].items())

    def pct(a: float, b: float) -> str:
        return f"{100 * a / b:.1f} %" if b else "–"

    def rate(v: float | None) -> str:
        return _f(v, ".3f")

    lines = [
        "# The LiDAR tracker against the true crowd",
        "",
        f"- episodes: {s['episodes']} LIP episodes, the {s.get('planner', 'mpc').upper()} "
        f"on the true crowd, seeds {seeds[0]}–{seeds[-1]} ({outcomes})",
        f"- scans: {_n(s['scans'])} (one per {s['settings']['scan_period_s']:g} s); "
        f"pedestrian-scans {_n(objects)}, {m['num_unique_objects']} pedestrians",
        f"- match: Euclidean distance ≤ {s['settings']['match_distance_m']:g} m "
        "(py-motmetrics CLEAR-MOT)",
    ]
    if "command" in s:
        lines.append(f"- command: `{s['command']}`")
    lines += [
        "",
        "## Tracking quality",
        "",
        "| metric | value |",
        "|---|---|",
        f"| MOTA | {_f(m['mota'], '.3f')} |",
        f"| MOTP (mean distance of the matched pairs) | {_f(m['motp'], '.1f', 1000)} mm |",
        f"| IDF1 | {_f(m['idf1'], '.3f')} |",
        f"| ID switches: swap / re-acquired within {coast:g} s / after the track's deletion "
        f"| {m['num_switches']}: {sw['swap']} / {sw['reacquired']} / {sw['after_deletion']} |",
        f"| pedestrian-scans matched | {_n(matched)} of {_n(objects)} ({pct(matched, objects)}) |",
        "| missed (FN): out of range / occluded / before confirmation / standing, "
        "reported as a static obstacle / other "
        f"| {_n(m['num_misses'])} ({pct(m['num_misses'], objects)}): "
        f"{_n(mc['out_of_range'])} / {_n(mc['occluded'])} / {_n(mc['unconfirmed'])} / "
        f"{_n(mc['static'])} / {_n(mc['other'])} |",
        "| false pedestrians (FP): static disc before its still time / track coasting / other "
        f"| {_n(m['num_false_positives'])} ({pct(m['num_false_positives'], objects)}): "
        f"{_n(fc['static_disc'])} / {_n(fc['coasting'])} / {_n(fc['other'])} |",
        f"| position error of the matched: RMSE / median / 90th percentile "
        f"| {_f(s['position_rmse'], '.1f', 100)} cm / {_f(pe['median'], '.1f', 1000)} mm / "
        f"{_f(pe['p90'], '.1f', 1000)} mm |",
        f"| velocity error of the matched: RMSE / median / 90th percentile "
        f"| {_f(s['velocity_rmse'], '.3f')} / {_f(ve['median'], '.3f')} / "
        f"{_f(ve['p90'], '.3f')} m/s |",
        f"| velocity RMSE of tracks older than {s['settings']['settled_track_age_s']:g} s "
        f"| {_f(s['velocity_rmse_settled'], '.3f')} m/s |",
        f"| fragmentations; pedestrians mostly tracked / partly / mostly lost "
        f"| {m['num_fragmentations']}; {m['mostly_tracked']} / {m['partially_tracked']} / "
        f"{m['mostly_lost']} |",
        "",
        "## Visibility",
        "",
        "| pedestrian-scans | count | share | detected | tracked |",
        "|---|---|---|---|---|",
    ]
    vis = s["visibility"]
    for name in CATEGORY_NAMES:
        c = vis["pedestrian_scans"][name]
        lines.append(
            f"| {name.replace('_', ' ')} | {_n(c)} | {pct(c, objects)} | "
            f"{rate(vis['detected_rate'][name])} | {rate(vis['tracked_rate'][name])} |"
        )
    d = s["static_discs"]
    lines += [
        "",
        "## Static discs",
        "",
        "| static discs | seen | reported as static | delay from first seen, median / max "
        f"| disc-scans from {still:g} s after first seen | reported static among them |",
        "|---|---|---|---|---|---|",
        f"| {d['discs']} | {d['seen']} | {d['reported_static']} | "
        f"{_f(d['delay_s']['median'], '.1f')} / {_f(d['delay_s']['max'], '.1f')} s | "
        f"{_n(d['scans_after_still_time'])} | {rate(d['reported_after_still_time'])} |",
        "",
    ]
    return "\n".join(lines)
