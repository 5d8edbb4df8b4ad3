"""The paper's resolution comparison between the LGM and the OGM (Section III-C, Eq. 2).

The "resolution" of a grid-map cell is the number of LiDAR beams per unit area (paper
Eq. 2) for the LGM, (M/2L)² cells per m² for the OGM; the paper's text compares the two
maps ring by ring. This module computes both (`lgm_cell_area`, `lgm_resolution`,
`lgm_mean_resolution`, `ogm_resolution`), the OGM cells that each LGM ring touches or that
its mid circle crosses (`ogm_ring_cell_counts`, `ogm_ring_circle_cell_counts`,
`ogm_cells_touched_by_disc`), and the ring from which the OGM is "denser" under each
reading of the paper (`resolution_crossing_rings`). The maps themselves are in
`sensing/grid_maps.py`.

Units: distances and cell sides [m], areas [m²], resolutions [1/m²]; rings are counted
from 1 (ring i spans radii ((i − 1)L/M, iL/M) around the robot, L = ``max_range``). The OGM
is the 2L × 2L square centred on the robot, which sits on a cell corner.
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.sensing.grid_maps import DEFAULT_GRID_SIZE, check_grid_size, check_max_range
from emonav_drake.sensing.lidar import DEFAULT_MAX_RANGE, DEFAULT_NUM_BEAMS, check_num_beams


def _check_ring(ring: int, grid_size: int) -> int:
    if isinstance(ring, bool) or not isinstance(ring, int | np.integer):
        raise ValueError(f"ring must be an int, got {ring!r}")
    if not 1 <= ring <= grid_size:
        raise ValueError(f"ring must be in 1..{grid_size} (counted from 1), got {ring}")
    return int(ring)


def lgm_cell_area(
    ring: int, grid_size: int = DEFAULT_GRID_SIZE, max_range: float = DEFAULT_MAX_RANGE
) -> float:
    """Area [m²] of one LGM cell in ring ``ring`` (counted from 1): π L² (2i − 1) / M³."""
    m = check_grid_size(grid_size)
    i = _check_ring(ring, m)
    max_range = check_max_range(max_range)
    return math.pi * max_range**2 * (2 * i - 1) / m**3


def lgm_resolution(
    ring: int,
    num_beams: int = DEFAULT_NUM_BEAMS,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
) -> float:
    """Paper Eq. 2: beams per m² in an LGM cell of ring i (from 1), K M² / (π L² (2i − 1))."""
    k = check_num_beams(num_beams)
    m = check_grid_size(grid_size)
    i = _check_ring(ring, m)
    max_range = check_max_range(max_range)
    return k * m**2 / (math.pi * max_range**2 * (2 * i - 1))


def lgm_mean_resolution(
    grid_size: int = DEFAULT_GRID_SIZE, max_range: float = DEFAULT_MAX_RANGE
) -> float:
    """The paper's LGM average, (M / (√π L))² = M² cells over the disc of radius L [1/m²]."""
    m = check_grid_size(grid_size)
    max_range = check_max_range(max_range)
    return (m / (math.sqrt(math.pi) * max_range)) ** 2


def ogm_resolution(
    grid_size: int = DEFAULT_GRID_SIZE, max_range: float = DEFAULT_MAX_RANGE
) -> float:
    """The paper's OGM resolution (M / 2L)² [cells per m²] (cell side 2L/M)."""
    m = check_grid_size(grid_size)
    max_range = check_max_range(max_range)
    return (m / (2.0 * max_range)) ** 2


def lgm_ring_cell_counts(grid_size: int = DEFAULT_GRID_SIZE) -> np.ndarray:
    """LGM cells in each ring 1…M, (M,) int: every ring holds M sector cells."""
    m = check_grid_size(grid_size)
    return np.full(m, m, dtype=np.int64)


