"""Face detection + emotion classification on real photographs shipped inside installed packages."""

import cv2
import numpy as np
import pytest

from emonav_drake.params import HAPPY, NEGATIVE, NEUTRAL
from emonav_drake.perception.face_assignment import assign_faces, face_bearings
from emonav_drake.perception.face_emotion import (
    SEVEN_TO_THREE,
    DetectorParams,
    FaceEmotion,
    FaceEmotionClassifier,
    annotate,
    frame_label,
    three_way_label,
    three_way_probabilities,
)
from emonav_drake.perception.face_tracking import EmotionSmoother, FaceTracker, box_iou
from emonav_drake.perception.image_io import ImageReadError, load_image, to_gray, video_frames
from emonav_drake.perception.mini_xception import CLASS_NAMES
from emonav_drake.perception.sample_photos import camera_frame, sample_photo

skimage = pytest.importorskip("skimage", reason="sample photos ship with scikit-image")

# The face of each photo: expected 3-way label, top class, and a pixel inside the face.
FACES = {
    "astronaut": (HAPPY, "happy", (225, 110)),
    "grace_hopper": (NEUTRAL, "neutral", (265, 215)),
}


@pytest.fixture(scope="module")
def classifier():
    return FaceEmotionClassifier()


def _shift(image, dx, dy):
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    return cv2.warpAffine(image, m, image.shape[1::-1], borderMode=cv2.BORDER_REPLICATE)


@pytest.mark.parametrize("name", sorted(FACES))
def test_the_face_is_found_and_its_emotion_is_sensible(classifier, name):
    label, top, (u, v) = FACES[name]
    faces = classifier.classify(sample_photo(name))
    assert len(faces) == 1
    f = faces[0]
    x, y, w, h = f.box
    assert x <= u <= x + w and y <= v <= y + h and w >= 50
    assert f.top_class == top and f.label == label
    assert f.probabilities.max() > 0.9 and abs(f.probabilities.sum() - 1) < 1e-5
    assert frame_label(faces) == label


@pytest.mark.parametrize("name", sorted(FACES))
@pytest.mark.parametrize("move", ["flip", (6, 0), (-9, 4), (0, -12), (13, 11)])
def test_flip_and_small_shifts_keep_the_label(classifier, name, move):
    label, top, _ = FACES[name]
    image = sample_photo(name)
    moved = image[:, ::-1].copy() if move == "flip" else _shift(image, *move)
    faces = classifier.classify(moved)
    assert len(faces) == 1
    assert faces[0].label == label and faces[0].top_class == top


@pytest.mark.parametrize("name", ["coffee", "chelsea", "rocket"])
def test_an_image_without_a_face_gives_neutral(classifier, name):
    faces = classifier.classify(sample_photo(name))
    assert faces == []
    assert frame_label(faces) == NEUTRAL


def test_blank_tiny_and_gray_images(classifier):
    assert classifier.classify(np.full((480, 640), 128, np.uint8)) == []
    assert classifier.classify(np.zeros((10, 7, 3), np.uint8)) == []
    bgr = sample_photo("astronaut")
    gray = classifier.classify(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))
    color = classifier.classify(bgr)
    assert [f.box for f in gray] == [f.box for f in color]
    assert np.allclose(gray[0].probabilities, color[0].probabilities)
    rgba = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGBA)
    assert classifier.classify(rgba, channel_order="rgb")[0].label == HAPPY


def test_a_face_in_a_640x480_camera_frame(classifier):
    frame = camera_frame("grace_hopper", "coffee", left=300, height=300)
    assert frame.shape == (480, 640, 3)
    faces = classifier.classify(frame)
    assert [f.label for f in faces] == [NEUTRAL]
    assert faces[0].box[0] > 300


def test_faster_half_resolution_detection_agrees(classifier):
    fast = FaceEmotionClassifier(DetectorParams(detection_scale=0.5), model=classifier.model)
    for name, (label, _, _) in FACES.items():
        a, b = classifier.classify(sample_photo(name)), fast.classify(sample_photo(name))
        assert len(a) == len(b) == 1 and b[0].label == label
        assert box_iou(a[0].box, b[0].box) > 0.8


