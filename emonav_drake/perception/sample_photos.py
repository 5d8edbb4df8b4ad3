"""Real photographs that ship inside installed packages, for tests, benchmarks and demos.

No download: the files are part of the wheels.

| name | package | file | content |
|---|---|---|---|
| grace_hopper | matplotlib | mpl-data/sample_data/grace_hopper.jpg | portrait, neutral face |
| astronaut | scikit-image | data/astronaut.png | Eileen Collins, smiling |
| camera | scikit-image | data/camera.png | cameraman, face too small / turned |
| chelsea | scikit-image | data/chelsea.png | a cat: no human face |
| coffee | scikit-image | data/coffee.png | a cup of coffee: no face |
| rocket | scikit-image | data/rocket.jpg | a rocket launch: no face |

matplotlib is a project dependency; scikit-image is a development dependency.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

PHOTOS = {
    "grace_hopper": ("matplotlib", "mpl-data/sample_data/grace_hopper.jpg"),
    "astronaut": ("skimage", "data/astronaut.png"),
    "camera": ("skimage", "data/camera.png"),
    "chelsea": ("skimage", "data/chelsea.png"),
    "coffee": ("skimage", "data/coffee.png"),
    "rocket": ("skimage", "data/rocket.jpg"),
}
_PIP_NAME = {"skimage": "scikit-image", "matplotlib": "matplotlib"}
FRAME_SIZE = (640, 480)  # (width, height) of `camera_frame`


def sample_photo_path(name: str) -> Path:
    """Path of a bundled photograph (see the table above).

    Raises:
        KeyError: unknown name.
        FileNotFoundError: the package that ships it is not installed.
    """
    if name not in PHOTOS:
        raise KeyError(f"unknown sample photo {name!r}: one of {sorted(PHOTOS)}")
    package, rel = PHOTOS[name]
    spec = importlib.util.find_spec(package)  # locates the package without importing it
    for root in (spec.submodule_search_locations or []) if spec else []:
        path = Path(root) / rel
        if path.is_file():
            return path
    raise FileNotFoundError(
        f"sample photo {name!r} ships with {_PIP_NAME[package]}: `pip install {_PIP_NAME[package]}`"
    )


def sample_photo(name: str) -> np.ndarray:
    """A bundled photograph as a BGR uint8 array."""
    from emonav_drake.perception.image_io import load_image

    return load_image(sample_photo_path(name))


def camera_frame(
    person: str = "astronaut",
    background: str = "coffee",
    left: int | None = None,
    height: int = 480,
) -> np.ndarray:
    """A 640 × 480 BGR frame: a photo of `person` (scaled to `height`) over `background`.

    Args:
        person: sample photo pasted at the bottom of the frame.
        background: sample photo stretched to fill the frame.
        left: column of the person photo's left edge [px]; default centred.
        height: height of the pasted photo [px] (≤ 480).
    """
    import cv2

    w_frame, h_frame = FRAME_SIZE
    frame = cv2.resize(sample_photo(background), FRAME_SIZE, interpolation=cv2.INTER_AREA)
    im = sample_photo(person)
    height = min(height, h_frame)
    width = min(round(im.shape[1] * height / im.shape[0]), w_frame)
    x0 = (w_frame - width) // 2 if left is None else int(np.clip(left, 0, w_frame - width))
    frame[h_frame - height :, x0 : x0 + width] = cv2.resize(
        im, (width, height), interpolation=cv2.INTER_AREA
    )
    return frame
