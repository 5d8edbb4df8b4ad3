"""The crowd as a robot perceives it from its LiDAR: one scan's update and the snapshot.

The perception pipeline of the deployable setting, in numpy, shared by the Drake diagram
(`systems/crowd_tracker_system.py`) and the fast LIP world (`navigation/lip_world.py`), so
that both perceive a scene the same way, scan for scan:

1. **known walls out**: a beam whose range is within `WALL_RETURN_TOLERANCE` of the range
   the known map's walls alone give it is the wall (map-based filtering, as a robot with
   a building's map does); it counts as no return;
2. **detection**: the scan is segmented and circles are fitted (`sensing/lidar_objects.py`),
   or legs paired into people (`sensing/leg_detection.py`) for a sensor that sees legs;
3. **tracking**: constant-velocity Kalman filters, gated Hungarian assignment, birth,
   confirmation, coasting, deletion (`sensing/crowd_tracker.py`);
4. **snapshot** at a time t: the confirmed moving tracks as pedestrians (predicted from
   the last scan to t with their velocities; the nominal radius; an emotion by
   association with the reports of an emotion source, or the one kept for the track id;
   its discomfort distance), the still tracks as static discs, and the known walls.

`CrowdPerception` holds the settings only; the tracker (`CrowdTracker`, the state) is
the caller's, so a Drake system can keep it in its abstract state.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.sensing.crowd_tracker import CrowdTracker, TrackerParams, tracker_params
from emonav_drake.sensing.leg_detection import detect_scan, detection_params
from emonav_drake.sensing.lidar import scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams

NEUTRAL = EMOTION_NAMES.index("neutral")  # a track no emotion report is near
# A return within this of the known walls' own range is the wall [m]: ~9 σ of the VLP-16's
# range noise (0.01125 m), well inside a person's radius (legs stand ≥ 0.1 m off a wall).
WALL_RETURN_TOLERANCE = 0.1


class CrowdPerception:
    """LiDAR detection and tracking of the crowd, with a known map of walls.

    Args:
        config: the LiDAR (beams, ranges), the nominal pedestrian radius, the emotions'
            discomfort distances and the static discomfort margin.
        known_walls: (W, 2, 2) wall segments [m, world] of the known map (None: none).
        detection, tracking: the detector's and the tracker's parameters (defaults:
            `detection_params` and `tracker_params` of the configuration).
    """

    def __init__(
        self,
        config: EmoNavConfig,
        known_walls: np.ndarray | None = None,
        detection: DetectionParams | None = None,
        tracking: TrackerParams | None = None,
    ) -> None:
        self.config = config
        walls = np.zeros((0, 2, 2)) if known_walls is None else np.asarray(known_walls, float)
        self.known_walls = walls.reshape(-1, 2, 2)
        self.detection = detection or detection_params(config)
        self.tracking = tracking or tracker_params(config)
        self._distances = np.asarray(config.reward.emotion_distances(), dtype=float)

    def new_tracker(self) -> CrowdTracker:
        """An empty tracker with these settings."""
        return CrowdTracker(self.tracking)

    def without_known_walls(self, ranges: np.ndarray, xy: np.ndarray, heading: float) -> np.ndarray:
        """`ranges` (K,) [m] with the returns of the known walls set to `max_range` (no
        return): a beam within `WALL_RETURN_TOLERANCE` of the walls' own range there,
        the LiDAR at `xy` [m, world] looking along `heading` [rad]."""
        if not len(self.known_walls):
            return ranges
        lidar = self.config.lidar
        walls = scan_discs(
            xy,
            heading,
            np.zeros((0, 2)),
            np.zeros(0),
            len(ranges),
            lidar.max_range,
            lidar.min_range,
            segments=self.known_walls,
        )
        wall = (walls < lidar.max_range) & (np.abs(ranges - walls) < WALL_RETURN_TOLERANCE)
        return np.where(wall, lidar.max_range, ranges)

    def update(
        self, tracker: CrowdTracker, t: float, ranges: np.ndarray, xy: np.ndarray, heading: float
    ) -> None:
        """Update `tracker` in place with the scan `ranges` (K,) [m] taken at time `t` [s]
        from `xy` [m, world] along `heading` [rad]."""
        ranges = np.asarray(ranges, dtype=float)
        detections = detect_scan(
            self.without_known_walls(ranges, xy, heading),
            xy,
            heading,
            self.config.lidar.max_range,
            self.detection,
        )
        tracker.update(t, detections)

    def snapshot(
        self,
        tracker: CrowdTracker,
        t: float,
        reported: CrowdSnapshot | None = None,
        kept: dict[int, int] | None = None,
    ) -> CrowdSnapshot:
        """The crowd of `tracker`'s confirmed tracks at time `t` [s] (module docstring):
        emotions from the track ids' `kept` codes if given, else by association with
        the pedestrians of `reported` (an emotion source's crowd: positions and emotion
        codes only), else neutral."""
        if kept is not None or reported is None:
            positions, codes = np.zeros((0, 2)), np.zeros(0, dtype=int)
        else:
            positions = np.asarray(reported.positions, dtype=float).reshape(-1, 2)
            codes = np.asarray(reported.emotions, dtype=int).reshape(-1)
        snap = tracker.snapshot(
            positions,
            codes,
            self._distances,
            self.config.crowd.pedestrian_radius,
            self.config.reward.static_discomfort,
            NEUTRAL,
            track_emotions=kept,
        )
        lag = t - tracker.time if tracker.time is not None else 0.0
        if lag > 0 and len(snap.positions):  # the last scan's tracks, predicted to now
            snap = dc.replace(snap, positions=snap.positions + snap.velocities * lag)
        if len(self.known_walls):
            snap = dc.replace(snap, wall_segments=self.known_walls)
        return snap


def perceived_inflation(crowd: CrowdSnapshot, seen: CrowdSnapshot) -> CrowdSnapshot:
    """The crowd whose discs ring the grid maps' inflated layer when the maps ring the
    pedestrians as the robot perceives them: `seen`'s pedestrians (positions, velocities,
    emotions, discomfort distances), `crowd`'s walls, and as static discs both `crowd`'s
    (the map's) and `seen`'s — the tracker's still tracks. A person who stands still
    long enough is a still track, not a pedestrian, of the tracker (as the planners that
    read tracks see them): without its still tracks the maps would ring a standing crowd
    nowhere, and show it only as the scan's returns of legs."""
    return dc.replace(
        crowd,
        positions=seen.positions,
        velocities=seen.velocities,
        emotions=seen.emotions,
        discomfort=seen.discomfort,
        static_centers=np.vstack([crowd.static_centers, seen.static_centers]).reshape(-1, 2),
        static_radii=np.concatenate([crowd.static_radii, seen.static_radii]),
    )
