"""Faces → tracked pedestrians by bearing, with a pinhole camera model.

`face_bearings` turns face boxes (x, y, w, h) [px] into bearings [rad] (counter-clockwise
positive, relative to the robot's heading when the camera's yaw is given; Drake
`CameraInfo` pixel convention), and `assign_faces` gives each face the pedestrian whose
bearing matches best within a gate, greedily, each pedestrian taking at most one face.
"""

from __future__ import annotations

import numpy as np


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


def pedestrian_bearings(
    positions: np.ndarray,
    robot_xy: np.ndarray,
    heading: float,
    camera_yaw: float,
    half_fov: float,
    max_range: float,
    radius: float,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bearing [rad] or NaN when the camera cannot see it, distance [m], gate [rad]) of
    each pedestrian at `positions` (P, 2) [m, world], for a camera at `robot_xy` whose
    optical axis is `camera_yaw` off the robot's `heading` [rad]. Bearings are relative
    to the heading (as `face_bearings` with that yaw); the gate is the pedestrian's
    angular radius (`radius` [m]) plus `tolerance` [rad]; a pedestrian farther than
    `max_range` [m] or more than `half_fov` + its gate off the axis is not seen."""
    d = np.asarray(positions, dtype=float).reshape(-1, 2) - np.asarray(robot_xy, dtype=float)
    dist = np.hypot(d[:, 0], d[:, 1])
    rel = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - heading - camera_yaw)))
    gate = np.arctan2(radius, np.maximum(dist, 1e-6)) + tolerance
    visible = (dist <= max_range) & (np.abs(rel) <= half_fov + gate)
    return np.where(visible, rel + camera_yaw, np.nan), dist, gate


def assign_faces(
    face_bearing: np.ndarray,
    pedestrian_bearing: np.ndarray,
    pedestrian_distance: np.ndarray,
    gate: np.ndarray,
    allowed: np.ndarray | None = None,
) -> np.ndarray:
    """Pedestrian index of each face (−1: none), greedily by smallest bearing error.

    A face may go to pedestrian p only if |bearing difference| ≤ gate[p] (and
    `allowed[f, p]`, when given: e.g. a range gate); each pedestrian takes at most one
    face. Pairs are taken in order of bearing error, ties to the nearer pedestrian (the
    one more likely to show its face).

    Args:
        face_bearing: (F,) [rad].
        pedestrian_bearing: (P,) [rad], in the same frame; NaN for pedestrians that
            cannot be seen (behind, out of range).
        pedestrian_distance: (P,) [m].
        gate: (P,) largest accepted bearing error [rad].
        allowed: (F, P) bool, pairs that other evidence permits (None: all).
    """
    fb = np.asarray(face_bearing, dtype=float).reshape(-1)
    pb = np.asarray(pedestrian_bearing, dtype=float).reshape(-1)
    out = np.full(fb.size, -1, dtype=np.int64)
    if fb.size == 0 or pb.size == 0:
        return out
    err = np.abs(np.angle(np.exp(1j * (fb[:, None] - pb[None, :]))))
    ok = np.isfinite(err) & (err <= np.asarray(gate, dtype=float)[None, :])
    if allowed is not None:
        ok &= np.asarray(allowed, dtype=bool).reshape(ok.shape)
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
