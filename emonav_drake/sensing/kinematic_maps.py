"""The DRL-VO* observation: a robot-centric image of the scan and the pedestrians' motion.

DRL-VO (Xie & Dames) feeds a CNN with an image built from the LiDAR scan history and a
pedestrian kinematic map (each cell a pedestrian occupies holds that pedestrian's
velocity). The paper's DRL-VO* keeps that observation and swaps in the paper's SAC.
Ours, on the OGM's Cartesian grid (2L × 2L, x forward and y left of the robot,
row ⌊(x + L)/(2L/M)⌋, column ⌊(L − y)/(2L/M)⌋):

    channel 0: the OGM of the current scan (255 hit, 127 discomfort ring, 0 free);
    channel 1: v_x of the pedestrian covering the cell, robot frame, 128 + 127·v/v_max;
    channel 2: v_y likewise (128 = at rest or no pedestrian).

uint8 (3, M, M); the temporal context comes from the velocity channels rather than a
frame stack.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from emonav_drake.params import NUM_BEAMS
from emonav_drake.sensing.grid_maps import lgm_frame, ogm_from_ranges
from emonav_drake.sensing.lidar import beam_table


def in_robot_frame(
    robot_xy: np.ndarray, heading: float, positions: np.ndarray, velocities: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World-frame positions [m] and velocities [m/s] (P, 2) → the robot frame (x forward,
    y left) of a robot at `robot_xy` [m] looking along `heading` [rad]."""
    c, s = math.cos(heading), math.sin(heading)
    rot = np.array([[c, s], [-s, c]])  # world → robot
    rel = (np.asarray(positions, float).reshape(-1, 2) - np.asarray(robot_xy, float)) @ rot.T
    return rel, np.asarray(velocities, float).reshape(-1, 2) @ rot.T


def byte_code(value: np.ndarray | float, scale: float) -> np.ndarray:
    """A signed quantity as a byte about 128: 128 + 127·value/`scale`, rounded, clipped."""
    return np.clip(np.rint(128 + 127 * np.asarray(value) / scale), 0, 255).astype(np.uint8)


def pedestrian_velocity_map(
    robot_xy: np.ndarray,
    heading: float,
    positions: np.ndarray,
    velocities: np.ndarray,
    radius: float,
    grid_size: int = 100,
    half_extent: float = 6.0,
    max_speed: float = 1.0,
) -> np.ndarray:
    """uint8 (2, M, M): pedestrians' (v_x, v_y) in the robot frame on the OGM grid."""
    out = np.full((2, grid_size, grid_size), 128, np.uint8)
    if len(positions) == 0:
        return out
    rel, vel = in_robot_frame(robot_xy, heading, positions, velocities)
    cell = 2.0 * half_extent / grid_size
    centres = -half_extent + (np.arange(grid_size) + 0.5) * cell  # x of row i, also −y of col j
    for (px, py), (vx, vy) in zip(rel, vel, strict=True):
        rows = np.flatnonzero(np.abs(centres - px) <= radius)
        cols = np.flatnonzero(np.abs(-centres - py) <= radius)  # col j ↔ y = −centre_j
        if rows.size == 0 or cols.size == 0:
            continue
        dx = centres[rows][:, None] - px
        dy = -centres[cols][None, :] - py
        inside = dx * dx + dy * dy <= radius * radius
        r, k = np.nonzero(inside)
        out[0, rows[r], cols[k]] = byte_code(vx, max_speed)
        out[1, rows[r], cols[k]] = byte_code(vy, max_speed)
    return out


def drlvo_image(
    robot_xy: np.ndarray,
    heading: float,
    centers: np.ndarray,
    radii: np.ndarray,
    margins: np.ndarray,
    ped_positions: np.ndarray,
    ped_velocities: np.ndarray,
    ped_radius: float,
    num_beams: int = NUM_BEAMS,
    grid_size: int = 100,
    max_range: float = 6.0,
    min_range: float = 0.27,
    segments: np.ndarray | None = None,
    segment_margin: float = 0.0,
) -> np.ndarray:
    """uint8 (3, M, M): scan OGM of all discs + pedestrian velocity map (module docstring).

    Optional walls ``segments`` (W, 2, 2) [m, world] and their discomfort margin [m] go
    into the scan OGM as `sensing/grid_maps.py::lgm_frame` describes.
    """
    image = np.empty((3, grid_size, grid_size), np.uint8)
    image[0] = lgm_frame(
        robot_xy,
        heading,
        centers,
        radii,
        margins,
        num_beams,
        grid_size,
        max_range,
        min_range,
        kind="ogm",
        segments=segments,
        segment_margin=segment_margin,
    )
    image[1:] = pedestrian_velocity_map(
        robot_xy, heading, ped_positions, ped_velocities, ped_radius, grid_size, max_range
    )
    return image


