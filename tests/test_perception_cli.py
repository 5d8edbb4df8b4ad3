"""`emonav emotion PATH [--json] [--annotate]` on real photographs and a video made from one."""

import json

import cv2
import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.perception.sample_photos import camera_frame, sample_photo_path

pytest.importorskip("skimage", reason="sample photos ship with scikit-image")


def test_image_to_json_and_annotated_png(tmp_path, capsys):
    out, png = tmp_path / "faces.json", tmp_path / "faces.png"
    photo = sample_photo_path("astronaut")
    assert main(["emotion", str(photo), "--json", str(out), "--annotate", str(png)]) == 0
    r = json.loads(out.read_text())
    assert r["kind"] == "image" and (r["width"], r["height"]) == (512, 512)
    assert r["label"] == "happy" and len(r["faces"]) == 1
    face = r["faces"][0]
    assert face["label"] == "happy" and face["top_class"] == "happy"
    assert set(face["probabilities"]) == {
        "angry",
        "disgust",
        "fear",
        "happy",
        "sad",
        "surprise",
        "neutral",
    }
    assert abs(sum(face["probabilities"].values()) - 1.0) < 1e-3
    drawn = cv2.imread(str(png))
    assert drawn.shape == (512, 512, 3)
    x, y, w, h = face["box"]
    assert tuple(drawn[y + h // 2, x]) == (60, 200, 60)  # the happy box edge
    assert "happy" in capsys.readouterr().out


def test_image_without_a_face_is_neutral(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["emotion", str(sample_photo_path("coffee")), "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["faces"] == [] and r["label"] == "neutral"
    assert "no face found: neutral" in capsys.readouterr().out


@pytest.mark.slow
def test_video_with_smoothing_json_and_annotation(tmp_path, capsys):
    video = tmp_path / "walk.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (640, 480))
    for k in range(6):
        writer.write(camera_frame("grace_hopper", "coffee", left=60 + 20 * k, height=300))
    writer.write(np.full((480, 640, 3), 100, np.uint8))  # the face leaves the frame
    writer.release()
    out, png, mp4 = tmp_path / "v.json", tmp_path / "v.png", tmp_path / "v.mp4"
    args = ["emotion", str(video), "--json", str(out), "--annotate", str(png), "--smooth", "0.5"]
    assert main(args) == 0
    r = json.loads(out.read_text())
    assert r["kind"] == "video" and r["summary"]["frames"] == 7
    assert r["summary"]["frames_with_faces"] == 6
    assert r["summary"]["labels"] == {"happy": 0, "neutral": 7, "negative": 0}
    assert [f["index"] for f in r["frames"]] == list(range(7))
    assert {f["faces"][0]["track"] for f in r["frames"][:6]} == {0}
    assert cv2.imread(str(png)).shape == (480, 640, 3)
    assert main(["emotion", str(video), "--every", "3", "--annotate", str(mp4)]) == 0
    cap = cv2.VideoCapture(str(mp4))
    frames = 0
    while cap.read()[0]:
        frames += 1
    assert frames == 3  # frames 0, 3, 6
    assert "7 frame(s) classified" in capsys.readouterr().out


@pytest.mark.parametrize(
    "content, name, message",
    [
        (b"hello, not an image", "x.png", "not a readable image"),
        (b"\x89PNG\r\n\x1a\n" + b"\x00" * 100, "broken.png", "not a readable image"),
        (b"", "empty.jpg", "empty"),
        (b"not a video", "clip.mp4", "not a readable video"),
    ],
)
def test_bad_files_exit_2_with_a_clear_message(tmp_path, capsys, content, name, message):
    path = tmp_path / name
    path.write_bytes(content)
    assert main(["emotion", str(path)]) == 2
    assert message in capsys.readouterr().err


def test_missing_file_and_bad_annotation_suffix(tmp_path, capsys):
    assert main(["emotion", str(tmp_path / "nothing.png")]) == 2
    assert "no such file" in capsys.readouterr().err
    photo = str(sample_photo_path("astronaut"))
    assert main(["emotion", photo, "--annotate", str(tmp_path / "a.txt")]) == 2
    assert "--annotate" in capsys.readouterr().err
