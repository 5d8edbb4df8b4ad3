"""emonav_drake: emotion-aware social navigation for the bipedal robot Digit in Drake.

Importing the package registers the Gymnasium environments ``EmoNavLIP-v0`` and
``EmoNavDigit-v0``, so that ``gymnasium.make("emonav_drake:EmoNavLIP-v0")`` works. Heavy
modules (pydrake, torch) are imported only by the parts that need them.
"""

__version__ = "0.1.0"


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
