"""What a LiDAR scan can show of each pedestrian: its own beams, its visible beams, and a
visibility category (the ground truth of the tracking study, `evaluation/tracking_study.py`).

A pedestrian's own beams are those that hit it when it is scanned alone; its visible
beams, those of its own beams whose range in the full scan (every pedestrian, static disc
and wall) equals its own within `SAME_RANGE`. Categories: `OUT_OF_RANGE` (centre beyond
`lidar.max_range`), `OCCLUDED` (fewer visible beams than the detector's `min_points`: it
drops such a sliver), `PARTLY_OCCLUDED` (some own beams hidden), `VISIBLE`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.lidar import scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams

SAME_RANGE = 1e-6  # a beam shows an object when the full scan's range equals its own [m]

VISIBLE, PARTLY_OCCLUDED, OCCLUDED, OUT_OF_RANGE = 0, 1, 2, 3
CATEGORY_NAMES = ("visible", "partly_occluded", "occluded", "out_of_range")


def visible_beams(
    robot_xy: np.ndarray,
    heading: float,
    centers: np.ndarray,
    radii: np.ndarray,
    full: np.ndarray,
    config: EmoNavConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """(own beams, visible beams) of each disc in the full scan `full`."""
    li = config.lidar
    own = np.zeros(len(radii), dtype=np.int64)
    vis = np.zeros(len(radii), dtype=np.int64)
    for i in range(len(radii)):
        one, r = centers[i : i + 1], radii[i : i + 1]
        alone = scan_discs(robot_xy, heading, one, r, li.num_beams, li.max_range, li.min_range)
        hits = alone < li.max_range
        own[i] = int(hits.sum())
        vis[i] = int((hits & (np.abs(full - alone) <= SAME_RANGE)).sum())
    return own, vis


def visibility(
    robot_xy: np.ndarray,
    heading: float,
    ped_positions: np.ndarray,
    ped_radius: float,
    static_centers: np.ndarray,
    static_radii: Sequence[float] | np.ndarray,
    config: EmoNavConfig,
    detection: DetectionParams | None = None,
    wall_segments: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How much of each pedestrian the scan from (`robot_xy` [m], `heading` [rad]) shows.

    Returns (own beams (P,), visible beams (P,), category (P,)): own = beams that hit
    the pedestrian scanned alone; visible = those whose range in the scan of every
    pedestrian (radius `ped_radius` [m]), disc and wall (`wall_segments` (W, 2, 2) [m],
    optional) equals its own (`SAME_RANGE`);
    category `OUT_OF_RANGE` (centre beyond `lidar.max_range`), `OCCLUDED` (fewer than
    `detection.min_points` visible), `PARTLY_OCCLUDED` (some own beams hidden), `VISIBLE`.
    """
    robot_xy = np.asarray(robot_xy, dtype=float)
    peds = np.asarray(ped_positions, dtype=float).reshape(-1, 2)
    centers = np.vstack([peds, np.asarray(static_centers, dtype=float).reshape(-1, 2)])
    radii = np.concatenate([np.full(len(peds), float(ped_radius)), np.asarray(static_radii, float)])
    li = config.lidar
    full = scan_discs(
        robot_xy,
        heading,
        centers,
        radii,
        li.num_beams,
        li.max_range,
        li.min_range,
        segments=wall_segments,
    )
    own, vis = visible_beams(robot_xy, heading, peds, radii[: len(peds)], full, config)
    return own, vis, categories(robot_xy, peds, own, vis, config, detection or DetectionParams())


def categories(
    robot_xy: np.ndarray,
    peds: np.ndarray,
    own: np.ndarray,
    vis: np.ndarray,
    config: EmoNavConfig,
    detection: DetectionParams,
) -> np.ndarray:
    dist = np.hypot(*(peds - robot_xy).T) if len(peds) else np.zeros(0)
    cat = np.full(len(peds), VISIBLE, dtype=np.int64)
    cat[vis < own] = PARTLY_OCCLUDED
    cat[vis < detection.min_points] = OCCLUDED
    cat[dist > config.lidar.max_range] = OUT_OF_RANGE
    return cat
