"""emonav_drake: emotion-aware social navigation for the bipedal robot Digit in Drake.

Importing the package registers the Gymnasium environments ``EmoNavLIP-v0`` and
``EmoNavDigit-v0``, so that ``gymnasium.make("emonav_drake:EmoNavLIP-v0")`` works. Heavy
modules (pydrake, torch) are imported only by the parts that need them.
"""

import os

__version__ = "0.1.0"

# The most pixels an image may have to be decoded (16384², 268 MP; decompression bombs
# declare more). OpenCV reads OPENCV_IO_MAX_IMAGE_PIXELS once, when it loads: set here,
# before any module imports cv2, so that every OpenCV image decoder refuses a larger image
# from its header (perception/image_io.py also checks the headers it can read, for a
# message of its own). ffmpeg prints nothing (a damaged video is one error line of ours).
MAX_DECODED_PIXELS = 16384 * 16384
os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_DECODED_PIXELS))
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET


def _register_envs() -> None:
    try:
        from gymnasium.envs.registration import register, registry
    except ImportError:  # gymnasium is a dependency; stay importable without it
        return
    if "EmoNavLIP-v0" not in registry:
        register(id="EmoNavLIP-v0", entry_point="emonav_drake.learning.env:EmoNavLIPEnv")
    if "EmoNavDigit-v0" not in registry:
        register(id="EmoNavDigit-v0", entry_point="emonav_drake.learning.digit_env:EmoNavDigitEnv")


_register_envs()
