"""`CrowdTrackerSystem`: the crowd as a robot estimates it from its LiDAR scan.

At the scan's rate (every `crowd.dt`, 10 Hz) it first drops the returns the known map
explains — a beam whose range is within `WALL_RETURN_TOLERANCE` of the range the map's
walls alone give it (`known_walls`; map-based filtering, as a robot with a building's map
does) — then segments the 1800-beam scan into objects
and fits circles (`sensing/lidar_objects.py`), then updates a multi-target tracker
(`sensing/crowd_tracker.py`: constant-velocity Kalman filters, gated Hungarian assignment,
birth, confirmation, coasting through occlusions, deletion). Its output replaces the
simulator's crowd on the planner's input when `perception.state_source` is "lidar":

    LidarGridMapBuilder ── scan ──► CrowdTrackerSystem ── crowd ──► NavigationPlanner
    crowd (emotion estimate) ──────────┘ (emotions, by association)

Input ports:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot CoM, world frame: the
        LiDAR's pose (it sits at the CoM; beam angles are measured from θ).
    scan (K): the LiDAR ranges now [m] (`LidarGridMapBuilder.scan`).
    crowd (abstract `CrowdSnapshot`): the crowd as the emotion source reports it; only
        its pedestrians' positions and emotion codes are read, to attach an emotion to a
        track (the nearest report within the tracker's association gate, else neutral).
        Not read when `track_emotions` is connected.
    track_emotions (abstract `TrackEmotions`, optional): the emotion kept for each
        track id (`TrackEmotionFusion`); a track it does not list is neutral.
Output ports:
    crowd (abstract `CrowdSnapshot`), world frame, SI units: the confirmed moving tracks as
        pedestrians (position predicted to the current time with the track's velocity,
        velocity, the nominal pedestrian radius, the associated emotion and its discomfort
        distance) and the confirmed still tracks as static discs (centre, fitted radius);
        its `wall_segments` are the known map's walls (`known_walls`), which the planners
        that read discs are given as the simulator's crowd gives them (a building's map,
        as the global route layer has it: the tracker does not have to find the walls).
    tracks (abstract `TrackedPeople`): every confirmed track's id, position [m, world]
        and whether it is static, at the last scan (what a face is assigned to).
Abstract state: the tracker (its tracks and the time of its last scan).
"""

from __future__ import annotations

import copy
import dataclasses as dc

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.sensing.crowd_tracker import CrowdTracker, TrackerParams, tracker_params
from emonav_drake.sensing.leg_detection import detect_scan, detection_params
from emonav_drake.sensing.lidar import scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector

NEUTRAL = EMOTION_NAMES.index("neutral")  # a track no emotion report is near
# A return within this of the known walls' own range is the wall [m]: ~9 σ of the VLP-16's
# range noise (0.01125 m), well inside a person's radius (legs stand ≥ 0.1 m off a wall).
WALL_RETURN_TOLERANCE = 0.1


@dc.dataclass(frozen=True)
class TrackedPeople:
    """The tracker's confirmed tracks at its last scan: ids (T,) int64, positions (T, 2)
    [m, world], whether each is static (a still person or an obstacle; the crowd's
    static discs) and the scan's time [s] (NaN before the first scan)."""

    ids: np.ndarray
    positions: np.ndarray
    static: np.ndarray
    time: float


@dc.dataclass(frozen=True)
class TrackEmotions:
    """The emotion code kept for each track id (`TrackEmotionFusion`'s output)."""

    codes: dict[int, int]


