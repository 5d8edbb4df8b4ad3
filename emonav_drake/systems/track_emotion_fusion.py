"""`TrackEmotionFusion`: the head camera's faces → the emotion kept on each LiDAR track.

Between the face classifier and the crowd tracker (`--emotion-source camera_tracks`):

    EmotionClassifier ── detections ──► TrackEmotionFusion ── track_emotions ──► CrowdTrackerSystem
    CrowdTrackerSystem ── tracks ──────────┘ ▲ robot_state

At every scan period (`crowd.dt`) it folds in the classifier's newest classification, if
it has not yet: each face goes to a track by bearing (`perception/track_emotions.py`:
the track's angular radius plus a tolerance; the camera's field of view and range decide
which tracks it could see), the face's happy / neutral / negative probabilities are
averaged into the track's memory, each reading weighted by its face's size (a face up to 32
px tall adds nothing, one of 48 px or more counts fully:
`TrackEmotionParams.reading_weight`), and the track remembers when it was seen. Its output
is each track's emotion now: the fused one until `decay_time` after the last face, then
neutral; a track never seen is neutral.

Input ports:
    detections (abstract `EmotionEstimate`): the classifier's last classification — its
        time [s], face bearings [rad, relative to the robot's heading, counter-clockwise
        positive] and 7-class probabilities.
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame: where
        the camera is and where it looks (θ + `camera_yaw`).
    tracks (abstract `TrackedPeople`): the tracker's confirmed tracks, ids, positions [m,
        world] and whether each is static, at its last scan; faces go to moving tracks
        only, a static track keeps its memory (a person standing still).
Output port:
    track_emotions (abstract `TrackEmotions`): track id → emotion code now (HAPPY 0,
        NEUTRAL 1, NEGATIVE 2), for the tracks that have one.
Abstract state: the memory (`TrackEmotionMemory`) and the time of the last
classification folded in. The system is a pure function of its inputs.
"""

from __future__ import annotations

import copy
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from emonav_drake.perception.face_assignment import pedestrian_bearings
from emonav_drake.perception.face_emotion import three_way_probabilities
from emonav_drake.perception.track_emotions import TrackEmotionMemory, TrackEmotionParams
from emonav_drake.systems.crowd_tracker_system import TrackEmotions
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector

# The height of a face's box [m] (either detector's, as the classifier reports it): on
# rendered faces 1-5 m away, facing the camera or turned 20°, the boxes are 0.72 (cascade)
# and 0.75 (BlazeFace, widened) of the 0.25 m face: a face's range is focal_y · this / box
# height, within about −37 % … +16 % (cascade) and −22 % … +9 % (BlazeFace).
FACE_BOX_HEIGHT = 0.18


class TrackEmotionFusion(LeafSystem):
    """Faces assigned to LiDAR tracks, emotions kept per track (module docstring).

    Args:
        period: how often it looks for a new classification [s] (the scan period).
        half_fov: half the camera's horizontal field of view [rad].
        max_range: tracks farther than this get no face [m].
        camera_yaw: the optical axis' yaw relative to the robot's heading [rad].
        params: the assignment gates, the running average and the decay time.
        focal_y: the camera's vertical focal length [px]: with it a face's range is read
            off its box (`FACE_BOX_HEIGHT`) and gates the assignment
            (`TrackEmotionParams.range_tolerance`); None: bearing only.
    """

    def __init__(
        self,
        period: float,
        half_fov: float,
        max_range: float,
        camera_yaw: float = 0.0,
        params: TrackEmotionParams | None = None,
        focal_y: float | None = None,
    ) -> None:
        super().__init__()
        self.params = (params or TrackEmotionParams()).validate()
        self.half_fov, self.max_range = float(half_fov), float(max_range)
        self.camera_yaw = float(camera_yaw)
        self.focal_y = None if focal_y is None else float(focal_y)
        self._detections_in = self.DeclareAbstractInputPort(
            "detections", AbstractValue.Make(object())
        )
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._tracks_in = self.DeclareAbstractInputPort("tracks", AbstractValue.Make(object()))
        self._memory = self.DeclareAbstractState(
            AbstractValue.Make((TrackEmotionMemory(self.params), -math.inf))
        )
        self.DeclareAbstractOutputPort(
            "track_emotions",
            lambda: AbstractValue.Make(TrackEmotions({})),
            self._calc_emotions,
            {self.all_state_ticket(), self.time_ticket()},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)

    def memory(self, context: Context) -> TrackEmotionMemory:
        """The memory in `context` (read only)."""
        return context.get_abstract_state(self._memory).get_value()[0]

    def _update(self, context: Context, state: State) -> None:
        estimate = self._detections_in.Eval(context)
        memory, fused_time = context.get_abstract_state(self._memory).get_value()
        if not (math.isfinite(estimate.time) and estimate.time > fused_time):
            return
        tracks = self._tracks_in.Eval(context)
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        bearings, distances, _ = pedestrian_bearings(
            tracks.positions,
            np.array([robot.x, robot.y]),
            robot.heading,
            self.camera_yaw,
            self.half_fov,
            self.max_range,
            self.params.pedestrian_radius,
            self.params.bearing_tolerance,
        )
        # a still track keeps its memory (a person standing), but takes no face: it may be
        # an obstacle, and a face seen at its bearing belongs to someone moving
        bearings = np.where(np.asarray(tracks.static, dtype=bool), np.nan, bearings)
        memory = copy.deepcopy(memory)
        heights = np.asarray(estimate.boxes, dtype=float).reshape(-1, 4)[:, 3]
        face_distances = None
        if self.focal_y is not None:
            face_distances = self.focal_y * FACE_BOX_HEIGHT / np.maximum(heights, 1.0)
        memory.update(
            estimate.time,
            tracks.ids,
            bearings,
            distances,
            estimate.bearings,
            three_way_probabilities(np.asarray(estimate.probabilities).reshape(-1, 7)),
            face_distances,
            heights,
        )
        state.get_mutable_abstract_state(self._memory).set_value((memory, estimate.time))

    def _calc_emotions(self, context: Context, output: AbstractValue) -> None:
        memory = self.memory(context)
        ids = memory.track_ids()
        codes, _ = memory.emotions(context.get_time(), ids)
        output.set_value(TrackEmotions(dict(zip(ids.tolist(), codes.tolist(), strict=True))))
