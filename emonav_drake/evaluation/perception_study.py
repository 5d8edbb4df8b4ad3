"""What the head camera really gives: detection and recognition, measured.

Two measurements of the camera chain (`diagrams/camera_perception.py`), both with the
real renderer, Haar cascade and CNN:

* `sweep`: one pedestrian placed in front of the robot's camera at a grid of distances
  [m], bearings [deg] (relative to the optical axis, counter-clockwise positive) and
  facing angles [deg] (0: it faces the camera; 180: its back), for each emotion; one
  classification each. Detection rate and recognition against the geometry.
* `episode_samples`: whole navigation episodes with camera emotions; at every
  classification (0.5 Hz) each pedestrian's true emotion, what the chain made of it,
  whether its face was found, and its geometry at that instant. The confusion matrix of
  the in-loop pipeline against the ground truth, with unseen pedestrians (neutral by
  rule) counted.
* `classification_seconds`: the wall time of one classification (render + Haar cascade
  + CNN + assignment) and of the cascade alone, at the camera of the params.

The camera is `EmotionEstimateParams.camera` (default: the ZED 2 at HD720; the earlier
640 × 480 camera is `HeadCameraParams.vga()`).

A sample is a plain dict (JSON-ready): distance, bearing_deg, facing_deg, truth, estimate
(codes HAPPY 0, NEUTRAL 1, NEGATIVE 2), detected (a face was assigned to it), and for
episodes seed and time.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.crowd.pedestrian_pose import bearing_and_facing
from emonav_drake.diagrams.episode import EpisodeStepper
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario

NUM_EMOTIONS = len(EMOTION_NAMES)


class CameraRig:
    """The camera chain with one pedestrian whose pose and emotion are set per shot.

    The robot stands at the origin facing +x with the LIP camera (`lip_height`); the
    pedestrian's position, heading and emotion come from constant sources changed
    between shots. The classifier is `EmotionClassifier.estimate` on the rendered image.
    """

    def __init__(self, params: EmotionEstimateParams | None = None) -> None:
        from emonav_drake.diagrams.camera_perception import make_classifier
        from emonav_drake.systems.head_camera import AddCameraScene, AddHeadCamera
        from emonav_drake.systems.pedestrian_bodies import PedestrianBodies

        self.params = (params or EmotionEstimateParams(mode="camera")).validate()
        cam = self.params.camera
        self.config = EmoNavConfig()
        scenario = Scenario(
            pedestrians=[PedestrianSpec(start=[2.0, 0.0], goal=[-2.0, 0.0])],
            obstacles=[],
            robot_start=[0.0, 0.0],
            robot_goal=[8.0, 0.0],
        )
        b = DiagramBuilder()
        robot = b.AddSystem(ConstantVectorSource(np.zeros(4)))
        mount = b.AddSystem(ConstantValueSource(AbstractValue.Make(RigidTransform())))
        scene = AddCameraScene(b)
        bodies = b.AddSystem(PedestrianBodies(scene, scenario))
        b.Connect(
            bodies.GetOutputPort("geometry_pose"), scene.get_source_pose_port(bodies.source_id)
        )
        camera = AddHeadCamera(
            b, scene, mount.get_output_port(), np.array([0.0, 0.0, cam.lip_height]), cam
        )
        self.classifier = b.AddSystem(make_classifier(self.params, camera))
        b.Connect(camera.color_image, self.classifier.GetInputPort("image"))
        b.Connect(robot.get_output_port(), self.classifier.GetInputPort("robot_state"))
        crowd = b.ExportInput(bodies.GetInputPort("crowd"), "crowd")
        b.ConnectInput(crowd, self.classifier.GetInputPort("crowd"))
        self.camera = camera
        self.diagram = b.Build()
        self.context = self.diagram.CreateDefaultContext()

    def _snapshot(self, x: float, y: float, heading: float, emotion: int = 1) -> CrowdSnapshot:
        speed = 1.0  # walking along its heading: PedestrianBodies faces it that way
        dist = np.asarray(self.config.reward.emotion_distances())
        return CrowdSnapshot(
            positions=np.array([[x, y]]),
            velocities=speed * np.array([[math.cos(heading), math.sin(heading)]]),
            radius=self.config.crowd.pedestrian_radius,
            emotions=np.array([emotion], np.int64),
            discomfort=dist[[emotion]],
            static_centers=np.zeros((0, 2)),
            static_radii=np.zeros(0),
            static_discomfort=self.config.reward.static_discomfort,
        )

    def shot(self, distance: float, bearing_deg: float, facing_deg: float, emotion: int) -> dict:
        """Place the pedestrian, render, classify: one sample (module docstring)."""
        self.place(distance, bearing_deg, facing_deg, emotion)
        est = self.classifier.estimate(self.classifier.GetMyContextFromRoot(self.context))
        return {
            "distance": float(distance),
            "bearing_deg": float(bearing_deg),
            "facing_deg": float(facing_deg),
            "truth": int(emotion),
            "estimate": int(est.pedestrian_emotions[0]),
            "detected": bool((est.face_pedestrian == 0).any()),
            "faces": len(est.boxes),
        }

    def place(self, distance: float, bearing_deg: float, facing_deg: float, emotion: int) -> None:
        """Place the pedestrian (as `shot`) without classifying."""
        b = math.radians(bearing_deg)
        x, y = distance * math.cos(b), distance * math.sin(b)
        heading = math.atan2(-y, -x) - math.radians(facing_deg)
        self.diagram.get_input_port(0).FixValue(
            self.context, AbstractValue.Make(self._snapshot(x, y, heading, emotion))
        )

    def face_pixel(self, distance: float, bearing_deg: float) -> tuple[float, float, float]:
        """(u, v, height) [px] of the placed pedestrian's face in the image: the head's
        centre projected by the pinhole camera (`PedestrianBody.head_center_height`, the
        face's height `face_height`)."""
        from emonav_drake.crowd.pedestrian_pose import PedestrianBody

        cam, body = self.params.camera, PedestrianBody()
        f = (cam.height / 2.0) / math.tan(math.radians(cam.fov_y_deg) / 2.0)
        b = math.radians(bearing_deg)
        ahead, left = distance * math.cos(b), distance * math.sin(b)
        u = (cam.width - 1) / 2.0 - f * left / ahead
        v = (cam.height - 1) / 2.0 - f * (body.head_center_height - cam.lip_height) / ahead
        return u, v, f * body.face_height / ahead

    def image(self) -> np.ndarray:
        """The last shot's image as RGB uint8 (H, W, 3)."""
        port = self.camera.color_image
        img = port.Eval(self.camera.sensor.GetMyContextFromRoot(self.context))
        return np.array(img.data)[:, :, :3].copy()


def classification_seconds(
    params: EmotionEstimateParams | None = None,
    distances: Sequence[float] = (1.5, 2.0, 3.0, 4.0, 5.0),
    repeats: int = 4,
) -> dict[str, float]:
    """Median wall times [s] of one classification at the camera of `params`: "shot"
    (render + Haar cascade + CNN + assignment: `CameraRig.shot`) and "detect" (the
    cascade alone on that image), over a happy pedestrian facing the camera at each of
    `distances` [m], `repeats` times each, after one warm-up shot."""
    import time

    from emonav_drake.perception.image_io import to_gray

    rig = CameraRig(params)
    rig.shot(distances[0], 0.0, 0.0, 0)  # warm-up: renderer and network initialised
    shot, detect = [], []
    for _ in range(repeats):
        for d in distances:
            t0 = time.perf_counter()
            rig.shot(d, 0.0, 0.0, 0)
            shot.append(time.perf_counter() - t0)
            gray = to_gray(rig.image(), "rgb")
            t0 = time.perf_counter()
            rig.classifier.classifier.detect(gray)
            detect.append(time.perf_counter() - t0)
    return {"shot": float(np.median(shot)), "detect": float(np.median(detect)), "n": len(shot)}


def detection_sweep(
    distances: Sequence[float],
    facings_deg: Sequence[float],
    detectors: dict[str, Any],
    emotions: Iterable[int] = range(NUM_EMOTIONS),
    params: EmotionEstimateParams | None = None,
    progress: bool = False,
    rig: CameraRig | None = None,
) -> list[dict]:
    """Face detection alone, per detector, on one rendered pedestrian straight ahead.

    For each (emotion, distance [m], facing [deg]: 0 faces the camera, 90 shows its
    profile) the pedestrian is rendered once and every detector of `detectors` (name →
    a callable (RGB image, (u, v, face height) [px] where the head projects: what a
    person tracker would tell) → boxes (F, 4) (x, y, w, h) [px]) runs on the image. A sample
    per detector: whether a box contains the projected centre of the face
    (`CameraRig.face_pixel`), the number of boxes, the face's height [px] and the
    detector's wall time [s]. `rig`: the camera rig to render with (default: a new one
    of `params`; a detector built on a rig's classifier can share it)."""
    import time

    from emonav_drake.progress import progress_bar

    rig = rig or CameraRig(params)
    grid = [(e, d, f) for e in emotions for d in distances for f in facings_deg]
    out = []
    for e, d, f in progress_bar(grid, desc="detection sweep", unit="shot", enabled=progress):
        rig.place(d, 0.0, f, e)
        image = rig.image()
        u, v, face_px = rig.face_pixel(d, 0.0)
        for name, detect in detectors.items():
            t0 = time.perf_counter()
            boxes = np.asarray(detect(image, (u, v, face_px))).reshape(-1, 4)
            seconds = time.perf_counter() - t0
            hit = (
                (boxes[:, 0] <= u)
                & (u <= boxes[:, 0] + boxes[:, 2])
                & (boxes[:, 1] <= v)
                & (v <= boxes[:, 1] + boxes[:, 3])
            )
            out.append(
                {
                    "detector": name,
                    "emotion": int(e),
                    "distance": float(d),
                    "facing_deg": float(f),
                    "face_px": round(float(face_px), 1),
                    "detected": bool(hit.any()),
                    "boxes": len(boxes),
                    "seconds": seconds,
                }
            )
    return out


def half_fov_x_deg(params: EmotionEstimateParams) -> float:
    """Half the camera's horizontal field of view [deg] (pinhole: from the vertical one
    and the aspect ratio)."""
    cam = params.camera
    half_y = math.radians(cam.fov_y_deg) / 2.0
    return math.degrees(math.atan(math.tan(half_y) * cam.width / cam.height))


def sweep(
    distances: Sequence[float],
    bearings_deg: Sequence[float],
    facings_deg: Sequence[float],
    emotions: Iterable[int] = range(NUM_EMOTIONS),
    params: EmotionEstimateParams | None = None,
    progress: bool = False,
) -> list[dict]:
    """One `CameraRig.shot` per (emotion, distance, bearing, facing), in that nesting."""
    from emonav_drake.progress import progress_bar

    rig = CameraRig(params)
    grid = [
        (e, d, b, f) for e in emotions for d in distances for b in bearings_deg for f in facings_deg
    ]
    return [
        rig.shot(d, b, f, e)
        for e, d, b, f in progress_bar(grid, desc="camera sweep", unit="shot", enabled=progress)
    ]


def episode_samples(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Any,
    params: EmotionEstimateParams | None = None,
) -> tuple[Any, list[dict]]:
    """Run one LIP episode with camera emotions; (its record, one sample per pedestrian
    per classification).

    The geometry and the true emotion are read at each classification instant before
    the updates at that instant (what the camera rendered); the estimate is the
    classifier's result of that instant, read one walking step later.
    """
    from pydrake.systems.analysis import Simulator

    from emonav_drake.diagrams.navigation import build_navigation_diagram
    from emonav_drake.systems.episode_monitor import episode_monitor_callback

    params = (params or EmotionEstimateParams(mode="camera")).validate()
    if params.mode != "camera":
        raise ValueError(f"episode_samples needs mode 'camera', not {params.mode!r}")
    nav = build_navigation_diagram(scenario, config, planner, emotion_estimate=params)
    sim = Simulator(nav.diagram)
    sim.set_monitor(episode_monitor_callback(nav.diagram, nav.monitor))
    sim.Initialize()
    ctx = sim.get_mutable_context()
    d = nav.diagram
    classifier = d.GetSubsystemByName("emotion_classifier")
    bodies = d.GetSubsystemByName("pedestrian_bodies")
    cam_pose = d.GetSubsystemByName("head_camera_pose")
    T, P = config.robot.step_time, params.period
    stepper = EpisodeStepper(sim, nav.systems(), T)
    samples: list[dict] = []
    pending: list[dict] = []
    while True:
        t = ctx.get_time()
        if pending:  # the classification of the previous instant is in the state now
            est = classifier.GetOutputPort("detections").Eval(classifier.GetMyContextFromRoot(ctx))
            for s in pending:
                p = s.pop("_index")
                s["estimate"] = int(est.pedestrian_emotions[p])
                s["detected"] = bool((est.face_pedestrian == p).any())
            samples += pending
            pending = []
        record = stepper.outcome()
        if record is not None:
            return record, samples
        if abs(t / P - round(t / P)) < 1e-9:  # a classification instant
            pending = _geometry(ctx, t, nav, bodies, cam_pose, scenario.seed)
        stepper.advance()  # the LIP cannot fall: a simulator error is raised


def _geometry(ctx, t, nav, bodies, cam_pose, seed) -> list[dict]:
    """Each pedestrian's truth and geometry seen from the camera at time t."""
    crowd = nav.crowd.GetOutputPort("crowd").Eval(nav.crowd.GetMyContextFromRoot(ctx))
    X_WC = (
        cam_pose.GetOutputPort("geometry_pose")
        .Eval(cam_pose.GetMyContextFromRoot(ctx))
        .value(cam_pose.frame_id)
    )
    headings = [
        X.rotation().ToRollPitchYaw().yaw_angle()
        for X in bodies.pedestrian_poses(bodies.GetMyContextFromRoot(ctx))
    ]
    cam_xy = X_WC.translation()[:2]
    cam_yaw = X_WC.rotation().ToRollPitchYaw().yaw_angle()
    pos = np.asarray(crowd.positions).reshape(-1, 2)
    dist, facing = bearing_and_facing(cam_xy, pos, np.asarray(headings))
    rel = pos - cam_xy
    bearing = np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - cam_yaw)))
    return [
        {
            "seed": int(seed),
            "time": float(t),
            "_index": i,
            "distance": float(dist[i]),
            "bearing_deg": float(np.degrees(bearing[i])),
            "facing_deg": float(np.degrees(facing[i])),
            "truth": int(crowd.emotions[i]),
        }
        for i in range(len(pos))
    ]


def confusion_counts(samples: Iterable[dict], detected_only: bool = False) -> np.ndarray:
    """(3, 3) counts: rows the true emotion, columns the estimate."""
    c = np.zeros((NUM_EMOTIONS, NUM_EMOTIONS), np.int64)
    for s in samples:
        if detected_only and not s["detected"]:
            continue
        c[s["truth"], s["estimate"]] += 1
    return c


def rate_by(
    samples: Sequence[dict], key: str, edges: Sequence[float], what: str = "detected"
) -> tuple[np.ndarray, np.ndarray]:
    """(rate of `what` per bin of `key` between `edges`, samples per bin)."""
    x = np.array([s[key] for s in samples], dtype=float)
    y = np.array([bool(s[what]) for s in samples], dtype=float)
    idx = np.digitize(x, edges) - 1
    n = np.array([(idx == i).sum() for i in range(len(edges) - 1)])
    rate = np.array(
        [y[idx == i].mean() if n[i] else np.nan for i in range(len(edges) - 1)], dtype=float
    )
    return rate, n
