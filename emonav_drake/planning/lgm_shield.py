"""A safety shield on a categorical policy that reads only the policy's own LGM.

Not part of the paper's method: an optional layer between a learned policy and the
walking controller (`planners/shield.py`). At each walking step it

1. reads the obstacles the robot sees from the newest LGM frame: every collision cell
   (value 255: a real LiDAR hit) becomes a point in the robot frame, at the angle of its
   sector's centre and the near edge of its ring (`lgm_hit_points`);
2. predicts, for every command of the policy's grid, where the CoM goes if the robot
   walks this step with that command and then stops: `brake_steps` steps of (0, 0)
   (the LIP of Eq. 1, or the fitted step response of the full-order robot, which answers
   a command a step late);
3. keeps the commands whose predicted CoM stays at least r_robot + `margin` from every
   point, and walks the one the policy scores highest among them; when none is, the one
   whose path keeps the largest gap (`shield_choice`).

The points are treated as still: a pedestrian's motion during the prediction is what
`margin` covers. With `static_margin` set, a point that was seen (within `static_match`,
in the world frame, after the robot's own motion) in the previous walking step's frame
counts as still and keeps only `static_margin`; the rest, and every point of the same
body (a chain of points closer than `body`), keep `margin` (`moving_points`). The
robot's pose at the foot switch places both frames in the world.

With `comfort_weight` > 0 the shield also prefers, among the admissible commands, those
whose path stays out of the still points' discomfort zones (d_static beyond the robot's
radius, as for a static disc): each command's score loses `comfort_weight` per metre the
path reaches into them (`zone_intrusion`).

A stop is the safe end of every prediction because a pedestrian who walks faster than
the robot sees it and steers round it (the crowd's visibility rule): a standing robot is
seen by every moving pedestrian. The shield never sees the crowd state, the emotions or
the map of the discs; only the LGM the policy reads.
"""

from __future__ import annotations

import dataclasses as dc
from functools import lru_cache

import numpy as np

from emonav_drake.config_fields import setting
from emonav_drake.planning.nearby_labels import restricted_softmax
from emonav_drake.sensing.grid_maps import COLLISION_VALUE, check_beams_per_sector
from emonav_drake.sensing.lidar import beam_table


@dc.dataclass(frozen=True)
class ShieldParams:
    """The shield's settings.

    Attributes:
        margin: clearance kept beyond the robot's radius from every seen LiDAR hit along
            the predicted path [m]; covers the pedestrians' motion during it.
        brake_steps: walking steps of (u_v, u_Δθ) = (0, 0) after the command's step in
            the prediction (the robot must be able to stop clear).
        static_margin: None: `margin` for every point; else the clearance [m] kept from
            points seen still since the previous walking step.
        static_match: a point within this distance [m] of one of the previous frame's
            (world frame) counts as still; covers the LGM's cell size.
        body: points closer than this [m] to a moving point move with it (one body).
        predict_motion: move each moving body's points along the path's samples at the
            body's measured velocity (`body_velocities`) instead of holding them still.
        max_body_speed: the fastest a body may have moved between two frames [m/s] to be
            matched with one of the previous frame.
        comfort_weight: score penalty [1/m] per metre the predicted path reaches into the
            discomfort zone of still points (radius r_robot + d_static around each); 0: off.
            Needs `static_margin` (the still/moving split).
    """

    margin: float = setting(
        0.2,
        "clearance kept beyond the robot's radius from every seen LiDAR hit along the predicted "
        "path [m]; covers the pedestrians' motion during it",
        "m",
    )
    brake_steps: int = setting(
        1,
        "walking steps of (u_v, u_Δθ) = (0, 0) after the command's step in the prediction (the "
        "robot must be able to stop clear)",
    )
    static_margin: float | None = setting(
        0.0,
        "None: `margin` for every point; else the clearance [m] kept from points seen still since"
        " the previous walking step",
        "m",
    )
    static_match: float = setting(
        0.12,
        "a point within this distance [m] of one of the previous frame's (world frame) counts as "
        "still; covers the LGM's cell size",
        "m",
    )
    body: float = setting(
        0.25,
        "points closer than this [m] to a moving point move with it (one body)",
        "m",
    )
    predict_motion: bool = setting(
        False,
        "move each moving body's points along the path's samples at the body's measured velocity "
        "(`body_velocities`) instead of holding them still",
    )
    max_body_speed: float = setting(
        1.5,
        "the fastest a body may have moved between two frames [m/s] to be matched with one of the"
        " previous frame",
        "m/s",
    )
    comfort_weight: float = setting(
        0.0,
        "score penalty [1/m] per metre the predicted path reaches into the discomfort zone of "
        "still points (radius r_robot + d_static around each); 0: off. Needs `static_margin` (the"
        " still/moving split)",
        "1/m",
    )

    def __post_init__(self) -> None:
        if self.comfort_weight and self.static_margin is None:
            raise ValueError("comfort_weight needs static_margin (which points are still)")
        for name in ("margin", "static_match", "body", "max_body_speed", "comfort_weight") + (
            ("static_margin",) if self.static_margin is not None else ()
        ):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0.0):
                unit = "1/m" if name == "comfort_weight" else "m"
                raise ValueError(f"shield {name} must be a finite number >= 0 {unit}, got {v}")
        if not isinstance(self.brake_steps, int) or self.brake_steps < 0:
            raise ValueError(f"brake_steps must be an int >= 0, got {self.brake_steps!r}")


