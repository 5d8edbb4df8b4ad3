"""Image and video input for the emotion classifier: reading, size limits, gray conversion.

* `load_image` / `load_image_limited`: a PNG/JPEG/… file as a BGR uint8 (H, W, 3) array,
  refused above `HARD_MAX_PIXELS` from its header and, for `load_image_limited`,
  downscaled to at most `MAX_IMAGE_PIXELS` (`fit_pixels`; `scale_box` maps a box found
  in the downscaled image back to the original's pixels);
* `image_header_size`: (width, height) from a file's header — Netpbm (PBM, PGM, PPM, PAM,
  PFM) and Radiance HDR read here, every other format through Pillow when it is
  installed. Behind it, OpenCV's own limit: `emonav_drake/__init__.py` sets
  `OPENCV_IO_MAX_IMAGE_PIXELS` to `HARD_MAX_PIXELS` before OpenCV loads, so every OpenCV
  decoder (BMP, JPEG, JPEG 2000, PNG, WebP, Netpbm, PFM, Sun raster, TIFF, OpenEXR, HDR,
  GIF, AVIF) refuses a larger image from its header, whatever format it is;
* `video_frames` / `is_video_path`: the frames of a video file, refused above
  `HARD_MAX_PIXELS` per frame;
* `to_gray`: gray uint8 (H, W) from a gray, BGR/RGB or BGRA/RGBA image (OpenCV weights);
* `ImageReadError`: a file or array that is not a usable image or video.

What the C libraries print while decoding (libpng's "libpng error: …", libjpeg's
"Corrupt JPEG data: …", OpenCV's log) is caught from file descriptor 2 around each
decoder call (`_library_messages`; ffmpeg is silenced by `OPENCV_FFMPEG_LOGLEVEL`): a
file that does not decode is one `ImageReadError` whose message quotes the library, and
an image decoded despite damage is one warning of ours — never the libraries' own lines.

Image coordinates: pixels, origin at the top-left corner, u (x) to the right, v (y) down;
a box is (x, y, w, h). Colour images are in OpenCV's BGR order unless said otherwise.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path

import cv2
import numpy as np

from emonav_drake import MAX_DECODED_PIXELS
from emonav_drake.errors import UserError

log = logging.getLogger(__name__)

VIDEO_SUFFIXES = frozenset({".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg"})


class ImageReadError(UserError, ValueError):
    """A file is not a readable image or video, or an array is not a usable image."""


# Images above MAX_IMAGE_PIXELS are classified on a downscaled copy (the Haar detector's
# time and memory grow with the pixel count: 8000 x 8000 took 16 s and 1.4 GB); images
# above HARD_MAX_PIXELS (read from the file header) are refused before decoding.
MAX_IMAGE_PIXELS = 4096 * 2048
HARD_MAX_PIXELS = MAX_DECODED_PIXELS  # 16384², OpenCV's limit too (emonav_drake/__init__.py)
_REDUCED_FLAGS = {
    2: cv2.IMREAD_REDUCED_COLOR_2,
    4: cv2.IMREAD_REDUCED_COLOR_4,
    8: cv2.IMREAD_REDUCED_COLOR_8,
}


def image_header_size(path: str | Path) -> tuple[int, int] | None:
    """(width, height) from the file header without decoding the pixels; None if unknown.

    Netpbm (P1–P7, PF, Pf) and Radiance HDR headers are read here (Pillow reads no PAM,
    PFM nor HDR); every other format through Pillow, when it is installed."""
    try:
        with open(path, "rb") as f:
            head = f.read(_HEADER_BYTES)
    except OSError:
        return None
    if head[:2] == b"#?":
        return _radiance_size(head)
    if re.match(rb"P[1-7Ff]\s", head[:3]):
        return _netpbm_size(head)
    return _pillow_size(path)


_HEADER_BYTES = 65536  # a Netpbm or Radiance header is far shorter


def _netpbm_size(head: bytes) -> tuple[int, int] | None:
    """(width, height) of a PBM/PGM/PPM (P1–P6), PFM (PF, Pf) or PAM (P7) header."""
    text = head.decode("latin-1")
    if text[1] == "7":  # PAM: "WIDTH w" and "HEIGHT h" lines before ENDHDR
        fields = dict(re.findall(r"^(WIDTH|HEIGHT)[ \t]+(\d+)", text, flags=re.MULTILINE))
        if "WIDTH" in fields and "HEIGHT" in fields:
            return int(fields["WIDTH"]), int(fields["HEIGHT"])
        return None
    tokens = re.sub(r"#[^\n\r]*", " ", text[2:]).split()  # comments run to the line end
    if len(tokens) >= 2 and tokens[0].isdigit() and tokens[1].isdigit():
        return int(tokens[0]), int(tokens[1])
    return None


def _radiance_size(head: bytes) -> tuple[int, int] | None:
    """(width, height) of a Radiance HDR header: the resolution line after the blank line
    ending the header, e.g. "-Y 480 +X 640" (any of the eight orientations)."""
    _, blank, rest = head.replace(b"\r\n", b"\n").partition(b"\n\n")
    if not blank:
        return None
    m = re.match(rb"\s*([+-])([XY])\s+(\d+)\s+([+-])([XY])\s+(\d+)", rest)
    if m is None or m.group(2) == m.group(5):
        return None
    sizes = {m.group(2): int(m.group(3)), m.group(5): int(m.group(6))}
    return sizes[b"X"], sizes[b"Y"]


def _pillow_size(path: str | Path) -> tuple[int, int] | None:
    try:
        import warnings

        from PIL import Image
    except ImportError:  # no Pillow: OpenCV's own limit still applies
        return None
    limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # our own limit applies (Pillow's would refuse to tell)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(path) as im:
                return int(im.size[0]), int(im.size[1])
    except Exception:  # not a format Pillow knows: OpenCV's limit applies
        return None
    finally:
        Image.MAX_IMAGE_PIXELS = limit


_LIBRARY_LOCK = threading.Lock()
# OpenCV's log lines ("[ WARN:0@0.01] global file.cpp:12 function …") and ffmpeg's
# ("[mov,mp4,… @ 0x55…] …"): prefixes dropped when quoted
_LOG_PREFIX = re.compile(r"^\[[^\]]*\]\s*(global\s+\S+\s+\S+\s+)?")


@contextlib.contextmanager
def _library_messages() -> Iterator[list[str]]:
    """Catch what C libraries write to file descriptor 2 while the block runs (libpng and
    libjpeg print there directly, OpenCV logs there); the list is filled on exit with the
    non-empty lines. Without a usable descriptor 2 nothing is caught."""
    caught: list[str] = []
    with _LIBRARY_LOCK, tempfile.TemporaryFile() as sink:
        with contextlib.suppress(Exception):  # Python's own buffered lines go out first
            sys.stderr.flush()
        try:
            saved = os.dup(2)
        except OSError:  # no descriptor 2 (a daemon): nothing to keep clean
            yield caught
            return
        level = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)  # not its warnings
        os.dup2(sink.fileno(), 2)
        try:
            yield caught
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            cv2.utils.logging.setLogLevel(level)
            sink.seek(0)
            text = sink.read(_HEADER_BYTES).decode("utf-8", errors="replace")
            caught += [line.strip() for line in text.splitlines() if line.strip()]


def _said(lines: list[str]) -> str:
    """What the libraries said, for a message: their own lines first (libpng, libjpeg),
    else OpenCV's; prefixes dropped, cut to ~160 characters; "" if nothing."""
    own = [line for line in lines if not line.startswith("[")]
    said = "; ".join(dict.fromkeys(_LOG_PREFIX.sub("", line) for line in (own or lines)))
    return said if len(said) <= 160 else said[:157] + "…"