def drlvo_image_from_ranges(
    hit_ranges: np.ndarray,
    inflated_ranges: np.ndarray,
    robot_xy: np.ndarray,
    heading: float,
    ped_positions: np.ndarray,
    ped_velocities: np.ndarray,
    ped_radius: float,
    grid_size: int = 100,
    max_range: float = 6.0,
) -> np.ndarray:
    """uint8 (3, M, M) as `drlvo_image`, from scans already cast: the real scan
    `hit_ranges` (K,) [m] and the inflated scan `inflated_ranges` (K,) [m] (a sensor's
    scan, `sensing/lidar_sensor.py`), robot at `robot_xy` [m] heading `heading` [rad], world
    frame; the velocity planes from the pedestrians' positions [m] and velocities [m/s]."""
    image = np.empty((3, grid_size, grid_size), np.uint8)
    image[0] = ogm_from_ranges(hit_ranges, inflated_ranges, grid_size, max_range)
    image[1:] = pedestrian_velocity_map(
        robot_xy, heading, ped_positions, ped_velocities, ped_radius, grid_size, max_range
    )
    return image


# The velocity planes of the "lgm_vel" observation saturate at this speed [m/s]: above the
# fastest crowd family's pedestrians, 1.6 cm/s per level.
LGM_VELOCITY_MAX_SPEED = 2.0


@lru_cache(maxsize=8)
def _lgm_cell_centres(num_beams: int, grid_size: int, max_range: float) -> np.ndarray:
    """(M, M, 2) robot-frame (x forward, y left) centre [m] of every LGM cell: row i the
    mean beam angle of sector i, column j the middle of ring j. Read-only."""
    angles, _, _ = beam_table(num_beams)
    sector = angles.reshape(grid_size, num_beams // grid_size).mean(axis=1)  # (M,)
    ring = (np.arange(grid_size) + 0.5) * (max_range / grid_size)  # (M,)
    centres = np.empty((grid_size, grid_size, 2))
    centres[..., 0] = np.cos(sector)[:, None] * ring[None, :]
    centres[..., 1] = np.sin(sector)[:, None] * ring[None, :]
    centres.flags.writeable = False
    return centres


def lgm_velocity_planes(
    robot_xy: np.ndarray,
    heading: float,
    positions: np.ndarray,
    velocities: np.ndarray,
    radius: float,
    num_beams: int = NUM_BEAMS,
    grid_size: int = 100,
    max_range: float = 6.0,
    max_speed: float = LGM_VELOCITY_MAX_SPEED,
) -> np.ndarray:
    """uint8 (2, M, M): the pedestrians' velocities on the LGM's polar grid (row = angular
    sector, column = ring; `sensing/grid_maps.py`). A cell whose centre lies inside a
    pedestrian's disc (`radius` [m]) holds that pedestrian's velocity in the robot frame,
    v_x forward in plane 0 and v_y left in plane 1, as 128 + 127·v/`max_speed` (clipped);
    128 elsewhere (at rest or nobody). Where discs overlap, the later pedestrian's.
    Positions [m] and velocities [m/s] (P, 2) in the world frame; the robot at `robot_xy`
    [m] looking along `heading` [rad]."""
    out = np.full((2, grid_size, grid_size), 128, np.uint8)
    rel, vel = in_robot_frame(robot_xy, heading, positions, velocities)
    centres = _lgm_cell_centres(num_beams, grid_size, float(max_range))
    codes = byte_code(vel, max_speed)
    for p, code in zip(rel, codes, strict=True):
        if math.hypot(p[0], p[1]) > max_range + radius:
            continue
        d = centres - p
        inside = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] <= radius * radius
        out[0][inside] = code[0]
        out[1][inside] = code[1]
    return out


# The track table of the "lgm_tracks" observation: the nearest pedestrians in range, each
# a row of TRACK_FIELDS bytes (present; x, y [m]; v_x, v_y [m/s]) in the first row of a plane.
TRACK_TABLE_ROWS = 8
TRACK_FIELDS = 5


def track_table_plane(
    robot_xy: np.ndarray,
    heading: float,
    positions: np.ndarray,
    velocities: np.ndarray,
    grid_size: int = 100,
    max_range: float = 6.0,
    rows: int = TRACK_TABLE_ROWS,
    max_speed: float = LGM_VELOCITY_MAX_SPEED,
) -> np.ndarray:
    """uint8 (M, M): the pedestrians as a table, written in the first row of a plane (the
    rest 0) so that it travels with the grid maps. Entry i (bytes 5i … 5i + 4) is the
    i-th nearest pedestrian within `max_range` [m] of the robot: 255 (present), then its
    position x, y as 128 + 127·p/`max_range` and velocity v_x, v_y as 128 + 127·v/`max_speed`
    (clipped), in the robot frame (x forward, y left); an absent entry is (0, 128, 128,
    128, 128). Ties in distance keep the pedestrians' order. Positions [m] and velocities
    [m/s] (P, 2) in the world frame; the robot at `robot_xy` [m] looking along `heading`."""
    if rows * TRACK_FIELDS > grid_size:
        raise ValueError(
            f"{rows} table entries of {TRACK_FIELDS} bytes exceed a row of {grid_size}"
        )
    plane = np.zeros((grid_size, grid_size), np.uint8)
    table = plane[0, : rows * TRACK_FIELDS].reshape(rows, TRACK_FIELDS)
    table[:, 1:] = 128
    rel, vel = in_robot_frame(robot_xy, heading, positions, velocities)
    distance = np.hypot(rel[:, 0], rel[:, 1])
    near = np.flatnonzero(distance <= max_range)
    near = near[np.argsort(distance[near], kind="stable")][:rows]
    n = len(near)
    table[:n, 0] = 255
    table[:n, 1:3] = byte_code(rel[near], max_range)
    table[:n, 3:5] = byte_code(vel[near], max_speed)
    return plane
