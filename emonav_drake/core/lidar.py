"""Simulated 2-D LiDAR: ray casting from the robot against discs (numpy only).

Conventions (DESIGN.md §3.2, shared with the authors' code so frames are comparable):

* K beams over 360°, 2π/K apart. Beam i points at ``(i − (K−1)/2)·2π/K`` radians from the
  robot's heading, counter-clockwise positive: with K = 1800, beam 0 is just behind on the
  right (−179.9°), straight ahead falls between beams 899 and 900 (∓0.1°) and beam 1799 is
  just behind on the left (+179.9°).
* A range is the distance [m] from the LiDAR origin to the nearest disc surface along the
  beam, clipped to ``[min_range, max_range]``: a nearer hit is raised to ``min_range``
  (and is still a hit); a beam with no hit, or whose hit is at or beyond ``max_range``,
  returns exactly ``max_range``, which grid maps read as "nothing here".
* A disc that contains the LiDAR origin, or touches it (centre distance ≤ radius), is hit
  by every beam at range 0, i.e. every beam returns ``min_range``.

The cast only evaluates, per disc, the beams inside the disc's angular half-width
``asin(r/d)`` (plus two beams of margin) and merges discs with ``np.minimum.at``, so it
costs O(beams actually covered) instead of O(K · discs).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

DEFAULT_NUM_BEAMS = 1800
DEFAULT_MAX_RANGE = 6.0  # L [m]
DEFAULT_MIN_RANGE = 0.27  # [m]

# Beams added on each side of a disc's exact angular window. Any beam outside
# the exact window misses the disc by a margin far larger than round-off, so the
# windowed cast returns exactly what an every-beam-against-every-disc cast returns.
_WINDOW_MARGIN = 2
# A disc whose nearest surface point is farther than max_range + this cannot be
# hit inside the range; it is skipped. The slack keeps the skip conservative.
_FAR_SLACK = 1e-9


def check_num_beams(num_beams: int) -> int:
    """Return ``num_beams`` as an int, or raise ValueError if it is not a positive integer."""
    if isinstance(num_beams, bool) or not isinstance(num_beams, int | np.integer):
        raise ValueError(f"num_beams must be an int, got {num_beams!r}")
    if num_beams < 1:
        raise ValueError(f"num_beams must be positive, got {num_beams}")
    return int(num_beams)


def check_ranges_limits(max_range: float, min_range: float) -> tuple[float, float]:
    """Validate ``0 ≤ min_range < max_range`` (finite, metres); returns them as floats."""
    max_range, min_range = float(max_range), float(min_range)
    if not (math.isfinite(max_range) and math.isfinite(min_range)):
        raise ValueError(f"ranges must be finite, got min {min_range}, max {max_range}")
    if not 0.0 <= min_range < max_range:
        raise ValueError(f"need 0 <= min_range < max_range, got {min_range}, {max_range}")
    return max_range, min_range


@lru_cache(maxsize=16)
def beam_table(num_beams: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read-only ``(angles, cos, sin)`` of the beams, each (K,), angles in radians
    relative to the robot's heading (robot frame).

    The cosines and sines come from ``math.cos``/``math.sin`` per beam (once, cached), so a
    plain-Python implementation of the same formulas reproduces them bit for bit.
    """
    k = check_num_beams(num_beams)
    angles = (np.arange(k, dtype=np.float64) - (k - 1) / 2) * (2.0 * math.pi / k)
    cos = np.array([math.cos(a) for a in angles.tolist()], dtype=np.float64)
    sin = np.array([math.sin(a) for a in angles.tolist()], dtype=np.float64)
    for a in (angles, cos, sin):
        a.flags.writeable = False
    return angles, cos, sin


def beam_angles(num_beams: int = DEFAULT_NUM_BEAMS) -> np.ndarray:
    """Beam directions (K,) in radians relative to the robot's heading, CCW positive.

    ``angle_i = (i − (K−1)/2)·2π/K``; e.g. K = 1800 gives −179.9°, −179.7°, …, +179.9°.
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
) -> np.ndarray:
    """Cast several scans at once against discs given in the robot frame (no validation).

    Args:
        px, py: disc centres (n,) in the robot frame [m] (x forward, y left).
        radii: (C, n) disc radii [m], one row per scan (e.g. real and inflated discs).
        num_beams: K.
        max_range, min_range: clipping limits [m].
        out: optional (C, K) float64 array to write into.

    Returns:
        (C, K) float64 ranges [m], clipped to [min_range, max_range].
    """
    k = num_beams
    n_scans = radii.shape[0]
    if out is None:
        out = np.empty((n_scans, k), dtype=np.float64)
    out.fill(np.inf)
    if px.size == 0:
        np.minimum(out, max_range, out=out)
        return out
    _, cos, sin = beam_table(k)
    d2 = px * px + py * py  # (n,)
    r2 = radii * radii  # (C, n)
    contains = d2 <= r2
    if contains.any():
        # The origin is inside (or on) a disc: every beam hits it at range 0.
        out[contains.any(axis=1)] = 0.0
    dist = np.sqrt(d2)
    active = ~contains & (dist - radii <= max_range + _FAR_SLACK)
    scan_idx, disc_idx = np.nonzero(active)
    if scan_idx.size:
        ra = radii[scan_idx, disc_idx]
        da = dist[disc_idx]
        # Half-width in beams; the clip guards round-off when d is within an ulp of r.
        half = np.arcsin(np.minimum(ra / da, 1.0)) * (k / (2.0 * math.pi))
        centre = np.arctan2(py[disc_idx], px[disc_idx]) * (k / (2.0 * math.pi)) + (k - 1) / 2
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
    np.minimum(out, max_range, out=out)
    np.maximum(out, min_range, out=out)
    return out


def scan_discs(
    origin_xy: object,
    heading: float,
    centers: object,
    radii: object,
    num_beams: int = DEFAULT_NUM_BEAMS,
    max_range: float = DEFAULT_MAX_RANGE,
    min_range: float = DEFAULT_MIN_RANGE,
) -> np.ndarray:
    """One 2-D LiDAR scan of discs.

    Args:
        origin_xy: LiDAR position (2,) in the world frame [m].
        heading: robot heading in the world frame [rad], CCW from +x.
        centers: disc centres (n, 2) in the world frame [m] (n may be 0).
        radii: disc radii (n,) [m], > 0.
        num_beams: K, beams over 360° (see module docstring for the beam angles).
        max_range, min_range: clipping limits [m].

    Returns:
        (K,) float64 ranges [m] in ``[min_range, max_range]``; ``max_range`` means no hit.
        A disc containing or touching the origin makes every beam return ``min_range``.
    """
    k = check_num_beams(num_beams)
    max_range, min_range = check_ranges_limits(max_range, min_range)
    origin = as_point(origin_xy)
    heading = float(heading)
    if not math.isfinite(heading):
        raise ValueError(f"heading must be finite, got {heading}")
    c, r = as_discs(centers, radii)
    px, py = robot_frame_centers(origin, heading, c)
    return cast_robot_frame(px, py, r[None, :], k, max_range, min_range)[0]
