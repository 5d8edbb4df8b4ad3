"""One typed configuration for the whole project.

Every number of the paper's Table I and of the environment (docs/facts.md) lives
here, in plain dataclasses. Configurations load from YAML (`load_config`) with Drake's
typed loader, which already rejects unknown fields, and are then validated
(`EmoNavConfig.validate`): a value outside its allowed range raises `ConfigError` naming
the dotted field path and the range.

This module is the public configuration: `EmoNavConfig`, its cross-field rules, loading
and dumping, and every name of its sections, which live by concept in
`params_robot.py` (the robot, its LiDAR and the LiDAR's sensor model, perception, Digit
walking), `params_crowd.py` (the crowd and its scenarios, rewards, episodes, the emotion
codes) and
`params_planners.py` (DWA, the MPC): import them from here. Each field declares its
default, doc, unit and allowed range (`config_fields.setting`); the schema-agnostic YAML
machinery (typed loading and dumping, error messages naming the field, the range check
`validate_fields`, `ConfigError`) is `typed_yaml.py`, shared with the training
configurations and the scenarios. `ConfigError` is importable from here too.

Units are SI throughout (metres, seconds, radians), but the sensor model's angles,
in degrees as datasheets give them (`*_deg`).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
from pathlib import Path

from emonav_drake.config_fields import setting
from emonav_drake.errors import did_you_mean
from emonav_drake.params_crowd import (
    EMOTION_NAMES,
    HAPPY,
    NEGATIVE,
    NEUTRAL,
    SCENARIO_FAMILIES,
    CrowdParams,
    EpisodeParams,
    RewardParams,
)
from emonav_drake.params_planners import DwaParams, MpcParams, RouteParams
from emonav_drake.params_robot import (
    LEG_JOINT_NAMES,
    MAP_RINGS,
    NUM_BEAMS,
    PEOPLE_AS,
    SENSOR_NAMES,
    SENSOR_PRESETS,
    STATE_SOURCES,
    LidarParams,
    PerceptionParams,
    RobotParams,
    SensorParams,
    WalkingParams,
    pendulum_frequency,
    sensor_preset,
)
from emonav_drake.typed_yaml import (
    ConfigError,
    dump_typed_yaml,
    load_typed_yaml_raw,
    require,
    validate_fields,
)

__all__ = [
    "EMOTION_NAMES",
    "HAPPY",
    "NEGATIVE",
    "NEUTRAL",
    "NUM_BEAMS",
    "PEOPLE_AS",
    "SCENARIO_FAMILIES",
    "SENSOR_NAMES",
    "SENSOR_PRESETS",
    "DEPLOYABLE_SENSOR",
    "MAP_RINGS",
    "STATE_SOURCES",
    "ConfigError",
    "CrowdParams",
    "DwaParams",
    "EmoNavConfig",
    "EpisodeParams",
    "LidarParams",
    "MpcParams",
    "PerceptionParams",
    "RewardParams",
    "RobotParams",
    "RouteParams",
    "SensorParams",
    "WalkingParams",
    "apply_deployable",
    "apply_sensor_preset",
    "is_deployable",
    "dump_config",
    "load_config",
    "pendulum_frequency",
    "sensor_preset",
]


@dc.dataclass
class EmoNavConfig:
    """Everything configurable, grouped as in the paper."""

    # Each section is documented by the first line of its class's docstring.
    robot: RobotParams = setting(factory=RobotParams)
    lidar: LidarParams = setting(factory=LidarParams)
    crowd: CrowdParams = setting(factory=CrowdParams)
    reward: RewardParams = setting(factory=RewardParams)
    episode: EpisodeParams = setting(factory=EpisodeParams)
    dwa: DwaParams = setting(factory=DwaParams)
    mpc: MpcParams = setting(factory=MpcParams)
    route: RouteParams = setting(factory=RouteParams)
    walking: WalkingParams = setting(factory=WalkingParams)
    perception: PerceptionParams = setting(factory=PerceptionParams)
    sensor: SensorParams = setting(factory=SensorParams)

    def validate(self) -> "EmoNavConfig":
        """Check every field against its range and the cross-field rules; raise
        `ConfigError` naming the field."""
        validate_fields(self)
        c = self.crowd
        require(
            c.min_pedestrians <= c.max_pedestrians,
            "crowd.min_pedestrians",
            c.min_pedestrians,
            f"<= crowd.max_pedestrians ({c.max_pedestrians})",
        )
        require(
            c.min_static <= c.max_static,
            "crowd.min_static",
            c.min_static,
            f"<= crowd.max_static ({c.max_static})",
        )
        require(
            c.static_radius_min <= c.static_radius_max,
            "crowd.static_radius_min",
            c.static_radius_min,
            "<= crowd.static_radius_max",
        )
        require(
            c.circle_radius_min <= c.circle_radius_max,
            "crowd.circle_radius_min",
            c.circle_radius_min,
            "<= crowd.circle_radius_max",
        )
        for name in ("static_x_range", "static_y_range"):
            lo, hi = getattr(c, name)
            require(lo <= hi, f"crowd.{name}", [lo, hi], "[low, high] with low <= high")
        require(
            abs(sum(c.emotion_probs) - 1.0) < 1e-6 and min(c.emotion_probs) >= 0,
            "crowd.emotion_probs",
            c.emotion_probs,
            "three non-negative values summing to 1",
        )
        li = self.lidar
        require(
            li.num_beams % li.grid_size == 0,
            "lidar.num_beams",
            li.num_beams,
            f"a multiple of lidar.grid_size ({li.grid_size})",
        )
        require(
            li.min_range < li.max_range,
            "lidar.min_range",
            li.min_range,
            f"< lidar.max_range ({li.max_range})",
        )
        family = self.crowd.family
        require(
            family in SCENARIO_FAMILIES,
            "crowd.family",
            family,
            f"one of {SCENARIO_FAMILIES}{did_you_mean(family, SCENARIO_FAMILIES)}",
        )
        source = self.perception.state_source
        require(source in STATE_SOURCES, "perception.state_source", source, '"truth" or "lidar"')
        rings = self.perception.map_rings
        require(rings in MAP_RINGS, "perception.map_rings", rings, '"truth" or "tracks"')
        require(
            rings == "truth" or source == "lidar",
            "perception.map_rings",
            rings,
            '"truth" unless perception.state_source is "lidar" (no tracks to ring otherwise)',
        )
        self._validate_sensor()
        w = self.walking
        require(w.arms in ("welded", "held"), "walking.arms", w.arms, '"welded" or "held"')
        require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            "< walking.lateral_step_max",
        )
        steps_per_walk = self.robot.step_time / self.crowd.dt
        require(
            abs(steps_per_walk - round(steps_per_walk)) < 1e-9,
            "crowd.dt",
            c.dt,
            f"a divisor of robot.step_time ({self.robot.step_time})",
        )
        self._validate_walking()
        return self

    def _validate_sensor(self) -> None:
        """The sensor's names, and what its scan must give the grid maps: at least one of
        its beams in every LGM sector (angular resolution ≤ 360° / lidar.grid_size) and a
        rated range that covers the maps' range L (docs/perception.md)."""
        s, li = self.sensor, self.lidar
        require(
            s.preset in SENSOR_PRESETS,
            "sensor.preset",
            s.preset,
            f"one of {SENSOR_NAMES}{did_you_mean(s.preset, SENSOR_NAMES)}",
        )
        require(s.people_as in PEOPLE_AS, "sensor.people_as", s.people_as, '"disc" or "legs"')
        sector = 360.0 / li.grid_size
        require(
            s.angular_resolution_deg <= sector,
            "sensor.angular_resolution_deg",
            s.angular_resolution_deg,
            f"<= {sector:g} (360° / lidar.grid_size: every LGM sector needs one of the "
            "sensor's beams)",
        )
        require(
            li.max_range <= s.rated_range,
            "lidar.max_range",
            li.max_range,
            f"<= sensor.rated_range ({s.rated_range:g} m, sensor {s.preset}): the maps "
            "cannot reach beyond what the sensor measures",
        )

    def _validate_walking(self) -> None:
        """Cross-field rules of the Digit walking stack (its rates are multiples)."""
        w = self.walking
        require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            f"< walking.lateral_step_max ({w.lateral_step_max})",
        )
        for j in w.implicit_damping:
            require(
                j in LEG_JOINT_NAMES,
                "walking.implicit_damping",
                w.implicit_damping,
                f"leg joints among {list(LEG_JOINT_NAMES)} ({j!r} is not one)",
            )
        require(
            len(set(w.implicit_damping)) == len(w.implicit_damping),
            "walking.implicit_damping",
            w.implicit_damping,
            "each joint once",
        )
        require(
            not w.implicit_damping or abs(w.controller_period - w.time_step) < 1e-12,
            "walking.controller_period",
            w.controller_period,
            f"= walking.time_step ({w.time_step}) when walking.implicit_damping names "
            "joints (the solver's damping needs the controller's reference velocity at "
            "every step)",
        )
        for name in ("planner_period", "controller_period", "fall_check_period"):
            period = getattr(w, name)
            ratio = period / w.time_step
            require(
                ratio >= 1.0 - 1e-9 and abs(ratio - round(ratio)) < 1e-9,
                f"walking.{name}",
                period,
                f"a whole multiple of walking.time_step ({w.time_step})",
            )


