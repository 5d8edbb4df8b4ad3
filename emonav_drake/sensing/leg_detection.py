"""People in a LiDAR scan that sees legs: leg clusters paired into people (numpy only).

A planar LiDAR at leg height sees a walking person as two small arcs, a few centimetres to
half a metre apart, whose spacing changes with every step (`crowd/pedestrian_legs.py`).
The disc detector of `sensing/lidar_objects.py` would fit each leg as an object of its own
(too small for a circle: two fallback discs of a pedestrian's radius that jump with the
gait). With `DetectionParams.legs` on (`detection_params` turns it on for a sensor with
`people_as: legs`; `sensing/crowd_tracker.py::tracker_params` widens the tracker's σ),
`detect_scan` takes the clusters of `sensing/lidar_objects.py` (steps 1-2 there, with
``max_missing_beams`` lost beams bridged inside a cluster — dropouts at a leg's grazing
edges would otherwise cut it — and lone spurious returns despeckled) and goes on here:

1. Clusters with fewer than ``leg_min_points`` beams are dropped (a spurious return, a
   mixed pixel on its own).
2. Walls are split off and cut into fixed pieces as in `sensing/lidar_objects.py` (step 4).
3. Every other cluster is classified by its width w (first point to last):
   * w ≤ ``leg_max_width``: **a leg**;
   * w ≤ 2 · ``leg_max_width`` with a **notch** — an inner point farther from the LiDAR
     than the nearest point on each side of it by more than ``leg_notch``, splitting it
     into two parts at most ``leg_max_width`` wide — **two legs** (one partly behind the
     other: a disc's range profile has no such dip, it is nearest in the middle);
   * otherwise **an object**: its circle (`fit_circles`); an accepted fit (radius in
     [min_radius, max_radius], RMS within tolerance) is larger than any leg and is not a
     person: flagged fixed (`Detections.walls`), so the tracker makes it a static
     obstacle at once instead of a pedestrian for its first ``still_duration``. A
     rejected fit keeps the fallback disc, unflagged. A leg whose points lie on an
     accepted circle (median distance ≤ `ON_CIRCLE_TOLERANCE`) is a piece of that object
     cut off by lost beams at its grazing edge, and is dropped.
   A whole-cluster "leg" of at least ``min_fit_points`` beams whose circle fit is
   accepted with a radius of at least `SLIVER_MIN_RADIUS` (0.18 m) is a sliver of a
   partly hidden object, not a leg (a leg's 0.07 m arc fails the fit's 0.1 m minimum):
   it joins the objects.
4. A leg's centre lies ``leg_radius`` behind the mean of its points along the line of
   sight. Legs are **paired** greedily, nearest centres first, while at most
   ``leg_pair_distance`` apart; each pair is one person at the midpoint of its legs (the
   pedestrian's centre, by the model's symmetry), a leg left alone a person at its own
   centre (the other leg hidden behind it or lost: up to 0.22 m off). A person's radius is
   ``prior_radius``.

Detections are reported by the first beam of their clusters, as `detect_objects` does.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.lidar_objects import (
    DetectionParams,
    Detections,
    _split_walls,
    checked_scan,
    detect_objects,
    fit_circles,
    segment_scan,
)

# A "leg" cluster whose circle fits with at least this radius is a sliver of an object [m].
SLIVER_MIN_RADIUS = 0.18
# A leg cluster whose points lie this close to a fitted object's circle is part of it [m].
ON_CIRCLE_TOLERANCE = 0.05


def detect_scan(
    ranges: np.ndarray,
    robot_xy: np.ndarray,
    heading: float,
    max_range: float,
    params: DetectionParams,
) -> Detections:
    """The detector of `params`: people as paired legs (``legs`` on, `detect_people`) or
    `sensing/lidar_objects.py::detect_objects`; the same arguments and result."""
    if not params.legs:
        return detect_objects(ranges, robot_xy, heading, max_range, params)
    r, origin, heading, max_range = checked_scan(ranges, robot_xy, heading, max_range, params)
    seg = segment_scan(r, origin, heading, max_range, params)
    if seg is None:
        return Detections.empty()
    return detect_people(seg, origin, params)


def detection_params(config: EmoNavConfig) -> DetectionParams:
    """The detector for the configured sensor: legs on when it sees people as legs."""
    if config.sensor.people_as == "legs":
        return DetectionParams(legs=True, max_missing_beams=2, despeckle=True)
    return DetectionParams()


def detect_people(
    seg: tuple[np.ndarray, ...], origin: tuple[float, float], params: DetectionParams
) -> Detections:
    """People (paired legs), wall pieces and objects from the clusters of one scan.

    Args:
        seg: `sensing/lidar_objects.py::segment_scan`'s ``(px, py, beams, order, starts,
            counts)``: world points [m] and beam indices of the hits, clusters end to end.
        origin: the LiDAR's position (2,) [m], world frame.
        params: the detector's parameters (``legs`` on).

    Returns:
        `Detections` (world frame), ordered by the first beam of each.
    """
    px, py, beams, order, starts, counts = seg
    big = counts >= params.leg_min_points
    if not big.any():
        return Detections.empty()
    order = order[np.repeat(big, counts)]
    counts = counts[big]
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    x, y = px[order], py[order]
    wall_params = dc.replace(params, min_points=params.leg_min_points)
    split = _split_walls(x, y, starts, counts, wall_params)
    out_c: list[np.ndarray] = []
    out_r: list[float] = []
    out_n: list[int] = []
    out_fixed: list[bool] = []
    out_first: list[int] = []
    if split is not None:
        keep, counts, piece_c, piece_r, piece_n, piece_first = split
        out_c += list(piece_c)
        out_r += piece_r.tolist()
        out_n += piece_n.tolist()
        out_fixed += [True] * len(piece_r)
        out_first += beams[order[piece_first]].tolist()
        order = order[keep]
        x, y = px[order], py[order]
        starts = (np.cumsum(counts) - counts).astype(np.intp)

    ox, oy = origin
    legs: list[tuple[int, int]] = []  # (start, stop) in x, y of each leg's points
    objects: list[int] = []  # clusters that are objects
    whole: list[int] = []  # per leg: its cluster, or -1 (half of a split cluster)
    for j in range(counts.size):
        a, b = int(starts[j]), int(starts[j] + counts[j])
        width = math.hypot(x[b - 1] - x[a], y[b - 1] - y[a])
        if width <= params.leg_max_width:
            legs.append((a, b))
            whole.append(j)
            continue
        if width <= 2.0 * params.leg_max_width:
            cut = _notch(x[a:b], y[a:b], (ox, oy), params)
            if cut is not None:
                legs += [(a, a + cut), (a + cut + 1, b)]
                whole += [-1, -1]
                continue
        objects.append(j)

    legs, slivers = _without_slivers(x, y, legs, whole, origin, params)
    if objects or slivers:
        objects = sorted(objects + slivers)
        sel = np.asarray(objects)
        idx = np.concatenate([np.arange(starts[j], starts[j] + counts[j]) for j in objects])
        o_counts = counts[sel]
        o_starts = np.concatenate(([0], np.cumsum(o_counts)[:-1]))
        centers, radii, ok = fit_circles(x[idx], y[idx], o_starts, o_counts, origin, params)
        out_c += list(centers)
        out_r += radii.tolist()
        out_n += o_counts.tolist()
        out_fixed += ok.tolist()
        out_first += beams[order[starts[sel]]].tolist()
        # A "leg" on a fitted object's circle is a piece of that object that lost beams
        # in between (dropouts at its grazing edge): not a person.
        legs = [
            (a, b)
            for a, b in legs
            if not _on_circle(x[a:b], y[a:b], centers[ok], radii[ok], ON_CIRCLE_TOLERANCE)
        ]

    if legs:
        centers = np.array([_leg_center(x[a:b], y[a:b], (ox, oy), params) for a, b in legs])
        firsts = np.array([beams[order[a]] for a, _ in legs])
        sizes = np.array([b - a for a, b in legs])
        for group in _pairs(centers, params.leg_pair_distance):
            out_c.append(centers[group].mean(axis=0))
            out_r.append(params.prior_radius)
            out_n.append(int(sizes[group].sum()))
            out_fixed.append(False)
            out_first.append(int(firsts[group].min()))

    if not out_r:
        return Detections.empty()
    rank = np.argsort(np.asarray(out_first), kind="stable")
    return Detections(
        np.asarray(out_c, dtype=np.float64).reshape(-1, 2)[rank],
        np.asarray(out_r, dtype=np.float64)[rank],
        np.asarray(out_n, dtype=np.int64)[rank],
        np.asarray(out_fixed, dtype=bool)[rank],
    )


def _without_slivers(
    x: np.ndarray,
    y: np.ndarray,
    legs: list[tuple[int, int]],
    whole: list[int],
    origin: tuple[float, float],
    params: DetectionParams,
) -> tuple[list[tuple[int, int]], list[int]]:
    """The legs that are legs, and the clusters among them that are slivers of objects: a
    whole-cluster "leg" with ``min_fit_points`` beams whose circle fit is accepted with a
    radius of at least `SLIVER_MIN_RADIUS` (a leg's arc has 0.07 m: its fit is rejected)."""
    cand = [
        i
        for i, j in enumerate(whole)
        if j >= 0 and legs[i][1] - legs[i][0] >= params.min_fit_points
    ]
    if not cand:
        return legs, []
    idx = np.concatenate([np.arange(*legs[i]) for i in cand])
    counts = np.array([legs[i][1] - legs[i][0] for i in cand])
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    _, radii, ok = fit_circles(x[idx], y[idx], starts, counts, origin, params)
    sliver = ok & (radii >= SLIVER_MIN_RADIUS)
    drop = {cand[k] for k in np.flatnonzero(sliver).tolist()}
    return [leg for i, leg in enumerate(legs) if i not in drop], sorted(whole[i] for i in drop)


def _on_circle(
    x: np.ndarray, y: np.ndarray, centers: np.ndarray, radii: np.ndarray, tolerance: float
) -> bool:
    """Whether the points (x, y) [m] lie on one of the circles (median distance to it at
    most `tolerance` [m])."""
    for c, r in zip(centers, radii, strict=True):
        if np.median(np.abs(np.hypot(x - c[0], y - c[1]) - r)) <= tolerance:
            return True
    return False


def _notch(
    x: np.ndarray, y: np.ndarray, origin: tuple[float, float], params: DetectionParams
) -> int | None:
    """The inner point of a cluster that splits it into two legs (module docstring, step
    3), or None. Each side keeps at least two points and is at most ``leg_max_width``."""
    n = x.size
    if n < 5:
        return None
    r = np.hypot(x - origin[0], y - origin[1])
    left = np.minimum.accumulate(r)  # nearest point up to each index
    right = np.minimum.accumulate(r[::-1])[::-1]
    k = np.arange(2, n - 2)
    depth = r[k] - np.maximum(left[k - 1], right[k + 1])
    best = int(k[np.argmax(depth)])
    if depth.max() <= params.leg_notch:
        return None
    w_left = math.hypot(x[best - 1] - x[0], y[best - 1] - y[0])
    w_right = math.hypot(x[-1] - x[best + 1], y[-1] - y[best + 1])
    if max(w_left, w_right) > params.leg_max_width:
        return None
    return best


def _leg_center(
    x: np.ndarray, y: np.ndarray, origin: tuple[float, float], params: DetectionParams
) -> np.ndarray:
    """A leg's centre: ``leg_radius`` behind the mean of its points, along the line of
    sight from `origin` [m]."""
    mx, my = float(x.mean()), float(y.mean())
    dx, dy = mx - origin[0], my - origin[1]
    norm = max(math.hypot(dx, dy), 1e-12)
    return np.array([mx + params.leg_radius * dx / norm, my + params.leg_radius * dy / norm])


def _pairs(centers: np.ndarray, max_distance: float) -> list[np.ndarray]:
    """Greedy pairing, nearest first, of leg centres (L, 2) [m] at most `max_distance`
    apart: index arrays of the pairs, then of the legs left alone, in leg order."""
    n = len(centers)
    gap = np.hypot(*(centers[:, None, :] - centers[None, :, :]).transpose(2, 0, 1))
    iu, ju = np.triu_indices(n, 1)
    d = gap[iu, ju]
    taken = np.zeros(n, dtype=bool)
    groups: list[np.ndarray] = []
    for e in np.argsort(d, kind="stable"):
        if d[e] > max_distance:
            break
        i, j = int(iu[e]), int(ju[e])
        if not (taken[i] or taken[j]):
            taken[i] = taken[j] = True
            groups.append(np.array([i, j]))
    groups += [np.array([i]) for i in np.flatnonzero(~taken)]
    return groups
