"""Simulated 2-D LiDAR: ray casting from the robot against discs (numpy only).

The conventions are those of the paper authors' simulator, so that our frames can be
compared with theirs pixel for pixel (see ``docs/lidar_grid_maps.md``):

* **Beams.** K beams around the robot. Beam i points at ``(i − (K−1)/2)·step`` radians
  from the robot's heading, counter-clockwise positive, with ``step = beam_step(K)``. For
  the paper's K = 1800 the step is the authors' constant ``AUTHORS_BEAM_STEP =
  0.003490659`` rad, their rounding of 2π/1800 = 0.00349065850…; for any other K it is
  2π/K. With K = 1800, beam 0 is just behind on the right (−899.5 steps ≈ −179.9°),
  straight ahead falls between beams 899 and 900 (∓ half a step ≈ ∓0.1°) and beam 1799
  is just behind on the left (≈ +179.9°). (The authors' rounded step makes the 1800 beams
  span 2π + 8.9e-7 rad, so the gap across the seam behind the robot is 8.9e-7 rad
  narrower than the others; nothing else depends on it.)
* **Range of a beam against one disc.** The points of beam u (unit vector) are t·u,
  t ≥ 0. They meet the circle of centre c and radius r where
  ``t² − 2bt + (d² − r²) = 0`` with ``b = c·u`` and ``d = |c|``, i.e. at
  ``t = b ∓ √(b² − (d² − r²))``. The beam's range to the disc is the **smallest positive
  root**; no positive root means the beam misses the disc. That gives:

  - origin outside the disc (d > r): the entry point ``b − √(…)``, when b > 0 and the
    root is real; otherwise a miss;
  - origin inside the disc (d < r): one root is negative and one positive, so *every*
    beam hits the disc, at the point where it leaves it, ``b + √(…)``; pointing at the
    centre gives d + r, pointing away r − d;
  - origin exactly on the circle (d = r): the roots are 0 and 2b; 0 is not positive, so a
    beam with b > 0 (pointing into the disc) hits it at 2b, where it leaves it again, and a
    beam with b ≤ 0 misses. This is what the authors' cast does too: it keeps an
    intersection only if it lies strictly ahead of the LiDAR.

  Why the exit point: a discomfort disc (pedestrian radius + emotion distance) that
  contains the robot then shows, on every beam, how far the robot has to go that way to
  get out of the zone, instead of a full ring at ``min_range`` that says nothing about the
  way out; this is the situation in which the policy needs the map the most.
* **Several discs and clipping.** A beam's range is the minimum over all discs, then
  clipped to ``[min_range, max_range]``: a nearer hit is raised to ``min_range`` (and is
  still a hit); a beam with no hit, or whose hit is at or beyond ``max_range`` (also an
  exit point beyond it), returns exactly ``max_range``, which the grid maps read as
  "nothing here".

The fast cast evaluates, for a disc not containing the origin, only the beams inside its
angular half-width ``asin(r/d)`` around its bearing (plus two beams of margin on each
side), and merges the discs with ``np.minimum.at``, so it costs O(beams actually covered)
instead of O(K · discs). A disc containing the origin (or with the origin on its circle)
covers every beam and is cast on all K of them.

**Walls.** `scan_discs` and `cast_robot_frame` also take line segments (walls, no
thickness, seen from either side; `scenarios/walls.py` casts them): a beam's range is the
nearest of its disc and wall hits, then clipped as above. Without walls the cast is the
disc cast alone, arithmetic unchanged.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from emonav_drake.params import NUM_BEAMS
from emonav_drake.scenarios.walls import as_segments, cast_segments, robot_frame_segments

DEFAULT_NUM_BEAMS = NUM_BEAMS
DEFAULT_MAX_RANGE = 6.0  # L [m]
DEFAULT_MIN_RANGE = 0.27  # [m]

# The authors' beam angle step [rad] (their rounding of 2π/1800); used for K = 1800 only.
AUTHORS_BEAM_STEP = 0.003490659
AUTHORS_NUM_BEAMS = 1800

# Beams added on each side of a disc's exact angular window. Any beam outside
# the exact window misses the disc by a margin far larger than round-off (and than the
# 2.6e-4-beam mismatch at the seam that the authors' rounded step causes), so the
# windowed cast returns exactly what an every-beam-against-every-disc cast returns.
_WINDOW_MARGIN = 2
# A disc whose nearest surface point is farther than max_range + this cannot be
# hit inside the range; it is skipped. The slack keeps the skip conservative.
_FAR_SLACK = 1e-9


def check_positive_int(value: int, name: str) -> int:
    """Return ``value`` as an int, or raise ValueError naming ``name`` if it is not a
    positive integer (bools are not integers here)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an int, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be positive, got {value}")
    return int(value)