@lru_cache(maxsize=8)
def _sector_geometry(num_beams: int, grid_size: int) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) (M,) of each LGM sector's central direction (robot frame)."""
    per = check_beams_per_sector(num_beams, grid_size)
    angles = beam_table(num_beams)[0].reshape(grid_size, per).mean(axis=1)
    return np.cos(angles), np.sin(angles)


def lgm_hit_points(frame: np.ndarray, num_beams: int, max_range: float) -> np.ndarray:
    """The collision cells (255) of one LGM frame as points (n, 2) in the robot frame [m]
    (x forward, y left): each at its sector's central angle and its ring's near edge."""
    f = np.asarray(frame)
    if f.ndim != 2 or f.shape[0] != f.shape[1]:
        raise ValueError(f"an LGM frame is a square (M, M) array, got shape {f.shape}")
    m = f.shape[0]
    cos, sin = _sector_geometry(num_beams, m)
    rows, cols = np.nonzero(f == COLLISION_VALUE)
    ranges = cols * (max_range / m)
    return np.stack([ranges * cos[rows], ranges * sin[rows]], axis=1)


def brake_plans(candidates: np.ndarray, brake_steps: int) -> np.ndarray:
    """Plans (C, 1 + brake_steps, 2): each candidate command (C, 2), then stop."""
    cand = np.asarray(candidates, float).reshape(-1, 2)
    plans = np.zeros((len(cand), 1 + brake_steps, 2))
    plans[:, 0] = cand
    return plans


def path_gaps(
    paths: np.ndarray,
    points: np.ndarray,
    margins: np.ndarray | None = None,
    velocities: np.ndarray | None = None,
    times: np.ndarray | None = None,
) -> np.ndarray:
    """Smallest distance (C,) [m] from each predicted CoM path (C, S, 2) to the points
    (n, 2), less each point's own extra margin (n,) [m] when given; +inf where there are
    no points. With `velocities` (n, 2) [m/s] and the samples' `times` (S,) [s], point i
    is at points[i] + velocities[i]·t at each sample."""
    if len(points) == 0:
        return np.full(len(paths), np.inf)
    pts = np.asarray(points, float)[None, None]
    if velocities is not None:
        pts = (
            pts + np.asarray(times, float)[None, :, None, None] * np.asarray(velocities)[None, None]
        )
    d = np.sqrt(((paths[:, :, None, :] - pts) ** 2).sum(-1))
    if margins is not None:
        d = d - np.asarray(margins, float)[None, None]
    return d.min(axis=(1, 2))


def zone_intrusion(paths: np.ndarray, points: np.ndarray, reach: float) -> np.ndarray:
    """How deep (C,) [m] each predicted CoM path (C, S, 2) reaches into the zones of radius
    `reach` [m] around the points (n, 2): max(0, reach − the path's smallest distance to a
    point); 0 where there are no points."""
    return np.maximum(0.0, reach - path_gaps(paths, points))


