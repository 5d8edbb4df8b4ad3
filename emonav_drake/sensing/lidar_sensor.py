"""The robot's LiDAR as the simulation senses the crowd: the one function every scan reads.

`sensed_ranges` is the real scan on the grid's K beams (world → robot frame, the beam
convention of `sensing/lidar.py`): what the grid maps' 255 layer, the `scan` output of
`LidarGridMapBuilder` (which the crowd tracker reads) and the "scan" observation all
use, in the Drake diagram and in the Gymnasium environment alike (`navigation/observations.py`).
`inflated_ranges` is the maps' other scan, the discs inflated by their discomfort
margins, exact whatever the sensor (the discomfort zones are the simulator's, not
something a sensor measures).

With an exact sensor (`SensorParams.is_exact`, the "ideal" preset) `sensed_ranges` is
`scan_discs` of the crowd's discs and walls, the code path of the paper's simulator, bit
for bit. Otherwise:

1. the scene as the sensor sees it: pedestrians as two legs (`sensor.people_as: legs`,
   `crowd/pedestrian_legs.py`) or as their discs, static discs, walls;
2. the exact cast on the sensor's own N beams: N = round(360° / angular resolution)
   equally spaced over the full turn (N = K when the resolution is 0);
3. the faults (`sensing/lidar_faults.py`) from `noise_rng(sensor.seed, crowd.seed,
   crowd.time)`: the scenario's seed and the crowd's time are in the `CrowdSnapshot`, so
   the same crowd state gives the same scan wherever it is cast;
4. each of the K grid beams reads the nearest sensor beam; a grid beam whose sensor beam
   lies outside the field of view (centred on the heading) reads `max_range`.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot, obstacle_discs
from emonav_drake.crowd.pedestrian_legs import leg_discs
from emonav_drake.params import EmoNavConfig, SensorParams
from emonav_drake.scenarios.walls import as_segments, robot_frame_segments
from emonav_drake.sensing.lidar import (
    as_point,
    beam_step,
    beam_table,
    cast_robot_frame,
    robot_frame_centers,
    scan_discs,
)
from emonav_drake.sensing.lidar_faults import apply_faults, noise_rng


def sensor_beam_count(sensor: SensorParams, num_beams: int) -> int:
    """N, the sensor's beams over the full turn: round(360° / angular resolution), or the
    grid's `num_beams` (K) when the resolution is 0."""
    if sensor.angular_resolution_deg == 0.0:
        return num_beams
    return max(1, round(360.0 / sensor.angular_resolution_deg))


@lru_cache(maxsize=16)
def grid_beam_sources(num_beams: int, sensor_beams: int, fov_deg: float) -> np.ndarray:
    """For each of the K grid beams, the index of the nearest of the N sensor beams, or −1
    when that beam lies outside the field of view `fov_deg` [deg] centred on the heading;
    (K,) intp, read-only."""
    grid_angles = beam_table(num_beams)[0]
    n = sensor_beams
    source = np.rint(grid_angles / beam_step(n) + (n - 1) / 2).astype(np.intp) % n
    sensor_angles = beam_table(n)[0]
    half_fov = math.radians(fov_deg) / 2.0 + 1e-9
    source[np.abs(sensor_angles[source]) > half_fov] = -1
    source.flags.writeable = False
    return source


def seen_discs(crowd: CrowdSnapshot, sensor: SensorParams) -> tuple[np.ndarray, np.ndarray]:
    """The discs the real scan sees (centres (n, 2) [m], radii (n,) [m], world frame):
    each pedestrian as its disc (`people_as: disc`) or as its two legs (`legs`), then the
    static discs."""
    if sensor.people_as != "legs" or len(crowd.positions) == 0:
        centers, radii, _ = obstacle_discs(crowd)
        return centers, radii
    p = len(crowd.positions)
    v = np.asarray(crowd.velocities, dtype=float).reshape(-1, 2)
    facing = crowd.facing if crowd.facing is not None else np.arctan2(v[:, 1], v[:, 0])
    phase = crowd.gait_phase if crowd.gait_phase is not None else np.zeros(p)
    legs, leg_radii = leg_discs(crowd.positions, v, facing, phase)
    centers = np.vstack([legs, np.asarray(crowd.static_centers).reshape(-1, 2)])
    return centers, np.concatenate([leg_radii, crowd.static_radii])


def sensed_ranges(
    origin_xy: object, heading: float, crowd: CrowdSnapshot, config: EmoNavConfig
) -> np.ndarray:
    """The real scan of `crowd` as the configured sensor reports it (module docstring).

    Args:
        origin_xy: the LiDAR's position (2,) [m], world frame (the robot's CoM).
        heading: the robot's heading [rad], world frame, CCW from +x.
        crowd: pedestrians, static discs and walls; its `seed` and `time` seed the noise.
        config: `lidar` (K, L, min_range) and `sensor`.

    Returns:
        (K,) float64 ranges [m] in [lidar.min_range, lidar.max_range], beam i at
        `sensing/lidar.py`'s angle i from the heading; `max_range` means nothing seen.
    """
    li, sensor = config.lidar, config.sensor
    if sensor.is_exact():
        centers, radii, _ = obstacle_discs(crowd)
        return scan_discs(
            origin_xy,
            heading,
            centers,
            radii,
            num_beams=li.num_beams,
            max_range=li.max_range,
            min_range=li.min_range,
            segments=crowd.wall_segments,
        )
    origin, heading = as_point(origin_xy), float(heading)
    n = sensor_beam_count(sensor, li.num_beams)
    centers, radii = seen_discs(crowd, sensor)
    px, py = robot_frame_centers(origin, heading, centers)
    segs = as_segments(crowd.wall_segments)
    local = robot_frame_segments(origin, heading, segs) if len(segs) else None
    exact = cast_robot_frame(px, py, radii[None, :], n, li.max_range, li.min_range, segments=local)[
        0
    ]
    rng = noise_rng(sensor.seed, crowd.seed, crowd.time)
    reported = apply_faults(exact, beam_step(n), sensor, li.min_range, li.max_range, rng)
    source = grid_beam_sources(li.num_beams, n, sensor.field_of_view_deg)
    ranges = reported[source]
    ranges[source < 0] = li.max_range
    return ranges


def inflated_ranges(
    origin_xy: object, heading: float, crowd: CrowdSnapshot, config: EmoNavConfig
) -> np.ndarray:
    """The grid maps' inflated scan on the K grid beams (K,) [m]: every disc grown by its
    discomfort margin (pedestrians as their discs, whatever the sensor) and the walls as
    bands of the static margin; exact, as `sensing/grid_maps.py::lgm_frame` casts it."""
    li = config.lidar
    origin, heading = as_point(origin_xy), float(heading)
    centers, radii, margins = obstacle_discs(crowd)
    px, py = robot_frame_centers(origin, heading, centers)
    segs = as_segments(crowd.wall_segments)
    local, widths = None, None
    if len(segs):
        local = robot_frame_segments(origin, heading, segs)
        widths = np.full((1, len(segs)), float(crowd.static_discomfort))
    inflated = np.add(radii, margins)[None, :]
    return cast_robot_frame(
        px,
        py,
        inflated,
        li.num_beams,
        li.max_range,
        li.min_range,
        segments=local,
        segment_half_widths=widths,
    )[0]
