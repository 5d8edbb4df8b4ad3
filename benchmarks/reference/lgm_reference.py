"""A straightforward per-beam reference for `emonav_drake.sensing.grid_maps.lgm_frame`.

Every beam is tested against every disc in plain Python, then the hit cells are marked one
beam at a time — the style of the authors' original implementation, and about as slow.
It exists to check the vectorised, windowed implementation: both must give identical
frames (``np.array_equal``).

To make an exact comparison meaningful, this code evaluates the same formulas in the
same floating-point order as the fast code (disc centres rotated into the robot frame,
``math.cos``/``math.sin`` per beam, hit = the smallest positive root t ∓ √(r² − (d² − t²)),
i.e. the exit point when the LiDAR is inside a disc; the authors' beam step 0.003490659
rad for 1800 beams); it shares no code with it.
"""

from __future__ import annotations

import math

import numpy as np


def _step(num_beams: int) -> float:
    """The authors' beam step for 1800 beams, 2π/K otherwise."""
    return 0.003490659 if num_beams == 1800 else 2.0 * math.pi / num_beams


def ranges_per_beam(
    origin, heading, centers, radii, num_beams=1800, max_range=6.0, min_range=0.27
) -> list[float]:
    """Plain-Python per-beam ranges: every beam against every disc, smallest positive root.

    Same formulas in the same floating-point order as the fast cast (centres rotated into
    the robot frame, math.cos/math.sin per beam, b = c·u, disc = r² − (d² − b²)), so the
    two must agree bit for bit; it shares no code with `emonav_drake.sensing.lidar`.
    """
    step = _step(num_beams)
    ox, oy = float(origin[0]), float(origin[1])
    ch, sh = math.cos(heading), math.sin(heading)
    discs = []
    for (cx, cy), r in zip(centers, radii, strict=True):
        dx, dy = float(cx) - ox, float(cy) - oy
        discs.append((ch * dx + sh * dy, ch * dy - sh * dx, float(r)))
    ranges = []
    for i in range(num_beams):
        angle = (i - (num_beams - 1) / 2) * step
        ux, uy = math.cos(angle), math.sin(angle)
        best = math.inf
        for px, py, r in discs:
            d2, r2 = px * px + py * py, r * r
            b = px * ux + py * uy
            disc = r2 - (d2 - b * b)
            if d2 > r2:  # outside: the entry root b − √disc, if real and ahead
                if b <= 0.0 or disc < 0.0:
                    continue
                t = b - math.sqrt(disc)
            else:  # inside: the exit root b + √disc; on the circle only if b > 0
                if d2 == r2 and b <= 0.0:
                    continue
                t = b + math.sqrt(max(disc, 0.0))
            best = min(best, t)
        ranges.append(max(min(best, max_range), min_range))
    return ranges


def lgm_frame_reference(
    origin_xy,
    heading: float,
    centers,
    radii,
    margins,
    num_beams: int = 1800,
    grid_size: int = 100,
    max_range: float = 6.0,
    min_range: float = 0.27,
    kind: str = "lgm",
) -> np.ndarray:
    """Reference grid-map frame: uint8 (M, M), same conventions as `lgm_frame`.

    ``kind`` is "lgm" (the pie map) or "ogm" (the Cartesian baseline).
    """
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    radii = [float(r) for r in radii]
    inflated = [r + float(m) for r, m in zip(radii, margins, strict=True)]
    hit = ranges_per_beam(origin_xy, heading, centers, radii, num_beams, max_range, min_range)
    infl = ranges_per_beam(origin_xy, heading, centers, inflated, num_beams, max_range, min_range)
    grid = np.zeros((grid_size, grid_size), dtype=np.uint8)
    for value, ranges in ((255, hit), (127, infl)):
        for i, rng in enumerate(ranges):
            if rng >= max_range:
                continue  # no hit within range
            if kind == "lgm":
                row = i // (num_beams // grid_size)
                col = min(int(rng / (max_range / grid_size)), grid_size - 1)
            elif kind == "ogm":
                angle = (i - (num_beams - 1) / 2) * _step(num_beams)
                x, y = rng * math.cos(angle), rng * math.sin(angle)
                cell = 2.0 * max_range / grid_size
                row = min(max(math.floor((x + max_range) / cell), 0), grid_size - 1)
                col = min(max(math.floor((max_range - y) / cell), 0), grid_size - 1)
            else:
                raise ValueError(f"kind must be 'lgm' or 'ogm', got {kind!r}")
            if value == 127 and grid[row, col] == 255:
                continue  # discomfort never overwrites a collision cell
            grid[row, col] = value
    return grid
