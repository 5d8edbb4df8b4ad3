"""The LiDAR tracks in Meshcat: the crowd as the robot tracks it, drawn beside the true one
by `NavigationMeshcatVisualizer` (`navigation_meshcat.py`, its `tracks` input).

Each tracked pedestrian is a flat violet ring at waist height (`TRACK_HEIGHT`), just wider
than a pedestrian, with a velocity arrow from its position along its velocity, as long as
the distance it covers in `TRACK_ARROW_HORIZON` (none for a track slower than
`TRACK_ARROW_MIN_SPEED`); each tracked static disc is a dark violet ring of its fitted
radius on top of the disc. Tracks come and go: a fixed pool of `TRACK_SLOTS` pedestrian and
`TRACK_STATIC_SLOTS` static slots is drawn once, hidden, and a slot is shown while a track
is in it (a track keeps its slot while it lives: `_assign_slots`). Every call passes the
simulation time, so a Meshcat recording animates the slots' visibility, poses and scales.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Box, Meshcat
from pydrake.math import RigidTransform, RotationMatrix

from emonav_drake.systems.navigation_meshcat_style import (
    PREFIX,
    STATIC_HEIGHT,
    TRACK_RGBA,
    TRACK_STATIC_RGBA,
)

TRACK_SLOTS = 24  # tracked pedestrians drawn at most (a pool of slots, shown or hidden)
TRACK_STATIC_SLOTS = 8  # tracked static discs drawn at most
TRACK_ARROW_HORIZON = 1.0  # a track's velocity arrow: the distance it covers in this [s]
TRACK_ARROW_MIN_SPEED = 0.05  # [m/s] a slower track gets no arrow
TRACK_HEIGHT = 1.0  # [m] the height of a tracked pedestrian's ring and arrow (its waist)
TRACK_RING_GAP = 0.05  # [m] between a tracked disc's radius and its ring's inner edge
TRACK_RING_WIDTH = 0.07  # [m] the ring's width (a static one's at its nominal radius)
TRACK_STATIC_NOMINAL = 0.3  # [m] the radius a static ring is drawn for, scaled to the track's
TRACK_SLOT_GATE = 0.8  # [m] a track stays in its slot when it moved at most this far


class TrackDrawing:
    """The tracks' slots in `meshcat` (module docstring): drawn at the first `draw`, then
    shown, moved and hidden. What has been sent to Meshcat, not simulation state: `reset`
    when a simulation is initialized (the pool itself stays drawn)."""

    def __init__(self, meshcat: Meshcat) -> None:
        self._meshcat = meshcat
        self._track_pool = False  # the tracks' slots are drawn (at the first publish)
        self.reset()

    def reset(self) -> None:
        # per slot: the position of the track it shows (None: hidden), and whether its
        # arrow is shown; None until the first publish draws every slot's visibility
        self._ped_slots: list[np.ndarray | None] | None = None
        self._static_slots: list[np.ndarray | None] | None = None
        self._arrows: list[bool] = [False] * TRACK_SLOTS

    def _draw_track_pool(self, radius: float) -> None:
        """Every slot, hidden: a ring and a velocity arrow per pedestrian slot (arrow along
        the slot's +x, its shaft 1 m long, scaled to the track's speed), a ring per static
        slot (drawn for `TRACK_STATIC_NOMINAL`, scaled to the track's radius)."""
        m = self._meshcat
        ring = _track_ring(radius)
        head = np.array([[0.0, -0.1, 0.0], [0.18, 0.0, 0.0], [0.0, 0.1, 0.0]]).T
        for j in range(TRACK_SLOTS):
            path = f"{PREFIX}/tracks/pedestrians/{j}"
            m.SetTriangleMesh(f"{path}/ring", *ring, TRACK_RGBA)
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, TRACK_HEIGHT]))
            m.SetObject(f"{path}/arrow/shaft", Box(1.0, 0.05, 0.03), TRACK_RGBA)
            m.SetTriangleMesh(
                f"{path}/arrow/head", head, np.array([[0], [1], [2]], dtype=np.int32), TRACK_RGBA
            )
            m.SetProperty(path, "visible", False)
            m.SetProperty(f"{path}/arrow", "visible", False)
        ring = _track_ring(TRACK_STATIC_NOMINAL)
        for j in range(TRACK_STATIC_SLOTS):
            path = f"{PREFIX}/tracks/static/{j}"
            m.SetTriangleMesh(f"{path}/ring", *ring, TRACK_STATIC_RGBA)
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, STATIC_HEIGHT + 0.02]))
            m.SetProperty(path, "visible", False)
        self._track_pool = True

    def _fill_slot(
        self, slots: list, j: int, path: str, position: np.ndarray | None, first: bool, t: float
    ) -> None:
        """Show slot `j` at a track (`position`) or hide it (None); its "visible" property is
        recorded only when that changes (and at the first publish)."""
        shown = position is not None
        if first or shown != (slots[j] is not None):
            self._meshcat.SetProperty(path, "visible", shown, t)
        slots[j] = position

    def draw(self, snap, t: float) -> None:
        """The tracked crowd `snap` (a `CrowdSnapshot`) at t: each track in a slot of its
        own, kept while it lives; slots without a track hidden."""
        if not self._track_pool:
            self._draw_track_pool(float(snap.radius))
        first = self._ped_slots is None
        if first:
            self._ped_slots = [None] * TRACK_SLOTS
            self._static_slots = [None] * TRACK_STATIC_SLOTS
        positions = np.asarray(snap.positions, dtype=float).reshape(-1, 2)
        velocities = np.asarray(snap.velocities, dtype=float).reshape(-1, 2)
        centres = np.asarray(snap.static_centers, dtype=float).reshape(-1, 2)
        radii = np.asarray(snap.static_radii, dtype=float).reshape(-1)
        peds = _assign_slots(self._ped_slots, positions)
        statics = _assign_slots(self._static_slots, centres)
        m = self._meshcat
        for j, i in enumerate(peds):
            path = f"{PREFIX}/tracks/pedestrians/{j}"
            self._fill_slot(self._ped_slots, j, path, None if i is None else positions[i], first, t)
            if i is None:
                if first:
                    m.SetProperty(f"{path}/arrow", "visible", False, t)
                    self._arrows[j] = False
                continue
            (px, py), (vx, vy) = positions[i], velocities[i]
            speed = math.hypot(vx, vy)
            arrow = speed >= TRACK_ARROW_MIN_SPEED  # a still track has no heading to show
            yaw = math.atan2(vy, vx) if arrow else 0.0
            m.SetTransform(path, RigidTransform(RotationMatrix.MakeZRotation(yaw), [px, py, 0]), t)
            if first or arrow != self._arrows[j]:
                m.SetProperty(f"{path}/arrow", "visible", arrow, t)
                self._arrows[j] = arrow
            if arrow:
                length = speed * TRACK_ARROW_HORIZON
                m.SetTransform(
                    f"{path}/arrow/shaft", RigidTransform([length / 2, 0, TRACK_HEIGHT]), t
                )
                m.SetProperty(f"{path}/arrow/shaft", "scale", [length, 1.0, 1.0], t)
                m.SetTransform(f"{path}/arrow/head", RigidTransform([length, 0, TRACK_HEIGHT]), t)
        for j, i in enumerate(statics):
            path = f"{PREFIX}/tracks/static/{j}"
            self._fill_slot(
                self._static_slots, j, path, None if i is None else centres[i], first, t
            )
            if i is None:
                continue
            cx, cy = centres[i]
            scale = _ring_outer(radii[i]) / _ring_outer(TRACK_STATIC_NOMINAL)
            m.SetTransform(path, RigidTransform([cx, cy, 0.0]), t)
            m.SetProperty(path, "scale", [scale, scale, 1.0], t)


