"""LiDAR grid maps (LGM, the paper's pie-shaped map) and occupancy grid maps (OGM), numpy only.

Both maps are ``uint8 (M, M)`` images built from two scans of the same discs (see
`emonav_drake.sensing.lidar` for the beam angles, the clipping and the exit-point rule for a
disc that contains the robot): the real scan, and a scan of the discs inflated by their
discomfort margins (pedestrian radius + emotion distance, static radius + 0.2 m; the
caller passes the margins). Each beam marks only the cell of its hit:

* 255 — the hit of the real scan (collision area, red in the paper);
* 127 — the hit of the inflated scan, where the cell is not already 255 (discomfort zone);
* 0 — everything else. A beam whose range equals ``max_range`` marks nothing.

Walls (line segments, optional) are cast too: in the real scan without thickness, in
the inflated scan as the band within their discomfort margin (`lgm_frame`).

The robot's own radius plays no part. When the robot stands inside an inflated disc, that
disc's 127 cells trace, beam by beam, where the beam leaves the discomfort zone.

LGM (paper Section III-C): row = angular sector ``⌊i/(K/M)⌋`` of beam i (row 0 just
behind on the right, rows M/2 − 1 and M/2 either side of straight ahead, CCW
increasing), column = ring ``⌊range/(L/M)⌋`` capped at M − 1 (column 0 at the robot), with
L = ``max_range``. With the paper's K = 1800, M = 100, L = 6 m: 18 beams per row, rings
0.06 m wide, and ``min_range`` 0.27 m lands in column 4.

OGM baseline: a 2L × 2L Cartesian square in the robot frame (x forward, y left) with
cell side h = 2L/M; the hit point ``(x, y) = range·(cos a, sin a)`` of beam angle a lands
in row ``⌊(x + L)/h⌋`` (row index grows forward) and column ``⌊(L − y)/h⌋`` (column index
grows to the robot's right), both clipped to 0…M−1 (12 × 12 m and 0.12 m cells for the
paper's values).

Frames are stacked oldest first in `FrameStack` (N = 9 in the paper; the first frame of an
episode fills every slot).

The paper's resolution comparison between the two maps (Eq. 2 and the text after it) is
in `sensing/grid_resolution.py`.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from emonav_drake.scenarios.walls import as_segments, robot_frame_segments
from emonav_drake.sensing.lidar import (
    DEFAULT_MAX_RANGE,
    DEFAULT_MIN_RANGE,
    DEFAULT_NUM_BEAMS,
    as_discs,
    as_point,
    beam_table,
    cast_robot_frame,
    check_num_beams,
    check_positive_int,
    check_ranges_limits,
    robot_frame_centers,
)

DEFAULT_GRID_SIZE = 100  # M
DEFAULT_NUM_FRAMES = 9  # N
COLLISION_VALUE = 255
DISCOMFORT_VALUE = 127
GRID_KINDS = ("lgm", "ogm")


# --------------------------------------------------------------------------- validation


def check_grid_size(grid_size: int) -> int:
    """Return ``grid_size`` (M) as an int, or raise ValueError if it is not a positive int."""
    return check_positive_int(grid_size, "grid_size")


def check_beams_per_sector(num_beams: int, grid_size: int) -> int:
    """K/M, the beams per LGM sector; ValueError unless M divides K."""
    if num_beams % grid_size:
        raise ValueError(
            f"num_beams ({num_beams}) must be divisible by grid_size ({grid_size}) "
            "so that every LGM sector holds the same number of beams"
        )
    return num_beams // grid_size


def check_max_range(max_range: float) -> float:
    """Return ``max_range`` (L) as a float, or raise ValueError unless it is finite and > 0."""
    max_range = float(max_range)
    if not (math.isfinite(max_range) and max_range > 0.0):
        raise ValueError(f"max_range must be finite and > 0, got {max_range}")
    return max_range


def _as_ranges(ranges: object, name: str, num_beams: int | None = None) -> np.ndarray:
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim != 1 or r.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array, got shape {r.shape}")
    if num_beams is not None and r.size != num_beams:
        raise ValueError(f"{name} has {r.size} beams, expected {num_beams}")
    if not (np.isfinite(r).all() and (r >= 0.0).all()):
        raise ValueError(f"{name} must be finite and >= 0")
    return r


def _out_grid(out: np.ndarray | None, grid_size: int) -> np.ndarray:
    if out is None:
        return np.zeros((grid_size, grid_size), dtype=np.uint8)
    if not isinstance(out, np.ndarray):
        raise ValueError("out must be a numpy array")
    if (
        out.shape != (grid_size, grid_size)
        or out.dtype != np.uint8
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        raise ValueError(
            f"out must be a writeable C-contiguous uint8 array of shape "
            f"({grid_size}, {grid_size}), got {out.dtype} {out.shape}"
        )
    out.fill(0)
    return out


# --------------------------------------------------------------------------- grid filling


@lru_cache(maxsize=16)
def _lgm_row_offsets(num_beams: int, grid_size: int) -> np.ndarray:
    """Flat-index offset ``row·M`` of every beam's LGM row, (K,) intp, read-only."""
    per_sector = num_beams // grid_size
    offsets = (np.arange(num_beams, dtype=np.intp) // per_sector) * grid_size
    offsets.flags.writeable = False
    return offsets


def _fill_lgm(ranges: np.ndarray, grid_size: int, max_range: float, out: np.ndarray) -> None:
    """Mark (2, K) ranges (row 0 real, row 1 inflated) into the zeroed LGM ``out``."""
    cell = max_range / grid_size
    flat_idx = (ranges / cell).astype(np.intp)
    np.minimum(flat_idx, grid_size - 1, out=flat_idx)
    flat_idx += _lgm_row_offsets(ranges.shape[1], grid_size)
    seen = ranges < max_range
    flat = out.reshape(-1)
    # 127 first, then 255 over it: "127 only where the cell is not 255".
    flat[flat_idx[1][seen[1]]] = DISCOMFORT_VALUE
    flat[flat_idx[0][seen[0]]] = COLLISION_VALUE


def _fill_ogm(ranges: np.ndarray, grid_size: int, max_range: float, out: np.ndarray) -> None:
    """Mark (2, K) ranges (row 0 real, row 1 inflated) into the zeroed OGM ``out``."""
    _, cos, sin = beam_table(ranges.shape[1])
    cell = 2.0 * max_range / grid_size
    row = np.floor((ranges * cos + max_range) / cell)
    col = np.floor((max_range - ranges * sin) / cell)
    np.clip(row, 0, grid_size - 1, out=row)
    np.clip(col, 0, grid_size - 1, out=col)
    row *= grid_size
    row += col
    flat_idx = row.astype(np.intp)
    seen = ranges < max_range
    flat = out.reshape(-1)
    flat[flat_idx[1][seen[1]]] = DISCOMFORT_VALUE
    flat[flat_idx[0][seen[0]]] = COLLISION_VALUE


def _grid_from_ranges(
    kind: str,
    hit_ranges: object,
    inflated_ranges: object,
    grid_size: int,
    max_range: float,
    out: np.ndarray | None,
) -> np.ndarray:
    m = check_grid_size(grid_size)
    max_range = check_max_range(max_range)
    hit = _as_ranges(hit_ranges, "hit_ranges")
    inflated = _as_ranges(inflated_ranges, "inflated_ranges", hit.size)
    if kind == "lgm":
        check_beams_per_sector(hit.size, m)
    grid = _out_grid(out, m)
    (_fill_lgm if kind == "lgm" else _fill_ogm)(np.stack((hit, inflated)), m, max_range, grid)
    return grid


def lgm_from_ranges(
    hit_ranges: object,
    inflated_ranges: object,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """LiDAR grid map from a real and an inflated scan.

    Args:
        hit_ranges: (K,) ranges [m] of the real discs (beam i as in `lidar.beam_angles`).
        inflated_ranges: (K,) ranges [m] of the discs inflated by their discomfort margins.
        grid_size: M, sectors (rows) and rings (columns); K must be divisible by M.
        max_range: L [m]; a range ≥ L marks nothing, ring width is L/M.
        out: optional writeable C-contiguous uint8 (M, M) array, zeroed and filled in place.

    Returns:
        uint8 (M, M): row = sector ⌊i/(K/M)⌋, column = ring ⌊range/(L/M)⌋ capped at M − 1;
        255 real hits, 127 inflated hits not on a 255 cell, 0 elsewhere.
    """
    return _grid_from_ranges("lgm", hit_ranges, inflated_ranges, grid_size, max_range, out)


def ogm_from_ranges(
    hit_ranges: object,
    inflated_ranges: object,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Occupancy grid map (2L × 2L square in the robot frame) from a real and an inflated scan.

    Args:
        hit_ranges: (K,) ranges [m] of the real discs (beam i as in `lidar.beam_angles`).
        inflated_ranges: (K,) ranges [m] of the inflated discs.
        grid_size: M cells per side; cell side 2L/M.
        max_range: L [m]; a range ≥ L marks nothing.
        out: optional writeable C-contiguous uint8 (M, M) array, zeroed and filled in place.

    Returns:
        uint8 (M, M): hit (x forward, y left) in row ⌊(x + L)/(2L/M)⌋, column
        ⌊(L − y)/(2L/M)⌋, clipped to 0…M−1; values 255 / 127 / 0 as for the LGM.
    """
    return _grid_from_ranges("ogm", hit_ranges, inflated_ranges, grid_size, max_range, out)


def lgm_frame(
    origin_xy: object,
    heading: float,
    centers: object,
    radii: object,
    margins: object,
    num_beams: int = DEFAULT_NUM_BEAMS,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    min_range: float = DEFAULT_MIN_RANGE,
    kind: str = "lgm",
    out: np.ndarray | None = None,
    segments: object | None = None,
    segment_margin: float = 0.0,
) -> np.ndarray:
    """One grid-map frame seen from a LiDAR: real scan + inflated scan + grid.

    Args:
        origin_xy: LiDAR position (2,) in the world frame [m].
        heading: robot heading in the world frame [rad], CCW from +x.
        centers: disc centres (n, 2) in the world frame [m]; n may be 0.
        radii: disc radii (n,) [m], > 0.
        margins: discomfort margins (n,) [m], ≥ 0, added to the radii for the second scan
            (pedestrian: its emotion's distance; static disc: 0.2 m).
        num_beams: K; for the LGM, K must be divisible by M.
        grid_size: M.
        max_range, min_range: LiDAR clipping limits [m] (L = max_range).
        kind: "lgm" (pie map, the paper's) or "ogm" (Cartesian baseline).
        out: optional writeable C-contiguous uint8 (M, M) array to fill in place.
        segments: optional walls (W, 2, 2) in the world frame [m] (segment k from
            ``[k, 0]`` to ``[k, 1]``): in the real scan a wall has no thickness; in the
            inflated scan it is the band within ``segment_margin`` of it (its discomfort
            zone, like a static disc's; `scenarios/walls.py::cast_segments`). ``None`` or
            W = 0: the frame of the discs alone, unchanged.
        segment_margin: the walls' discomfort margin [m], ≥ 0 (the static discs' 0.2 m).

    Returns:
        uint8 (M, M) frame, as `lgm_from_ranges` / `ogm_from_ranges` describe.
    """
    if kind not in GRID_KINDS:
        raise ValueError(f"kind must be one of {GRID_KINDS}, got {kind!r}")
    k = check_num_beams(num_beams)
    m = check_grid_size(grid_size)
    if kind == "lgm":
        check_beams_per_sector(k, m)
    max_range, min_range = check_ranges_limits(max_range, min_range)
    origin = as_point(origin_xy)
    heading = float(heading)
    if not math.isfinite(heading):
        raise ValueError(f"heading must be finite, got {heading}")
    c, r = as_discs(centers, radii)
    mg = np.asarray(margins, dtype=np.float64)
    if mg.size == 0:
        mg = mg.reshape(0)
    if mg.shape != r.shape:
        raise ValueError(f"margins must have shape {r.shape} to match radii, got {mg.shape}")
    if not (np.isfinite(mg).all() and (mg >= 0.0).all()):
        raise ValueError(f"margins must be finite and >= 0, got {mg.tolist()}")
    segs = as_segments(segments)
    segment_margin = float(segment_margin)
    if not (math.isfinite(segment_margin) and segment_margin >= 0.0):
        raise ValueError(f"segment_margin must be finite and >= 0, got {segment_margin}")
    grid = _out_grid(out, m)
    px, py = robot_frame_centers(origin, heading, c)
    scan_radii = np.empty((2, r.size), dtype=np.float64)
    scan_radii[0] = r
    np.add(r, mg, out=scan_radii[1])
    if len(segs) == 0:
        ranges = cast_robot_frame(px, py, scan_radii, k, max_range, min_range)
    else:
        widths = np.zeros((2, len(segs)))
        widths[1] = segment_margin
        local = robot_frame_segments(origin, heading, segs)
        ranges = cast_robot_frame(
            px, py, scan_radii, k, max_range, min_range, segments=local, segment_half_widths=widths
        )
    (_fill_lgm if kind == "lgm" else _fill_ogm)(ranges, m, max_range, grid)
    return grid


# --------------------------------------------------------------------------- frame stack


class FrameStack:
    """The last N grid-map frames, oldest first, as one ``uint8 (N, M, M)`` array.

    Args:
        num_frames: N (the paper's 9).
        grid_size: M.

    `reset(frame)` fills all N slots with the first frame; `push(frame)` drops the oldest
    frame and appends the new one last. `array`, `reset` and `push` return copies, so a
    caller may keep them (e.g. in a replay buffer) while the stack moves on.
    """

    def __init__(
        self, num_frames: int = DEFAULT_NUM_FRAMES, grid_size: int = DEFAULT_GRID_SIZE
    ) -> None:
        num_frames = check_positive_int(num_frames, "num_frames")
        self._grid_size = check_grid_size(grid_size)
        self._frames = np.zeros((num_frames, self._grid_size, self._grid_size), np.uint8)
        self._started = False

    @property
    def num_frames(self) -> int:
        return self._frames.shape[0]

    @property
    def grid_size(self) -> int:
        return self._grid_size

    def _check(self, frame: object) -> np.ndarray:
        f = np.asarray(frame)
        m = self._grid_size
        if f.shape != (m, m) or f.dtype != np.uint8:
            raise ValueError(f"frame must be uint8 ({m}, {m}), got {f.dtype} {f.shape}")
        return f

    def reset(self, frame: object) -> np.ndarray:
        """Fill every slot with ``frame`` (uint8 (M, M)); returns the stack (a copy)."""
        self._frames[:] = self._check(frame)
        self._started = True
        return self.array

    def push(self, frame: object) -> np.ndarray:
        """Drop the oldest frame, append ``frame`` last; returns the stack (a copy).

        Before the first `reset`, `push` acts as `reset`.
        """
        f = self._check(frame)
        if not self._started:
            return self.reset(f)
        self._frames[:-1] = self._frames[1:]  # numpy handles the overlapping copy
        self._frames[-1] = f
        return self.array

    def load(self, frames: object) -> None:
        """Restore a saved `array` (uint8 (N, M, M), oldest first)."""
        f = np.asarray(frames)
        if f.shape != self._frames.shape or f.dtype != np.uint8:
            raise ValueError(f"frames must be uint8 {self._frames.shape}, got {f.dtype} {f.shape}")
        self._frames[:] = f
        self._started = True

    @property
    def array(self) -> np.ndarray:
        """The stack, uint8 (N, M, M), oldest first, newest last (a copy)."""
        return self._frames.copy()
