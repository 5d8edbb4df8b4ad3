"""Emotion known when it matters: what the robot believed of each person as they came close.

A discomfort zone only matters once the robot is near it. For each pedestrian of an
episode (`EpisodeTrace` with its `perceived` column), the *approach* is the first planner
instant at which the robot comes within that pedestrian's true discomfort distance + 1 m
(`APPROACH_MARGIN`) of the pedestrian's surface, i.e. the gap of the zone test of
`navigation/reward.py` (centre distance − pedestrian radius < d + robot radius) widened by the
margin. At that instant the sample records the true emotion, the emotion the planner's
crowd gave that pedestrian (−1: not perceived at all) and whether its face could have been
seen before: at some classification instant up to then (every `period` s) the pedestrian
was in the camera's field of view, within its range, and turned at most `max_yaw` from the
camera (its heading taken from its motion over the step; a pedestrian that did not move
is not counted as seen). Occlusion is not modelled, so "could have been seen" is an upper
bound. Pedestrians the robot never approaches give no sample.

Pure numpy; angles in radians, distances in metres, times in seconds.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.navigation.episode_trace import EpisodeTrace

APPROACH_MARGIN = 1.0  # [m] added to a pedestrian's discomfort distance: "close"


@dc.dataclass(frozen=True)
class CameraView:
    """Where the head camera can see a face: half its horizontal field of view [rad], its
    range [m], the largest head yaw from it at which a face is found [rad], and the
    classification period [s]."""

    half_fov: float
    max_range: float = 6.0
    max_yaw: float = math.radians(45.0)
    period: float = 2.0


def approach_samples(
    trace: EpisodeTrace,
    emotion_distances: np.ndarray,
    pedestrian_radius: float,
    robot_radius: float,
    camera: CameraView,
    margin: float = APPROACH_MARGIN,
) -> list[dict]:
    """One dict per approached pedestrian (module docstring): pedestrian, t, true,
    perceived (−1: not perceived), known (perceived == true), face_seen_before."""
    if not trace.perceived or any(
        len(p) != len(e) for p, e in zip(trace.perceived, trace.emotions, strict=True)
    ):
        raise ValueError("the trace has no perceived emotions (EpisodeRequest(trace=True))")
    dist = np.asarray(emotion_distances, dtype=float).reshape(-1)
    robot = np.asarray(trace.robot, dtype=float).reshape(-1, 4)
    t = np.asarray(trace.t, dtype=float)
    peds = [np.asarray(p, dtype=float).reshape(-1, 2) for p in trace.pedestrians]
    num = len(peds[0]) if peds else 0
    seen = _face_visible(robot, peds, t, camera)  # (rows, P)
    out = []
    for i in range(num):
        for r in range(len(t)):
            gap = math.hypot(*(peds[r][i] - robot[r, :2])) - pedestrian_radius
            true = int(trace.emotions[r][i])
            if gap < dist[true] + robot_radius + margin:
                perceived = int(trace.perceived[r][i])
                out.append(
                    {
                        "pedestrian": i,
                        "t": float(t[r]),
                        "true": true,
                        "perceived": perceived,
                        "known": perceived == true,
                        "face_seen_before": bool(seen[: r + 1, i].any()),
                    }
                )
                break
    return out


def _face_visible(
    robot: np.ndarray, peds: list[np.ndarray], t: np.ndarray, camera: CameraView
) -> np.ndarray:
    """(rows, P) bool: at a classification instant, in view, in range, facing the camera."""
    rows = len(t)
    num = len(peds[0]) if peds else 0
    out = np.zeros((rows, num), dtype=bool)
    for r in range(rows):
        phase = t[r] / camera.period
        if abs(phase - round(phase)) > 1e-6:
            continue
        a, b = (r, r + 1) if r + 1 < rows else (r - 1, r)
        if a < 0:
            continue
        motion = peds[b] - peds[a]
        moving = np.hypot(motion[:, 0], motion[:, 1]) > 1e-3
        heading = np.arctan2(motion[:, 1], motion[:, 0])
        rel = peds[r] - robot[r, :2]
        d = np.hypot(rel[:, 0], rel[:, 1])
        bearing = np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - robot[r, 2])))
        to_camera = np.arctan2(-rel[:, 1], -rel[:, 0])
        yaw = np.abs(np.angle(np.exp(1j * (to_camera - heading))))
        out[r] = (
            moving
            & (d <= camera.max_range)
            & (np.abs(bearing) <= camera.half_fov)
            & (yaw <= camera.max_yaw)
        )
    return out


def summarise_approaches(samples: list[dict]) -> dict:
    """Shares known: over all approaches, per true emotion, and among those whose face
    could have been seen before; with their counts."""

    def share(rows: list[dict]) -> dict:
        n = len(rows)
        k = sum(r["known"] for r in rows)
        return {"known": k, "n": n, "share": (k / n) if n else None}

    by = {code: [s for s in samples if s["true"] == code] for code in (0, 1, 2)}
    seen = [s for s in samples if s["face_seen_before"]]
    return {
        "all": share(samples),
        "happy": share(by[0]),
        "neutral": share(by[1]),
        "negative": share(by[2]),
        "non_neutral_face_seen": share([s for s in seen if s["true"] != 1]),
        "face_seen_before": share(seen),
        "never_perceived": sum(s["perceived"] < 0 for s in samples),
    }
