"""`CrowdTrackerSystem`: the crowd as a robot estimates it from its LiDAR scan.

At the scan's rate (every `crowd.dt`, 10 Hz) it runs the perception pipeline of
`sensing/crowd_perception.py` (the same code the fast LIP world runs): the returns the
known map explains dropped (`known_walls`), people detected in the 1800-beam scan, and a
multi-target tracker updated. Its output replaces the
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
from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.crowd_perception import (
    NEUTRAL,
    WALL_RETURN_TOLERANCE,
    CrowdPerception,
)
from emonav_drake.sensing.crowd_tracker import CrowdTracker, TrackerParams
from emonav_drake.sensing.lidar_objects import DetectionParams
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector

__all__ = [
    "NEUTRAL",
    "WALL_RETURN_TOLERANCE",
    "CrowdTrackerSystem",
    "TrackEmotions",
    "TrackedPeople",
]


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
        known_walls: (W, 2, 2) wall segments [m, world] of the known map (None: none).
    """

    def __init__(
        self,
        config: EmoNavConfig,
        detection: DetectionParams | None = None,
        tracking: TrackerParams | None = None,
        known_walls: np.ndarray | None = None,
    ) -> None:
        super().__init__()
        self._config = config
        self.perception = CrowdPerception(config, known_walls, detection, tracking)
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._scan_in = self.DeclareVectorInputPort("scan", config.lidar.num_beams)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._emotions_in = self.DeclareAbstractInputPort(
            "track_emotions", AbstractValue.Make(TrackEmotions({}))
        )
        self._tracker = self.DeclareAbstractState(AbstractValue.Make(self.perception.new_tracker()))
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
        return): `CrowdPerception.without_known_walls`."""
        return self.perception.without_known_walls(ranges, xy, heading)

    def _scan(self, context: Context, state: State) -> None:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        tracker = copy.deepcopy(self.tracker(context))
        self.perception.update(
            tracker,
            context.get_time(),
            self._scan_in.Eval(context),
            np.array([robot.x, robot.y]),
            robot.heading,
        )
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
        if self._emotions_in.HasValue(context):
            kept, reported = self._emotions_in.Eval(context).codes, None
        else:
            kept, reported = None, self._crowd_in.Eval(context)
        return self.perception.snapshot(self.tracker(context), context.get_time(), reported, kept)
