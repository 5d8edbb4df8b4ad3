"""Where a simulated pedestrian's body, head and face are, for a camera to see them.

A pedestrian of the crowd is a point (x, y) [m, world] with a velocity. For rendering it
is a body (a cylinder), a head (a box) and a face (a textured quad on the front of the
head, one per emotion, only the one of its current emotion in view). This module holds the
numbers and the pose arithmetic (numpy only); `systems/pedestrian_bodies.py` registers
the geometry with a Drake `SceneGraph` and sends the poses.

Frames: world W (z up); pedestrian P at (x, y, 0), its x axis along the direction it
faces (its walking direction), z up. The face quad lies in the head's front face
(x = HEAD_DEPTH / 2 in P), its normal along +x of P, so a camera in front of the
pedestrian sees the face and one behind it sees the back of the head.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

# the walking direction is the heading when the pedestrian moves faster than this [m/s]
MOVING_SPEED = 0.05
# a face not in use is parked this far below the ground [m]: out of every camera's view
HIDDEN_DEPTH = 50.0


@dc.dataclass(frozen=True)
class PedestrianBody:
    """Sizes of the rendered pedestrian [m] (an adult of 1.75 m).

    The head box is larger than the face quad in width and height, so from behind (or
    from the side beyond 90°) the head hides the face entirely.
    """

    body_radius: float = 0.22
    body_height: float = 1.45
    head_depth: float = 0.18
    head_width: float = 0.22
    head_height: float = 0.28
    head_center_height: float = 1.60
    face_width: float = 0.20
    face_height: float = 0.25

    def __post_init__(self) -> None:
        if not (self.face_width < self.head_width and self.face_height < self.head_height):
            raise ValueError("the face quad must be smaller than the head's front face")

    @property
    def face_offset(self) -> np.ndarray:
        """Centre of the face quad in the pedestrian frame P [m] (just in front of the
        head's front face, so the two never z-fight)."""
        return np.array([self.head_depth / 2 + 5e-4, 0.0, self.head_center_height])


def facing_headings(
    velocities: np.ndarray, fallback: np.ndarray, min_speed: float = MOVING_SPEED
) -> np.ndarray:
    """Yaw [rad] each pedestrian faces: its walking direction, or `fallback` when slower
    than `min_speed` [m/s].

    Args:
        velocities: (P, 2) [m/s], world frame.
        fallback: (P,) [rad], e.g. the direction from its start to its goal.
    """
    v = np.asarray(velocities, dtype=float).reshape(-1, 2)
    fb = np.asarray(fallback, dtype=float).reshape(-1)
    if fb.shape != (len(v),):
        raise ValueError(f"{fb.size} fallback headings for {len(v)} pedestrians")
    moving = np.hypot(v[:, 0], v[:, 1]) > min_speed
    return np.where(moving, np.arctan2(v[:, 1], v[:, 0]), fb)


def start_to_goal_headings(starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Yaw [rad] from each pedestrian's start to its goal (0 when they coincide)."""
    d = np.asarray(goals, dtype=float).reshape(-1, 2) - np.asarray(starts, dtype=float).reshape(
        -1, 2
    )
    return np.arctan2(d[:, 1], d[:, 0])


def bearing_and_facing(
    camera_xy: np.ndarray, positions: np.ndarray, headings: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distance [m], facing angle [rad]) of each pedestrian seen from `camera_xy`.

    The facing angle is between the pedestrian's heading and the direction from it to
    the camera: 0 when it faces the camera, ±π when it turns its back.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 2)
    d = np.asarray(camera_xy, dtype=float).reshape(2) - p
    to_camera = np.arctan2(d[:, 1], d[:, 0])
    facing = np.angle(np.exp(1j * (to_camera - np.asarray(headings, dtype=float))))
    return np.hypot(d[:, 0], d[:, 1]), facing