# --- Preprocessing (fer.FER.detect_emotions semantics) -----------------------------------


def test_crop_box_squares_adds_margin_and_shifts_by_the_padding(classifier):
    # tall box: widened by 10 px, centred; then 10 px margin, + 40 px padding offset
    assert classifier.crop_box((10, 20, 50, 60)) == (35, 50, 115, 130)
    # wide box at the image corner: grown upwards; the top-left is clamped at 0
    assert classifier.crop_box((0, 0, 60, 50)) == (30, 25, 110, 105)
    assert classifier.crop_box((-45, -48, 60, 60)) == (0, 0, 65, 62)


def test_padding_uses_the_mean_of_the_bottom_two_rows(classifier):
    gray = np.zeros((100, 80), np.uint8)
    gray[-2:] = [[10], [31]]  # mean 20.5 → rounded by OpenCV to 20
    padded = classifier.pad(gray)
    assert padded.shape == (180, 160)
    assert padded[0, 0] == padded[-1, -1] == 20 and padded[40, 40] == 0


def test_crops_are_64x64_scaled_to_minus_one_one(classifier):
    gray = np.full((200, 200), 255, np.uint8)
    gray[100:] = 0
    crops = classifier.crops(gray, np.array([[50, 50, 100, 100]]))
    assert crops.shape == (1, 64, 64) and crops.dtype == np.float32
    assert crops.max() == 1.0 and crops.min() == -1.0
    assert np.all(crops[0, :20] == 1.0) and np.all(crops[0, -20:] == -1.0)


def test_seven_classes_map_to_the_papers_three_emotions():
    names = dict(zip(CLASS_NAMES, SEVEN_TO_THREE, strict=True))
    assert names == {
        "angry": NEGATIVE,
        "disgust": NEGATIVE,
        "fear": NEGATIVE,
        "happy": HAPPY,
        "sad": NEGATIVE,
        "surprise": NEGATIVE,
        "neutral": NEUTRAL,
    }
    for k in range(7):
        assert three_way_label(np.eye(7)[k]) == SEVEN_TO_THREE[k]
    p = np.array([0.1, 0.05, 0.05, 0.3, 0.1, 0.1, 0.3])
    assert np.allclose(three_way_probabilities(p), [0.3, 0.3, 0.4])
    assert three_way_label(p) == HAPPY  # top class (first of the tie), not the group sum


# --- Bad input ------------------------------------------------------------------------------


def test_corrupted_or_non_image_files_give_a_clear_error(tmp_path):
    text = tmp_path / "notes.png"
    text.write_text("this is not a picture\n")
    empty = tmp_path / "empty.jpg"
    empty.write_bytes(b"")
    png = skimage.data.__path__[0] + "/astronaut.png"
    truncated = tmp_path / "truncated.png"
    truncated.write_bytes(open(png, "rb").read()[:3000])
    garbage = tmp_path / "garbage.jpg"
    garbage.write_bytes(b"\xff\xd8\xff\xe0" + bytes(range(256)) * 8)
    for path in (text, truncated, garbage):
        with pytest.raises(ImageReadError, match="not a readable image"):
            load_image(path)
    with pytest.raises(ImageReadError, match="empty"):
        load_image(empty)
    with pytest.raises(FileNotFoundError, match="no such file"):
        load_image(tmp_path / "missing.png")
    bad_video = tmp_path / "clip.mp4"
    bad_video.write_text("not a video")
    with pytest.raises(ImageReadError, match="not a readable video"):
        list(video_frames(bad_video))


def test_bad_arrays_are_refused():
    with pytest.raises(ImageReadError, match="uint8"):
        to_gray(np.zeros((10, 10), np.float32))
    with pytest.raises(ImageReadError, match="shape"):
        to_gray(np.zeros((10, 10, 2), np.uint8))
    with pytest.raises(ValueError, match="detection_scale"):
        DetectorParams(detection_scale=2.0)