def load_config(path: str | Path | None = None, data: str | None = None) -> EmoNavConfig:
    """The default configuration, overridden by a YAML file or string, validated.

    A `sensor` mapping that names a `preset` starts from the preset: the sensor fields it
    does not give take the preset's values (`apply_sensor_preset`)."""
    if path is None and data is None:
        return EmoNavConfig().validate()
    cfg, raw = load_typed_yaml_raw(EmoNavConfig, path=path, data=data)
    try:
        sensor = raw.get("sensor") if isinstance(raw, dict) else None
        if isinstance(sensor, dict) and "preset" in sensor:
            apply_sensor_preset(cfg, cfg.sensor.preset, keep=tuple(sensor))
        return cfg.validate()
    except ConfigError as e:
        raise ConfigError(f"{path if path is not None else '<yaml>'}: {e}") from None


def apply_sensor_preset(config: EmoNavConfig, name: str, keep: tuple[str, ...] = ()) -> None:
    """Set `config.sensor` to the preset `name`, in place: every field the preset gives,
    except those named in `keep` (given explicitly); the seed is kept. `ConfigError`
    naming `sensor.preset` for an unknown name."""
    require(name in SENSOR_PRESETS, "sensor.preset", name, f"one of {SENSOR_NAMES}")
    config.sensor.preset = name
    for field, value in SENSOR_PRESETS[name].items():
        if field not in keep:
            setattr(config.sensor, field, value)