def _ring_outer(radius: float) -> float:
    """The outer radius [m] of the ring drawn around a tracked disc of `radius` [m]."""
    return radius + TRACK_RING_GAP + TRACK_RING_WIDTH


def _track_ring(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The ring drawn around a tracked disc of `radius` [m] (`_annulus`): from
    `TRACK_RING_GAP` beyond the disc to `_ring_outer`."""
    return _annulus(radius + TRACK_RING_GAP, _ring_outer(radius))


def _annulus(inner: float, outer: float, sides: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A flat ring in the plane z = 0, centred at the origin: (vertices (3, 2n), faces
    (3, 2n) int32) for `Meshcat.SetTriangleMesh`."""
    ang = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    rim = np.vstack([np.cos(ang), np.sin(ang), np.zeros(sides)])
    vertices = np.hstack([inner * rim, outer * rim])
    i = np.arange(sides)
    n = (i + 1) % sides
    faces = np.hstack([np.vstack([i, sides + i, sides + n]), np.vstack([i, sides + n, n])])
    return vertices, faces.astype(np.int32)


def _assign_slots(slots: list[np.ndarray | None], points: np.ndarray) -> list[int | None]:
    """Which of `points` (N, 2) each slot shows now (an index, or None): a point within
    `TRACK_SLOT_GATE` of a slot's last position stays in it (nearest pairs first); the others
    take a slot that showed nothing, else one freed now, so that a new track rarely takes
    the slot a dead one just left. Points beyond the slots are not drawn."""
    out: list[int | None] = [None] * len(slots)
    taken = set()
    pairs = sorted(
        (float(np.hypot(*(points[i] - last))), j, i)
        for j, last in enumerate(slots)
        if last is not None
        for i in range(len(points))
    )
    for gap, j, i in pairs:
        if gap > TRACK_SLOT_GATE:
            break
        if out[j] is None and i not in taken:
            out[j] = i
            taken.add(i)
    # a new track takes a slot that showed nothing before, else one just freed
    free = [j for j in range(len(slots)) if slots[j] is None] + [
        j for j in range(len(slots)) if slots[j] is not None and out[j] is None
    ]
    for i in range(len(points)):
        if i not in taken and free:
            out[free.pop(0)] = i
    return out
