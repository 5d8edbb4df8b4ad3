"""Walls as line segments: validation, distances, LiDAR casting and a disc-chain stand-in.

A wall is a segment from ``a`` to ``b`` (world frame, x towards the robot's goal, y left,
metres) without thickness, blocked on both sides; a scenario's walls come as a
``(W, 2, 2)`` array, segment k running from ``[k, 0]`` to ``[k, 1]``
(`crowd/crowd.py::CrowdSnapshot.wall_segments`).

* `as_segments` validates such an array; `point_segment_distances` gives a point's
  distance to every wall (the robot collides with a wall when its centre is within its
  radius of it, `navigation/reward.py`).
* `cast_segments` lowers LiDAR ranges to the hits on walls (`sensing/lidar.py` calls it;
  beams as in `sensing/lidar.py::beam_table`). With a half-width ``h > 0`` a wall is cast as
  the band of points within ``h`` of it (a capsule: two sides parallel to the wall and a
  half circle round each end), the way a disc is inflated by its discomfort margin for
  the grid maps. As for discs, a beam's range is the **smallest positive** distance at
  which it meets the shape's boundary: the entry point from outside, the exit point when
  the LiDAR is inside the band, and a miss for a beam that leaves the boundary from a
  LiDAR exactly on it. A zero-width wall is hit where the beam crosses it, from either
  side; a beam running exactly along a wall's line hits its nearer end (if both ends lie
  ahead). The LiDAR exactly on a zero-width wall sees nothing of it.
* `wall_discs` approximates a wall by a chain of discs for the planners that only read
  discs (DWA, MPC, SARL); see its docstring for what the approximation does.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DEFAULT_WALL_DISC_SPACING",
    "as_segments",
    "cast_segments",
    "point_segment_distances",
    "robot_frame_segments",
    "wall_discs",
]

DEFAULT_WALL_DISC_SPACING = 0.2  # [m] between the centres of a wall's disc chain
# A wall whose nearest point is farther than max_range + half-width + this is skipped.
_FAR_SLACK = 1e-9


def as_segments(segments: object, name: str = "segments") -> np.ndarray:
    """``segments`` as a finite float64 ``(W, 2, 2)`` array of non-zero-length segments
    (W may be 0; ``None`` gives W = 0); ValueError naming ``name`` otherwise."""
    if segments is None:
        return np.zeros((0, 2, 2))
    try:
        s = np.asarray(segments, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a numeric array: {error}") from error
    if s.size == 0:
        return np.zeros((0, 2, 2))
    if s.ndim != 3 or s.shape[1:] != (2, 2):
        raise ValueError(f"{name} must have shape (W, 2, 2), got {s.shape}")
    if not np.isfinite(s).all():
        raise ValueError(f"{name} must be finite")
    length = np.hypot(s[:, 1, 0] - s[:, 0, 0], s[:, 1, 1] - s[:, 0, 1])
    if (length <= 0.0).any():
        k = int(np.argmin(length))
        raise ValueError(f"{name}[{k}] has zero length (both ends at {s[k, 0].tolist()})")
    return s


def point_segment_distances(point: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distances [m] (W,) from ``point`` (2,) to each segment of ``segments`` (W, 2, 2)."""
    a = segments[:, 0]
    e = segments[:, 1] - a
    d = np.asarray(point, dtype=np.float64) - a
    s = np.clip(np.sum(d * e, axis=1) / np.sum(e * e, axis=1), 0.0, 1.0)
    return np.hypot(d[:, 0] - s * e[:, 0], d[:, 1] - s * e[:, 1])


def robot_frame_segments(
    origin: tuple[float, float], heading: float, segments: np.ndarray
) -> np.ndarray:
    """Segments (W, 2, 2) in the world frame → the robot frame (x forward, y left) [m]."""
    ch, sh = math.cos(heading), math.sin(heading)
    dx = segments[..., 0] - origin[0]
    dy = segments[..., 1] - origin[1]
    return np.stack([ch * dx + sh * dy, ch * dy - sh * dx], axis=-1)


def cast_segments(
    out: np.ndarray,
    segments: np.ndarray,
    half_widths: np.ndarray,
    cos: np.ndarray,
    sin: np.ndarray,
    max_range: float,
) -> None:
    """Lower the ranges ``out`` (C, K) to the hits on walls (module docstring).

    Args:
        out: (C, K) ranges [m] of C scans, lowered in place (not clipped here).
        segments: (W, 2, 2) walls in the LiDAR's frame [m] (the LiDAR at the origin).
        half_widths: (C, W) half-width ≥ 0 of each wall in each scan [m] (0: the wall).
        cos, sin: (K,) beam directions in the same frame.
        max_range: walls farther than this (plus their half-width) are skipped [m].
    """
    dist0 = point_segment_distances(np.zeros(2), segments)
    for c in range(out.shape[0]):
        near = np.flatnonzero(dist0 <= max_range + half_widths[c] + _FAR_SLACK)
        for w in near.tolist():
            h = float(half_widths[c, w])
            hit = _cast_one(segments[w], h, cos, sin)
            np.minimum(out[c], hit, out=out[c])