# The sensor of the `deployable` setting: the Velodyne VLP-16, the LiDAR Digit carries on
# its head (docs/perception.md, "The deployable setting").
DEPLOYABLE_SENSOR = "vlp16"


def apply_deployable(config: EmoNavConfig, sensor: str | None = None) -> None:
    """Make `config` the deployable setting, in place: what a robot can run. The
    state-based planners read the crowd tracked in the LiDAR scan
    (`perception.state_source = "lidar"`) and the scan is a real sensor's, the preset
    `sensor` (default `DEPLOYABLE_SENSOR`) with its faults; the learned policies read
    their grid maps of that scan. Without `sensor`, a sensor with faults that `config`
    already has (a configuration file's) is kept. Emotions are not touched
    (`--emotion-source`). A `ConfigError` for a sensor whose scan is exact (ideal: no
    robot has it) or unknown."""
    name = sensor
    if name is None:
        name = config.sensor.preset if not config.sensor.is_exact() else DEPLOYABLE_SENSOR
    if sensor is not None or config.sensor.is_exact():
        apply_sensor_preset(config, name)
    require(
        not config.sensor.is_exact(),
        "sensor.preset",
        name,
        "a real sensor for the deployable setting (the ideal scan is exact: no robot has it)",
    )
    config.perception.state_source = "lidar"


def is_deployable(config: EmoNavConfig) -> bool:
    """True when `config` is a deployable setting: LiDAR state on a scan with faults."""
    return config.perception.state_source == "lidar" and not config.sensor.is_exact()


def dump_config(config: EmoNavConfig) -> str:
    """The configuration as YAML text (loadable by `load_config`)."""
    return dump_typed_yaml(config)