def check_num_beams(num_beams: int) -> int:
    """Return ``num_beams`` as an int, or raise ValueError if it is not a positive integer."""
    return check_positive_int(num_beams, "num_beams")


def check_ranges_limits(max_range: float, min_range: float) -> tuple[float, float]:
    """Validate ``0 ≤ min_range < max_range`` (finite, metres); returns them as floats."""
    max_range, min_range = float(max_range), float(min_range)
    if not (math.isfinite(max_range) and math.isfinite(min_range)):
        raise ValueError(f"ranges must be finite, got min {min_range}, max {max_range}")
    if not 0.0 <= min_range < max_range:
        raise ValueError(f"need 0 <= min_range < max_range, got {min_range}, {max_range}")
    return max_range, min_range


def beam_step(num_beams: int) -> float:
    """Angle between neighbouring beams [rad]: ``AUTHORS_BEAM_STEP`` for K = 1800, else 2π/K.

    0.003490659 is the constant of the authors' simulator, 2π/1800 rounded to 9 decimals;
    it only has a meaning for their 1800 beams, so other beam counts keep 2π/K.
    """
    k = check_num_beams(num_beams)
    return AUTHORS_BEAM_STEP if k == AUTHORS_NUM_BEAMS else 2.0 * math.pi / k


@lru_cache(maxsize=16)
def beam_table(num_beams: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read-only ``(angles, cos, sin)`` of the beams, each (K,), angles in radians
    relative to the robot's heading (robot frame).

    ``angles[i] = (i − (K−1)/2) · beam_step(K)`` in float64, i.e. exactly the product of
    the two float64 numbers. The cosines and sines come from ``math.cos``/``math.sin`` per
    beam (once, cached), so a plain-Python implementation of the same formulas reproduces
    them bit for bit.
    """
    k = check_num_beams(num_beams)
    angles = (np.arange(k, dtype=np.float64) - (k - 1) / 2) * beam_step(k)
    cos = np.array([math.cos(a) for a in angles.tolist()], dtype=np.float64)
    sin = np.array([math.sin(a) for a in angles.tolist()], dtype=np.float64)
    for a in (angles, cos, sin):
        a.flags.writeable = False
    return angles, cos, sin


def beam_angles(num_beams: int = DEFAULT_NUM_BEAMS) -> np.ndarray:
    """Beam directions (K,) in radians relative to the robot's heading, CCW positive.

    ``angle_i = (i − (K−1)/2)·beam_step(K)``; e.g. K = 1800 gives −899.5 · 0.003490659 rad
    (≈ −179.9°), −898.5 · 0.003490659 rad (≈ −179.7°), …, +899.5 · 0.003490659 rad.
    """
    return beam_table(num_beams)[0].copy()


def as_point(origin_xy: object, name: str = "origin_xy") -> tuple[float, float]:
    """A finite 2-D point as two floats; ValueError otherwise."""
    p = np.asarray(origin_xy, dtype=np.float64)
    if p.shape != (2,):
        raise ValueError(f"{name} must have shape (2,), got {p.shape}")
    x, y = float(p[0]), float(p[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{name} must be finite, got {p.tolist()}")
    return x, y


def as_discs(centers: object, radii: object) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(centers (n, 2), radii (n,))`` float64 arrays; n may be 0.

    Radii must be finite and > 0 [m]; centres finite [m].
    """
    c = np.asarray(centers, dtype=np.float64)
    if c.size == 0:
        c = c.reshape(0, 2)
    if c.ndim != 2 or c.shape[1] != 2:
        raise ValueError(f"centers must have shape (n, 2), got {c.shape}")
    r = np.asarray(radii, dtype=np.float64)
    if r.size == 0:
        r = r.reshape(0)
    if r.shape != (c.shape[0],):
        raise ValueError(f"radii must have shape ({c.shape[0]},) to match centers, got {r.shape}")
    if not np.isfinite(c).all():
        raise ValueError("centers must be finite")
    if not (np.isfinite(r).all() and (r > 0.0).all()):
        raise ValueError(f"radii must be finite and > 0, got {r.tolist()}")
    return c, r


def robot_frame_centers(
    origin: tuple[float, float], heading: float, centers: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Disc centres (n, 2) in the world frame → (x forward, y left) in the robot frame."""
    ch, sh = math.cos(heading), math.sin(heading)
    dx = centers[:, 0] - origin[0]
    dy = centers[:, 1] - origin[1]
    return ch * dx + sh * dy, ch * dy - sh * dx


def cast_robot_frame(
    px: np.ndarray,
    py: np.ndarray,
    radii: np.ndarray,
    num_beams: int,
    max_range: float,
    min_range: float,
    out: np.ndarray | None = None,
    segments: np.ndarray | None = None,
    segment_half_widths: np.ndarray | None = None,
) -> np.ndarray:
    """Cast several scans at once against discs (and walls) in the robot frame (no validation).

    Args:
        px, py: disc centres (n,) in the robot frame [m] (x forward, y left).
        radii: (C, n) disc radii [m], one row per scan (e.g. real and inflated discs).
        num_beams: K.
        max_range, min_range: clipping limits [m].
        out: optional (C, K) float64 array to write into.
        segments: optional (W, 2, 2) walls in the robot frame [m], each of non-zero length.
        segment_half_widths: optional (C, W) half-widths ≥ 0 of the walls per scan [m]
            (`scenarios/walls.py::cast_segments`); default 0 (the walls themselves).

    Returns:
        (C, K) float64 ranges [m], clipped to [min_range, max_range]: per beam, the
        smallest positive root over the discs (module docstring), so a disc containing the
        origin is hit by every beam where the beam leaves it, or the nearer wall hit.
    """
    k = num_beams
    n_scans = radii.shape[0]
    if out is None:
        out = np.empty((n_scans, k), dtype=np.float64)
    out.fill(np.inf)
    if segments is not None and len(segments):
        if segment_half_widths is None:
            segment_half_widths = np.zeros((n_scans, len(segments)))
        _, cos, sin = beam_table(k)
        cast_segments(out, segments, segment_half_widths, cos, sin, max_range)
        if px.size == 0:
            np.minimum(out, max_range, out=out)
            np.maximum(out, min_range, out=out)
            return out
    if px.size == 0:
        np.minimum(out, max_range, out=out)
        return out
    beams = beam_table(k)  # (angles, cos, sin); also checks k
    d2 = px * px + py * py  # (n,)
    r2 = radii * radii  # (C, n)
    # The origin inside the disc or on its circle: the disc is cast on every beam below.
    encloses = d2 <= r2
    dist = np.sqrt(d2)
    # Origin outside: the entry point, on the beams of the disc's angular window only.
    active = ~encloses & (dist - radii <= max_range + _FAR_SLACK)
    scan_idx, disc_idx = np.nonzero(active)
    if scan_idx.size:
        _cast_entry_points(out, beams, px, py, radii, d2, r2, dist, scan_idx, disc_idx)
    if encloses.any():
        _cast_exit_points(out, beams, px, py, d2, r2, encloses)
    np.minimum(out, max_range, out=out)
    np.maximum(out, min_range, out=out)
    return out


def _cast_entry_points(
    out: np.ndarray,
    beams: tuple[np.ndarray, np.ndarray, np.ndarray],
    px: np.ndarray,
    py: np.ndarray,
    radii: np.ndarray,
    d2: np.ndarray,
    r2: np.ndarray,
    dist: np.ndarray,
    scan_idx: np.ndarray,
    disc_idx: np.ndarray,
) -> None:
    """Lower `out` (C, K) to the entry points of the (scan, disc) pairs `scan_idx`,
    `disc_idx` whose disc does not contain the origin, on the beams of each disc's angular
    window only (`beams` = `beam_table(K)`, `d2` = |c|², `r2` = radii², `dist` = |c|)."""
    _, cos, sin = beams
    k = cos.size
    beams_per_rad = 1.0 / beam_step(k)
    ra = radii[scan_idx, disc_idx]
    da = dist[disc_idx]
    # Half-width in beams; the clip guards round-off when d is within an ulp of r.
    half = np.arcsin(np.minimum(ra / da, 1.0)) * beams_per_rad
    centre = np.arctan2(py[disc_idx], px[disc_idx]) * beams_per_rad + (k - 1) / 2
    lo = np.floor(centre - half).astype(np.intp) - _WINDOW_MARGIN
    count = np.ceil(centre + half).astype(np.intp) + (_WINDOW_MARGIN + 1) - lo
    np.minimum(count, k, out=count)
    ends = np.cumsum(count)
    total = int(ends[-1])
    # Beam index of every (window, position) pair, wrapped across the ±180° seam.
    beam = np.arange(total, dtype=np.intp)
    beam += np.repeat(lo - (ends - count), count)
    beam %= k
    rep = np.repeat(np.arange(scan_idx.size), count)
    di = disc_idx[rep]
    t = px[di] * cos[beam] + py[di] * sin[beam]
    disc = r2[scan_idx, disc_idx][rep] - (d2[di] - t * t)
    miss = (disc < 0.0) | (t <= 0.0)
    np.maximum(disc, 0.0, out=disc)
    np.sqrt(disc, out=disc)
    hit = np.subtract(t, disc, out=t)
    hit[miss] = np.inf
    beam += scan_idx[rep] * k
    np.minimum.at(out.reshape(-1), beam, hit)


def _cast_exit_points(
    out: np.ndarray,
    beams: tuple[np.ndarray, np.ndarray, np.ndarray],
    px: np.ndarray,
    py: np.ndarray,
    d2: np.ndarray,
    r2: np.ndarray,
    encloses: np.ndarray,
) -> None:
    """Lower `out` (C, K) to the exit points of the (scan, disc) pairs where `encloses`
    (the origin inside the disc or on its circle), on all K beams (`beams` =
    `beam_table(K)`)."""
    _, cos, sin = beams
    for s, j in zip(*np.nonzero(encloses), strict=True):
        # Origin inside (d < r): the roots have opposite signs, every beam leaves the disc
        # at the positive one, b + √(…). Origin on the circle (d = r): the roots are 0 and
        # 2b; only beams with b > 0 have a positive root (2b = b + √(…)), the rest miss.
        t = px[j] * cos + py[j] * sin  # b, the centre's projection on every beam (K,)
        behind = t <= 0.0 if d2[j] == r2[s, j] else None
        disc = r2[s, j] - (d2[j] - t * t)
        np.maximum(disc, 0.0, out=disc)
        np.sqrt(disc, out=disc)
        hit = np.add(t, disc, out=t)
        if behind is not None:
            hit[behind] = np.inf
        np.minimum(out[s], hit, out=out[s])


def scan_discs(
    origin_xy: object,
    heading: float,
    centers: object,
    radii: object,
    num_beams: int = DEFAULT_NUM_BEAMS,
    max_range: float = DEFAULT_MAX_RANGE,
    min_range: float = DEFAULT_MIN_RANGE,
    segments: object | None = None,
) -> np.ndarray:
    """One 2-D LiDAR scan of discs and walls.

    Args:
        origin_xy: LiDAR position (2,) in the world frame [m].
        heading: robot heading in the world frame [rad], CCW from +x.
        centers: disc centres (n, 2) in the world frame [m] (n may be 0).
        radii: disc radii (n,) [m], > 0.
        num_beams: K, beams over 360° (see module docstring for the beam angles).
        max_range, min_range: clipping limits [m].
        segments: optional walls (W, 2, 2) in the world frame [m], segment k from
            ``[k, 0]`` to ``[k, 1]`` (`CrowdSnapshot.wall_segments`); no thickness, a beam
            hits either side. ``None`` or W = 0: discs only (the same result as without).

    Returns:
        (K,) float64 ranges [m] in ``[min_range, max_range]``; ``max_range`` means no hit.
        A disc containing the origin is hit by every beam where the beam leaves it (the
        smallest positive root; module docstring, also for the origin on the circle).
        Per beam, the nearer of the disc and wall hits.
    """
    k = check_num_beams(num_beams)
    max_range, min_range = check_ranges_limits(max_range, min_range)
    origin = as_point(origin_xy)
    heading = float(heading)
    if not math.isfinite(heading):
        raise ValueError(f"heading must be finite, got {heading}")
    c, r = as_discs(centers, radii)
    segs = as_segments(segments)
    px, py = robot_frame_centers(origin, heading, c)
    if len(segs) == 0:
        return cast_robot_frame(px, py, r[None, :], k, max_range, min_range)[0]
    local = robot_frame_segments(origin, heading, segs)
    return cast_robot_frame(px, py, r[None, :], k, max_range, min_range, segments=local)[0]