def _decode(path: Path, flags: int) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise ImageReadError(f"{path}: the file is empty, not an image")
    too_large = False
    with _library_messages() as said:
        try:
            image = cv2.imdecode(data, flags)
        except cv2.error as e:  # OpenCV's size limit, from the header, before any pixel
            image, too_large = None, "validateInputImageSize" in str(e)
    if too_large:
        raise ImageReadError(
            f"{path}: larger than the {HARD_MAX_PIXELS / 1e6:.0f} megapixels this tool "
            "decodes (the decoder read its size from the header and refused it); "
            "downscale it first"
        )
    detail = _said(said)
    if image is None or image.size == 0:
        raise ImageReadError(
            f"{path}: not a readable image (PNG, JPEG, BMP, …): the file is corrupted "
            "or has another format" + (f" (the decoder said: {detail})" if detail else "")
        )
    if detail:
        log.warning("%s: decoded, but the decoder said: %s (the file may be damaged)", path, detail)
    return image


def load_image(path: str | Path) -> np.ndarray:
    """Read a PNG/JPEG/… file as a BGR uint8 (H, W, 3) array.

    Raises:
        FileNotFoundError: no such file.
        ImageReadError: the file is empty, corrupted, not an image, or larger than
            `HARD_MAX_PIXELS` (checked from the header, before decoding).
    """
    path = Path(path)
    _check_hard_limit(path, image_header_size(path) if path.is_file() else None)
    return _decode(path, cv2.IMREAD_COLOR)


def _check_hard_limit(path: Path, size: tuple[int, int] | None) -> None:
    if size is not None and size[0] * size[1] > HARD_MAX_PIXELS:
        raise ImageReadError(
            f"{path}: {size[0]}x{size[1]} = {size[0] * size[1] / 1e6:.0f} megapixels is more "
            f"than the {HARD_MAX_PIXELS / 1e6:.0f} this tool decodes; downscale it first"
        )


def fit_pixels(image: np.ndarray, max_pixels: int | None) -> tuple[np.ndarray, float]:
    """`image` downscaled (area interpolation) to at most `max_pixels`, and the scale used."""
    h, w = image.shape[:2]
    if not max_pixels or h * w <= max_pixels:
        return image, 1.0
    scale = (max_pixels / (h * w)) ** 0.5
    size = (max(1, int(w * scale)), max(1, int(h * scale)))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA), size[0] / w


