"""The pedestrians' face textures (`emonav_drake/data/faces`): files, provenance, and what
the real classifier says of them (`scripts/make_face_textures.py`)."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from emonav_drake.params import EMOTION_NAMES
from emonav_drake.perception.face_emotion import FaceEmotionClassifier
from emonav_drake.perception.image_io import load_image
from emonav_drake.perception.mini_xception import CLASS_NAMES

ROOT = Path(__file__).resolve().parent.parent
FACES = ROOT / "emonav_drake" / "data" / "faces"
SCRIPT = ROOT / "scripts" / "make_face_textures.py"
PNGS = [f"{e}.png" for e in EMOTION_NAMES]
PROB_TOL = 1e-4


def _faces_json() -> dict[str, Any]:
    return json.loads((FACES / "faces.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def script() -> Iterator[ModuleType]:
    """scripts/make_face_textures.py, imported as a module."""
    name = "make_face_textures"
    spec = importlib.util.spec_from_file_location(name, SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look their module up there
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        sys.modules.pop(name, None)


def _assert_same(a: Any, b: Any, where: str = "") -> None:
    """Equal JSON values, floats within PROB_TOL."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, abs=PROB_TOL), where
    else:
        assert a == b, where


@pytest.fixture(scope="module")
def classifier() -> FaceEmotionClassifier:
    """The real classifier with its default settings."""
    return FaceEmotionClassifier()


def test_shipped_files_exist_and_are_rgb_portraits() -> None:
    assert (FACES / "faces.json").is_file()
    assert (FACES / "README.md").is_file()
    for name in PNGS:
        image = load_image(FACES / name)
        assert image.shape == (320, 256, 3), name


def test_sha256_in_faces_json_matches_files() -> None:
    textures = _faces_json()["textures"]
    assert sorted(textures) == sorted(EMOTION_NAMES)
    for emotion, entry in textures.items():
        assert entry["file"] == f"{emotion}.png"
        digest = hashlib.sha256((FACES / entry["file"]).read_bytes()).hexdigest()
        assert digest == entry["sha256"], emotion


def test_recorded_classifier_results_match_the_real_classifier(
    classifier: FaceEmotionClassifier,
) -> None:
    for emotion, entry in _faces_json()["textures"].items():
        recorded = entry["classifier"]
        faces = classifier.classify(load_image(FACES / entry["file"]))
        assert recorded["face_detected"] == bool(faces), emotion
        if not faces:
            assert recorded["label"] == "neutral"  # no face -> NEUTRAL (paper §IV-G)
            continue
        face = max(faces, key=lambda f: f.box[2] * f.box[3])
        assert face.top_class == recorded["top_class"], emotion
        assert face.label_name == recorded["label"], emotion
        want = np.array([recorded["probabilities"][n] for n in CLASS_NAMES])
        np.testing.assert_allclose(face.probabilities, want, atol=PROB_TOL, err_msg=emotion)


def test_every_tried_morph_is_recorded_and_the_shipped_one_is_negative_png(
    script: ModuleType,
) -> None:
    meta = _faces_json()
    tried = meta["tried"]
    assert len(tried) == len(script.TRIED_MORPHS) >= 1
    shipped = [t for t in tried if t["shipped"]]
    assert len(shipped) == 1
    negative = meta["textures"]["negative"]
    assert shipped[0]["morph"] == negative["morph"]
    _assert_same(shipped[0]["classifier"], negative["classifier"], "negative")


def test_script_reproduces_the_shipped_files(script: ModuleType, tmp_path: Path) -> None:
    """Byte for byte on the processor that made them; elsewhere OpenCV's SIMD paths
    (AVX-512 against AVX2) may round a shrunk pixel the other way, so a file may differ by
    one grey level in a few pixels, and then only its digest may change."""
    pytest.importorskip("skimage", reason="the happy face's photograph ships with scikit-image")
    assert script.main(["--out", str(tmp_path)]) == 0
    new = json.loads((tmp_path / "faces.json").read_text(encoding="utf-8"))
    old = _faces_json()
    for name, emotion in zip(PNGS, EMOTION_NAMES, strict=True):
        made, shipped = load_image(tmp_path / name), load_image(FACES / name)
        assert made.shape == shipped.shape, name
        step = np.abs(made.astype(int) - shipped.astype(int))
        assert step.max() <= 1 and np.count_nonzero(step) <= 16, (name, step.max())
        if not step.any():
            assert (tmp_path / name).read_bytes() == (FACES / name).read_bytes(), name
        else:
            new["textures"][emotion].pop("sha256")
            old["textures"][emotion].pop("sha256")
    new.pop("versions")  # library versions may move while the files stay identical
    old.pop("versions")
    _assert_same(new, old)
