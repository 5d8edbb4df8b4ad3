"""How the navigation scene looks in Meshcat: the shared palette's roles as Drake colours,
the scene's root path and the height of its static things.

Read by `NavigationMeshcatVisualizer` (`navigation_meshcat.py`), its LiDAR tracks
(`navigation_meshcat_tracks.py`) and the replay's legend (`diagrams/meshcat_viewing.py`).
"""

from __future__ import annotations

from pydrake.geometry import Rgba

from emonav_drake import palette


def _rgba(rgb: palette.RGB, alpha: float = 1.0) -> Rgba:
    """A palette colour as a Drake `Rgba`."""
    return Rgba(*rgb, alpha)


# The palette's roles as Drake colours (the replay's legend reads them too)
EMOTION_RGBA = tuple(_rgba(rgb) for rgb in palette.EMOTION_RGB)
STATIC_RGBA = _rgba(palette.STATIC_RGB)
ROBOT_RGBA = _rgba(palette.ROBOT_RGB)
HEADING_RGBA = _rgba(palette.INK_RGB)  # the robot's heading marker
TRAIL_RGBA = _rgba(palette.TRAIL_RGB)
GOAL_RGBA = _rgba(palette.GOAL_RGB)
GOAL_RADIUS_RGBA = _rgba(palette.GOAL_RADIUS_RGB)
RAY_RGBA = _rgba(palette.LIDAR_RAY_RGB, 0.8)
HIT_RGBA = _rgba(palette.LIDAR_HIT_RGB)  # a LiDAR return (a point above the heads)
START_RGBA = _rgba(palette.ROBOT_RGB, 0.45)  # the start pad: the robot's colour, see-through
FOOT_RGBA = tuple(_rgba(rgb, 0.9) for rgb in palette.FOOTSTEP_RGB)  # left, right
TRACK_RGBA = _rgba(palette.TRACK_RGB)  # a tracked pedestrian: ring and velocity arrow
TRACK_STATIC_RGBA = _rgba(palette.TRACK_STATIC_RGB)  # a tracked static disc: ring
PREFIX = "/emonav"
STATIC_HEIGHT = 0.8  # [m] of a static disc's column (and of a wall)
