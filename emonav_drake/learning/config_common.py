"""What the training configurations share: their common ranges and cross-field rules.

Every numeric field of a training configuration is bounded both ways: seeds in
[0, 2**64 - 1], seed offsets so that offset + i stays a seed, counts and sizes up to
`MAX_COUNT` (a run that long would never end on any machine; a typo such as 1e12 is
refused instead of started). The ranges of what a training configuration shares with
`EmoNavConfig` (a goal radius, a frame count, a grid size) are the configuration's.
"""

import dataclasses as dc

from emonav_drake.config_fields import SEED_RANGE, field_range, setting
from emonav_drake.errors import did_you_mean
from emonav_drake.navigation.observations import observation_kind, observation_kinds
from emonav_drake.params import (
    SENSOR_NAMES,
    EmoNavConfig,
    EpisodeParams,
    LidarParams,
    apply_sensor_preset,
)
from emonav_drake.typed_yaml import ConfigError

# The 4-conv encoder (3 x 3, strides 2-1-1-1) needs an input of at least this many cells.
MIN_ENCODER_INPUT = 15
# `emonav benchmark`'s evaluation seeds are 0 … EVALUATION_SEEDS − 1 (docs/results.md): a
# training or selection seed range must stay clear of them.
EVALUATION_SEEDS = 500

MAX_COUNT = 10**9
MAX_SEED_OFFSET = 2**63
COUNT = (1, MAX_COUNT)  # episodes, steps, sizes: at least one
COUNT_OR_NONE = (0, MAX_COUNT)  # … or none
SEED_OFFSET = (0, MAX_SEED_OFFSET)
LEARNING_RATE = (1e-8, 1.0)
THREADS = (1, 1024)
WIDTH = (1, 65536)  # a hidden layer's or a feature vector's size
POOL = (1, 6)  # max-pool factor before the encoder
FRACTION = (0.0, 1.0)  # a probability, a discount, a fraction
TEMPERATURE = (1e-8, 1e3)  # SAC's entropy temperature α
POLYAK = (1e-6, 1.0)  # a target network's Polyak rate
GOAL_RADIUS = field_range(EpisodeParams, "goal_radius")
NUM_FRAMES = field_range(LidarParams, "num_frames")
GRID_SIZE = field_range(LidarParams, "grid_size")


def check_observation(grid_kind: str, encoder: str, num_frames: int) -> None:
    """The observation variant's cross-field rules (shared by the DAgger and SAC routes)."""
    check_choice("grid_kind", grid_kind, observation_kinds())
    check_choice("encoder", encoder, ("cnn", "lstm"))
    kind = observation_kind(grid_kind)
    if encoder == "lstm" and not kind.scans:
        raise ConfigError(
            f"encoder = 'lstm' is invalid with grid_kind = {grid_kind!r}: "
            "the LSTM encoder reads scans (grid_kind: scan)"
        )
    if kind.single_frame and num_frames != 1:
        raise ConfigError(
            f"num_frames = {num_frames} is invalid with grid_kind = {grid_kind!r}: "
            f"it observes one {kind.description} (num_frames: 1)"
        )


# The doc of every training configuration's `sensor` field (`emonav train --sensor`).
SENSOR_DOC = (
    "the LiDAR sensor of the training and selection world, by preset (the world's "
    "`sensor` section, docs/perception.md): ideal (the exact scan), vlp16 or ust10lx"
)


def check_sensor(sensor: str) -> None:
    """`ConfigError` naming `sensor` unless it is a sensor preset."""
    check_choice("sensor", sensor, SENSOR_NAMES)


def with_sensor(env_cfg: EmoNavConfig, sensor: str) -> EmoNavConfig:
    """`env_cfg` (changed in place and returned) with the training configuration's sensor
    preset: any preset but "ideal" sets its whole `sensor` section (the seed kept);
    "ideal", the default, leaves the world's own sensor as it is."""
    check_sensor(sensor)
    if sensor != "ideal":
        apply_sensor_preset(env_cfg, sensor)
        env_cfg.validate()
    return env_cfg


# What the training world's robot knows of the crowd (`TrainingRunConfig.perception`).
PERCEPTIONS = ("truth", "tracks")
PERCEPTION_DOC = (
    "what the training world's robot knows of the crowd: \"truth\" (the simulator's "
    "pedestrians: a teacher that reads the crowd reads them, the grid maps ring them) or "
    '"tracks" (the LiDAR tracker\'s, as a deployed robot has them: perception.state_source '
    "lidar and map_rings tracks, docs/perception.md; with a real `sensor` this is the "
    "deployable setting's perception, emotions associated from the simulator's)"
)


def with_run_world(env_cfg: EmoNavConfig, cfg: "TrainingRunConfig") -> EmoNavConfig:
    """`env_cfg` (changed in place and returned) as the training run's world: its
    `sensor` preset (`with_sensor`) and its `perception` ("tracks": the planners and the
    maps' rings read the LiDAR tracker's crowd; "truth" leaves the world's own)."""
    with_sensor(env_cfg, cfg.sensor)
    check_choice("perception", cfg.perception, PERCEPTIONS)
    if cfg.perception == "tracks":
        env_cfg.perception.state_source = "lidar"
        env_cfg.perception.map_rings = "tracks"
        env_cfg.validate()
    return env_cfg


def with_run_family(env_cfg: EmoNavConfig, family: str) -> EmoNavConfig:
    """`env_cfg` (changed in place and returned) with the training run's scenario
    `family`: "paper" leaves the configuration's own; any other family replaces the paper's
    arena. `ConfigError` if the configuration already names another family (two answers to
    one question: give one)."""
    if family != "paper":
        if env_cfg.crowd.family not in ("paper", family):
            raise ConfigError(
                f"the run trained in family {family!r} and the environment configuration "
                f"names family {env_cfg.crowd.family!r}: give one"
            )
        env_cfg.crowd.family = family
    return env_cfg


def check_choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    """`ConfigError` unless `value` is one of `allowed`."""
    if value not in allowed:
        raise ConfigError(
            f"{name} = {value!r} is invalid: must be one of {list(allowed)}"
            f"{did_you_mean(value, allowed)}"
        )


@dc.dataclass
class TrainingRunConfig:
    """The fields every training configuration shares (DAgger, SAC, the SAC fine-tuning,
    SARL): the run's seed, its torch device, the LiDAR sensor of its world and what its
    robot knows of the crowd. Each route's
    configuration adds its own fields after these."""

    seed: int = setting(
        0,
        "the run's seed: every random choice of the run (networks, sampling, scenarios, "
        "exploration) follows from it",
        "",
        SEED_RANGE,
    )
    device: str = setting("cpu", "the torch device")
    sensor: str = setting("ideal", SENSOR_DOC)
    perception: str = setting("truth", PERCEPTION_DOC)

    def check_common(self) -> None:
        """`ConfigError` naming the field for a shared field out of its range or choices."""
        check_sensor(self.sensor)
        check_choice("perception", self.perception, PERCEPTIONS)