def to_world(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Robot-frame points (n, 2) at pose (x [m], y [m], θ [rad]) in the world frame."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    p = np.asarray(points, float)
    return np.stack([pose[0] + c * p[:, 0] - s * p[:, 1], pose[1] + s * p[:, 0] + c * p[:, 1]], 1)


def body_labels(points: np.ndarray, body: float) -> np.ndarray:
    """(n,) int: the connected groups of points (n, 2) joined by chains of points less than
    `body` [m] apart, numbered 0, 1, … in the order of their first point."""
    n = len(points)
    labels = np.full(n, -1)
    if n == 0:
        return labels
    near = ((points[:, None, :] - points[None]) ** 2).sum(-1) < body**2
    current = 0
    for i in range(n):
        if labels[i] >= 0:
            continue
        member = np.zeros(n, bool)
        member[i] = True
        while True:
            grown = member | near[:, member].any(axis=1)
            if (grown == member).all():
                break
            member = grown
        labels[member] = current
        current += 1
    return labels


def body_velocities(
    world: np.ndarray, previous: np.ndarray, body: float, step_time: float, max_speed: float
) -> np.ndarray:
    """(n, 2) [m/s]: for each point (world frame) its body's velocity — the displacement of
    the body's centroid from the nearest body centroid of the previous frame, over
    `step_time`; zero when none is within max_speed · step_time."""
    out = np.zeros((len(world), 2))
    if len(world) == 0 or previous is None or len(previous) == 0:
        return out
    prev = np.asarray(previous, float)
    lab, lab_prev = body_labels(world, body), body_labels(prev, body)
    c_prev = np.array([prev[lab_prev == j].mean(axis=0) for j in range(lab_prev.max() + 1)])
    for j in range(lab.max() + 1):
        c = world[lab == j].mean(axis=0)
        jump = np.linalg.norm(c_prev - c, axis=1)
        k = int(np.argmin(jump))
        if jump[k] <= max_speed * step_time:
            out[lab == j] = (c - c_prev[k]) / step_time
    return out


def moving_points(
    world: np.ndarray, previous: np.ndarray | None, match: float, body: float = 0.0
) -> np.ndarray:
    """(n,) bool: which points (world frame) move: those with no point of the previous
    frame within `match` [m] (all of them when there is no previous frame), and every point
    joined to a moving one by a chain of points less than `body` [m] apart (the seen side
    of one body moves as a whole, though part of it may fall where it was seen before)."""
    if previous is None or len(previous) == 0 or len(world) == 0:
        return np.ones(len(world), bool)
    d2 = ((world[:, None, :] - np.asarray(previous, float)[None]) ** 2).sum(-1)
    moving = d2.min(axis=1) > match**2
    if body > 0.0 and moving.any() and not moving.all():
        labels = body_labels(world, body)
        moving = np.isin(labels, labels[moving])
    return moving


def shield_distribution(scores: np.ndarray, gaps: np.ndarray, clearance: float) -> np.ndarray:
    """The shield as a distribution over the candidates (C,): softmax(`scores`) restricted to
    those whose gap is at least `clearance` [m] and renormalised — its argmax is
    `shield_choice`'s —, or, when none is admissible, all mass on `shield_choice`'s
    candidate. A distilled student learns this (`DaggerConfig.soft_labels`)."""
    s, g = np.asarray(scores, float), np.asarray(gaps, float)
    ok = g >= clearance
    if not ok.any():
        out = np.zeros(len(s))
        out[shield_choice(s, g, clearance)[0]] = 1.0
        return out
    return restricted_softmax(s, ok)


def shield_choice(scores: np.ndarray, gaps: np.ndarray, clearance: float) -> tuple[int, bool]:
    """(index, whether it was admissible): the best-scored candidate whose gap is at least
    `clearance` [m]; if none is, the one with the largest gap (ties: the better score)."""
    s, g = np.asarray(scores, float), np.asarray(gaps, float)
    ok = g >= clearance
    if ok.any():
        return int(np.argmax(np.where(ok, s, -np.inf))), True
    best = np.flatnonzero(g == g.max())
    return int(best[np.argmax(s[best])]), False