def load_image_limited(
    path: str | Path, max_pixels: int | None = MAX_IMAGE_PIXELS
) -> tuple[np.ndarray, float, tuple[int, int]]:
    """Read an image at most `max_pixels` large: (BGR image, scale, original (w, h)).

    A larger image is downscaled by `scale` < 1: decoded at 1/2, 1/4 or 1/8 size when that
    still leaves at least `max_pixels` (JPEG decodes so without ever holding the full
    image), then area-resized to fit. An
    image above `HARD_MAX_PIXELS` is refused from its header. `max_pixels` None or 0: no
    downscaling.
    """
    path = Path(path)
    size = image_header_size(path) if path.is_file() else None
    _check_hard_limit(path, size)
    flags = cv2.IMREAD_COLOR
    if size is not None and max_pixels and size[0] * size[1] > max_pixels:
        ratio = size[0] * size[1] / max_pixels  # > 1
        factor = max(f for f in (1, 2, 4, 8) if f * f <= ratio)  # still >= max_pixels
        flags = _REDUCED_FLAGS.get(factor, cv2.IMREAD_COLOR)
    image = _decode(path, flags)
    if size is None or flags == cv2.IMREAD_COLOR:
        size = (image.shape[1], image.shape[0])
    image, _ = fit_pixels(image, max_pixels)
    return image, image.shape[1] / size[0], size


def scale_box(box: Sequence[int], scale: float) -> tuple[int, int, int, int]:
    """A box (x, y, w, h) found in an image downscaled by `scale`, in the original's pixels."""
    if scale == 1.0:
        return tuple(int(v) for v in box)  # type: ignore[return-value]
    return tuple(int(round(v / scale)) for v in box)  # type: ignore[return-value]


def is_video_path(path: str | Path) -> bool:
    """Whether `path` names a video by its suffix (.mp4, .avi, .mov, .mkv, .webm, …)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def video_frames(path: str | Path, every: int = 1) -> Iterator[tuple[int, float, np.ndarray]]:
    """Frames of a video file: (frame index, time [s], BGR uint8 image), every `every`-th.

    Raises:
        FileNotFoundError: no such file.
        ImageReadError: the file cannot be opened as a video or holds no frame.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    if every < 1:
        raise ValueError(f"every = {every}: must be >= 1")
    with _library_messages() as said:
        cap = cv2.VideoCapture(str(path))
        opened = cap.isOpened()
    try:
        if not opened:
            detail = _said(said)
            raise ImageReadError(
                f"{path}: not a readable video (corrupted or unknown format)"
                + (f" (the decoder said: {detail})" if detail else "")
            )
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        if w * h > HARD_MAX_PIXELS:
            raise ImageReadError(
                f"{path}: frames of {w}x{h} = {w * h / 1e6:.0f} megapixels are more than the "
                f"{HARD_MAX_PIXELS / 1e6:.0f} this tool decodes; downscale the video first"
            )
        fps = cap.get(cv2.CAP_PROP_FPS)
        fps = fps if fps and np.isfinite(fps) and fps > 0 else 0.0
        index = 0
        damage = ""
        while True:
            with _library_messages() as said:
                ok, frame = cap.read()
            damage = damage or _said(said)
            if not ok or frame is None:
                break
            if index % every == 0:
                yield index, (index / fps if fps else float("nan")), frame
            index += 1
        if index == 0:
            raise ImageReadError(
                f"{path}: the video holds no readable frame"
                + (f" (the decoder said: {damage})" if damage else "")
            )
        if damage:
            log.warning(
                "%s: the video is damaged (%s); using the frames it could read", path, damage
            )
    finally:
        cap.release()


def to_gray(image: np.ndarray, channel_order: str = "bgr") -> np.ndarray:
    """Gray uint8 (H, W) from a uint8 gray, BGR/RGB or BGRA/RGBA image.

    Args:
        image: uint8 array (H, W), (H, W, 1), (H, W, 3) or (H, W, 4).
        channel_order: "bgr" (OpenCV) or "rgb" (Drake `ImageRgba8U`, PIL) for colour input.
    """
    a = np.asarray(image)
    if a.dtype != np.uint8:
        raise ImageReadError(f"image dtype {a.dtype}: expected uint8")
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim == 2:
        gray = a
    elif a.ndim == 3 and a.shape[2] in (3, 4):
        if channel_order not in ("bgr", "rgb"):
            raise ValueError(f"channel_order = {channel_order!r}: must be 'bgr' or 'rgb'")
        codes = {
            ("bgr", 3): cv2.COLOR_BGR2GRAY,
            ("bgr", 4): cv2.COLOR_BGRA2GRAY,
            ("rgb", 3): cv2.COLOR_RGB2GRAY,
            ("rgb", 4): cv2.COLOR_RGBA2GRAY,
        }
        gray = cv2.cvtColor(np.ascontiguousarray(a), codes[channel_order, a.shape[2]])
    else:
        raise ImageReadError(f"image shape {a.shape}: expected (H, W), (H, W, 3) or (H, W, 4)")
    if gray.shape[0] < 1 or gray.shape[1] < 1:
        raise ImageReadError(f"image shape {a.shape}: empty")
    return np.ascontiguousarray(gray)