# --- Video, tracking, smoothing, drawing ----------------------------------------------------


def _pan_video(path, frames=8):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (640, 480))
    for k in range(frames):
        writer.write(camera_frame("grace_hopper", "coffee", left=40 + 15 * k, height=300))
    writer.release()


def test_video_frames_track_one_face(tmp_path, classifier):
    video = tmp_path / "pan.avi"
    _pan_video(video)
    frames = list(video_frames(video, every=2))
    assert [i for i, _, _ in frames] == [0, 2, 4, 6]
    assert np.allclose([t for _, t, _ in frames], [0.0, 0.2, 0.4, 0.6])
    tracker = FaceTracker()
    ids, labels = [], []
    for _, _, frame in frames:
        faces = classifier.classify(frame)
        ids.append(tracker.update([f.box for f in faces]))
        labels.append(frame_label(faces))
    assert all(i == [0] for i in ids)  # one face, one identity as it moves
    assert labels == [NEUTRAL] * 4


def test_tracker_and_smoother():
    t = FaceTracker(min_iou=0.3, max_missed=1)
    assert t.update([(0, 0, 10, 10), (50, 50, 10, 10)]) == [0, 1]
    assert t.update([(52, 51, 10, 10), (1, 1, 10, 10)]) == [1, 0]
    assert t.update([]) == []
    assert t.update([]) == []  # both tracks dropped after one missed frame too many
    assert t.update([(0, 0, 10, 10)]) == [2]
    s = EmotionSmoother(alpha=0.25)
    a, b = np.eye(7)[3], np.eye(7)[6]
    assert np.allclose(s.update(0, a), a)
    assert np.allclose(s.update(0, b), 0.75 * a + 0.25 * b)
    s.forget([])
    assert np.allclose(s.update(0, b), b)
    with pytest.raises(ValueError):
        EmotionSmoother(alpha=0.0)


def test_annotate_draws_boxes_in_the_label_colour():
    image = np.zeros((200, 200, 3), np.uint8)
    face = FaceEmotion((50, 60, 80, 80), np.eye(7)[3])
    out = annotate(image, [face])
    assert out.shape == image.shape and image.max() == 0  # the input is not modified
    assert tuple(out[100, 50]) == (60, 200, 60)  # the happy colour on the box's left edge


# --- Faces → pedestrians ----------------------------------------------------------------


def test_face_bearings_in_a_pinhole_camera():
    # principal point 319.5 (Drake CameraInfo), focal 400 px
    b = face_bearings(np.array([[300, 0, 40, 40], [0, 0, 40, 40], [600, 0, 40, 40]]), 400, 319.5)
    assert b[0] == pytest.approx(0.0)
    assert b[1] == pytest.approx(np.arctan2(300, 400)) and b[1] > 0  # left of the axis
    assert b[2] == pytest.approx(-np.arctan2(300, 400))
    assert face_bearings(np.array([[300, 0, 40, 40]]), 400, 319.5, camera_yaw=0.5)[0] == 0.5


def test_assign_faces_by_bearing():
    faces = np.array([0.30, -0.02, -0.5])
    peds = np.array([0.0, 0.28, np.nan, 0.05])  # pedestrian 2 is out of view
    dist = np.array([2.0, 3.0, 1.0, 4.0])
    gate = np.full(4, 0.1)
    assert assign_faces(faces, peds, dist, gate).tolist() == [1, 0, -1]
    # two faces near one pedestrian: only the closer in bearing gets it
    assert assign_faces(np.array([0.01, 0.02]), np.array([0.0]), [2.0], [0.1]).tolist() == [0, -1]
    # equal bearing errors: the nearer pedestrian wins
    assert assign_faces(np.array([0.0]), np.array([0.05, -0.05]), [3.0, 1.5], [0.1, 0.1]) == [1]
    assert assign_faces(np.zeros(0), peds, dist, gate).shape == (0,)