def _cast_one(seg: np.ndarray, h: float, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """(K,) smallest positive range of every beam to the boundary of one wall's band of
    half-width ``h`` (``inf`` where a beam misses)."""
    (ax, ay), (bx, by) = seg.tolist()
    ex, ey = bx - ax, by - ay
    if h == 0.0:
        return _cross_side(ax, ay, ex, ey, cos, sin, collinear_hits=True)
    length = math.hypot(ex, ey)
    nx, ny = -ey / length * h, ex / length * h  # the normal, scaled to the half-width
    best = _cross_side(ax + nx, ay + ny, ex, ey, cos, sin, collinear_hits=False)
    np.minimum(best, _cross_side(ax - nx, ay - ny, ex, ey, cos, sin, False), out=best)
    np.minimum(best, _cap(ax, ay, -ex, -ey, h, cos, sin), out=best)
    np.minimum(best, _cap(bx, by, ex, ey, h, cos, sin), out=best)
    return best


def _cross_side(
    px: float,
    py: float,
    ex: float,
    ey: float,
    cos: np.ndarray,
    sin: np.ndarray,
    collinear_hits: bool,
) -> np.ndarray:
    """Range of every beam to the segment p → p + e (``inf`` on a miss).

    A beam t·u meets it where t·u = p + s·e, 0 ≤ s ≤ 1: with ``u × e`` the 2-D cross
    product, ``t = (p × e) / (u × e)`` and ``s = (p × u) / (u × e)``; only t > 0 counts.
    A beam parallel to the segment misses it, or, with ``collinear_hits``, hits the nearer
    end if it runs along the segment's line and both ends lie ahead.
    """
    denom = cos * ey - sin * ex
    p_cross_u = px * sin - py * cos
    parallel = denom == 0.0
    safe = np.where(parallel, 1.0, denom)
    t = (px * ey - py * ex) / safe
    s = p_cross_u / safe
    hit = np.where(~parallel & (s >= 0.0) & (s <= 1.0) & (t > 0.0), t, np.inf)
    if collinear_hits and parallel.any():
        along = parallel & (p_cross_u == 0.0)
        t0 = px * cos + py * sin
        t1 = (px + ex) * cos + (py + ey) * sin
        ahead = along & (t0 > 0.0) & (t1 > 0.0)
        hit = np.where(ahead, np.minimum(t0, t1), hit)
    return hit


def _cap(
    cx: float, cy: float, ox: float, oy: float, h: float, cos: np.ndarray, sin: np.ndarray
) -> np.ndarray:
    """Range of every beam to the half circle of radius ``h`` round the wall's end
    ``(cx, cy)`` on the side ``(ox, oy)`` points to (away from the wall), ``inf`` on a miss:
    the positive roots of ``t² − 2bt + (|c|² − h²) = 0`` (``b = c·u``) on that half."""
    b = cx * cos + cy * sin
    disc = b * b - (cx * cx + cy * cy - h * h)
    real = disc >= 0.0
    root = np.sqrt(np.where(real, disc, 0.0))
    best = np.full(cos.shape, np.inf)
    for t in (b - root, b + root):
        outer = (t * cos - cx) * ox + (t * sin - cy) * oy >= 0.0
        ok = real & (t > 0.0) & outer
        best = np.where(ok & (t < best), t, best)
    return best


def wall_discs(segments: object, spacing: float = DEFAULT_WALL_DISC_SPACING) -> tuple:
    """A chain of discs standing in for each wall, for planners that only read discs.

    Along a wall of length L, ``n = ⌈L / spacing⌉ + 1`` centres are spread evenly from one
    end to the other (both ends included), so neighbouring centres are ``g = L / (n − 1)
    ≤ spacing`` apart; every disc has radius ``g / 2``. The chain then covers the wall:
    every point of the segment lies within ``g / 2`` of a centre, and two neighbouring
    discs touch on the wall, so nothing with a radius above zero fits between them.

    The approximation: the chain is wider than the wall (which has no thickness). Its
    outline bulges up to ``g / 2`` out from the wall at each centre and comes back to the
    wall where neighbouring discs touch, so a planner keeps up to ``spacing / 2`` more
    distance from a wall than it needs, and its distance to the wall is rough by as much
    (the true wall is in `scenarios/walls.py::point_segment_distances`). Smaller spacings are
    truer and cost more discs (a 6 m wall at 0.2 m: 31 discs).

    Args:
        segments: (W, 2, 2) walls, world frame [m] (W may be 0).
        spacing: largest distance between neighbouring centres [m], > 0.

    Returns:
        (centres (n, 2) [m], radii (n,) [m]), the discs of wall 0 first, then wall 1, …
    """
    segs = as_segments(segments)
    spacing = float(spacing)
    if not (math.isfinite(spacing) and spacing > 0.0):
        raise ValueError(f"spacing must be finite and > 0, got {spacing}")
    centers, radii = [], []
    for (ax, ay), (bx, by) in segs.tolist():
        length = math.hypot(bx - ax, by - ay)
        n = math.ceil(length / spacing) + 1
        f = np.linspace(0.0, 1.0, n)
        centers.append(np.column_stack([ax + f * (bx - ax), ay + f * (by - ay)]))
        radii.append(np.full(n, length / (n - 1) / 2.0))
    if not centers:
        return np.zeros((0, 2)), np.zeros(0)
    return np.vstack(centers), np.concatenate(radii)