class CrowdTrackerSystem(LeafSystem):
    """LiDAR detection + tracking → the crowd snapshot the state-based planners read.

    Args:
        config: the LiDAR (beams, range), the scan period `crowd.dt`, the nominal
            pedestrian radius and the discomfort distances.
        detection, tracking: the detector's and the tracker's parameters (defaults:
            `sensing/leg_detection.py`'s `detection_params` and `tracker_params` of the
            configuration: the disc detector, or legs paired into people for a sensor
            that sees legs; the configuration's `perception.still_duration`).
    """

    def __init__(
        self,
        config: EmoNavConfig,
        detection: DetectionParams | None = None,
        tracking: TrackerParams | None = None,
        known_walls: np.ndarray | None = None,
    ) -> None:
        """`known_walls`: (W, 2, 2) wall segments [m, world] of the known map (None: none)."""
        super().__init__()
        self._config = config
        walls = np.zeros((0, 2, 2)) if known_walls is None else np.asarray(known_walls, float)
        self._known_walls = walls.reshape(-1, 2, 2)
        self._detection = detection or detection_params(config)
        self._tracking = tracking or tracker_params(config)
        self._distances = np.asarray(config.reward.emotion_distances(), dtype=float)
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._scan_in = self.DeclareVectorInputPort("scan", config.lidar.num_beams)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._emotions_in = self.DeclareAbstractInputPort(
            "track_emotions", AbstractValue.Make(TrackEmotions({}))
        )
        self._tracker = self.DeclareAbstractState(AbstractValue.Make(CrowdTracker(self._tracking)))
        self.DeclareAbstractOutputPort(
            "crowd",
            lambda: AbstractValue.Make(object()),
            self._calc_crowd,
            {
                self.all_state_ticket(),
                self.input_port_ticket(self._crowd_in.get_index()),
                self.input_port_ticket(self._emotions_in.get_index()),
            },
        )
        self.DeclareAbstractOutputPort(
            "tracks",
            lambda: AbstractValue.Make(
                TrackedPeople(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0, bool), 0.0)
            ),
            self._calc_tracks,
            {self.all_state_ticket()},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.crowd.dt, 0.0, self._scan)

    def tracker(self, context: Context) -> CrowdTracker:
        """The tracker in `context` (read only)."""
        return context.get_abstract_state(self._tracker).get_value()

    def without_known_walls(self, ranges: np.ndarray, xy: np.ndarray, heading: float) -> np.ndarray:
        """`ranges` (K,) [m] with the returns of the known walls set to `max_range` (no
        return): a beam within `WALL_RETURN_TOLERANCE` of the walls' own range there."""
        if not len(self._known_walls):
            return ranges
        lidar = self._config.lidar
        walls = scan_discs(
            xy,
            heading,
            np.zeros((0, 2)),
            np.zeros(0),
            len(ranges),
            lidar.max_range,
            lidar.min_range,
            segments=self._known_walls,
        )
        wall = (walls < lidar.max_range) & (np.abs(ranges - walls) < WALL_RETURN_TOLERANCE)
        return np.where(wall, lidar.max_range, ranges)

    def _scan(self, context: Context, state: State) -> None:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        xy = np.array([robot.x, robot.y])
        ranges = np.asarray(self._scan_in.Eval(context), dtype=float)
        detections = detect_scan(
            self.without_known_walls(ranges, xy, robot.heading),
            xy,
            robot.heading,
            self._config.lidar.max_range,
            self._detection,
        )
        tracker = copy.deepcopy(self.tracker(context))
        tracker.update(context.get_time(), detections)
        state.get_mutable_abstract_state(self._tracker).set_value(tracker)

    def _calc_crowd(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self.perceived(context))

    def _calc_tracks(self, context: Context, output: AbstractValue) -> None:
        tracker = self.tracker(context)
        confirmed = tracker.tracks()
        output.set_value(
            TrackedPeople(
                np.array([tr.id for tr in confirmed], dtype=np.int64),
                np.array([tr.x[:2] for tr in confirmed], dtype=float).reshape(-1, 2),
                np.array([tracker.is_static(tr) for tr in confirmed], dtype=bool),
                float("nan") if tracker.time is None else tracker.time,
            )
        )

    def perceived(self, context: Context) -> CrowdSnapshot:
        """The crowd snapshot of the tracks now (see the output port)."""
        tracker = self.tracker(context)
        kept = None
        if self._emotions_in.HasValue(context):
            kept = self._emotions_in.Eval(context).codes
            positions, codes = np.zeros((0, 2)), np.zeros(0, dtype=int)
        else:
            reported: CrowdSnapshot = self._crowd_in.Eval(context)
            positions = np.asarray(reported.positions, dtype=float).reshape(-1, 2)
            codes = np.asarray(reported.emotions, dtype=int).reshape(-1)
        snap = tracker.snapshot(
            positions,
            codes,
            self._distances,
            self._config.crowd.pedestrian_radius,
            self._config.reward.static_discomfort,
            NEUTRAL,
            track_emotions=kept,
        )
        lag = context.get_time() - tracker.time if tracker.time is not None else 0.0
        if lag > 0 and len(snap.positions):  # the last scan's tracks, predicted to now
            snap = dc.replace(snap, positions=snap.positions + snap.velocities * lag)
        if len(self._known_walls):
            snap = dc.replace(snap, wall_segments=self._known_walls)
        return snap
