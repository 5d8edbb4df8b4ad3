"""BlazeFace on OpenCV's DNN (`perception/blazeface.py`) and the detection sweep.

The real network (MediaPipe's short-range model from the mediapipe wheel) on the
package's own face images, whole and shrunk into a 1280 × 720 frame, and on faces the
head camera renders at 5 m, where the Haar cascade finds none.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from emonav_drake.perception.blazeface import (
    INPUT,
    BlazeFaceDetector,
    BlazeFaceParams,
    anchors,
    blazeface_model_path,
)

FACES = ("happy", "neutral", "negative")


def face_image(name: str) -> np.ndarray:
    from importlib.resources import files

    path = files("emonav_drake") / "data" / "faces" / f"{name}.png"
    return np.ascontiguousarray(cv2.imread(str(path))[:, :, ::-1])


@pytest.fixture(scope="module")
def detector():
    return BlazeFaceDetector()


def test_the_anchors_are_the_networks_896_cell_centres():
    a = anchors()
    assert a.shape == (896, 2)
    assert np.allclose(a[0], [0.5 / 16, 0.5 / 16]) and np.allclose(a[1], a[0])  # 2 per cell
    assert np.allclose(a[512], [0.5 / 8, 0.5 / 8]) and np.allclose(a[517], a[512])  # 6 per cell
    assert blazeface_model_path().stat().st_size > 100_000


@pytest.mark.parametrize("name", FACES)
def test_each_face_is_found_whole_and_at_24_px_in_a_wide_frame(detector, name):
    img = face_image(name)
    boxes, scores = detector.detect(img)
    assert len(boxes) >= 1 and scores[0] > 0.8
    x, y, w, h = boxes[0]
    assert w > 0.4 * img.shape[1]  # the face fills the portrait
    frame = np.full((720, 1280, 3), 90, np.uint8)
    small = cv2.resize(img, (24, 30), interpolation=cv2.INTER_AREA)
    frame[300:330, 600:624] = small
    boxes, _ = detector.detect(frame)
    centres = boxes[:, :2] + boxes[:, 2:] / 2
    assert np.any(np.hypot(*(centres - [612, 315]).T) < 12), boxes
    # one region around it finds it too, a region elsewhere does not
    near, _ = detector.detect_regions(frame, [(548, 251, INPUT)])
    far, _ = detector.detect_regions(frame, [(0, 0, INPUT)])
    assert len(near) >= 1 and len(far) == 0


def test_the_tiles_cover_the_frame_and_regions_may_leave_it(detector):
    tiles = detector.tiles(720, 1280)
    covered = np.zeros((720, 1280), bool)
    for x, y, side in tiles[:-1]:
        covered[y : y + side, x : x + side] = True
    assert covered.all() and tiles[-1] == (0, 0, 1280)
    frame = np.zeros((720, 1280, 3), np.uint8)
    regions = [(-64, -64, 128), (1200, 680, 128), (-1400, 10, 380), (1300, 800, 128)]
    boxes, scores = detector.detect_regions(frame, regions)
    assert boxes.shape == (0, 4) and scores.shape == (0,)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="score_threshold"):
        BlazeFaceParams(score_threshold=1.5)
    with pytest.raises(ValueError, match="overlap"):
        BlazeFaceParams(tile=128, overlap=128)


@pytest.mark.slow
def test_the_head_camera_at_5_m_blazeface_finds_the_face_the_cascade_does_not():
    """The detection sweep on real renders: at 1.5 m both find the face; at 5 m facing
    the camera the cascade's 24-px minimum is not reached, BlazeFace finds it."""
    from emonav_drake.evaluation.perception_study import CameraRig, detection_sweep
    from emonav_drake.perception.image_io import to_gray
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    params = EmotionEstimateParams(mode="camera")
    rig = CameraRig(params)
    haar = rig.classifier.classifier
    blaze = BlazeFaceDetector()
    detectors = {
        "haar": lambda image, hint: haar.detect(to_gray(image, "rgb")),
        "blazeface": lambda image, hint: blaze.detect(image)[0],
    }
    samples = detection_sweep([1.5, 5.0], [0.0], detectors, emotions=[0], params=params, rig=rig)
    found = {(s["detector"], s["distance"]): s["detected"] for s in samples}
    assert found == {
        ("haar", 1.5): True,
        ("blazeface", 1.5): True,
        ("haar", 5.0): False,
        ("blazeface", 5.0): True,
    }
    face = {s["distance"]: s["face_px"] for s in samples}
    assert face[5.0] < 30 < face[1.5]


@pytest.mark.slow
def test_the_classifier_with_blazeface_assigns_a_face_at_5_m_and_reads_it_at_1_m():
    """`face_detector: blazeface`: the face at the pedestrian's projected head is found
    at 5 m (the cascade finds none there) and, near, its emotion is read right."""
    from emonav_drake.evaluation.perception_study import CameraRig
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    params = EmotionEstimateParams(mode="camera")
    params.camera.face_detector = "blazeface"
    rig = CameraRig(params.validate())
    far = rig.shot(5.0, 0.0, 0.0, 2)
    assert far["detected"]
    for emotion in (0, 1, 2):
        near = rig.shot(1.0, 0.0, 0.0, emotion)
        assert near["detected"] and near["estimate"] == emotion
    haar = CameraRig(EmotionEstimateParams(mode="camera")).shot(5.0, 0.0, 0.0, 2)
    assert not haar["detected"]


def test_an_unknown_face_detector_names_the_field():
    from emonav_drake.params import ConfigError
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    params = EmotionEstimateParams(mode="camera")
    params.camera.face_detector = "yolo"
    with pytest.raises(ConfigError, match="emotion_estimate.camera.face_detector"):
        params.validate()