def _ogm_cell_distance_bounds(
    grid_size: int, max_range: float, cell_size: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest and farthest distance from the robot to every OGM cell square.

    The cells tile the 2L × 2L square centred on the robot with side ``cell_size``
    (default 2L/M, the OGM's), so the robot sits on a cell corner as in `ogm_from_ranges`.
    """
    m = check_grid_size(grid_size)
    max_range = check_max_range(max_range)
    side = 2.0 * max_range / m if cell_size is None else float(cell_size)
    n = round(2.0 * max_range / side)
    if not (side > 0.0 and n >= 1 and math.isclose(n * side, 2.0 * max_range)):
        raise ValueError(f"cell_size must tile 2L = {2.0 * max_range} m, got {cell_size}")
    edges = (np.arange(n + 1) - n / 2) * side
    lo, hi = edges[:-1], edges[1:]
    near_1d = np.maximum(np.maximum(lo, -hi), 0.0)
    far_1d = np.maximum(np.abs(lo), np.abs(hi))
    near = np.hypot(near_1d[:, None], near_1d[None, :])
    far = np.hypot(far_1d[:, None], far_1d[None, :])
    return near, far


def ogm_cells_touched_by_disc(
    radius: float,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    cell_size: float | None = None,
) -> int:
    """OGM cells sharing a positive area with the disc of ``radius`` [m] around the robot."""
    near, _ = _ogm_cell_distance_bounds(grid_size, max_range, cell_size)
    return int(np.count_nonzero(near < radius))


def ogm_ring_cell_counts(
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    cell_size: float | None = None,
) -> np.ndarray:
    """OGM cells sharing a positive area with each LGM ring's annulus, (M,) int.

    Ring i (from 1) spans radii ((i − 1)L/M, iL/M). Ring 1 with the paper's M = 100,
    L = 6 m is the 0.06 m disc around the robot, which touches 4 OGM cells.
    """
    m = check_grid_size(grid_size)
    near, far = _ogm_cell_distance_bounds(grid_size, max_range, cell_size)
    width = float(max_range) / m
    return np.array(
        [np.count_nonzero((near < i * width) & (far > (i - 1) * width)) for i in range(1, m + 1)]
    )


def ogm_ring_circle_cell_counts(
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
    cell_size: float | None = None,
) -> np.ndarray:
    """OGM cells whose interior each ring's mid circle (radius (i − ½)L/M) crosses, (M,) int.

    These are the OGM cells that hits at mid-ring can land in (dense enough beams reach
    them all), the OGM's counterpart of the M LGM cells of a ring. With the robot on a
    cell corner and cell side h it equals 8⌊R/h⌋ + 4.
    """
    m = check_grid_size(grid_size)
    near, far = _ogm_cell_distance_bounds(grid_size, max_range, cell_size)
    width = float(max_range) / m
    counts = []
    for i in range(1, m + 1):
        radius = (i - 0.5) * width
        counts.append(np.count_nonzero((near < radius) & (far > radius)))
    return np.array(counts)


def _first_ring_for_good(ogm_exceeds: np.ndarray) -> int | None:
    """Smallest ring i (from 1) with the OGM ahead in ring i and every ring after it."""
    if not ogm_exceeds[-1]:
        return None
    behind = np.flatnonzero(~ogm_exceeds)
    return 1 if behind.size == 0 else int(behind[-1]) + 2


def resolution_crossing_rings(
    num_beams: int = DEFAULT_NUM_BEAMS,
    grid_size: int = DEFAULT_GRID_SIZE,
    max_range: float = DEFAULT_MAX_RANGE,
) -> dict[str, int | None]:
    """The ring from which the OGM is "denser" than the LGM, under each reading of the paper.

    The paper (Section III-C) says that for M = 100, L = 6 m, K = 1800 "when i > 13 the
    density of the OGM grid surpasses that of the LGM". For each definition below the value
    is the smallest ring i (from 1) such that the OGM is strictly ahead in ring i and in
    every ring after it (None: never within the map's M rings):

    * ``cell_density`` — cells per m²: 1 / LGM cell area M³/(π L² (2i − 1)) against the
      OGM's (M/2L)². Same ring for beams per m² with K/M beams in every cell of both maps.
    * ``eq2_vs_ogm_resolution`` — Eq. 2's beams per m² against (M/2L)² cells per m², the two
      numbers the paper prints side by side.
    * ``cells_overlapping_ring`` — OGM cells sharing area with ring i's annulus
      (`ogm_ring_cell_counts`) against the ring's M LGM cells (the paper's i = 1 example:
      4 against 100).
    * ``cells_crossed_by_mid_circle`` — OGM cells crossed by ring i's mid circle
      (`ogm_ring_circle_cell_counts`), i.e. the distinct OGM cells the beams' mid-ring hits
      land in, against M.
    * ``cells_crossed_by_mid_circle_half_cell`` — the same with a hypothetical OGM cell of
      side L/M (half the OGM's 2L/M): 8(i − ½) > M, i.e. i > M/8 + ½.
    """
    k = check_num_beams(num_beams)
    m = check_grid_size(grid_size)
    max_range = check_max_range(max_range)
    rings = np.arange(1, m + 1)
    lgm_cells = lgm_ring_cell_counts(m)
    lgm_density = m**3 / (math.pi * max_range**2 * (2 * rings - 1))
    eq2 = k * m**2 / (math.pi * max_range**2 * (2 * rings - 1))
    ogm_density = ogm_resolution(m, max_range)
    return {
        "cell_density": _first_ring_for_good(ogm_density > lgm_density),
        "eq2_vs_ogm_resolution": _first_ring_for_good(ogm_density > eq2),
        "cells_overlapping_ring": _first_ring_for_good(
            ogm_ring_cell_counts(m, max_range) > lgm_cells
        ),
        "cells_crossed_by_mid_circle": _first_ring_for_good(
            ogm_ring_circle_cell_counts(m, max_range) > lgm_cells
        ),
        "cells_crossed_by_mid_circle_half_cell": _first_ring_for_good(
            ogm_ring_circle_cell_counts(m, max_range, cell_size=max_range / m) > lgm_cells
        ),
    }
